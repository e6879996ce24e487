"""The model-discrepancy workflow from the command line: report, tables and plots.

    python studies/discrepancy.py --hidden-effect backlash --seed 0 --out results/discrepancy
    python studies/discrepancy.py --measured results/discrepancy/measured.parquet --out results/again
    python studies/discrepancy.py --hidden-effect none
    python studies/discrepancy.py --ablate coupling                 # the model lacks a term the data have
    python studies/discrepancy.py --measured ../shared/data/dvrk_hwang2020
    python studies/discrepancy.py --sweep --seeds 5 --duration 240  # hidden vs named, with the oracle
    python studies/discrepancy.py --merge-sweeps PART1 PART2        # one table from sweeps run apart

``--measured PATH`` is the blind analysis. On RAVEN-II data (a dataset file ``.parquet``/``.csv``,
ROS bags, or a folder of either) it always starts from the same structure, the cable model of
``STARTING_STRUCTURE`` identified on the first half of the record, and screens the same library
``LIBRARY`` (:mod:`studies.common.discrepancy_runs`); it takes no seed and knows nothing of how the
data were made. ``--max-rate HZ`` keeps every k-th row of a faster RAVEN-II log first (its thresholds
were set on 30 Hz logs, and its cost grows with the rows). ``--backfit-rounds N`` allows N rounds
of re-identifying the starting structure around a candidate instead of thirty (``report.json``'s
``backfit_capped`` names the fits the cap cut short; with ``--hidden-effect`` the oracle gets the
same cap). On the dVRK folder format the start is
the dVRK's own nominal model (measured joints = reported joints plus offsets; wrist joints 4-6 by
default) with the generic library.

``--hidden-effect NAME`` generates data with the virtual RAVEN-II (twenty minutes of random motion
unless ``--duration`` says otherwise): the starting structure plus NAME and nothing else (``none``:
nothing; several names separated by commas; NAME from the library, or ``capstan_runout``, which the
library lacks), logged at the robot's 30 Hz unless ``--log-rate`` says otherwise. It writes them as
``DIR/measured.parquet`` and runs
exactly the ``--measured`` analysis on that file. Only then, knowing the generator, it adds to the
report the true parameters beside the fitted ones and the oracle: the generator's true structure
fitted to the same fit part, whose held-out gap is what a model of the right structure closes, and
the floor: the gap the starting model leaves on the same seed's record with nothing hidden, and the
share of this record's gap above it (``floor_gap``, ``floor_bound``). An
effect of the starting structure cannot be hidden (the data would not change): ``--ablate NAME``
instead generates with the full structure and analyses from the structure without NAME, with NAME
among the candidates; that is an ablation, and its report says so.

Every run writes ``DIR/report.json``, ``DIR/report.md`` and PNG plots, and exits 0 whenever the
workflow ran, whatever it found; a mistake in the arguments or an unreadable input file gets one
line and exit status 2, before any work and with nothing written.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from simulation.discrepancy import DiscrepancyResult, WorkflowSettings, localize, strongest_dependence
from simulation.discrepancy.signals import RAVEN_UNITS, pooled_rmse, report_scale
from simulation.engine.robot import LOG_RATE, TRUTH_RATE
from studies.common.data_sources import is_dvrk_folder
from studies.common.discrepancy_runs import (
    ABLATION_CHOICES,
    DEFAULT_RECORD_S,
    HIDDEN_CHOICES,
    HIDDEN_PAYLOAD_KG,
    LIBRARY,
    learned_calibrators_on_dvrk,
    STARTING_STRUCTURE,
    UNMODELLED_EFFECTS,
    analyse_measured,
    analysis_settings,
    check_hidden,
    floor_bound,
    floor_gap,
    shrink_bound,
    generate_measured,
    largest_share,
    oracle,
    read_measured,
    record_length,
    run_ablation,
    run_on_dvrk,
    run_on_raven_dataset,
    SHORT_RECORD_S,
    drift_record_note,
    log_rate_options,
    short_record_note,
    true_values,
    verdict,
    write_measured,
)
from studies.common.reporting import markdown_table, now_iso, to_jsonable, write_json, write_text
from studies.common.runner import (
    StudyRun,
    UsageError,
    existing_path,
    non_negative_int,
    positive_float,
    positive_int,
    say,
    script_parser,
)

STUDY = "discrepancy"
SWEEP_EFFECTS = HIDDEN_CHOICES
DVRK_STARTING_MODEL = "reported joints plus constant offsets (the dVRK's nominal model)"


def parse_hidden(text: str) -> tuple[str, ...]:
    """``"none"`` -> (); ``"backlash,drift"`` -> ("backlash", "drift"), refusing what cannot be hidden."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if names == ("none",):
        return ()
    if not names:
        raise argparse.ArgumentTypeError(f"unknown hidden effect {text!r}; choose 'none' or from "
                                         f"{', '.join(HIDDEN_CHOICES[1:])}")
    try:
        return check_hidden(names)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def parse_effect_list(text: str) -> tuple[str, ...]:
    """``"none,backlash"`` -> ("none", "backlash"): the hidden effects of a sweep, each a valid choice."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    for name in names:
        if name != "none":
            parse_hidden(name)
    if not names:
        raise argparse.ArgumentTypeError(f"expected effect names separated by commas, got {text!r}")
    return names


def parse_ablated(text: str) -> str:
    if text not in ABLATION_CHOICES:
        raise argparse.ArgumentTypeError(f"cannot ablate {text!r}; choose from {', '.join(ABLATION_CHOICES)}")
    return text


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


REPORT_UNITS = {"rad": ("deg", 180.0 / np.pi), "m": ("mm", 1000.0), "rad/h": ("deg/h", 180.0 / np.pi),
                "m/h": ("mm/h", 1000.0), "rad/rad": ("deg/deg", 1.0), "m/m": ("mm/mm", 1.0)}
"""SI units of parameter values shown in degrees or millimetres in ``report.md`` (others stay SI)."""


def _value_labels(size: int, joint_names, block: str = "") -> list[str]:
    """What each value of a parameter block refers to: a joint, a pair of joints, or a homing (second,
    third ... of the record: registration offsets relative to the first) and a joint, or a pair of joints
    (or a joint and its own motion) and a play operator's half-width (the weights of
    ``coupled_hysteresis``, in either of its forms)."""
    from simulation.discrepancy.generic import HYSTERESIS_WIDTH_FRACTIONS

    j = len(joint_names)
    if block == "weight" and size == j * j * len(HYSTERESIS_WIDTH_FRACTIONS):
        return [f"{joint_names[r]} from {joint_names[c]}, play of 1/{round(1 / f)} of its range"
                for r in range(j) for c in range(j) for f in HYSTERESIS_WIDTH_FRACTIONS]
    if block == "weight" and size == j * len(HYSTERESIS_WIDTH_FRACTIONS):
        return [f"{joint_names[r]} from its own motion, play of 1/{round(1 / f)} of its range"
                for r in range(j) for f in HYSTERESIS_WIDTH_FRACTIONS]
    if block == "offset" and size % j == 0:
        return [f"homing {k + 2} of the record, {joint_names[i]}" for k in range(size // j) for i in range(j)]
    if size == j:
        return list(joint_names)
    if size == j * (j - 1):
        return [f"{joint_names[r]} from {joint_names[c]}" for r in range(j) for c in range(j) if r != c]
    return [str(i) for i in range(size)]


def parameter_rows(fitted: dict, units: dict, joint_names, truth: dict | None = None) -> list[list]:
    """Rows (effect, parameter, joint, fitted[, true], unit) in report units, one per value."""
    rows = []
    for effect, blocks in fitted.items():
        for block, values in blocks.items():
            values = np.atleast_1d(np.asarray(values, dtype=float))
            block_units = units.get(effect, {}).get(block, [""] * values.size)
            true = None if truth is None else truth.get(effect)
            true = true.get(block) if isinstance(true, dict) else true
            labels = _value_labels(values.size, joint_names, block)
            for i, (label, value, unit) in enumerate(zip(labels, values, block_units)):
                shown, factor = REPORT_UNITS.get(unit, (unit, 1.0))
                row = [effect, block, label, value * factor]
                if truth is not None:
                    row.append("-" if true is None else true if isinstance(true, str)
                               else np.asarray(true, dtype=float).ravel()[i] * factor)
                rows.append(row + [shown or "1"])
    return rows


def file_digest(path: Path) -> str:
    """SHA-256 of a file (a folder: of its files in name order), so a report names exactly its input."""
    digest = hashlib.sha256()
    files = sorted(p for p in Path(path).rglob("*") if p.is_file()) if Path(path).is_dir() else [Path(path)]
    for file in files:
        digest.update(file.read_bytes())
    return digest.hexdigest()


def _command_shrink(result: DiscrepancyResult) -> float | None:
    """1 - after/before of the controller replay's held-out command gap, pooled over the joints
    (N m); None when the controller was not replayed."""
    check = result.controller
    if check is None:
        return None
    before = float(np.sqrt(np.mean(np.square(check.held_out_gap_before))))
    return float(1.0 - np.sqrt(np.mean(np.square(check.held_out_gap_kept))) / before) if before > 0 else 0.0


def _controller_document(result: DiscrepancyResult) -> dict | None:
    """The controller replay's part of ``report.json`` (command gaps: RMS of logged minus replayed
    command per joint, N m at the gearbox output), None when it did not run."""
    check = result.controller
    if check is None:
        return None
    return {"named": bool(check.named), "scale_error": [float(v) for v in check.scale_error],
            "command_gap_before": [float(v) for v in check.held_out_gap_before],
            "command_gap_after": [float(v) for v in check.held_out_gap_kept],
            "fit_command_gap": [[float(v) for v in check.fit_gap_before], [float(v) for v in check.fit_gap_after]],
            "validation_command_gap": [[float(v) for v in check.validation_gap_before],
                                       [float(v) for v in check.validation_gap_after]],
            "bic": [check.bic_before, check.bic_after], "units": "N m at the gearbox output"}


def report_document(result: DiscrepancyResult, source: dict, runtime_s: float,
                    starting_structure=STARTING_STRUCTURE, analysis: str = "blind") -> dict:
    """``report.json``: what the analysis found, its starting point and library, the iterations."""
    return {
        "analysis": analysis,
        "starting_structure": list(starting_structure),
        "library": list(result.library),
        "named_effects": list(result.named_effects),
        "unexplained": bool(result.unexplained),
        "gap_before": [float(v) for v in result.gap_before],
        "gap_after": [float(v) for v in result.gap_after],
        "shrink": float(result.shrink),
        "torque_gap_before": None if result.torque_gap_before is None else [float(v) for v in result.torque_gap_before],
        "torque_gap_after": None if result.torque_gap_after is None else [float(v) for v in result.torque_gap_after],
        "equivalent": {k: list(v) for k, v in result.equivalent.items()},
        "rivals": {k: dict(v) for k, v in result.rivals.items()},
        "signature": list(result.signature),
        "residual_structure": _structure_list(result),
        "backfit_rounds": result.backfit_rounds,
        "backfit_capped": list(result.backfit_capped),
        "controller": _controller_document(result),
        "fitted_parameters": to_jsonable(result.fitted_parameters),
        "parameter_units": to_jsonable(result.parameter_units),
        "units": list(result.units),
        "joints": list(result.joint_names),
        "gap_before_report_units": _scaled(result.gap_before, result.units),
        "gap_after_report_units": _scaled(result.gap_after, result.units),
        "report_units": _unit_names(result.units),
        "iterations": [
            {"validation_gap": it.gap_before, "fit_gap": it.fit_gap_before, "bic": it.bic_before, "named": it.named,
             "validation_torque_gap": it.torque_gap_before, "fit_torque_gap": it.fit_torque_gap_before,
             "equivalent": list(it.equivalent), "rivals": dict(it.rivals),
             "candidates": [{"name": s.name, "fitted": s.fitted, "validation_gap": s.validation_gap, "fit_gap": s.fit_gap,
                             "validation_torque_gap": s.torque_gap, "fit_torque_gap": s.fit_torque_gap,
                             "bic": s.bic, "screened_chi_square": s.screened_chi_square, "parameters": s.values,
                             "backfit_rounds": s.backfit_rounds, "backfit_capped": s.backfit_capped}
                            for s in it.scores]}
            for it in result.iterations
        ],
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
        ax.set_ylabel(f"{result.joint_names[j]} residual ({units[j]})")
        ax.grid(alpha=0.3)
    np.atleast_1d(axes)[0].legend(loc="upper right")
    np.atleast_1d(axes)[-1].set_xlabel("time since the start of the record (s)")
    figure.suptitle("Held-out part: residual (measured minus model) over time")
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
        axes[j, 0].set_xlabel(f"{result.joint_names[j]} velocity ({units[j]}/s)")
        axes[j, 0].set_ylabel(f"{result.joint_names[j]} residual ({units[j]})")
        axes[j, 1].scatter(signals.travel[mask, j] * scale[j], residual[mask, j] * scale[j], s=2, alpha=0.3)
        axes[j, 1].set_xlabel(f"{result.joint_names[j]} accumulated travel ({units[j]})")
    figure.suptitle("Fit and validation parts: starting model's residual against velocity and accumulated travel")
    figure.tight_layout()
    paths.append(out / "residual_vs_variables.png")
    figure.savefig(paths[-1], dpi=110)
    plt.close(figure)
    return paths


COLUMNS_EXPLAINED = """\
Each iteration first shows the current model (candidate "(current model)"), then each candidate
added to it. Columns: *fitted*: fitted in full (or only screened by a coarse scan of its
parameters); *fit-part gap*, *validation gap*: pooled RMSE of measured minus model over the joints
(degrees and millimetres together) on the fit part and on the validation part; *BIC*: the
validation part's weighted squared residual (joints and motor torques, each weighted by the current
model's misfit) plus k ln n for the candidate's k parameters; lower BIC is better; *torque gap*: RMS
of the motor-torque residual on the validation part, each joint over the current model's typical
misfit (1 = as large as the current model's; "-" without torques). The candidate named is the one
of lowest BIC, below the current model's, that cuts both joint gaps by at least 10 % (or, for an
effect seen only in the motor torques, the torque gap on both parts)."""


def _drag_section(result: DiscrepancyResult, signals, split) -> list[str]:
    """With ``coupled_hysteresis`` named on generic data, how much each joint's motion drags each
    joint (RMS over the fit and validation parts, report units): its weights summed per pair."""
    from simulation.discrepancy.generic import NominalModel, coupled_hysteresis_shares

    model = result.model_after
    if not isinstance(model, NominalModel) or "coupled_hysteresis" not in model.effects:
        return []
    shares = coupled_hysteresis_shares(model.effects["coupled_hysteresis"], signals, split.fit | split.validation)
    scale = report_scale(result.units)
    units = _unit_names(result.units)
    rows = [[f"{name} ({unit})", *(shares[j] * scale[j])] for j, (name, unit) in enumerate(zip(result.joint_names,
                                                                                                units))]
    return ["## Which joint drags which (coupled hysteresis)", "",
            "RMS over the fit and validation parts of what each joint's motion (column) adds to each joint (row) "
            "through the named coupled hysteresis; the diagonal is a joint's own hysteresis.", "",
            markdown_table(["moved joint", *[f"by {name}" for name in result.joint_names]], rows, digits=3), ""]


def write_report(result: DiscrepancyResult, signals, split, source: dict, out: Path, runtime_s: float,
                 starting_structure=STARTING_STRUCTURE, analysis: str = "blind") -> list[Path]:
    """Write ``report.json``, ``report.md`` and the plots of one workflow run in the folder ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    document = report_document(result, source, runtime_s, starting_structure, analysis)
    note = short_record_note(signals)
    document["record_s"] = float(signals.time[-1] - signals.time[0])
    document["short_record"] = note
    drift_note = drift_record_note(signals)
    document["drift_note"] = drift_note
    json_path = write_json(out / "report.json", document)
    units = _unit_names(result.units)
    before_state = result.model_before.replay(signals)
    table = localize(signals, signals.truth - before_state.joints, before_state, split.fit | split.validation)
    dependence = strongest_dependence(table)
    rows = [[name, f"{b:.4f} {u}", f"{a:.4f} {u}"] for name, b, a, u in
            zip(result.joint_names, document["gap_before_report_units"], document["gap_after_report_units"], units)]
    iteration_rows = []
    for k, it in enumerate(result.iterations):
        iteration_rows.append([str(k + 1), "(current model)", "", it.fit_gap_before, it.gap_before,
                               it.torque_gap_before, it.bic_before, ""])
        for s in it.scores:
            iteration_rows.append([str(k + 1), s.name, "yes" if s.fitted else "screened only", s.fit_gap,
                                   s.validation_gap, s.torque_gap, s.bic, "named" if it.named == s.name else ""])
    start = ", ".join(starting_structure) if starting_structure else DVRK_STARTING_MODEL
    kind = "Ablation (the model lacks a term the data have)" if analysis == "ablation" else "Blind analysis"
    parameter_table = parameter_rows(result.fitted_parameters, result.parameter_units, result.joint_names)
    sections = [
        f"# Model discrepancy: {source.get('description', '')}",
        "",
        f"{kind}. Starting structure: {start}. Candidates screened: {', '.join(result.library) or 'none'}.",
        "",
        *([] if note is None else [f"**Short record:** {note}.", ""]),
        *([] if drift_note is None else [f"**Record too short for drift:** {drift_note}.", ""]),
        f"- named effects (in order): {', '.join(result.named_effects) or 'none'}",
        *[f"- {named} was named by a BIC margin of at most {WorkflowSettings().bic_tie:g} over "
          + ", ".join(f"{name} (BIC higher by {d:.2f})" for name, d in rivals.items())
          + ": the data support those about as well" for named, rivals in result.rivals.items()],
        f"- unexplained residual left: {'yes' if result.unexplained else 'no'}",
        *[f"- the backfit of {name} was still lowering the fit part's residual at its last allowed round "
          f"(round {result.backfit_rounds}; `--backfit-rounds` allows more): its fit, and the shrink, may stop short"
          for name in result.backfit_capped],
        *([] if result.residual_structure is None else [
            "- repeatable structure of the residual the final model leaves (share of each joint's variance the "
            f"generic term library predicts on blocks it was not fitted to; flagged unexplained at "
            f"{100 * WorkflowSettings().structure_share:.0f} % or more; 0 % where the library predicts no "
            "better than each block's mean): "
            + ", ".join(f"{name} {100 * max(v, 0.0):.0f} %" for name, v in zip(result.joint_names,
                                                                            result.residual_structure))]),
        *([] if result.controller is None else [
            "- controller replay (logged commands against the controller's law, held-out RMS per joint, N m): "
            + ", ".join(f"{name} {b:.4g} -> {a:.4g}" for name, b, a in zip(
                result.joint_names, document["controller"]["command_gap_before"],
                document["controller"]["command_gap_after"]))
            + (f"; gravity model scale error fitted: {', '.join(f'{v:+.4f}' for v in result.controller.scale_error)}"
               if result.controller.named else "; nothing named")]),
        f"- held-out gap shrink (pooled RMSE, deg and mm): {100 * result.shrink:.1f} %",
        f"- run: {document['created']}, {runtime_s:.0f} s",
        "",
        "## Held-out gap per joint (RMSE, measured minus model)",
        "",
        markdown_table(["joint", "starting model", "with named effects"], rows),
        "",
        "## Candidates per iteration (gaps: pooled RMSE, deg and mm)",
        "",
        COLUMNS_EXPLAINED,
        "",
        markdown_table(["iteration", "candidate", "fitted", "fit-part gap", "validation gap", "torque gap", "BIC", ""],
                       iteration_rows, digits=4),
        "",
        "## Where the starting model's residual is (fit and validation parts)",
        "",
        "The residual binned by each variable (quartiles; direction of motion; homing); the spread is the "
        "largest minus the smallest bin mean, in degrees or millimetres: large means the residual depends on it.",
        "",
        markdown_table(list(dependence.columns), dependence.values.tolist(), digits=4),
        "",
        "## Fitted parameters of the named effects",
        "",
        markdown_table(["effect", "parameter", "joint", "fitted", "unit"], parameter_table, digits=4)
        if parameter_table else "(none named)",
        "",
        *_drag_section(result, signals, split),
        "## Signature of the unexplained residual (fit and validation parts)",
        "",
        "\n".join(f"- {s}" for s in result.signature) if result.signature else
        ("(a residual is left but no term of the generic library stands out)" if result.unexplained
         else "(nothing unexplained)"),
        "",
    ]
    figures = _plots(result, signals, split, out)
    table.to_csv(out / "localization.csv", index=False)
    sections += ["## Figures", ""] + [f"![{p.stem}]({p.name})" for p in figures] + [""]
    md_path = write_text(out / "report.md", "\n".join(sections))
    return [json_path, md_path, *figures]


