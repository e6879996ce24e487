"""Directions of the calibration trajectories (the paper's Table I).

For each of the 7 zig-zag directions (J1, J2, J3, J1-J2, J2-J3, J1-J3, J1-J2-J3) a fresh session of
the virtual RAVEN-II records the zig-zags at sparsities 1/6, 1/4, 1/3 and an independent 20-minute
random test; DNN (averaged over 5 seeds), 2nd-order polynomial, linear regression and fixed offset
are trained on the zig-zags and scored on the test. The table gives the RMSE per joint, the
percentage of the fixed-offset RMSE (as the paper does), and the paper's numbers beside.

Run: ``python studies/directions.py [--quick] [--out DIR] [--jobs N] [--backend loky|ray|dask]``
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from simulation import powered_on, record_calibration, record_random_test
from simulation.trajectories import PAPER_SPARSITIES
from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.evaluation import JOINT_HEADERS, percentage_of
from studies.common.methods import MODEL_LABELS, Method, MethodSettings, dnn, raw, regression
from studies.common.runner import StudyRun, names, positive_int, say, study_parser
from studies.common.samples import Samples
from studies.common.sessions import samples_of, spawn_seeds
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "directions"
MODELS = ("dnn", "polynomial", "linear", "fixed_offset", "raw")
LEARNED = ("dnn", "polynomial", "linear")


@dataclass(frozen=True)
class DirectionsConfig:
    """Directions, calibration sparsities, test length and training budgets of the study."""

    seed: int = 0
    directions: tuple[str, ...] = paper.TABLE_I_DIRECTIONS
    sparsities: tuple[float, ...] = PAPER_SPARSITIES
    test_duration: float = 1200.0
    settings: MethodSettings = field(default_factory=MethodSettings)

    def __post_init__(self) -> None:
        unknown = [d for d in self.directions if d not in paper.TABLE_I_DIRECTIONS]
        if unknown or not self.directions:
            raise ValueError(f"directions must be among {paper.TABLE_I_DIRECTIONS}, got {self.directions}")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "DirectionsConfig":
        """All 7 directions, one sparsity (1/3), 4-minute tests, one DNN seed."""
        return cls(**{"seed": seed, "sparsities": (1 / 3,), "test_duration": 240.0,
                      "settings": MethodSettings.quick(), **changes})


def direction_session(direction: str, seed: int, sparsities: tuple[float, ...],
                      test_duration: float) -> tuple[Samples, Samples]:
    """A fresh robot session: zig-zags of one direction, then an independent random test."""
    robot = powered_on(seed=seed)
    calibration = record_calibration(robot, direction, sparsities)
    test = record_random_test(robot, test_duration, seed=seed + 1, segment="test")
    return samples_of(calibration)["selected"], samples_of(test)["selected"]


def _methods(settings: MethodSettings) -> dict[str, Method]:
    return {"dnn": dnn(settings), "polynomial": regression("polynomial"), "linear": regression("linear"),
            "fixed_offset": regression("fixed_offset"),
            "raw": raw()}


def session_seeds(config: DirectionsConfig) -> dict[str, int]:
    """Seed of each direction's session (independent sessions, as the paper recorded them)."""
    seeds = spawn_seeds(config.seed, len(paper.TABLE_I_DIRECTIONS))
    return {d: seeds[paper.TABLE_I_DIRECTIONS.index(d)] for d in config.directions}


def run(config: DirectionsConfig, *, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
        progress: bool = True) -> dict:
    """Simulate the sessions, train and score every model; the numbers of ``results.json``."""
    seeds = session_seeds(config)
    sessions = run_tasks(direction_session, [(d, seeds[d], tuple(config.sparsities), config.test_duration)
                                             for d in config.directions],
                         n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress,
                         description="sessions")
    methods = _methods(config.settings)
    cells = [GridCell((d, m), methods[m], train, {"test": test})
             for d, (train, test) in zip(config.directions, sessions) for m in MODELS]
    outcomes = fit_grid(cells, seed=config.seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                        progress=progress)
    rmse = {d: {m: mean_joint_rmse(outcomes[(d, m)], "test").tolist() for m in MODELS} for d in config.directions}
    spread = {d: {m: np.std([o.scores["test"].joint for o in outcomes[(d, m)]], axis=0).tolist()
                  if not any(o.error for o in outcomes[(d, m)]) else None for m in MODELS}
              for d in config.directions}
    percent = {d: {m: percentage_of(rmse[d][m], rmse[d]["fixed_offset"]).tolist() for m in LEARNED}
               for d in config.directions}
    durations = {d: round(train.duration, 1) for d, (train, _) in zip(config.directions, sessions)}
    return {"rmse": rmse, "rmse_std_over_seeds": spread, "percent_of_fixed_offset": percent,
            "calibration_duration_s": durations, "session_seeds": seeds, "failures": failures(outcomes)}


