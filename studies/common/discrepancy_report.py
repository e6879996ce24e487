"""The reports of the model-discrepancy workflow's runs: ``report.json``, ``report.md`` and plots.

:func:`write_report` writes what one blind analysis found (its starting structure and library, the
named effects, the held-out gaps, every candidate of every iteration, the fitted parameters in
report units, where the starting model's residual is, and the signature of what is left).
A run that generated its data adds the generator's knowledge afterwards
(:func:`add_generator_knowledge`: the true parameters, the oracle and the floor), and a run on the
dVRK data the learned calibrators scored on the same split (:func:`add_learned_comparison`).
SI inside; degrees and millimetres in the reports (:data:`REPORT_UNITS`).
``studies/discrepancy.py`` is the command line that calls them.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

from simulation.discrepancy import DiscrepancyResult, WorkflowSettings, localize, strongest_dependence
from simulation.discrepancy.workflow import values_at_bounds
from simulation.discrepancy.signals import pooled_rmse, report_scale
from simulation.engine.robot import LOG_RATE
from simulation.discrepancy.replay import RavenModel
from studies.common.discrepancy_runs import (
    HIDDEN_PAYLOAD_KG,
    STARTING_STRUCTURE,
    STRUCTURE_FIELDS,
    drift_record_note,
    floor_bound,
    floor_record,
    held_out_gap,
    inertial_loads_from,
    largest_share,
    log_rate_options,
    oracle,
    short_record_note,
    structure_values,
    true_values,
)
from studies.common.reporting import machine_description, markdown_table, now_iso, to_jsonable, write_json, write_text

DVRK_STARTING_MODEL = "reported joints plus constant offsets (the dVRK's nominal model)"
"""What ``report.md`` calls the dVRK's starting model (it has no cable structure)."""


def in_report_units(values, units) -> list[float]:
    """Per-joint values in SI (rad, m) as a list in report units (deg, mm), in the order of ``units``."""
    return (np.asarray(values) * report_scale(units)).tolist()


def report_unit_names(units) -> list[str]:
    """The report unit of each joint: "deg" for a rotation, "mm" for a translation."""
    return ["deg" if u == "rad" else "mm" for u in units]



REPORT_UNITS = {"rad": ("deg", 180.0 / np.pi), "m": ("mm", 1000.0), "rad/h": ("deg/h", 180.0 / np.pi),
                "m/h": ("mm/h", 1000.0), "rad/rad": ("deg/deg", 1.0), "m/m": ("mm/mm", 1.0)}
"""SI units of parameter values shown in degrees or millimetres in ``report.md`` (others stay SI)."""


def value_labels(size: int, joint_names, block: str = "") -> list[str]:
    """What each value of a parameter block refers to: a joint, a pair of joints, or a homing (second,
    third ... of the record: registration offsets relative to the first) and a joint, or a pair of joints
    (or a joint and its own motion) and a play operator's half-width (the weights of
    ``coupled_hysteresis``, in either of its forms)."""
    from simulation.discrepancy.generic import HYSTERESIS_WIDTH_FRACTIONS

    j = len(joint_names)
    if block == "delta" and size == 3:
        from simulation.identification.layout import COUPLING_NAMES

        return [f"coupling term {name}" for name in COUPLING_NAMES]
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


def parameter_rows(fitted: dict, units: dict, joint_names, truth: dict | None = None,
                   bounds: dict | None = None) -> list[list]:
    """Rows (effect, parameter, joint, fitted[, true], unit[, search range, at bound]) in report
    units, one per value. With ``bounds`` (``DiscrepancyResult.parameter_bounds``) each row also
    gives the range the value was searched in and "lower" or "upper" where it sits at an end of it
    ("-" for a value fitted outside the workflow's own fits: by the identification, or the
    controller replay's unbounded gravity-model scale)."""
    rows = []
    for effect, blocks in fitted.items():
        for block, values in blocks.items():
            values = np.atleast_1d(np.asarray(values, dtype=float))
            block_units = units.get(effect, {}).get(block, [""] * values.size)
            true = None if truth is None else truth.get(effect)
            true = true.get(block) if isinstance(true, dict) else true
            searched = None if bounds is None else bounds.get(effect, {}).get(block)
            ends = None if searched is None else values_at_bounds(values, *searched)
            labels = value_labels(values.size, joint_names, block)
            for i, (label, value, unit) in enumerate(zip(labels, values, block_units)):
                shown, factor = REPORT_UNITS.get(unit, (unit, 1.0))
                row = [effect, block, label, value * factor]
                if truth is not None:
                    row.append("-" if true is None else true if isinstance(true, str)
                               else np.asarray(true, dtype=float).ravel()[i] * factor)
                row.append(shown or "1")
                if bounds is not None:
                    if searched is None:
                        row += ["-", "-"]
                    else:
                        lower, upper = (np.broadcast_to(np.asarray(e, dtype=float), values.shape)[i] * factor
                                        for e in searched)
                        row += [f"[{lower:.4g}, {upper:.4g}]", ends[i]]
                rows.append(row)
    return rows