def analyse(path: Path, out: Path, runtime_s=None, shown_path: Path | None = None, arm: str = "left",
            progress: bool = False, max_rate: float | None = None, backfit_rounds: int | None = None):
    """The blind ``--measured`` analysis of RAVEN-II data at ``path``, reported in ``out``.

    Returns the result, signals and split. ``shown_path`` is the input's name in the report (where
    the file will be once published); ``arm`` is for bags and CSV files (a Parquet dataset file
    records its own); ``max_rate`` (Hz) thins a faster log first; ``backfit_rounds`` caps the
    backfit's rounds instead of the workflow's default. The analysis reads ``path`` and
    nothing else (:func:`~studies.common.discrepancy_runs.analyse_measured`).
    """
    import time

    clock = time.perf_counter()
    say("identifying the starting model and screening the library...")
    if arm == "left":
        result, signals, split = analyse_measured(path, progress=progress, max_rate=max_rate,
                                                  backfit_rounds=backfit_rounds)
    else:
        result, signals, split = run_on_raven_dataset(read_measured(path, arm, max_rate), progress=progress,
                                                      settings=analysis_settings(backfit_rounds))
    source = {"kind": "raven", "path": str(shown_path or path), "sha256": file_digest(path),
              "description": f"RAVEN-II data {Path(shown_path or path).name}"}
    if max_rate is not None:
        source["max_rate_hz"] = float(max_rate)
        source["description"] += f", thinned to at most {max_rate:g} Hz"
    write_report(result, signals, split, source, out, time.perf_counter() - clock if runtime_s is None else runtime_s)
    return result, signals, split