def overall_ranking(percent: dict) -> list[tuple[str, float]]:
    """Directions ordered by the mean percentage of fixed offset over the learned models and joints."""
    scores = {d: float(np.nanmean([v for m in LEARNED for v in percent[d][m]])) for d in percent}
    return sorted(scores.items(), key=lambda item: item[1])


def paper_percentages() -> dict:
    """The paper's Table I percentages, computed from its RMSE."""
    return {d: {m: percentage_of(paper.TABLE_I[d][m], paper.TABLE_I[d]["fixed_offset"]).tolist() for m in LEARNED}
            for d in paper.TABLE_I_DIRECTIONS}


def finding(results: dict) -> str:
    ranking = overall_ranking(results["percent_of_fixed_offset"])
    paper_rank = overall_ranking(paper_percentages())
    best = ranking[0][0]
    simulated = ("directions by mean % of fixed offset (learned models, 3 joints): "
                 + ", ".join(f"{d} {p:.1f}%" for d, p in ranking) + ".")
    if "J2-J3" not in results["rmse"]:
        return reporting.agreement_line(False, simulated + " (J2-J3 was not run)", paper.FINDINGS["directions"],
                                        paper.FINDING_KIND["directions"])
    return reporting.agreement_line(
        best == "J2-J3", simulated,
        paper.FINDINGS["directions"] + f" (same measure on Table I: {paper_rank[0][0]} {paper_rank[0][1]:.1f}%, "
        f"{paper_rank[1][0]} {paper_rank[1][1]:.1f}%.)", paper.FINDING_KIND["directions"])


def tables(results: dict) -> list[str]:
    """One Markdown table per joint, Table I layout: simulated RMSE (% of fixed offset) | paper."""
    sections = []
    headers = ["Direction"]
    for m in MODELS:
        headers += [f"{MODEL_LABELS[m]} sim", f"{MODEL_LABELS[m]} paper"]
    for j, joint in enumerate(JOINT_HEADERS):
        rows = []
        for d, models in results["rmse"].items():
            row = [d]
            for m in MODELS:
                value = models[m][j]
                pct = results["percent_of_fixed_offset"][d][m][j] if m in LEARNED else None
                published = paper.TABLE_I[d][m][j]
                published_pct = paper_percentages()[d][m][j] if m in LEARNED else None
                row.append(f"{reporting.format_value(value)}" + (f" ({pct:.1f}%)" if pct is not None and
                                                                   np.isfinite(pct) else ""))
                row.append(f"{published:.3f}" + (f" ({published_pct:.1f}%)" if published_pct is not None else ""))
            rows.append(row)
        sections += [f"## {joint}", "", reporting.markdown_table(headers, rows), ""]
    sections.append("Percentages are of the fixed-offset RMSE of the same direction, as in the paper; "
                    "'sim' is simulated here, 'paper' is the paper's Table I.")
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    directions = list(results["rmse"])
    simulated = {MODEL_LABELS[m]: np.array([results["rmse"][d][m] for d in directions]) for m in MODELS}
    published = {MODEL_LABELS[m]: np.array([paper.TABLE_I[d][m] for d in directions]) for m in MODELS}
    return [plots.grouped_bars(directions, simulated, JOINT_HEADERS, out / "directions_simulated.png",
                               "RMSE by calibration direction (simulated here)"),
            plots.grouped_bars(directions, published, JOINT_HEADERS, out / "directions_paper.png",
                               "RMSE by calibration direction (paper, Table I)")]


def configure(args) -> DirectionsConfig:
    config = (DirectionsConfig.quick if args.quick else DirectionsConfig)(seed=args.seed, directions=args.directions)
    if args.dnn_seeds is not None:
        config = replace(config, settings=config.settings.with_(dnn_seeds=args.dnn_seeds))
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--directions", type=names(paper.TABLE_I_DIRECTIONS, "direction"),
                        default=",".join(paper.TABLE_I_DIRECTIONS), help="comma-separated")
    parser.add_argument("--dnn-seeds", type=positive_int, default=None, help="network training seeds to average")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"{len(config.directions)} directions x {len(config.sparsities)} sparsities, "
            f"{config.test_duration:.0f} s tests")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Directions of calibration trajectories (Table I)", finding=finding,
                              tables=tables, figures=figures, extra={"published": {"table_i": paper.TABLE_I}})


if __name__ == "__main__":
    main()