def structure_document(result: DiscrepancyResult) -> dict | None:
    """The starting structure's parameters (SI) as identified at the start and in the final model
    (re-identified by the backfit around the named effects), with their units; None for a model
    that is not a RAVEN-II cable model (the dVRK's)."""
    if not isinstance(result.model_before, RavenModel):
        return None
    start = structure_values(result.model_before.params)
    from simulation.identification.layout import COUPLING_NAMES

    errors = result.model_before.standard_errors or {}

    def error(effect, field, i):
        # by the identification's names: the joint, or the coupling term
        label = (COUPLING_NAMES if effect == "coupling" else result.joint_names)[i]
        value = errors.get(f"{effect}.{field}[{label}]")
        return None if value is None else float(value)

    return {"identified": start,
            "identified_standard_error": {effect: {field: [error(effect, field, i) for i in range(len(values))]
                                                   for field, values in fields.items()}
                                          for effect, fields in start.items()},
            "final": structure_values(result.model_after.params),
            "units": {name: {field: list(STRUCTURE_FIELDS[name][field]) for field in fields}
                      for name, fields in start.items()}}


def structure_rows(document: dict, joint_names, truth: dict | None = None) -> list[list]:
    """Rows (effect, parameter, what, identified, its standard error, final[, true], unit) in report
    units of :func:`structure_document`'s ``document`` (``truth``: a generator's values, like it;
    "-" for a standard error the identification did not give: a parameter it holds fixed)."""
    from simulation.identification.layout import DEFAULT_FIXED

    rows = []
    for effect, fields in document["identified"].items():
        for field, start in fields.items():
            final = document["final"].get(effect, {}).get(field, [np.nan] * len(start))
            shown_field = f"{field} (held at its nominal)" if f"{effect}.{field}" in DEFAULT_FIXED else field
            true = None if truth is None else truth.get(effect, {}).get(field)
            for i, label in enumerate(value_labels(len(start), joint_names, field)):
                shown, factor = REPORT_UNITS.get(document["units"][effect][field][i],
                                                 (document["units"][effect][field][i], 1.0))
                se = document.get("identified_standard_error", {}).get(effect, {}).get(field, [None] * len(start))[i]
                row = [effect, shown_field, label, start[i] * factor, "-" if se is None else se * factor,
                       final[i] * factor]
                if truth is not None:
                    row.append("-" if true is None else true[i] * factor)
                rows.append(row + [shown])
    return rows


def values_at_their_bounds(result: DiscrepancyResult, joint_names=None) -> list[str]:
    """The named effects' fitted values at an end of their search range, as
    ``"effect.parameter[what] (lower|upper)"``: where the fit was stopped rather than where the data
    put the value (a lower bound of zero: none of that effect on that joint)."""
    names = result.joint_names if joint_names is None else joint_names
    found = []
    for effect, blocks in result.fitted_parameters.items():
        for block, values in blocks.items():
            searched = result.parameter_bounds.get(effect, {}).get(block)
            if searched is None:
                continue
            values = np.atleast_1d(np.asarray(values, dtype=float))
            for label, end in zip(value_labels(values.size, names, block), values_at_bounds(values, *searched)):
                if end:
                    found.append(f"{effect}.{block}[{label}] ({end})")
    return found


def file_digest(path: Path) -> str:
    """SHA-256 of a file (a folder: of its files in name order), so a report names exactly its input."""
    digest = hashlib.sha256()
    files = sorted(p for p in Path(path).rglob("*") if p.is_file()) if Path(path).is_dir() else [Path(path)]
    for file in files:
        digest.update(file.read_bytes())
    return digest.hexdigest()