def _insert_before_figures(out: Path, lines: list[str]) -> None:
    """Insert a section (``lines``) into ``out/report.md`` just before its figures."""
    md = Path(out) / "report.md"
    text = md.read_text()
    cut = text.index("## Figures")
    write_text(md, text[:cut] + "\n".join(lines) + "\n" + text[cut:])


def _structure_list(result: DiscrepancyResult) -> list[float] | None:
    """The per-joint shares of the structure check, as a JSON list (None where the record was too short)."""
    return None if result.residual_structure is None else [float(v) for v in result.residual_structure]


def _share_text(shares) -> str:
    share = largest_share(shares)
    return "-" if share is None else f"{share:.0f}"


def _repeats(shares) -> bool:
    """Whether a run's per-joint structure shares reach the workflow's flag."""
    return shares is not None and max(shares) >= WorkflowSettings().structure_share


def add_generator_knowledge(out: Path, hidden, seed: int, duration: float, generator, path: Path,
                            result: DiscrepancyResult, size_factor: float = 1.0, log_rate: float = LOG_RATE) -> dict:
    """After the blind analysis: add the hidden effect, the true parameters, the oracle (with the
    analysis's backfit cap) and the floor (:func:`~studies.common.discrepancy_runs.floor_gap`: the
    gap the starting model leaves on the same seed's record with nothing hidden) to the report."""
    report_path = Path(out) / "report.json"
    document = json.loads(report_path.read_text())
    fit = oracle(path, hidden, backfit_rounds=result.backfit_rounds)
    floor = result.gap_before if not hidden else floor_gap(seed, duration, log_rate_options(log_rate))
    bound = floor_bound(floor, result.gap_before, result.units)
    to_report = report_scale(result.units)
    before = pooled_rmse(result.residual_before.joints, result.units)
    oracle_after = float(np.sqrt(np.mean(np.square(fit.gap_after * to_report))))
    oracle_shrink = float(1.0 - oracle_after / before) if before > 0 else 0.0
    fraction = float(result.shrink / oracle_shrink) if oracle_shrink > 0 else None
    payload_kg = HIDDEN_PAYLOAD_KG * size_factor if "payload" in hidden else 0.0
    structure = list(generator.enabled_effects) + (["payload"] if payload_kg else [])

    def truth_of(name):
        if name not in structure:
            return "absent from the generator"
        return true_values(generator, name, payload_kg) or "drawn at each homing"

    named = set(hidden) | set(result.named_effects) | set(fit.named_effects)
    truth = {name: truth_of(name) for name in named}
    document.update({
        "hidden_effect": list(hidden),
        "seed": seed,
        "duration_s": duration,
        "size_factor": size_factor,
        "log_rate_hz": log_rate,
        "generator_structure": structure,
        "true_parameters": to_jsonable({k: v for k, v in truth.items() if isinstance(v, dict)}),
        "oracle_gap_after": [float(v) for v in fit.gap_after],
        "oracle_shrink": oracle_shrink,
        "oracle_fitted_parameters": to_jsonable(fit.fitted_parameters),
        "fraction_of_oracle_shrink": fraction,
        "oracle_residual_structure": _structure_list(fit),
        "oracle_backfit_capped": list(fit.backfit_capped),
        "floor_gap": [float(v) for v in floor],
        "floor_bound": bound,
    })
    write_json(report_path, document)
    units = _unit_names(result.units)
    rows = [[name, f"{b:.4f} {u}", f"{a:.4f} {u}", f"{o:.4f} {u}"] for name, b, a, o, u in
            zip(result.joint_names, _scaled(result.gap_before, result.units), _scaled(result.gap_after, result.units),
                _scaled(fit.gap_after, result.units), units)]
    fitted_rows = parameter_rows(result.fitted_parameters, result.parameter_units, result.joint_names, truth)
    oracle_rows = parameter_rows(fit.fitted_parameters, fit.parameter_units, result.joint_names, truth)
    section = [
        "## What generated the data (added after the blind analysis)",
        "",
        f"Hidden effect: {', '.join(hidden) or 'none'} (seed {seed}, {duration:.0f} s of random motion logged at "
        f"{log_rate:g} Hz, "
        + ("at its default size" if size_factor == 1.0 else f"at {size_factor:g} times its default size")
        + f"); the generator's effects: {', '.join(structure)}.",
        "",
        "The oracle fits the generator's true structure to the same fit part (the starting structure "
        "identified as above, then the hidden effects added with their parameters fitted, never given): its "
        "held-out gap is what a model of the right structure closes.",
        "",
        markdown_table(["joint", "starting model", "with named effects", "oracle"], rows),
        "",
        f"- shrink: workflow {100 * result.shrink:.1f} %, oracle {100 * oracle_shrink:.1f} %"
        + (f"; the workflow reached {100 * fraction:.0f} % of the oracle's shrink" if fraction is not None else ""),
        *([] if fit.residual_structure is None or result.residual_structure is None else [
            f"- repeatable structure of the residual left (largest share of one joint's variance): workflow "
            f"{largest_share(result.residual_structure):.0f} %, oracle {largest_share(fit.residual_structure):.0f} % "
            "(flagged at "
            f"{100 * WorkflowSettings().structure_share:.0f} %): the oracle's shows what a model of the right "
            "structure, fitted to this record, still leaves"]),
        ("- floor: nothing is hidden, so the starting model's held-out gap is the floor under every analysis of "
         "this motion" if not hidden else
         f"- floor: the same seed's record with nothing hidden leaves a held-out gap of "
         f"{pooled_rmse(np.asarray(floor)[None, :], result.units):.5f} (pooled, deg and mm) after the starting "
         f"model, against {before:.5f} here: about {100 * bound:.1f} % of this gap is the most a model replayed "
         "this way closes (`python studies/discrepancy_floor.py`)"),
        "",
        "Named effects, fitted beside true values:",
        "",
        markdown_table(["effect", "parameter", "joint", "fitted", "true", "unit"], fitted_rows, digits=4)
        if fitted_rows else "(none named)",
        "",
        "The oracle's fitted parameters beside the true values:",
        "",
        markdown_table(["effect", "parameter", "joint", "fitted", "true", "unit"], oracle_rows, digits=4)
        if oracle_rows else "(nothing hidden)",
        "",
    ]
    _insert_before_figures(out, section)
    return document


