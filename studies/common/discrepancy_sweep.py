"""Sweeps of the model-discrepancy workflow: each hidden effect with each seed, through the file and
the blind analysis, with the oracle and the floor; the confusion matrix of hidden against named
effects and the per-effect summary (``confusion.md``, ``confusion.json``), and sweeps run apart
merged into one. ``studies/discrepancy.py --sweep`` and ``--merge-sweeps`` call them.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from simulation.discrepancy import WorkflowSettings
from simulation.discrepancy.signals import RAVEN_UNITS, pooled_rmse
from studies.common.discrepancy_report import command_gap_shrink, command_shrink, scored_gaps, structure_shares
from studies.common.discrepancy_runs import (
    HIDDEN_CHOICES,
    LIBRARY,
    SHORT_RECORD_S,
    STARTING_STRUCTURE,
    UNMODELLED_EFFECTS,
    analyse_measured,
    floor_record,
    generate_measured,
    held_out_gap,
    largest_share,
    oracle,
    shrink_bound,
    verdict,
    write_measured,
)
from studies.common.plant_scoring import plant_floor_gap, pooled_gap, score_oracle_with_plant, score_with_plant
from studies.common.reporting import markdown_table, write_json, write_text
from studies.common.runner import UsageError

SWEEP_EFFECTS = HIDDEN_CHOICES
"""What ``--sweep`` hides unless ``--effects`` says otherwise: every choice of ``--hidden-effect``."""


def _share_text(shares) -> str:
    share = largest_share(shares)
    return "-" if share is None else f"{share:.0f}"


def _repeats(shares) -> bool:
    """Whether a run's per-joint structure shares reach the workflow's flag."""
    return shares is not None and max(shares) >= WorkflowSettings().structure_share


SHRINK_DIGITS = 9
"""Decimals (of a per cent) to which the summary reads shrinks: a gap the named effects leave as it
was is 1 - after / before, which rounding leaves a few 1e-14 % either side of zero, and read to
the last bit the goal (a shrink of at least 80 % of the oracle's) would be met or missed by that
rounding (the controller's gravity model, which the joints' gap does not show)."""


def _percent(fractions) -> np.ndarray:
    """Shrinks (fractions) in per cent, to :data:`SHRINK_DIGITS` decimals (and no negative zero)."""
    return np.round(np.asarray(fractions, dtype=float) * 100, SHRINK_DIGITS) + 0.0


def _first_named(named, unexplained: bool) -> str:
    """The confusion matrix's column of a run: the first effect ``named``, else "unexplained" where the
    residual was flagged, else "none"."""
    return named[0] if named else ("unexplained" if unexplained else "none")


def _named_first(hidden: str, result) -> bool:
    """Whether the first effect named is the hidden one, or one the data cannot tell from it; for an
    effect the library lacks, whether nothing was named and the residual was flagged unexplained."""
    if hidden in UNMODELLED_EFFECTS:
        return not result["named"] and result["unexplained"]
    if not result["named"]:
        return hidden == "none"
    first = result["named"][0]
    return first == hidden or hidden in result["equivalent"].get(first, [])


def sweep_line(run: dict, done: int, total: int) -> str:
    """One line on a finished sweep run: what was hidden, what was named, and the two shrinks (%)."""
    named = ", ".join(run["named"]) or "nothing"
    flag = " (unexplained residual)" if run["unexplained"] else ""
    return (f"run {done} of {total}: {run['hidden']}, seed {run['seed']}: named {named}{flag}, "
            f"shrink {100 * run['shrink']:.1f} %, oracle {100 * run['oracle_shrink']:.1f} %")


def sweep(effects, seeds, duration: float, out: Path, progress: bool = True, size_factor: float = 1.0,
          lines: bool = False, fit_plant_lag: bool = True) -> dict:
    """Hide each effect with each seed, through the file and the blind analysis, with the oracle:
    the confusion matrix of hidden vs named (first named), and per effect how often it was named
    first and the shrink beside the oracle's. ``progress`` draws a bar on stderr; ``lines`` writes
    one line per finished run there instead (for a log file, where a bar cannot redraw).

    Each seed's floor is measured once, by its ``none`` run where one is swept: quasi-statically,
    and scored with the plant replay (``plant_floor``) as a run whose shrink the plant scores reads
    its bound against. A named hysteresis's lag in the plant is fitted, as the command fits it
    (``fit_plant_lag`` False: the candidate's constant, ``--fixed-plant-lag``); each run records
    the final model's fitted lag (``hysteresis_lag_s``, None where none was fitted) and whether the
    lag was fitted (``plant_lag_fitted``)."""
    import tempfile

    from joblib import Parallel, delayed

    from kinematics import RavenII

    def one(effect, seed):
        hidden = () if effect == "none" else (effect,)
        dataset, generator = generate_measured(hidden, seed, duration, size_factor=size_factor)
        with tempfile.TemporaryDirectory() as tmp:
            path = write_measured(dataset, tmp)
            result, signals, split = analyse_measured(path)
            fit = oracle(path, hidden)
        before = pooled_rmse(result.residual_before.joints, result.units)
        after = pooled_rmse(fit.residual_after.joints, result.units)
        quasi_oracle_shrink = float(1.0 - after / before) if before > 0 else 0.0
        # scored as the command's report scores them: the plant replay's where it applies
        plant = score_with_plant(result, signals, split, fit_lag=fit_plant_lag)
        scored = score_oracle_with_plant(fit, plant, signals, split)
        _, _, shrink, scored_by = scored_gaps(result, plant)
        oracle_shrink = quasi_oracle_shrink if scored is None else float(scored[1])
        floor = {}
        if effect == "none":
            # this record is the seed's floor record: its starting model scored as a plant-scored run's is
            robot = RavenII(signals.arm, check_limits=False)
            floor["plant_floor"] = pooled_gap(plant_floor_gap((signals, split, robot, result.model_before)))
        return {"hidden": effect, "seed": seed, "named_first": _first_named(result.named_effects, result.unexplained),
                "named": list(result.named_effects),
                "equivalent": {k: list(v) for k, v in result.equivalent.items()},
                "rivals": {k: dict(v) for k, v in result.rivals.items()},
                "unexplained": result.unexplained, "gap_before": pooled_rmse(result.residual_before.joints, result.units),
                "plant_gap_before": pooled_gap(plant.gap_before) if plant.applies else None, **floor,
                "shrink": shrink, "oracle_shrink": oracle_shrink, "scored_by": scored_by,
                "plant_lag_fitted": bool(fit_plant_lag),
                "hysteresis_lag_s": plant.hysteresis_lag if plant.applies else None,
                "quasi_static_shrink": float(result.shrink), "oracle_quasi_static_shrink": quasi_oracle_shrink,
                "residual_structure": structure_shares(result), "oracle_residual_structure": structure_shares(fit),
                "signature": list(result.signature), "command_shrink": command_shrink(result),
                "backfit_capped": list(result.backfit_capped), "oracle_backfit_capped": list(fit.backfit_capped)}

    def floor_of(seed, plant_scored):
        signals, split, robot, model = record = floor_record(seed, duration)
        quasi = pooled_rmse(held_out_gap(model, signals, split, robot)[None, :], RAVEN_UNITS)
        return seed, {"floor": quasi, **({"plant_floor": pooled_gap(plant_floor_gap(record))} if plant_scored else {})}

    jobs = [(e, s) for e in effects for s in seeds]
    results = Parallel(n_jobs=-1, return_as="generator")(delayed(one)(e, s) for e, s in jobs)
    runs = []
    for run in tqdm(results, total=len(jobs), desc="hidden-effect runs", disable=not progress, file=sys.stderr):
        runs.append(run)
        if lines:
            print(sweep_line(run, len(runs), len(jobs)), file=sys.stderr, flush=True)
    if "none" not in effects:
        # each seed's floor once: the 'none' runs give it where they are swept
        plant_scored = {r["seed"] for r in runs if r["plant_gap_before"] is not None}
        floors = dict(Parallel(n_jobs=-1)(delayed(floor_of)(s, s in plant_scored) for s in seeds))
        runs = [{**run, **floors[run["seed"]]} for run in runs]
    return summarise_sweep(runs, duration, out, size_factor, effects)


def _goal_misses(effect: str, runs: list[dict], named: int, shrink: np.ndarray, closable: np.ndarray) -> list[str]:
    """What keeps a hidden effect's row from the workflow's goal, in words (empty where it is met):
    named first on fewer than four seeds in five, or, for an effect of the library, a seed whose
    shrink (%) reaches neither 50 % nor 80 % of its oracle's. ``shrink`` and ``closable`` are the
    runs' shrinks and oracle shrinks in %, in the order of ``runs``."""
    misses = [] if named >= 0.8 * len(runs) else [f"named first on {named} of {len(runs)}"]
    if effect not in UNMODELLED_EFFECTS:
        misses += [f"seed {run['seed']} closes {s:.1f} % (oracle {c:.1f} %)"
                   for run, s, c in zip(runs, shrink, closable) if s < min(50.0, 0.8 * c)]
    return misses


def summarise_sweep(runs: list[dict], duration: float, out: Path, size_factor: float = 1.0, effects=None,
                    extra: dict | None = None) -> dict:
    """Write the confusion matrix, the per-effect summary and the runs' table of sweep ``runs``
    (``confusion.md``, ``confusion.json`` in ``out``) and return the document.

    ``effects`` orders the rows (default: the order of :data:`SWEEP_EFFECTS`); the seeds are those
    the runs hold, so effects may have been run on different seeds (a merged sweep). ``extra`` is
    added to ``confusion.json`` as it is.
    """
    present = {r["hidden"] for r in runs}
    order = list(effects) if effects is not None else list(SWEEP_EFFECTS)
    effects = [e for e in order if e in present] + sorted(present - set(order))
    runs = sorted(runs, key=lambda r: (effects.index(r["hidden"]), r["seed"]))
    seeds = sorted({r["seed"] for r in runs})
    columns = sorted({r["named_first"] for r in runs} | set(effects) | {"unexplained"}, key=lambda n: (n != "none", n))
    matrix = {e: {c: sum(1 for r in runs if r["hidden"] == e and r["named_first"] == c) for c in columns}
              for e in effects}
    rows = [[e] + [matrix[e][c] for c in columns] for e in effects]
    floors = {r["seed"]: r["gap_before"] for r in runs if r["hidden"] == "none"}
    plant_floors = {r["seed"]: r["plant_floor"] for r in runs if r["hidden"] == "none" and "plant_floor" in r}

    def bound_of(run) -> float | None:
        # the floor: what the starting model leaves on the same seed's record with nothing hidden
        # (the seed's 'none' run, or the floor a sweep without them measured for each seed), scored
        # as the run's shrink is: with the plant replay where it scored the run
        if run["hidden"] == "none":
            return None
        if run.get("plant_gap_before") is not None:
            floor = run.get("plant_floor", plant_floors.get(run["seed"]))
            return None if floor is None else shrink_bound(floor, run["plant_gap_before"])
        floor = run.get("floor", floors.get(run["seed"]))
        return None if floor is None else shrink_bound(floor, run["gap_before"])

    summary_rows = []
    for e in effects:
        mine = [r for r in runs if r["hidden"] == e]
        named = sum(_named_first(e, r) for r in mine)
        shrink = _percent([r["shrink"] for r in mine])
        closable = _percent([r["oracle_shrink"] for r in mine])
        gap = np.array([r["gap_before"] for r in mine])
        misses = _goal_misses(e, mine, named, shrink, closable)
        left = [r for r in mine if r["named"] and r["unexplained"]]
        also = sum(_repeats(r.get("oracle_residual_structure")) for r in left)
        notes = [f"{len(left)} then unexplained, the oracle's residual too in {also}"] if left else []
        # runs recorded before the backfit counted its rounds carry no such key
        cut = sum(1 for r in mine if r.get("backfit_capped"))
        notes += [f"the backfit cut by its cap in {cut}"] if cut else []
        flags = f" ({'; '.join(notes)})" if notes else ""
        bounds = [bound_of(r) for r in mine]
        bounds = np.array(bounds, dtype=float) * 100 if None not in bounds else None
        summary_rows.append([e, f"{named} of {len(mine)}" + flags,
                             f"{np.mean(gap):.4f}",
                             f"{np.mean(shrink):.1f} [{np.min(shrink):.1f}, {np.max(shrink):.1f}]",
                             f"{np.mean(closable):.1f} [{np.min(closable):.1f}, {np.max(closable):.1f}]",
                             "-" if bounds is None else
                             f"{np.mean(bounds):.1f} [{np.min(bounds):.1f}, {np.max(bounds):.1f}]",
                             "-" if e == "none" else ("no: " + "; ".join(misses) if misses else "yes")])
    run_rows = [[r["hidden"], str(r["seed"]), verdict(r["named"], r["unexplained"]),
                 "; ".join(f"{k} = {', '.join(v)}" for k, v in r["equivalent"].items()),
                 "; ".join(f"{k} ~ {n} ({d:.2f})" for k, v in r.get("rivals", {}).items() for n, d in v.items()),
                 r["gap_before"],
                 *_percent([r["shrink"], r["oracle_shrink"]]),
                 # runs recorded before the plant scored them were scored quasi-statically
                 _percent([r.get("quasi_static_shrink", r["shrink"])])[0],
                 "-" if bound_of(r) is None else f"{100 * bound_of(r):.1f}",
                 _share_text(r.get("residual_structure")), _share_text(r.get("oracle_residual_structure")),
                 "-" if r.get("command_shrink") is None else f"{100 * r['command_shrink']:.1f}"]
                for r in runs]
    sizes = "at their default sizes" if size_factor == 1.0 else f"at {size_factor:g} times their default sizes"
    text = "\n".join([
        "# Hidden vs named effects (blind analysis of generated files)", "",
        f"Seeds {list(seeds)}, {duration:.0f} s of random motion per run, hidden effects {sizes}; starting "
        f"structure {', '.join(STARTING_STRUCTURE)}; library {', '.join(LIBRARY)}.", "",
        *([] if not any(r.get("inertial_loads") == "motors" for r in runs) else [
            "**Inertial loads from the motors:** every run's replay took the links' inertial loads from the motors' "
            "acceleration through the arm's nominal coupling (`--inertial-loads motors`).", ""]),
        *([] if duration >= SHORT_RECORD_S else [
            f"**Short records:** under {SHORT_RECORD_S:.0f} s the starting structure, identified on each record's "
            "first half, may itself leave a gap that a candidate then takes.", ""]),
        "## Per hidden effect", "",
        "Named first: runs whose first named effect is the hidden one (or one the data cannot tell from it, "
        "e.g. the two kinds of per-homing offset); for an effect the library lacks, runs that name nothing and "
        "flag the residual unexplained. Gap: the starting model's held-out gap (pooled RMSE, deg and "
        "mm). Shrink and oracle shrink: mean [min, max] over the seeds, %, as the command's report scores them "
        "(the plant replay's where it applies, the quasi-static replay's otherwise; the runs' table gives the "
        "quasi-static shrink beside); the oracle is the generator's true "
        "structure fitted to the same fit part by the same steps; 'then unexplained': runs that named an effect "
        "and still left a residual that repeats, and in how many of them the oracle's residual repeats as well (a "
        "model of the right structure fitted to that record leaves it too); 'the backfit cut by its cap': runs "
        "whose named effect's backfit was still improving at its last allowed round (its fit may stop short). "
        "Floor bound: 1 - the gap the starting model leaves on the same seed's record with nothing hidden "
        "/ this gap, both pooled and scored as the run's shrink is (with the plant replay where it scored the run, "
        "quasi-statically otherwise): about the most a model scored that way closes ('-' for runs recorded "
        "without it and without a 'none' run of their seed that measured it). "
        "Goal: named first on at least 4 of 5 seeds "
        "and, on every seed, a shrink of at least 50 % or 80 % of the oracle's; where it is missed, the "
        "column says which part, and which seeds fall short of the shrink.", "",
        markdown_table(["hidden", "named first", "gap", "shrink %", "oracle shrink %", "floor bound %", "goal met"],
                       summary_rows), "",
        "## Confusion matrix", "",
        "A row is the hidden effect, a column the first effect the workflow named ('none': nothing named; "
        "'unexplained': nothing named but a residual left above the floor, or one that repeats; a run that "
        "names an effect and still leaves such a residual is counted under the name, and its flag is in the "
        "runs' table).", "",
        markdown_table(["hidden \\ named"] + columns, rows, digits=0), "",
        "## Runs", "",
        "Rivals: candidates that also explained enough with a BIC at most "
        f"{WorkflowSettings().bic_tie:g} above the named one's (the data support them about as well). "
        "Structure %: the largest share of one joint's variance of the residual the final model leaves that the generic "
        "term library predicts on blocks it was not fitted to (0 where it predicts no better than the blocks' "
        "means; flagged unexplained at "
        f"{100 * WorkflowSettings().structure_share:.0f} % or more); oracle structure %: the same for the "
        "residual the oracle leaves. Command shrink %: how much of the held-out "
        "gap between the logged commands and the controller's law the named effects close (only a "
        "controller candidate closes any).", "",
        markdown_table(["hidden", "seed", "named", "indistinguishable", "rivals (BIC higher by)", "gap", "shrink %",
                        "oracle shrink %", "quasi-static shrink %", "floor bound %", "structure %",
                        "oracle structure %", "command shrink %"],
                       run_rows,
                       digits=4),
        ""])
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "confusion.md", text)
    document = {"effects": list(effects), "seeds": list(seeds), "duration_s": duration, "size_factor": size_factor,
                "columns": columns, "starting_structure": list(STARTING_STRUCTURE), "library": list(LIBRARY),
                "inertial_loads": runs[0].get("inertial_loads", "joints") if runs else "joints",
                "matrix": matrix, "runs": runs, **(extra or {})}
    write_json(out / "confusion.json", document)
    print(text)
    return document


def inertial_loads_of(document: dict) -> str:
    """Where the replay of a ``--hidden-effect`` run's ``report.json`` took the links' inertial
    loads from (:data:`~studies.common.discrepancy_runs.INERTIAL_LOADS`): its ``inertial_loads``, or
    for a report written before the option, ``motors`` where the study that preceded it
    (``studies/discrepancy_motor_loads.py``, since removed) marked it (``motor_side_loads``) and
    ``joints`` otherwise."""
    return document.get("inertial_loads") or ("motors" if document.get("motor_side_loads") else "joints")


def run_of_report(document: dict, file) -> dict:
    """The sweep run (as :func:`sweep` records one) of the ``report.json`` of one ``--hidden-effect``
    run, read from ``file``, so that runs made one command per seed are summarised as a sweep is.

    Only a run that knows its generator can be a row: a blind analysis (``--measured``), an ablation
    or a run hiding more than one effect raises :class:`UsageError` naming the file. The floors are
    the report's own (``floor_gap``, ``plant_floor_gap``: the same seed's record with nothing hidden),
    so each run's bound is the one its report states.
    """
    if document.get("analysis") != "blind" or not isinstance(document.get("hidden_effect"), list) \
            or "seed" not in document:
        kind = document.get("analysis", "unknown")
        raise UsageError(f"{file} is not the report of a --hidden-effect run (analysis {kind!r}, no hidden effect "
                         "and seed to tabulate)")
    hidden = document["hidden_effect"]
    if len(hidden) > 1:
        raise UsageError(f"{file} hides {len(hidden)} effects ({', '.join(hidden)}); a row of the table is one effect")
    try:
        named = list(document["named_effects"])
        plant = document["plant_replay"]
        quasi = document["quasi_static"]
        run = {"hidden": hidden[0] if hidden else "none", "seed": int(document["seed"]),
               "inertial_loads": inertial_loads_of(document),
               "named_first": _first_named(named, document["unexplained"]),
               "named": named, "equivalent": {k: list(v) for k, v in document["equivalent"].items()},
               "rivals": {k: dict(v) for k, v in document["rivals"].items()},
               "unexplained": bool(document["unexplained"]), "gap_before": pooled_gap(quasi["gap_before"]),
               "plant_gap_before": pooled_gap(plant["gap_before"]) if plant["applies"] else None,
               "floor": pooled_gap(document["floor_gap"]),
               **({"plant_floor": pooled_gap(document["plant_floor_gap"])}
                  if document.get("plant_floor_gap") is not None else {}),
               "shrink": float(document["shrink"]), "oracle_shrink": float(document["oracle_shrink"]),
               "scored_by": document["scored_by"], "plant_lag_fitted": bool(plant["fits_lag"]),
               "hysteresis_lag_s": plant.get("hysteresis_lag_s"), "quasi_static_shrink": float(quasi["shrink"]),
               "oracle_quasi_static_shrink": float(document["oracle_quasi_static"]["shrink"]),
               "residual_structure": document["residual_structure"],
               "oracle_residual_structure": document["oracle_residual_structure"],
               "signature": list(document["signature"]), "command_shrink": _command_shrink(document["controller"]),
               "backfit_capped": list(document["backfit_capped"]),
               "oracle_backfit_capped": list(document["oracle_backfit_capped"])}
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise UsageError(f"{file} is not a complete --hidden-effect report "
                         f"({type(error).__name__}: {error})") from error
    return run


def _command_shrink(controller: dict | None) -> float | None:
    """:func:`~studies.common.discrepancy_report.command_shrink` from a report's ``controller`` part."""
    if controller is None:
        return None
    return command_gap_shrink(controller["command_gap_before"], controller["command_gap_after"])


def _read_part(path: Path) -> tuple[Path, dict]:
    """The file of one part (a sweep's ``confusion.json`` or a run's ``report.json``, or the folder
    holding one of them) and its JSON document."""
    file = path
    if path.is_dir():
        file = next((path / name for name in ("confusion.json", "report.json") if (path / name).is_file()),
                    path / "confusion.json")
    try:
        document = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise UsageError(f"{file} is not a sweep's confusion.json or a run's report.json "
                         f"({type(error).__name__}: {error})") from error
    return file, document


def read_sweeps(paths) -> tuple[list[dict], float, float, list[str]]:
    """The runs of sweeps made apart (each a folder holding ``confusion.json``, or that file) and of
    single ``--hidden-effect`` runs (a folder holding ``report.json``, or that file;
    :func:`run_of_report`), to be summarised as one: ``(runs, duration_s, size_factor, files)``.

    Sweeps take hours, so they are often run in parts (other seeds, other effects, other hosts), or
    as one command per effect and seed.
    The parts must share the record length, the effect sizes, how a named hysteresis's lag was
    scored by the plant (fitted, or the candidate's constant: a run without ``plant_lag_fitted``
    was swept before the lag was fitted), where the replay took the links' inertial loads from (a
    sweep's runs: from the joints), and this version's starting structure and library, and no
    hidden effect may appear twice with the same seed; anything else raises :class:`UsageError`
    naming the file and what differs.
    """
    runs, seen, files, lengths, factors, lags, loads = [], {}, [], set(), set(), set(), set()
    for path in map(Path, paths):
        file, document = _read_part(path)
        if isinstance(document, dict) and "named_effects" in document and "runs" not in document:
            document = {"runs": [run_of_report(document, file)],
                        **{key: document[key] for key in ("duration_s", "size_factor", "starting_structure", "library")
                           if key in document}}
        if not isinstance(document, dict) or not isinstance(document.get("runs"), list) or "duration_s" not in document:
            raise UsageError(f"{file} is not a sweep's confusion.json or a run's report.json (no 'runs' and "
                             "'duration_s', no 'named_effects')")
        for key, ours in (("starting_structure", STARTING_STRUCTURE), ("library", LIBRARY)):
            if document.get(key) != list(ours):
                raise UsageError(f"{file} was swept with another {key.replace('_', ' ')} ({document.get(key)}) than "
                                 f"this version's ({list(ours)})")
        lengths.add(float(document["duration_s"]))
        factors.add(float(document.get("size_factor", 1.0)))
        if len(lengths) > 1 or len(factors) > 1:
            raise UsageError(f"{file} differs from the sweeps before it in record length or effect size "
                             f"(durations {sorted(lengths)} s, size factors {sorted(factors)})")
        for run in document["runs"]:
            lags.add(bool(run.get("plant_lag_fitted", False)))
            if len(lags) > 1:
                raise UsageError(f"{file} differs from the sweeps before it in how the plant scored a named "
                                 "hysteresis's lag (fitted in some runs, the candidate's constant in others)")
            loads.add(run.get("inertial_loads", "joints"))
            if len(loads) > 1:
                raise UsageError(f"{file} differs from the sweeps before it in where the replay took the links' "
                                 "inertial loads from (the joints in some runs, the motors in others)")
            key = (run["hidden"], run["seed"])
            if key in seen:
                raise UsageError(f"{run['hidden']} with seed {run['seed']} is in both {seen[key]} and {file}")
            seen[key] = file
            runs.append(run)
        files.append(str(file))
    if not runs:
        raise UsageError("the sweeps hold no runs")
    return runs, lengths.pop(), factors.pop(), files