def command_shrink(result: DiscrepancyResult) -> float | None:
    """1 - after/before of the controller replay's held-out command gap, pooled over the joints
    (N m); None when the controller was not replayed."""
    check = result.controller
    if check is None:
        return None
    return command_gap_shrink(check.held_out_gap_before, check.held_out_gap_kept)


def command_gap_shrink(before, after) -> float:
    """1 - after/before of two per-joint held-out command gaps (N m), each pooled over the joints
    as a root mean square; 0 where there was no gap."""
    pooled = float(np.sqrt(np.mean(np.square(before))))
    return float(1.0 - np.sqrt(np.mean(np.square(after))) / pooled) if pooled > 0 else 0.0


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


SCORED_BY_QUASI_STATIC = "quasi-static replay"
SCORED_BY_PLANT = "plant replay"


def scored_gaps(result: DiscrepancyResult, plant=None) -> tuple[np.ndarray, np.ndarray, float, str]:
    """The held-out gaps before and after (SI per joint), the shrink (pooled, deg and mm) and the
    replay that scored them: the plant replay's where its score applies
    (:class:`~studies.common.plant_scoring.PlantScore`), the workflow's quasi-static one otherwise."""
    if plant is not None and plant.applies:
        return np.asarray(plant.gap_before), np.asarray(plant.gap_after), float(plant.shrink), SCORED_BY_PLANT
    return np.asarray(result.gap_before), np.asarray(result.gap_after), float(result.shrink), SCORED_BY_QUASI_STATIC


def report_document(result: DiscrepancyResult, source: dict, runtime_s: float,
                    starting_structure=STARTING_STRUCTURE, analysis: str = "blind", plant=None,
                    plant_refit=None, inertial_loads: str | None = None) -> dict:
    """``report.json``: what the analysis found, its starting point and library, the iterations.

    ``gap_before``, ``gap_after`` and ``shrink`` are scored by ``scored_by`` (:func:`scored_gaps`);
    ``quasi_static`` keeps the workflow's own, and ``plant_replay`` the plant's score (None where
    none was asked for, as on dVRK data and in an ablation). ``plant_refit`` is the named effects
    refitted with the plant replay (:class:`~studies.common.plant_scoring.PlantRefit`; None where
    ``--plant-refit`` was not asked for): beside the headline figures, which stay the workflow's
    models'. ``inertial_loads`` is where the RAVEN-II replay took the links' inertial loads from
    (:data:`~studies.common.discrepancy_runs.INERTIAL_LOADS`; None for other robots' data)."""
    gap_before, gap_after, shrink, scored_by = scored_gaps(result, plant)
    return {
        "analysis": analysis,
        "starting_structure": list(starting_structure),
        "library": list(result.library),
        "named_effects": list(result.named_effects),
        "unexplained": bool(result.unexplained),
        "gap_before": [float(v) for v in gap_before],
        "gap_after": [float(v) for v in gap_after],
        "shrink": shrink,
        "scored_by": scored_by,
        "inertial_loads": inertial_loads,
        "quasi_static": {"gap_before": [float(v) for v in result.gap_before],
                         "gap_after": [float(v) for v in result.gap_after], "shrink": float(result.shrink)},
        "plant_replay": None if plant is None else plant.document(),
        "plant_refit": None if plant_refit is None else plant_refit.document(),
        "torque_gap_before": None if result.torque_gap_before is None else [float(v) for v in result.torque_gap_before],
        "torque_gap_after": None if result.torque_gap_after is None else [float(v) for v in result.torque_gap_after],
        "equivalent": {k: list(v) for k, v in result.equivalent.items()},
        "rivals": {k: dict(v) for k, v in result.rivals.items()},
        "signature": list(result.signature),
        "residual_structure": structure_shares(result),
        "backfit_rounds": result.backfit_rounds,
        "backfit_patience": result.backfit_patience,
        "named_backfit_patience": result.named_backfit_patience,
        "backfit_capped": list(result.backfit_capped),
        "max_effects": result.max_effects,
        "search_capped": bool(result.search_capped),
        "controller": _controller_document(result),
        "fitted_parameters": to_jsonable(result.fitted_parameters),
        "parameter_units": to_jsonable(result.parameter_units),
        "parameter_bounds": to_jsonable(result.parameter_bounds),
        "at_bound": values_at_their_bounds(result),
        "starting_parameters": structure_document(result),
        "units": list(result.units),
        "joints": list(result.joint_names),
        "gap_before_report_units": in_report_units(gap_before, result.units),
        "gap_after_report_units": in_report_units(gap_after, result.units),
        "report_units": report_unit_names(result.units),
        "iterations": [
            {"validation_gap": it.gap_before, "fit_gap": it.fit_gap_before, "bic": it.bic_before, "named": it.named,
             "validation_torque_gap": it.torque_gap_before, "fit_torque_gap": it.fit_torque_gap_before,
             "equivalent": list(it.equivalent), "rivals": dict(it.rivals),
             "refined_rounds": it.refined_rounds, "refined_capped": it.refined_capped,
             "candidates": [{"name": s.name, "fitted": s.fitted, "validation_gap": s.validation_gap, "fit_gap": s.fit_gap,
                             "validation_torque_gap": s.torque_gap, "fit_torque_gap": s.fit_torque_gap,
                             "bic": s.bic, "screened_chi_square": s.screened_chi_square, "parameters": s.values,
                             "backfit_rounds": s.backfit_rounds, "backfit_capped": s.backfit_capped,
                             "shortfalls": list(it.shortfalls.get(s.name, ()))}
                            for s in it.scores]}
            for it in result.iterations
        ],
        "source": source,
        "created": now_iso(),
        "machine": machine_description(),
        "runtime_s": round(runtime_s, 1),
    }


