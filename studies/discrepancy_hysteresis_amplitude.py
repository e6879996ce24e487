"""How far each fitted hysteresis lands from the generator's, beside how far its run stops short of its bound.

A diagnostic that reads reports and runs nothing. It takes the folders (or ``report.json`` files)
of ``python studies/discrepancy.py --hidden-effect hysteresis --seed S --out DIR`` runs: their
reports hold the generator's values, which the command adds after the blind analysis. For each run
it prints how many points the reported shrink stops short of the floor's bound (the plant floor's
where the plant replay scored the run, the quasi-static floor's otherwise) and, per joint, the
relative error (%) of

- the **hysteretic amplitude**: the largest hysteretic load, ``stiffness / (beta + gamma)`` =
  ``stiffness * width / (1 + shape)`` in the candidate's terms (N m, N m, N), the height of the
  loop the hysteresis adds to the cable's tension;
- the hysteresis's **stiffness** (N m/rad, N m/rad, N/m);
- the **cable stiffness** of the final model's base, the starting structure as the backfit
  re-identified it around the hysteresis.

Then, over the runs, the Spearman rank correlation of the shortfall with each of those errors: which
error ranks with the points a run leaves to its bound. A correlation says what goes with the
shortfall, not what causes it. Run::

    python studies/discrepancy_hysteresis_amplitude.py results/hysteresis-124 results/hysteresis-125 ...
"""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from studies.common.reporting import write_json
from studies.common.runner import UsageError, existing_path, fail, script_parser

STUDY = "discrepancy_hysteresis_amplitude"

QUANTITIES = ("amplitude", "stiffness", "cable_stiffness")
"""The errors compared with the shortfall, per joint (see the module's text)."""

MIN_RUNS_FOR_RANKS = 3
"""Fewest runs over which a rank correlation is computed (with two, it is always +1 or -1)."""


@dataclass(frozen=True)
class HysteresisRun:
    """What one report says about its fitted hysteresis beside the generator's.

    ``shortfall`` in points (percent of the gap); each error a fraction (0.1 = 10 % too large),
    one per joint in the order of ``joints``; ``record_s`` the record's length (s), None where the
    report does not say it."""

    source: str
    seed: int | None
    joints: tuple[str, ...]
    shortfall: float
    errors: dict[str, np.ndarray]
    record_s: float | None = None


def hysteretic_amplitude(parameters: dict) -> np.ndarray:
    """The largest hysteretic load per joint (N m, N m, N), ``stiffness * width / (1 + shape)``, of
    a hysteresis in the candidate's terms (``beta = 1 / width``, ``gamma = shape / width``)."""
    stiffness, width, shape = (np.asarray(parameters[k], dtype=float) for k in ("stiffness", "width", "shape"))
    return stiffness * width / (1.0 + shape)


def _report_path(path: Path) -> Path:
    return path / "report.json" if path.is_dir() else path