def add_learned_comparison(out: Path, result: DiscrepancyResult, scores: dict) -> dict:
    """Add learned calibrators' held-out RMSE on the same split (``scores``: name -> (J,) SI) to the
    report, beside the starting model and the model with the named effects."""
    report_path = Path(out) / "report.json"
    document = json.loads(report_path.read_text())
    scale = report_scale(result.units)

    def pooled(gap):
        return float(np.sqrt(np.mean(np.square(np.asarray(gap) * scale))))

    rows = [["starting model", *(_scaled(result.gap_before, result.units)), pooled(result.gap_before)],
            [f"with named effects ({', '.join(result.named_effects) or 'none'})",
             *(_scaled(result.gap_after, result.units)), pooled(result.gap_after)]]
    rows += [[name, *(_scaled(gap, result.units)), pooled(gap)] for name, gap in scores.items()]
    best = min(scores, key=lambda n: pooled(scores[n]))
    document["learned_calibrators"] = {name: {"gap": [float(v) for v in gap], "pooled_report_units": pooled(gap)}
                                       for name, gap in scores.items()}
    document["best_learned_calibrator"] = best
    write_json(report_path, document)
    units = _unit_names(result.units)
    section = [
        "## Compared with learned calibrators on the same split",
        "",
        "Trained on the whole random motion (the fit and validation parts) with the six commanded joints as "
        "inputs, scored on the held-out peg transfer; RMSE per joint and pooled.",
        "",
        markdown_table(["model"] + [f"{n} ({u})" for n, u in zip(result.joint_names, units)] + ["pooled"], rows,
                       digits=3),
        "",
        f"Best learned calibrator: {best} ({pooled(scores[best]):.3f} pooled, against "
        f"{pooled(result.gap_after):.3f} with the named effects).",
        "",
    ]
    _insert_before_figures(out, section)
    return document


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
          lines: bool = False) -> dict:
    """Hide each effect with each seed, through the file and the blind analysis, with the oracle:
    the confusion matrix of hidden vs named (first named), and per effect how often it was named
    first and the shrink beside the oracle's. ``progress`` draws a bar on stderr; ``lines`` writes
    one line per finished run there instead (for a log file, where a bar cannot redraw)."""
    import tempfile

    from joblib import Parallel, delayed

    def one(effect, seed):
        hidden = () if effect == "none" else (effect,)
        dataset, generator = generate_measured(hidden, seed, duration, size_factor=size_factor)
        with tempfile.TemporaryDirectory() as tmp:
            path = write_measured(dataset, tmp)
            result, *_ = analyse_measured(path)
            fit = oracle(path, hidden)
        before = pooled_rmse(result.residual_before.joints, result.units)
        after = pooled_rmse(fit.residual_after.joints, result.units)
        oracle_shrink = float(1.0 - after / before) if before > 0 else 0.0
        first = result.named_effects[0] if result.named_effects else ("unexplained" if result.unexplained else "none")
        return {"hidden": effect, "seed": seed, "named_first": first, "named": list(result.named_effects),
                "equivalent": {k: list(v) for k, v in result.equivalent.items()},
                "rivals": {k: dict(v) for k, v in result.rivals.items()},
                "unexplained": result.unexplained, "gap_before": pooled_rmse(result.residual_before.joints, result.units),
                "shrink": float(result.shrink), "oracle_shrink": oracle_shrink,
                "residual_structure": _structure_list(result), "oracle_residual_structure": _structure_list(fit),
                "signature": list(result.signature), "command_shrink": _command_shrink(result),
                "backfit_capped": list(result.backfit_capped), "oracle_backfit_capped": list(fit.backfit_capped)}

    def floor_of(seed):
        return seed, pooled_rmse(np.asarray(floor_gap(seed, duration))[None, :], RAVEN_UNITS)

    jobs = [(e, s) for e in effects for s in seeds]
    results = Parallel(n_jobs=-1, return_as="generator")(delayed(one)(e, s) for e, s in jobs)
    runs = []
    for run in tqdm(results, total=len(jobs), desc="hidden-effect runs", disable=not progress, file=sys.stderr):
        runs.append(run)
        if lines:
            print(sweep_line(run, len(runs), len(jobs)), file=sys.stderr, flush=True)
    if "none" not in effects:
        # each seed's floor once: the 'none' runs give it where they are swept
        floors = dict(Parallel(n_jobs=-1)(delayed(floor_of)(s) for s in seeds))
        runs = [{**run, "floor": floors[run["seed"]]} for run in runs]
    return summarise_sweep(runs, duration, out, size_factor, effects)


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

    def bound_of(run) -> float | None:
        # the floor: what the starting model leaves on the same seed's record with nothing hidden
        # (the seed's 'none' run, or the floor a sweep without them measured for each seed)
        floor = run.get("floor", floors.get(run["seed"]))
        if floor is None or run["hidden"] == "none":
            return None
        return shrink_bound(floor, run["gap_before"])

    summary_rows = []
    for e in effects:
        mine = [r for r in runs if r["hidden"] == e]
        named = sum(_named_first(e, r) for r in mine)
        shrink = np.array([r["shrink"] for r in mine]) * 100
        closable = np.array([r["oracle_shrink"] for r in mine]) * 100
        gap = np.array([r["gap_before"] for r in mine])
        goal = named >= 0.8 * len(mine) and (e in UNMODELLED_EFFECTS
                                             or bool(np.all(shrink >= np.minimum(50.0, 0.8 * closable))))
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
                             "-" if e == "none" else ("yes" if goal else "no")])
    run_rows = [[r["hidden"], str(r["seed"]), verdict(r["named"], r["unexplained"]),
                 "; ".join(f"{k} = {', '.join(v)}" for k, v in r["equivalent"].items()),
                 "; ".join(f"{k} ~ {n} ({d:.2f})" for k, v in r.get("rivals", {}).items() for n, d in v.items()),
                 r["gap_before"],
                 100 * r["shrink"], 100 * r["oracle_shrink"],
                 "-" if bound_of(r) is None else f"{100 * bound_of(r):.1f}",
                 _share_text(r.get("residual_structure")), _share_text(r.get("oracle_residual_structure")),
                 "-" if r.get("command_shrink") is None else f"{100 * r['command_shrink']:.1f}"]
                for r in runs]
    sizes = "at their default sizes" if size_factor == 1.0 else f"at {size_factor:g} times their default sizes"
    text = "\n".join([
        "# Hidden vs named effects (blind analysis of generated files)", "",
        f"Seeds {list(seeds)}, {duration:.0f} s of random motion per run, hidden effects {sizes}; starting "
        f"structure {', '.join(STARTING_STRUCTURE)}; library {', '.join(LIBRARY)}.", "",
        *([] if duration >= SHORT_RECORD_S else [
            f"**Short records:** under {SHORT_RECORD_S:.0f} s the starting structure, identified on each record's "
            "first half, may itself leave a gap that a candidate then takes.", ""]),
        "## Per hidden effect", "",
        "Named first: runs whose first named effect is the hidden one (or one the data cannot tell from it, "
        "e.g. the two kinds of per-homing offset); for an effect the library lacks, runs that name nothing and "
        "flag the residual unexplained. Gap: the starting model's held-out gap (pooled RMSE, deg and "
        "mm). Shrink and oracle shrink: mean [min, max] over the seeds, %; the oracle is the generator's true "
        "structure fitted to the same fit part by the same steps; 'then unexplained': runs that named an effect "
        "and still left a residual that repeats, and in how many of them the oracle's residual repeats as well (a "
        "model of the right structure fitted to that record leaves it too); 'the backfit cut by its cap': runs "
        "whose named effect's backfit was still improving at its last allowed round (its fit may stop short). "
        "Floor bound: 1 - the gap the starting model leaves on the same seed's record with nothing hidden "
        "/ this gap, both pooled: about the most a model replayed this way closes ('-' for runs recorded "
        "without it and without a 'none' run of their seed). "
        "Goal: named first on at least 4 of 5 seeds "
        "and, on every seed, a shrink of at least 50 % or 80 % of the oracle's.", "",
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
                        "oracle shrink %", "floor bound %", "structure %", "oracle structure %", "command shrink %"],
                       run_rows,
                       digits=4),
        ""])
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "confusion.md", text)
    document = {"effects": list(effects), "seeds": list(seeds), "duration_s": duration, "size_factor": size_factor,
                "columns": columns, "starting_structure": list(STARTING_STRUCTURE), "library": list(LIBRARY),
                "matrix": matrix, "runs": runs, **(extra or {})}
    write_json(out / "confusion.json", document)
    print(text)
    return document


