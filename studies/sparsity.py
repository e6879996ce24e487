"""Sparsity and calibration time (the paper's Fig. 5).

Each of ``repeats`` independent sessions of the virtual RAVEN-II records J2-J3 zig-zags at five
sparsities, one recording each, and an independent 20-minute random test (so that time effects
do not mix in). Models are trained on each single sparsity and on combinations of the paper's
sparsities 1/6, 1/4, 1/3 (at most 1013 s, the paper's longest), and scored on their session's
test. The figure gives mean +- standard deviation over sessions against the calibration time.

The paper's five sparsities are lost from the available text except 1/6, 1/4 and 1/3; 1/2 and
1/5 are chosen here to span 2 to 9 minutes of recording (a parameter).

Run: ``python studies/sparsity.py [--quick] [--out DIR] [--jobs N] [--backend loky|ray|dask]``
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from simulation import powered_on, record_random_test
from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.evaluation import JOINT_HEADERS
from studies.common.methods import MODEL_LABELS, MethodSettings, dnn, regression
from studies.common.runner import StudyRun, positive_int, say, study_parser
from studies.common.samples import Samples
from studies.common.sessions import combination_label, record_zigzags, samples_of, spawn_seeds, training_sets
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "sparsity"
MODELS = ("dnn", "polynomial", "linear", "fixed_offset")
STUDY_SPARSITIES = (1 / 2, 1 / 3, 1 / 4, 1 / 5, 1 / 6)
"""Sparsities of the study: the paper's 1/6, 1/4, 1/3 and, chosen here, 1/2 and 1/5."""
PAPER_COMBINATIONS = ((1 / 4, 1 / 3), (1 / 6, 1 / 3), (1 / 6, 1 / 4), (1 / 6, 1 / 4, 1 / 3))
"""Combinations of the paper's sparsities (479 s to 1002 s of recording)."""


@dataclass(frozen=True)
class SparsityConfig:
    """Sessions, sparsities, combinations, test length and training budgets of the study."""

    seed: int = 0
    direction: str = "J2-J3"
    sparsities: tuple[float, ...] = STUDY_SPARSITIES
    combinations: tuple[tuple[float, ...], ...] = PAPER_COMBINATIONS
    repeats: int = 3
    test_duration: float = 1200.0
    settings: MethodSettings = field(default_factory=MethodSettings)

    def __post_init__(self) -> None:
        if int(self.repeats) != self.repeats or self.repeats < 1:
            raise ValueError(f"repeats must be a positive integer, got {self.repeats}")
        missing = sorted({s for combo in self.combinations for s in combo} - set(self.sparsities))
        if missing:
            raise ValueError(f"combinations use sparsities {missing} that are not recorded")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "SparsityConfig":
        """Sparsities 1/2 and 1/3 and their combination, 2 sessions, 3-minute tests, one DNN seed."""
        return cls(**{"seed": seed, "sparsities": (1 / 2, 1 / 3), "combinations": ((1 / 2, 1 / 3),),
                      "repeats": 2, "test_duration": 180.0, "settings": MethodSettings.quick(), **changes})

    @property
    def training_combinations(self) -> tuple[tuple[float, ...], ...]:
        return tuple((s,) for s in self.sparsities) + tuple(tuple(c) for c in self.combinations)


def sparsity_session(seed: int, direction: str, sparsities: tuple[float, ...],
                     test_duration: float) -> tuple[dict[float, Samples], Samples]:
    """One session: the zig-zags at each sparsity (one recording each), then a random test."""
    robot = powered_on(seed=seed)
    parts = {s: samples_of(r, recording_id=k)["selected"]
             for k, (s, r) in enumerate(record_zigzags(robot, direction, sparsities).items())}
    test = record_random_test(robot, test_duration, seed=seed + 1, segment="test")
    return parts, samples_of(test)["selected"]


