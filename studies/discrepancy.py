"""The model-discrepancy workflow from the command line: report, tables and plots.

    python studies/discrepancy.py --hidden-effect backlash --seed 0 --out results/discrepancy
    python studies/discrepancy.py --hidden-effect none
    python studies/discrepancy.py --measured ../shared/data/dvrk_hwang2020
    python studies/discrepancy.py --measured recordings/          # bags or dataset files
    python studies/discrepancy.py --sweep --seeds 3               # confusion matrix of hidden vs named

With ``--hidden-effect NAME`` the virtual RAVEN-II generates the "measured" data with its nominal
structure plus NAME (``none``: nothing extra; several names separated by commas); the workflow
starts from the nominal structure without NAME, identified from that data, and must find NAME.
With ``--measured PATH`` it runs on recorded data: RAVEN-II bags or dataset files (a cable model
identified from the data is the start), or the dVRK folder format (nominal model: measured
joints = commanded joints; wrist joints 4-6 by default).

Every run writes ``DIR/report.json``, ``DIR/report.md`` and PNG plots, and exits 0 whenever the
workflow ran, whatever it found; a mistake in the arguments or an unreadable input file gets one
line and exit status 2, before any work and with nothing written.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from simulation.discrepancy import LIBRARY_NAMES, DiscrepancyResult, localize, strongest_dependence
from simulation.discrepancy.signals import pooled_rmse, report_scale
from simulation.model.effects import EFFECT_NAMES
from simulation.recordings.dataset import CalibrationDataset
from studies.common.data_sources import is_dvrk_folder, recorded_datasets
from studies.common.discrepancy_runs import run_hidden_effect, run_on_dvrk, run_on_raven_dataset
from studies.common.reporting import markdown_table, now_iso, to_jsonable, write_json, write_text
from studies.common.runner import (
    StudyRun,
    existing_path,
    non_negative_int,
    positive_float,
    positive_int,
    script_parser,
)

STUDY = "discrepancy"
HIDDEN_CHOICES = ("none",) + tuple(n for n in EFFECT_NAMES if n not in ("cable_stretch", "quantization", "noise",
                                                                         "homing_offset"))
SWEEP_EFFECTS = ("none", "backlash", "coulomb_friction", "viscous_friction", "hysteresis", "gravity_stretch",
                 "coupling", "drift", "capstan_runout")


def parse_hidden(text: str) -> tuple[str, ...]:
    """``"none"`` -> (); ``"backlash,coupling"`` -> ("backlash", "coupling"), with clear errors."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if names == ("none",):
        return ()
    unknown = [n for n in names if n not in HIDDEN_CHOICES or n == "none"]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown hidden effect {', '.join(unknown) or text!r}; choose 'none' or from {', '.join(HIDDEN_CHOICES[1:])}")
    return names


def read_raven_dataset(path: Path, arm: str = "left"):
    """A RAVEN-II dataset from a bag, a folder of bags or dataset files, or one dataset file."""
    datasets, _ = recorded_datasets(path, arm)
    return CalibrationDataset.concat(datasets) if Path(path).is_dir() else datasets[0]