def read_sweeps(paths) -> tuple[list[dict], float, float, list[str]]:
    """The runs of sweeps made apart (each a folder holding ``confusion.json``, or that file), to be
    summarised as one: ``(runs, duration_s, size_factor, files)``.

    Sweeps take hours, so they are often run in parts (other seeds, other effects, other hosts).
    The parts must share the record length, the effect sizes, and this version's starting structure
    and library, and no hidden effect may appear twice with the same seed; anything else raises
    :class:`UsageError` naming the file and what differs.
    """
    runs, seen, files, lengths, factors = [], {}, [], set(), set()
    for path in map(Path, paths):
        file = path / "confusion.json" if path.is_dir() else path
        try:
            document = json.loads(file.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
            raise UsageError(f"{file} is not a sweep's confusion.json ({type(error).__name__}: {error})") from error
        if not isinstance(document, dict) or not isinstance(document.get("runs"), list) or "duration_s" not in document:
            raise UsageError(f"{file} is not a sweep's confusion.json (no 'runs' and 'duration_s')")
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
            key = (run["hidden"], run["seed"])
            if key in seen:
                raise UsageError(f"{run['hidden']} with seed {run['seed']} is in both {seen[key]} and {file}")
            seen[key] = file
            runs.append(run)
        files.append(str(file))
    if not runs:
        raise UsageError("the sweeps hold no runs")
    return runs, lengths.pop(), factors.pop(), files


def main(argv=None) -> int:
    parser = script_parser(STUDY, __doc__)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--hidden-effect", type=parse_hidden, metavar="NAME",
                        help=f"'none' or effects to hide, comma-separated: {', '.join(HIDDEN_CHOICES[1:])}")
    source.add_argument("--measured", type=existing_path, metavar="PATH",
                        help="recorded data: a dataset file, bag(s), or the dVRK folder format (blind analysis)")
    source.add_argument("--ablate", type=parse_ablated, metavar="NAME",
                        help=f"ablation: the model lacks one of {', '.join(ABLATION_CHOICES)}")
    source.add_argument("--sweep", action="store_true", help="confusion matrix of hidden vs named effects")
    source.add_argument("--merge-sweeps", type=existing_path, nargs="+", metavar="DIR",
                        help="one confusion matrix from sweeps run apart (their --out folders or confusion.json)")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of generated data")
    parser.add_argument("--seeds", type=positive_int, default=3, help="seeds per effect for --sweep")
    parser.add_argument("--duration", type=record_length, default=DEFAULT_RECORD_S,
                        help="seconds of generated random motion (default: twenty minutes, the paper's random tests "
                             "and the shortest record on which drift at its published size was named; 240 for a "
                             "quicker look that cannot show drift; at most six hours)")
    parser.add_argument("--size-factor", type=positive_float, default=1.0,
                        help="generate the hidden effect at this multiple of its default size (default 1: the "
                             "size its source gives)")
    parser.add_argument("--log-rate", type=positive_float, default=LOG_RATE, metavar="HZ",
                        help="--hidden-effect only: log the generated robot state (and the ground truth, at least "
                             f"at its {TRUTH_RATE:g} Hz) at this rate instead of the robot's {LOG_RATE:g} Hz")
    parser.add_argument("--max-rate", type=positive_float, default=None, metavar="HZ",
                        help="--measured RAVEN-II data only: keep every k-th row so that the log's rate is at most "
                             "HZ (the workflow's cost grows with the rows, and its thresholds were set at 30 Hz)")
    parser.add_argument("--backfit-rounds", type=non_negative_int, default=None, metavar="N",
                        help="--measured RAVEN-II data and --hidden-effect only: at most N backfit rounds instead of "
                             f"the workflow's {WorkflowSettings().backfit_rounds} (report.json's backfit_capped names "
                             "fits the cap cut short)")
    parser.add_argument("--effects", type=parse_effect_list, default=None, metavar="NAMES",
                        help="--sweep only these hidden effects (comma-separated; default: every choice)")
    parser.add_argument("--joints", type=joint_numbers, default="4,5,6", help="dVRK joints (1-6) to study")
    parser.add_argument("--arm", default="left", choices=("left", "right"),
                        help="arm of --measured bags or CSV files (Parquet dataset files record theirs)")
    parser.add_argument("--out", type=Path, default=Path("results") / "discrepancy")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress bars (nor, when stderr is not a terminal, a line per finished sweep run)")
    with StudyRun(parser, argv) as study:
        args = study.args
        if args.log_rate != LOG_RATE and args.hidden_effect is None:
            parser.error("--log-rate applies to --hidden-effect only: it is the rate of the data that option generates")
        if args.max_rate is not None and (args.measured is None or is_dvrk_folder(args.measured)):
            parser.error("--max-rate applies to --measured RAVEN-II data only")
        if args.backfit_rounds is not None and (args.hidden_effect is None and (
                args.measured is None or is_dvrk_folder(args.measured))):
            parser.error("--backfit-rounds applies to --measured RAVEN-II data and --hidden-effect only")
        progress = not args.no_progress and sys.stderr.isatty()
        if args.merge_sweeps:
            runs, duration, size_factor, files = read_sweeps(args.merge_sweeps)
            summarise_sweep(runs, duration, study.folder, size_factor, extra={"merged_from": files})
            study.publish()
            study.done()
            return 0
        if args.sweep:
            sweep(args.effects or SWEEP_EFFECTS, range(args.seed, args.seed + args.seeds), args.duration, study.folder,
                  progress, args.size_factor, lines=not args.no_progress and not progress)
            study.publish()
            study.done()
            return 0
        if args.hidden_effect is not None:
            say(f"generating {args.duration:.0f} s of motion with {', '.join(args.hidden_effect) or 'nothing'} hidden...")
            dataset, generator = generate_measured(args.hidden_effect, seed=args.seed, duration=args.duration,
                                                   size_factor=args.size_factor,
                                                   robot_options=log_rate_options(args.log_rate))
            path = write_measured(dataset, study.folder)
            del dataset
            result, signals, split = analyse(path, study.folder, shown_path=study.final(path), progress=progress,
                                             backfit_rounds=args.backfit_rounds)
            add_generator_knowledge(study.folder, args.hidden_effect, args.seed, args.duration, generator, path, result,
                                    args.size_factor, args.log_rate)
        elif args.ablate is not None:
            result, signals, split, generator = run_ablation(args.ablate, seed=args.seed, duration=args.duration,
                                                             folder=study.folder)
            source = {"kind": "simulated", "ablated": args.ablate, "seed": args.seed, "duration_s": args.duration,
                      "description": f"ablation of {args.ablate} on the virtual RAVEN-II"}
            structure = tuple(e for e in STARTING_STRUCTURE if e != args.ablate)
            write_report(result, signals, split, source, study.folder, study.stop_clock(), structure, "ablation")
        elif is_dvrk_folder(args.measured):
            joints = tuple(j - 1 for j in args.joints)
            root = args.measured.parent if (args.measured / "q_des.npy").exists() else args.measured
            with study.reading(args.measured):
                result, signals, split = run_on_dvrk(root, joints)
            text = ",".join(str(j) for j in args.joints)
            source = {"kind": "dvrk", "path": str(args.measured), "joints": [j + 1 for j in joints],
                      "description": f"dVRK data of Hwang et al. 2020, joints {text} "
                                     "(fit on random motion, held out: peg transfer)"}
            write_report(result, signals, split, source, study.folder, study.stop_clock(), (), "blind")
            say("training the learned calibrators on the same split...")
            add_learned_comparison(study.folder, result, learned_calibrators_on_dvrk(root, joints))
        else:
            with study.reading(args.measured):
                read_measured(args.measured, args.arm)  # an unreadable input is a one-line usage error, before any work
            result, signals, split = analyse(args.measured, study.folder, arm=args.arm, progress=progress,
                                             max_rate=args.max_rate, backfit_rounds=args.backfit_rounds)
        study.publish()
    units = _unit_names(result.units)
    note = short_record_note(signals)
    if note is not None:
        print(f"warning: {note}", file=sys.stderr)
    drift_note = drift_record_note(signals)
    if drift_note is not None:
        print(f"note: {drift_note}", file=sys.stderr)
    print(f"named effects: {', '.join(result.named_effects) or 'none'}; unexplained: {result.unexplained}")
    for name, b, a, u in zip(result.joint_names, _scaled(result.gap_before, result.units),
                             _scaled(result.gap_after, result.units), units):
        print(f"  {name:12s} held-out gap {b:9.4f} -> {a:9.4f} {u}")
    print(f"shrink (pooled, deg and mm): {100 * result.shrink:.1f} %   "
          f"[{pooled_rmse(result.residual_before.joints, result.units):.4f} -> "
          f"{pooled_rmse(result.residual_after.joints, result.units):.4f}]")
    for sentence in result.signature:
        print(f"  unexplained: {sentence}")
    study.done()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