def _plots(result: DiscrepancyResult, signals, split, out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scale = report_scale(result.units)
    units = report_unit_names(result.units)
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
of lowest BIC, below the current model's, that cuts both joint gaps by at least 10 % and the
validation gap by at least 0.001 (or, for an effect seen only in the motor torques, the torque gap
on both parts by 10 %); the defaults, the run's own in *verdict*, which says for each fitted
candidate not named why it was not."""


def _verdict(iteration, score) -> str:
    """The last column of the candidates' table: named, or why a fitted candidate was not."""
    if iteration.named == score.name:
        return "named"
    if score.name in iteration.shortfalls:
        return "; ".join(iteration.shortfalls[score.name])
    if score.fitted and iteration.named is not None:
        if score.name in iteration.equivalent:
            return f"fits exactly as {iteration.named} does (the same form)"
        return f"explains enough; {iteration.named} has the lower BIC"
    return ""


def _structure_section(result: DiscrepancyResult) -> list[str]:
    """The starting structure's identified parameters at the start and in the final model (RAVEN-II)."""
    document = structure_document(result)
    if document is None:
        return []
    return ["## Parameters of the starting structure", "",
            "Identified on the fit part at the start (step 0), and in the final model: re-identified with the "
            "named effects' shares removed, where a backfit ran (a parameter that moves between the two had taken "
            "part of a missing effect). The standard error is the identification's (Newey-West, the residuals "
            "being correlated in time) at step 0: it measures how well the data pin a parameter of the starting "
            "structure down, not how far a missing effect bends it. The cable damping is held at its round "
            "nominal value (its fit is biased low by the encoders' noise on the stretch rate), not fitted.", "",
            markdown_table(["effect", "parameter", "joint", "identified", "standard error", "final", "unit"],
                           structure_rows(document, result.joint_names), digits=4), ""]


def _drag_section(result: DiscrepancyResult, signals, split) -> list[str]:
    """With ``coupled_hysteresis`` named on generic data, how much each joint's motion drags each
    joint (RMS over the fit and validation parts, report units): its weights summed per pair."""
    from simulation.discrepancy.generic import NominalModel, coupled_hysteresis_shares

    model = result.model_after
    if not isinstance(model, NominalModel) or "coupled_hysteresis" not in model.effects:
        return []
    shares = coupled_hysteresis_shares(model.effects["coupled_hysteresis"], signals, split.fit | split.validation)
    scale = report_scale(result.units)
    units = report_unit_names(result.units)
    rows = [[f"{name} ({unit})", *(shares[j] * scale[j])] for j, (name, unit) in enumerate(zip(result.joint_names,
                                                                                                units))]
    return ["## Which joint drags which (coupled hysteresis)", "",
            "RMS over the fit and validation parts of what each joint's motion (column) adds to each joint (row) "
            "through the named coupled hysteresis; the diagonal is a joint's own hysteresis.", "",
            markdown_table(["moved joint", *[f"by {name}" for name in result.joint_names]], rows, digits=3), ""]


def write_report(result: DiscrepancyResult, signals, split, source: dict, out: Path, runtime_s: float,
                 starting_structure=STARTING_STRUCTURE, analysis: str = "blind", plant=None,
                 plant_refit=None, inertial_loads: str | None = None) -> list[Path]:
    """Write ``report.json``, ``report.md`` and the plots of one workflow run in the folder ``out``;
    ``plant`` is the plant replay's score of it and ``plant_refit`` its named effects refitted with
    the plant, each if one was asked for, and ``inertial_loads`` where a RAVEN-II replay took the
    links' inertial loads from (:func:`report_document`)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    document = report_document(result, source, runtime_s, starting_structure, analysis, plant, plant_refit,
                               inertial_loads)
    note = short_record_note(signals)
    document["record_s"] = float(signals.time[-1] - signals.time[0])
    document["short_record"] = note
    drift_note = drift_record_note(signals)
    document["drift_note"] = drift_note
    json_path = write_json(out / "report.json", document)
    units = report_unit_names(result.units)
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
                                   s.validation_gap, s.torque_gap, s.bic, _verdict(it, s)])
    start = ", ".join(starting_structure) if starting_structure else DVRK_STARTING_MODEL
    kind = "Ablation (the model lacks a term the data have)" if analysis == "ablation" else "Blind analysis"
    parameter_table = parameter_rows(result.fitted_parameters, result.parameter_units, result.joint_names,
                                     bounds=result.parameter_bounds)
    sections = [
        f"# Model discrepancy: {source.get('description', '')}",
        "",
        f"{kind}. Starting structure: {start}. Candidates screened: {', '.join(result.library) or 'none'}.",
        "",
        *([] if inertial_loads != "motors" else [
            "The replay took the links' inertial loads from the motors' acceleration through the arm's nominal "
            "coupling (`--inertial-loads motors`), not from the measured joints.", ""]),
        *([] if note is None else [f"**Short record:** {note}.", ""]),
        *([] if drift_note is None else [f"**Record too short for drift:** {drift_note}.", ""]),
        f"- named effects (in order): {', '.join(result.named_effects) or 'none'}",
        *[f"- {named} was named by a BIC margin of at most {WorkflowSettings().bic_tie:g} over "
          + ", ".join(f"{name} (BIC higher by {d:.2f})" for name, d in rivals.items())
          + ": the data support those about as well" for named, rivals in result.rivals.items()],
        f"- unexplained residual left: {'yes' if result.unexplained else 'no'}",
        *[f"- the backfit of {it.named} stopped at a round that did not lower the fit part's residual and, once it "
          f"was named, went on from there (up to {result.named_backfit_patience} such rounds in a row): "
          f"{it.refined_rounds} more round{'s' if it.refined_rounds != 1 else ''} kept"
          for it in result.iterations if it.refined_rounds is not None],
        *[f"- the backfit of {name} was still lowering the fit part's residual at its last allowed round "
          f"(round {result.backfit_rounds}; `--backfit-rounds` allows more): its fit, and the shrink, may stop short"
          for name in result.backfit_capped],
        *([f"- the search stopped after naming {result.max_effects} effect{'s' if result.max_effects != 1 else ''}, "
           "its cap (`--max-effects`): it did not check whether the data hold more"] if result.search_capped else []),
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
        f"- held-out gap shrink (pooled RMSE, deg and mm): {100 * document['shrink']:.1f} %, scored by the "
        f"{document['scored_by']}"
        + ("" if document["scored_by"] == SCORED_BY_QUASI_STATIC else
           f" (the workflow's quasi-static replay: {100 * result.shrink:.1f} %; each model's Coulomb forces "
           f"refitted to the plant on the fit part, {plant.replays} replays)"),
        *([] if plant is None or not plant.applies or plant.hysteresis_lag is None else [
            f"- the named hysteresis's lag behind the stretch, fitted to the plant with the Coulomb forces "
            f"(from 0.1 s): {plant.hysteresis_lag:.3f} s"]),
        *([] if plant is None or not plant.applies or plant.fits_lag
          or not result.model_after.params.is_enabled("hysteresis") else [
            f"- the named hysteresis's lag behind the stretch in the plant: the candidate's fixed "
            f"{float(result.model_after.params.effect('hysteresis').response_time[0]):g} s (--fixed-plant-lag), "
            "not fitted"]),
        *([] if plant is None or plant.applies else [f"- not scored by the plant replay: {plant.reason}"]),
        f"- run: {document['created']}, {runtime_s:.0f} s",
        "",
        f"## Held-out gap per joint (RMSE, measured minus model; {document['scored_by']})",
        "",
        markdown_table(["joint", "starting model", "with named effects"], rows),
        "",
        "## Candidates per iteration (gaps: pooled RMSE, deg and mm)",
        "",
        COLUMNS_EXPLAINED,
        "",
        markdown_table(["iteration", "candidate", "fitted", "fit-part gap", "validation gap", "torque gap", "BIC",
                        "verdict"], iteration_rows, digits=4),
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
        "Each value with the range it was searched in; \"lower\" or \"upper\": the fit stopped at that end of "
        "its range, so the data may put the value beyond it (a lower bound of 0: none of the effect on that "
        "joint); \"-\": fitted with the starting structure by the identification, in its own ranges "
        "(non-negative frictions, free ratio errors), or by the controller replay's least squares (unbounded).",
        "",
        markdown_table(["effect", "parameter", "joint", "fitted", "unit", "search range", "at bound"], parameter_table,
                       digits=4)
        if parameter_table else "(none named)",
        "",
        *_structure_section(result),
        *plant_refit_section(plant_refit, result),
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


def plant_refit_section(refit, result: DiscrepancyResult) -> list[str]:
    """The report's section on the named effects refitted with the plant replay (``refit``, a
    :class:`~studies.common.plant_scoring.PlantRefit`; nothing where none was asked for)."""
    if refit is None:
        return []
    head = ["## Named effects refitted with the plant replay", ""]
    if not refit.applies:
        return head + [f"Not refitted: {refit.reason}.", ""]
    units = {name: result.parameter_units.get(name, {}) for name in refit.effects}
    rows = [row[:4] + [after[3]] + row[4:] for row, after in zip(
        parameter_rows(refit.fitted, units, result.joint_names), parameter_rows(refit.refitted, units, result.joint_names))]
    gaps = ", ".join(f"{name} {v:.4f} {u}" for name, v, u in zip(
        result.joint_names, in_report_units(refit.gap_after, result.units), report_unit_names(result.units)))
    return head + [
        f"{', '.join(refit.effects)} refitted on the fit part with the plant replay, together with the final "
        f"model's Coulomb forces (factors {', '.join(f'{f:.3f}' for f in refit.friction_factors)}), from the "
        f"values above, each searched from a third to three times its value (from its lower bound to its typical "
        f"scale where the fit left it at zero; {refit.replays} replays). "
        f"Held-out gap: {gaps}; shrink {100 * refit.shrink:.1f} % over the same starting gap (the headline "
        "figures stay the workflow's own models').",
        "",
        markdown_table(["effect", "parameter", "joint", "fitted", "refitted with the plant", "unit"], rows, digits=4),
        "",
    ]


def _insert_before_figures(out: Path, lines: list[str]) -> None:
    """Insert a section (``lines``) into ``out/report.md`` just before its figures."""
    md = Path(out) / "report.md"
    text = md.read_text()
    cut = text.index("## Figures")
    write_text(md, text[:cut] + "\n".join(lines) + "\n" + text[cut:])


def structure_shares(result: DiscrepancyResult) -> list[float] | None:
    """The per-joint shares of the structure check, as a JSON list (None where the record was too short)."""
    return None if result.residual_structure is None else [float(v) for v in result.residual_structure]



TRUE_PARAMETER_COLUMNS = ["effect", "parameter", "joint", "fitted", "true", "unit", "search range", "at bound"]
"""Columns of the tables that show fitted parameters beside the generator's (:func:`parameter_rows`)."""