def joint_numbers(text: str) -> tuple[int, ...]:
    """``"4,5,6"`` -> (4, 5, 6): dVRK joints, numbered 1 to 6."""
    try:
        joints = tuple(int(j) for j in text.split(",") if j.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected joint numbers 1-6 separated by commas, got {text!r}") from None
    if not joints or any(not 1 <= j <= 6 for j in joints) or len(set(joints)) != len(joints):
        raise argparse.ArgumentTypeError(f"expected distinct joint numbers 1-6 separated by commas, got {text!r}")
    return joints


def _scaled(values, units) -> list[float]:
    return (np.asarray(values) * report_scale(units)).tolist()


def _unit_names(units) -> list[str]:
    return ["deg" if u == "rad" else "mm" for u in units]


def report_document(result: DiscrepancyResult, source: dict, runtime_s: float) -> dict:
    """``report.json``: the issue's keys plus the iterations and the configuration."""
    return {
        "named_effects": list(result.named_effects),
        "unexplained": bool(result.unexplained),
        "gap_before": [float(v) for v in result.gap_before],
        "gap_after": [float(v) for v in result.gap_after],
        "shrink": float(result.shrink),
        "fitted_parameters": to_jsonable(result.fitted_parameters),
        "units": list(result.units),
        "joints": list(result.joint_names),
        "gap_before_report_units": _scaled(result.gap_before, result.units),
        "gap_after_report_units": _scaled(result.gap_after, result.units),
        "report_units": _unit_names(result.units),
        "iterations": [
            {"validation_gap": it.gap_before, "named": it.named,
             "candidates": [{"name": s.name, "fitted": s.fitted, "validation_gap": s.validation_gap, "fit_gap": s.fit_gap,
                             "bic": s.bic, "screened_chi_square": s.screened_chi_square, "parameters": s.values}
                            for s in it.scores]}
            for it in result.iterations
        ],
        "library": list(LIBRARY_NAMES),
        "source": source,
        "created": now_iso(),
        "runtime_s": round(runtime_s, 1),
    }


def _plots(result: DiscrepancyResult, signals, split, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scale = report_scale(result.units)
    units = _unit_names(result.units)
    paths = []
    time_axis = signals.time[split.held_out] - signals.time[0]
    figure, axes = plt.subplots(signals.n_joints, 1, figsize=(9, 2.4 * signals.n_joints), sharex=True)
    for j, ax in enumerate(np.atleast_1d(axes)):
        ax.plot(time_axis, result.residual_before.joints[:, j] * scale[j], lw=0.8, label="starting model")
        ax.plot(time_axis, result.residual_after.joints[:, j] * scale[j], lw=0.8, label="with named effects")
        ax.set_ylabel(f"{result.joint_names[j]} ({units[j]})")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].legend(loc="upper right")
    np.atleast_1d(axes)[-1].set_xlabel("time (s)")
    figure.suptitle("Held-out residual, measured minus model")
    figure.tight_layout()
    paths.append(out / "residual_over_time.png")
    figure.savefig(paths[-1], dpi=110)
    plt.close(figure)

    before = result.model_before.replay(signals).joints
    residual = signals.truth - before
    velocity = signals.velocity
    figure, axes = plt.subplots(signals.n_joints, 2, figsize=(10, 2.4 * signals.n_joints))
    axes = np.atleast_2d(axes)
    mask = split.fit | split.validation
    for j in range(signals.n_joints):
        axes[j, 0].scatter(velocity[mask, j] * scale[j], residual[mask, j] * scale[j], s=2, alpha=0.3)
        axes[j, 0].set_xlabel(f"{result.joint_names[j]} speed ({units[j]}/s)")
        axes[j, 0].set_ylabel(f"residual ({units[j]})")
        axes[j, 1].scatter(signals.travel[mask, j] * scale[j], residual[mask, j] * scale[j], s=2, alpha=0.3)
        axes[j, 1].set_xlabel(f"{result.joint_names[j]} accumulated travel ({units[j]})")
    figure.suptitle("Residual of the starting model against speed and operating time")
    figure.tight_layout()
    paths.append(out / "residual_vs_variables.png")
    figure.savefig(paths[-1], dpi=110)
    plt.close(figure)
    return paths


def write_report(result: DiscrepancyResult, signals, split, source: dict, out: Path, runtime_s: float) -> list[Path]:
    """Write ``report.json``, ``report.md`` and the plots of one workflow run in the folder ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    document = report_document(result, source, runtime_s)
    json_path = write_json(out / "report.json", document)
    units = _unit_names(result.units)
    before_state = result.model_before.replay(signals)
    table = localize(signals, signals.truth - before_state.joints, before_state, split.fit | split.validation)
    dependence = strongest_dependence(table)
    rows = [[name, f"{b:.4f} {u}", f"{a:.4f} {u}"] for name, b, a, u in
            zip(result.joint_names, document["gap_before_report_units"], document["gap_after_report_units"], units)]
    iteration_rows = []
    for k, it in enumerate(result.iterations):
        for s in it.scores:
            iteration_rows.append([str(k + 1), s.name, "yes" if s.fitted else "screened only", s.fit_gap,
                                   s.validation_gap, s.bic, "named" if it.named == s.name else ""])
    sections = [
        f"# Model discrepancy: {source.get('description', '')}",
        "",
        f"- named effects (in order): {', '.join(result.named_effects) or 'none'}",
        f"- unexplained residual left: {'yes' if result.unexplained else 'no'}",
        f"- held-out gap shrink (pooled, deg and mm): {100 * result.shrink:.1f} %",
        f"- run: {document['created']}, {runtime_s:.0f} s",
        "",
        "## Held-out gap per joint (RMSE, measured minus model)",
        "",
        markdown_table(["joint", "before", "after"], rows),
        "",
        "## Candidates per iteration (gaps: pooled RMSE, deg and mm)",
        "",
        markdown_table(["iteration", "candidate", "fitted", "fit-part gap", "validation gap", "BIC", ""], iteration_rows,
                       digits=4),
        "",
        "## Where the starting model's residual is (spread of bin means, deg or mm)",
        "",
        markdown_table(list(dependence.columns), dependence.values.tolist(), digits=4),
        "",
        "## Fitted parameters of the named effects (SI)",
        "",
        "```",
        "\n".join(f"{name}: {values}" for name, values in result.fitted_parameters.items()) or "(none)",
        "```",
        "",
    ]
    figures = _plots(result, signals, split, out)
    table.to_csv(out / "localization.csv", index=False)
    sections += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in figures] + [""]
    md_path = write_text(out / "report.md", "\n".join(sections))
    return [json_path, md_path, *figures]


def sweep(effects, seeds, duration: float, out: Path) -> dict:
    """Hide each effect with each seed; the confusion matrix of hidden vs named (first named)."""
    from joblib import Parallel, delayed

    def one(effect, seed):
        hidden = () if effect == "none" else (effect,)
        result, *_ = run_hidden_effect(hidden, seed=seed, duration=duration)
        named = result.named_effects[0] if result.named_effects else ("unexplained" if result.unexplained else "none")
        return effect, seed, named, list(result.named_effects), float(result.shrink)

    runs = Parallel(n_jobs=-1)(delayed(one)(e, s) for e in effects for s in seeds)
    columns = sorted({r[2] for r in runs} | set(effects) | {"unexplained"}, key=lambda n: (n != "none", n))
    matrix = {e: {c: sum(1 for r in runs if r[0] == e and r[2] == c) for c in columns} for e in effects}
    rows = [[e] + [matrix[e][c] for c in columns] for e in effects]
    text = "\n".join([
        "# Hidden vs named effects", "",
        f"Seeds {list(seeds)}, {duration:.0f} s of random motion per run; a row is the hidden effect, "
        "a column the first effect the workflow named ('none': nothing named; 'unexplained': nothing named "
        "but a residual left).", "",
        markdown_table(["hidden \\ named"] + columns, rows, digits=0), "",
        "Runs: " + "; ".join(f"{e} seed {s}: {n} (shrink {100 * k:.0f} %)" for e, s, _, n, k in runs), ""])
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "confusion.md", text)
    document = {"effects": list(effects), "seeds": list(seeds), "duration_s": duration, "columns": columns,
                "matrix": matrix, "runs": [{"hidden": e, "seed": s, "named": n, "shrink": k} for e, s, _, n, k in runs]}
    write_json(out / "confusion.json", document)
    print(text)
    return document


def main(argv=None) -> int:
    parser = script_parser(STUDY, __doc__)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--hidden-effect", type=parse_hidden, metavar="NAME",
                        help=f"'none' or effects to hide, comma-separated: {', '.join(HIDDEN_CHOICES[1:])}")
    source.add_argument("--measured", type=existing_path, metavar="PATH",
                        help="recorded data: bag(s), dataset file(s), or the dVRK folder format")
    source.add_argument("--sweep", action="store_true", help="confusion matrix of hidden vs named effects")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument("--seeds", type=positive_int, default=3, help="seeds per effect for --sweep")
    parser.add_argument("--duration", type=positive_float, default=240.0, help="seconds of generated random motion")
    parser.add_argument("--joints", type=joint_numbers, default="4,5,6", help="dVRK joints (1-6) to study")
    parser.add_argument("--arm", default="left", choices=("left", "right"))
    parser.add_argument("--out", type=Path, default=Path("results") / "discrepancy")
    with StudyRun(parser, argv) as study:
        args = study.args
        if args.sweep:
            sweep(SWEEP_EFFECTS, range(args.seed, args.seed + args.seeds), args.duration, study.folder)
            study.publish()
            study.done()
            return 0
        if args.hidden_effect is not None:
            result, signals, split, generator = run_hidden_effect(args.hidden_effect, seed=args.seed,
                                                                  duration=args.duration)
            source = {"kind": "simulated", "hidden": list(args.hidden_effect), "seed": args.seed,
                      "duration_s": args.duration,
                      "description": f"virtual RAVEN-II with hidden {', '.join(args.hidden_effect) or 'nothing'}"}
        elif is_dvrk_folder(args.measured):
            joints = tuple(j - 1 for j in args.joints)
            root = args.measured.parent if (args.measured / "q_des.npy").exists() else args.measured
            with study.reading(args.measured):
                result, signals, split = run_on_dvrk(root, joints)
            text = ",".join(str(j) for j in args.joints)
            source = {"kind": "dvrk", "path": str(args.measured), "joints": [j + 1 for j in joints],
                      "description": f"dVRK data of Hwang et al. 2020, joints {text} "
                                     "(fit on random motion, held out: peg transfer)"}
        else:
            with study.reading(args.measured):
                dataset = read_raven_dataset(args.measured, args.arm)
            result, signals, split = run_on_raven_dataset(dataset)
            source = {"kind": "raven", "path": str(args.measured), "description": f"RAVEN-II data {args.measured}"}
        write_report(result, signals, split, source, study.folder, study.stop_clock())
        study.publish()
    units = _unit_names(result.units)
    print(f"named effects: {', '.join(result.named_effects) or 'none'}; unexplained: {result.unexplained}")
    for name, b, a, u in zip(result.joint_names, _scaled(result.gap_before, result.units),
                             _scaled(result.gap_after, result.units), units):
        print(f"  {name:12s} held-out gap {b:9.4f} -> {a:9.4f} {u}")
    print(f"shrink (pooled, deg and mm): {100 * result.shrink:.1f} %   "
          f"[{pooled_rmse(result.residual_before.joints, result.units):.4f} -> "
          f"{pooled_rmse(result.residual_after.joints, result.units):.4f}]")
    study.done()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