def run(config: SparsityConfig, *, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
        progress: bool = True) -> dict:
    """Simulate the sessions, train every model on every training set; the numbers of ``results.json``."""
    seeds = spawn_seeds(config.seed, config.repeats)
    sessions = run_tasks(sparsity_session, [(s, config.direction, tuple(config.sparsities), config.test_duration)
                                            for s in seeds],
                         n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress,
                         description="sessions")
    methods = {"dnn": dnn(config.settings), **{m: regression(m) for m in MODELS if m != "dnn"}}
    cells, durations = [], {}
    for r, (parts, test) in enumerate(sessions):
        for label, train in training_sets(parts, config.training_combinations).items():
            durations.setdefault(label, []).append(train.duration)
            cells += [GridCell((r, label, m), methods[m], train, {"test": test}) for m in MODELS]
    outcomes = fit_grid(cells, seed=config.seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                        progress=progress)
    labels = sorted(durations, key=lambda label: np.mean(durations[label]))
    per_session = {label: {m: [mean_joint_rmse(outcomes[(r, label, m)], "test").tolist()
                               for r in range(config.repeats)] for m in MODELS} for label in labels}
    return {
        "training_sets": labels,
        "calibration_time_s": {label: round(float(np.mean(durations[label])), 1) for label in labels},
        "rmse_mean": {label: {m: np.nanmean(per_session[label][m], axis=0).tolist() for m in MODELS}
                      for label in labels},
        "rmse_std_over_sessions": {label: {m: np.nanstd(per_session[label][m], axis=0).tolist() for m in MODELS}
                                   for label in labels},
        "rmse_per_session": per_session,
        "session_seeds": seeds,
        "failures": failures(outcomes),
    }


def improvement(results: dict) -> dict:
    """Per model and joint: % of RMSE removed by the longest training set over the shortest one."""
    shortest, longest = results["training_sets"][0], results["training_sets"][-1]
    return {m: (100.0 * (1.0 - np.asarray(results["rmse_mean"][longest][m])
                         / np.asarray(results["rmse_mean"][shortest][m]))).tolist() for m in MODELS}


def finding(results: dict) -> str:
    gain = improvement(results)
    learned_improve = all(v > 0 for m in ("dnn", "linear") for v in gain[m])
    fixed_less = np.mean(gain["fixed_offset"]) < min(np.mean(gain["dnn"]), np.mean(gain["linear"]))
    shortest, longest = results["training_sets"][0], results["training_sets"][-1]
    simulated = (f"from the shortest ({shortest}, {results['calibration_time_s'][shortest]:.0f} s) to the longest "
                 f"training set ({longest}, {results['calibration_time_s'][longest]:.0f} s) the RMSE of joints "
                 "1/2/3 falls by " + "; ".join(f"{MODEL_LABELS[m]} " + "/".join(f"{v:.0f}%" for v in gain[m])
                                              for m in MODELS) + ".")
    return reporting.agreement_line(learned_improve and fixed_less, simulated, paper.FINDINGS["sparsity"],
                                    paper.FINDING_KIND["sparsity"])


def tables(results: dict) -> list[str]:
    sections = []
    for j, joint in enumerate(JOINT_HEADERS):
        rows = []
        for label in results["training_sets"]:
            row = [label, f"{results['calibration_time_s'][label]:.0f}"]
            for m in MODELS:
                mean = results["rmse_mean"][label][m][j]
                std = results["rmse_std_over_sessions"][label][m][j]
                row.append(f"{reporting.format_value(mean)} +- {reporting.format_value(std)}")
            rows.append(row)
        sections += [f"## {joint}", "", reporting.markdown_table(
            ["Training set (sparsities)", "Calibration time (s)", *[MODEL_LABELS[m] for m in MODELS]], rows), ""]
    sections.append("Mean +- standard deviation over independent sessions (each with its own test). "
                    "The paper gives this experiment as a figure (Fig. 5); its numbers are not available here.")
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    labels = results["training_sets"]
    x = [results["calibration_time_s"][label] for label in labels]
    series = {MODEL_LABELS[m]: (np.array([results["rmse_mean"][label][m] for label in labels]),
                                np.array([results["rmse_std_over_sessions"][label][m] for label in labels]))
              for m in MODELS}
    return [plots.lines_with_spread(x, series, JOINT_HEADERS, out / "sparsity_rmse.png",
                                    "RMSE against calibration time (mean +- std over sessions)",
                                    "calibration time (s)", log_scale=True)]


def configure(args) -> SparsityConfig:
    config = (SparsityConfig.quick if args.quick else SparsityConfig)(seed=args.seed)
    if args.repeats is not None:
        config = replace(config, repeats=args.repeats)
    if args.dnn_seeds is not None:
        config = replace(config, settings=config.settings.with_(dnn_seeds=args.dnn_seeds))
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--repeats", type=positive_int, default=None, help="independent sessions")
    parser.add_argument("--dnn-seeds", type=positive_int, default=None, help="network training seeds to average")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"{config.repeats} sessions x sparsities {[combination_label((s,)) for s in config.sparsities]}")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Sparsity and calibration time (Fig. 5)", finding=finding,
                              tables=tables, figures=figures,
                              extra={"improvement_longest_over_shortest_percent": improvement(results)})


if __name__ == "__main__":
    main()