def add_generator_knowledge(out: Path, hidden, seed: int, duration: float, generator, path: Path,
                            result: DiscrepancyResult, size_factor: float = 1.0, log_rate: float = LOG_RATE,
                            plant=None, signals=None, split=None) -> dict:
    """After the blind analysis: add the hidden effect, the true parameters, the oracle (with the
    analysis's backfit cap) and the floor (:func:`~studies.common.discrepancy_runs.floor_gap`: the
    gap the starting model leaves on the same seed's record with nothing hidden) to the report. Both
    are replayed with the inertial loads the report's ``inertial_loads`` names, as the analysis was.

    The oracle is scored as the analysis was: where ``plant`` (the analysis's plant score, on
    ``signals`` and ``split``) applies, by the plant replay with its Coulomb forces refitted
    (:func:`~studies.common.plant_scoring.score_oracle_with_plant`); its quasi-static score is kept
    in ``oracle_quasi_static``. The floor (``floor_gap``, ``floor_bound``) is the quasi-static
    replay's; where the plant scores the analysis, the same record's floor scored with the plant
    (:func:`~studies.common.plant_scoring.plant_floor_gap`) and its bound over the plant-scored
    gap are added as ``plant_floor_gap`` and ``plant_floor_bound`` (None otherwise): the bound a
    plant-scored shrink is read against."""
    from studies.common.plant_scoring import plant_floor_gap, pooled_gap, score_oracle_with_plant

    report_path = Path(out) / "report.json"
    document = json.loads(report_path.read_text())
    plant_scored = plant is not None and plant.applies
    # the oracle and the floor are replayed as the report says the analysis was
    with inertial_loads_from(document.get("inertial_loads") or "joints"):
        fit = oracle(path, hidden, backfit_rounds=result.backfit_rounds, backfit_patience=result.backfit_patience or 0,
                     named_backfit_patience=result.named_backfit_patience)
        if not hidden:
            floor = result.gap_before
            plant_floor = plant.gap_before if plant_scored else None
        else:
            # the same seed's record with nothing hidden, and its starting model
            record = floor_record(seed, duration, log_rate_options(log_rate))
            none_signals, none_split, none_robot, none_model = record
            floor = held_out_gap(none_model, none_signals, none_split, none_robot)
            plant_floor = plant_floor_gap(record) if plant_scored else None
            del record, none_signals
        scored = None if plant is None else score_oracle_with_plant(fit, plant, signals, split)
    bound = floor_bound(floor, result.gap_before, result.units)
    plant_bound = None if plant_floor is None else floor_bound(plant_floor, plant.gap_before, result.units)
    to_report = report_scale(result.units)
    before = pooled_rmse(result.residual_before.joints, result.units)
    quasi_after = float(np.sqrt(np.mean(np.square(fit.gap_after * to_report))))
    quasi_shrink = float(1.0 - quasi_after / before) if before > 0 else 0.0
    oracle_gap, oracle_shrink = (np.asarray(fit.gap_after), quasi_shrink) if scored is None else scored
    oracle_shrink = float(oracle_shrink)
    _, gap_after, shrink, scored_by = scored_gaps(result, plant)
    fraction = float(shrink / oracle_shrink) if oracle_shrink > 0 else None
    payload_kg = HIDDEN_PAYLOAD_KG * size_factor if "payload" in hidden else 0.0
    structure = list(generator.enabled_effects) + (["payload"] if payload_kg else [])

    def truth_of(name):
        if name not in structure:
            return "absent from the generator"
        return true_values(generator, name, payload_kg) or "drawn at each homing"

    named = set(hidden) | set(result.named_effects) | set(fit.named_effects)
    truth = {name: truth_of(name) for name in named}
    starting = structure_document(result)
    starting_truth = structure_values(generator)
    document.update({
        "hidden_effect": list(hidden),
        "seed": seed,
        "duration_s": duration,
        "size_factor": size_factor,
        "log_rate_hz": log_rate,
        "generator_structure": structure,
        "true_parameters": to_jsonable({k: v for k, v in truth.items() if isinstance(v, dict)}),
        "oracle_gap_after": [float(v) for v in oracle_gap],
        "oracle_shrink": oracle_shrink,
        "oracle_fitted_parameters": to_jsonable(fit.fitted_parameters),
        "fraction_of_oracle_shrink": fraction,
        "oracle_residual_structure": structure_shares(fit),
        "oracle_backfit_capped": list(fit.backfit_capped),
        "oracle_parameter_bounds": to_jsonable(fit.parameter_bounds),
        "oracle_at_bound": values_at_their_bounds(fit, result.joint_names),
        "true_starting_parameters": starting_truth,
        "floor_gap": [float(v) for v in floor],
        "floor_bound": bound,
        "plant_floor_gap": None if plant_floor is None else [float(v) for v in plant_floor],
        "plant_floor_bound": plant_bound,
    })
    document["oracle_quasi_static"] = {"gap_after": [float(v) for v in fit.gap_after], "shrink": quasi_shrink}
    write_json(report_path, document)
    units = report_unit_names(result.units)
    rows = [[name, f"{b:.4f} {u}", f"{a:.4f} {u}", f"{o:.4f} {u}"] for name, b, a, o, u in
            zip(result.joint_names, document["gap_before_report_units"], in_report_units(gap_after, result.units),
                in_report_units(oracle_gap, result.units), units)]
    fitted_rows = parameter_rows(result.fitted_parameters, result.parameter_units, result.joint_names, truth,
                                 result.parameter_bounds)
    oracle_rows = parameter_rows(fit.fitted_parameters, fit.parameter_units, result.joint_names, truth,
                                 fit.parameter_bounds)
    refit = document.get("plant_refit") or {"applies": False}
    refit_rows = [] if not refit["applies"] else parameter_rows(
        refit["refitted"], {name: result.parameter_units.get(name, {}) for name in refit["refitted"]},
        result.joint_names, truth)
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
        f"held-out gap is what a model of the right structure closes (scored by the {scored_by}, as the "
        "analysis is).",
        "",
        markdown_table(["joint", "starting model", "with named effects", "oracle"], rows),
        "",
        f"- shrink ({scored_by}): workflow {100 * shrink:.1f} %, oracle {100 * oracle_shrink:.1f} %"
        + (f"; the workflow reached {100 * fraction:.0f} % of the oracle's shrink" if fraction is not None else "")
        + ("" if scored is None else
           f" (quasi-static replay: workflow {100 * result.shrink:.1f} %, oracle {100 * quasi_shrink:.1f} %)")
        + ("" if not refit["applies"] else
           f"; with {', '.join(refit['effects'])} refitted with the plant replay, {100 * refit['shrink']:.1f} %"),
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
         f"model, against {before:.5f} here, both replayed quasi-statically: about {100 * bound:.1f} % of this "
         "gap is the most a model replayed that way closes (`python studies/discrepancy_floor.py`)"
         + ("" if plant_bound is None else
            f"; scored with the plant replay as the analysis is, {pooled_gap(plant_floor):.5f} against "
            f"{pooled_gap(plant.gap_before):.5f}: about {100 * plant_bound:.1f} %")),
        "",
        "Named effects, fitted beside true values:",
        "",
        markdown_table(TRUE_PARAMETER_COLUMNS, fitted_rows, digits=4) if fitted_rows else "(none named)",
        "",
        *([] if not refit_rows else [
            "The named effects refitted with the plant replay, beside true values:", "",
            markdown_table(["effect", "parameter", "joint", "refitted", "true", "unit"], refit_rows, digits=4), ""]),
        "The oracle's fitted parameters beside the true values:",
        "",
        markdown_table(TRUE_PARAMETER_COLUMNS, oracle_rows, digits=4) if oracle_rows else "(nothing hidden)",
        "",
        *([] if starting is None else [
            "The starting structure's parameters beside the generator's (identified at the start, and in the "
            "final model):", "",
            markdown_table(["effect", "parameter", "joint", "identified", "standard error", "final", "true", "unit"],
                           structure_rows(starting, result.joint_names, starting_truth), digits=4), ""]),
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

    rows = [["starting model", *(in_report_units(result.gap_before, result.units)), pooled(result.gap_before)],
            [f"with named effects ({', '.join(result.named_effects) or 'none'})",
             *(in_report_units(result.gap_after, result.units)), pooled(result.gap_after)]]
    rows += [[name, *(in_report_units(gap, result.units)), pooled(gap)] for name, gap in scores.items()]
    best = min(scores, key=lambda n: pooled(scores[n]))
    document["learned_calibrators"] = {name: {"gap": [float(v) for v in gap], "pooled_report_units": pooled(gap)}
                                       for name, gap in scores.items()}
    document["best_learned_calibrator"] = best
    write_json(report_path, document)
    units = report_unit_names(result.units)
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