def read_run(path: Path) -> HysteresisRun:
    """The fitted hysteresis of the report at ``path`` (a run's folder or its ``report.json``) beside
    the generator's; raises :class:`UsageError`, naming the file and the problem, for a report that
    cannot be read or does not hold a generated hysteresis that the analysis named."""
    report_path = _report_path(Path(path))
    if not report_path.is_file():
        raise UsageError(f"{path} holds no report.json")
    try:
        report = json.loads(report_path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise UsageError(f"{report_path} is not a readable report ({type(error).__name__})") from None
    if not isinstance(report, dict) or "shrink" not in report:
        raise UsageError(f"{report_path} is not a discrepancy run's report (no 'shrink')")
    if "true_parameters" not in report:
        raise UsageError(f"{report_path} is a blind report: it holds no generator values "
                         "(run studies/discrepancy.py --hidden-effect hysteresis)")
    if "hysteresis" not in report["true_parameters"]:
        raise UsageError(f"{report_path}: no hysteresis was hidden (hidden: "
                         f"{', '.join(report.get('hidden_effect') or []) or 'nothing'})")
    if "hysteresis" not in report.get("fitted_parameters", {}):
        raise UsageError(f"{report_path}: the analysis named no hysteresis "
                         f"(named: {', '.join(report.get('named_effects') or []) or 'nothing'})")
    plant = report.get("scored_by") == "plant replay"
    bound = report.get("plant_floor_bound") if plant else report.get("floor_bound")
    if bound is None:
        raise UsageError(f"{report_path} holds no floor bound for the replay that scored it")
    try:
        fitted, true = report["fitted_parameters"]["hysteresis"], report["true_parameters"]["hysteresis"]
        final_base = report["starting_parameters"]["final"]["cable_stretch"]["stiffness"]
        true_base = report["true_starting_parameters"]["cable_stretch"]["stiffness"]
        pairs = {"amplitude": (hysteretic_amplitude(fitted), hysteretic_amplitude(true)),
                 "stiffness": (fitted["stiffness"], true["stiffness"]),
                 "cable_stiffness": (final_base, true_base)}
        with np.errstate(divide="ignore", invalid="ignore"):
            errors = {name: np.asarray(got, dtype=float) / np.asarray(want, dtype=float) - 1.0
                      for name, (got, want) in pairs.items()}
    except (KeyError, TypeError, ValueError) as error:
        raise UsageError(f"{report_path} is not a complete --hidden-effect report "
                         f"({type(error).__name__}: {error})") from None
    for name, error in errors.items():
        if not np.all(np.isfinite(error)):
            raise UsageError(f"{report_path}: the {name.replace('_', ' ')} is not finite or the generator's is 0")
    length = report.get("record_s")
    return HysteresisRun(str(report_path), report.get("seed"), tuple(report.get("joints", ())),
                         100.0 * (float(bound) - float(report["shrink"])), errors,
                         float(length) if isinstance(length, (int, float)) else None)


def rank_correlations(runs: list[HysteresisRun]) -> dict[str, list[float | None]] | None:
    """Spearman's rank correlation of the shortfall with each quantity's error, per joint, over the
    runs; None with fewer than :data:`MIN_RUNS_FOR_RANKS` runs, and None for a joint where either
    side is the same on every run (no ranks to compare)."""
    from scipy.stats import spearmanr

    if len(runs) < MIN_RUNS_FOR_RANKS:
        return None
    shortfall = np.array([run.shortfall for run in runs])
    n_joints = len(runs[0].errors["amplitude"])

    def rho(values):
        if np.ptp(shortfall) == 0 or np.ptp(values) == 0:
            return None
        return float(spearmanr(shortfall, values).statistic)

    return {name: [rho(np.array([run.errors[name][j] for run in runs])) for j in range(n_joints)]
            for name in QUANTITIES}


def table(runs: list[HysteresisRun], ranks: dict[str, list[float]] | None) -> str:
    """The runs (errors in %) and the rank correlations, as Markdown."""
    joints = runs[0].joints or tuple(f"joint {j}" for j in range(len(runs[0].errors["amplitude"])))
    header = ["seed", "short of the bound (points)"] + [f"{name.replace('_', ' ')} error, {joint} %"
                                                        for name in QUANTITIES for joint in joints]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for run in sorted(runs, key=lambda r: r.shortfall):
        cells = ["-" if run.seed is None else str(run.seed), f"{run.shortfall:.1f}"]
        cells += [f"{100 * run.errors[name][j]:+.1f}" for name in QUANTITIES for j in range(len(joints))]
        lines.append("| " + " | ".join(cells) + " |")
    if ranks is None:
        lines.append(f"\nRank correlations need at least {MIN_RUNS_FOR_RANKS} runs.")
    else:
        cells = ["Spearman with the shortfall", ""] + ["-" if ranks[name][j] is None else f"{ranks[name][j]:+.2f}"
                                                       for name in QUANTITIES for j in range(len(joints))]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> dict:
    parser = script_parser(STUDY, __doc__)
    parser.add_argument("reports", nargs="+", type=existing_path, metavar="RUN",
                        help="a --hidden-effect hysteresis run's folder or report.json")
    parser.add_argument("--out", type=Path, default=None, help="write the runs and the correlations to this JSON file")
    args = parser.parse_args(argv)
    try:
        runs = [read_run(path) for path in args.reports]
    except UsageError as error:
        fail(parser.prog, str(error))
    if len({run.joints for run in runs}) > 1:
        fail(parser.prog, "the reports name different joints")
    ranks = rank_correlations(runs)
    print(table(runs, ranks))
    out = {"runs": [{"source": run.source, "seed": run.seed, "joints": list(run.joints),
                     "shortfall_points": run.shortfall,
                     "errors": {name: run.errors[name].tolist() for name in QUANTITIES}} for run in runs],
           "spearman": ranks}
    if args.out is not None:
        write_json(args.out, out)
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
