"""Effects of homing: training that saw no re-homing vs one re-homing (the paper's Fig. 9).

Two sessions of the virtual RAVEN-II, each with 5 re-homings (``simulation.rehome``) and an
independent 20-minute random test before the first, between the others and after the last:

* "seen 0 homings": all J2-J3 zig-zags (sparsities 1/6, 1/4, 1/3) are recorded before the first
  test, so the training data saw no homing;
* "seen 1 homing": the zig-zags are split before and after the first re-homing (the first
  sparsity before, the others after), with the same sparsities and length.

DNN, linear regression and fixed offset are trained on each session's zig-zags and scored on
the test after each homing.

Run: ``python studies/homing.py [--quick] [--out DIR] [--jobs N] [--backend loky|ray|dask]``
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from simulation import powered_on, record_calibration, record_random_test, rehome
from simulation.trajectories import PAPER_SPARSITIES
from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.evaluation import JOINT_HEADERS
from studies.common.methods import MODEL_LABELS, MethodSettings, dnn, regression
from studies.common.runner import StudyRun, positive_int, say, study_parser
from studies.common.samples import Samples
from studies.common.sessions import samples_of, spawn_seeds
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "homing"
SEEN = (0, 1)
MODELS = ("dnn", "linear", "fixed_offset")


@dataclass(frozen=True)
class HomingConfig:
    """Sessions, homings, test length and training budgets of the study."""

    seed: int = 0
    direction: str = "J2-J3"
    sparsities: tuple[float, ...] = PAPER_SPARSITIES
    n_homings: int = 5
    test_duration: float = 1200.0
    settings: MethodSettings = field(default_factory=MethodSettings)

    def __post_init__(self) -> None:
        if len(self.sparsities) < 2:
            raise ValueError("the 'seen 1 homing' session splits the zig-zags: give at least 2 sparsities")
        if int(self.n_homings) != self.n_homings or self.n_homings < 1:
            raise ValueError(f"n_homings must be a positive integer, got {self.n_homings}")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "HomingConfig":
        """Sparsities 1/2 and 1/3, 3 homings, 2-minute tests, one DNN seed."""
        return cls(**{"seed": seed, "sparsities": (1 / 2, 1 / 3), "n_homings": 3, "test_duration": 120.0,
                      "settings": MethodSettings.quick(), **changes})


def homing_session(seen: int, seed: int, config: HomingConfig) -> tuple[Samples, dict[str, Samples]]:
    """One session: training zig-zags (split around the first re-homing when ``seen`` is 1) and the
    test after each homing, keyed ``"homing 0"`` (before the first) ... ``"homing n"``."""
    if seen not in SEEN:
        raise ValueError(f"seen must be 0 or 1, got {seen}")
    robot = powered_on(seed=seed)
    test_seeds = [seed + 1 + k for k in range(config.n_homings + 1)]
    before = config.sparsities if seen == 0 else config.sparsities[:1]
    parts = [samples_of(record_calibration(robot, config.direction, before), recording_id=0)["selected"]]
    tests = {"homing 0": record_random_test(robot, config.test_duration, test_seeds[0], "test")}
    for k in range(1, config.n_homings + 1):
        rehome(robot)
        if seen == 1 and k == 1:
            after = record_calibration(robot, config.direction, config.sparsities[1:])
            parts.append(samples_of(after, recording_id=1)["selected"])
        tests[f"homing {k}"] = record_random_test(robot, config.test_duration, test_seeds[k], "test")
    return Samples.concat(parts), {name: samples_of(r)["selected"] for name, r in tests.items()}


def run(config: HomingConfig, *, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
        progress: bool = True) -> dict:
    """Simulate both sessions, train each model, score after every homing."""
    # below 2**31 with room for the seeds of the tests after each homing (seed + 1 + k)
    seeds = spawn_seeds(config.seed, len(SEEN), modulus=2**31 - 64)
    sessions = run_tasks(homing_session, [(seen, seeds[seen], config) for seen in SEEN], n_jobs=n_jobs,
                         backend=backend, scheduler=scheduler, progress=progress, description="sessions")
    methods = {"dnn": dnn(config.settings), "linear": regression("linear"),
               "fixed_offset": regression("fixed_offset")}
    cells = [GridCell((seen, m), methods[m], train, tests) for seen, (train, tests) in zip(SEEN, sessions)
             for m in MODELS]
    outcomes = fit_grid(cells, seed=config.seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                        progress=progress)
    names = list(sessions[0][1])
    rmse = {f"seen {seen}": {m: {name: mean_joint_rmse(outcomes[(seen, m)], name).tolist() for name in names}
                             for m in MODELS} for seen in SEEN}
    return {"homings": names, "rmse": rmse, "session_seeds": seeds,
            "training_duration_s": {f"seen {seen}": round(train.duration, 1) for seen, (train, _) in zip(SEEN, sessions)},
            "failures": failures(outcomes)}


def joint2_after_homing(results: dict, model: str = "dnn") -> dict:
    """Joint 2 RMSE (deg) before any re-homing and its mean after them, per session."""
    out = {}
    for session, models in results["rmse"].items():
        values = [models[model][name][1] for name in results["homings"]]
        out[session] = {"before": values[0], "after_mean": float(np.mean(values[1:])), "after_max": float(max(values[1:]))}
    return out


def finding(results: dict) -> str:
    j2 = joint2_after_homing(results)
    degrades = j2["seen 0"]["after_mean"] > j2["seen 0"]["before"]
    helped = j2["seen 1"]["after_mean"] < j2["seen 0"]["after_mean"]
    simulated = ("DNN joint 2 RMSE before re-homing / mean after re-homings: "
                 + "; ".join(f"{session} {v['before']:.3f} / {v['after_mean']:.3f} deg" for session, v in j2.items())
                 + ".")
    return reporting.agreement_line(degrades and helped, simulated, paper.FINDINGS["homing"],
                                    paper.FINDING_KIND["homing"])


def tables(results: dict) -> list[str]:
    sections = []
    for j, joint in enumerate(JOINT_HEADERS):
        headers = ["Test after", *[f"{MODEL_LABELS[m]}, {session}" for m in MODELS for session in results["rmse"]]]
        rows = [[name, *[results["rmse"][session][m][name][j] for m in MODELS for session in results["rmse"]]]
                for name in results["homings"]]
        sections += [f"## {joint}", "", reporting.markdown_table(headers, rows), ""]
    sections.append("'homing 0' is the test before the first re-homing; 'seen 1' trained on zig-zags recorded "
                    "before and after the first re-homing. The paper gives this experiment as a figure (Fig. 9); "
                    "its numbers are not available here.")
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    x = list(range(len(results["homings"])))
    series = {f"{MODEL_LABELS[m]}, {session}": (np.array([models[m][name] for name in results["homings"]]),
                                                np.zeros((len(x), 3)))
              for session, models in results["rmse"].items() for m in MODELS}
    return [plots.lines_with_spread(x, series, JOINT_HEADERS, out / "homing.png",
                                    "RMSE after each re-homing", "re-homings before the test", log_scale=True)]


def configure(args) -> HomingConfig:
    config = (HomingConfig.quick if args.quick else HomingConfig)(seed=args.seed)
    if args.dnn_seeds is not None:
        config = replace(config, settings=config.settings.with_(dnn_seeds=args.dnn_seeds))
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--dnn-seeds", type=positive_int, default=None, help="network training seeds to average")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"2 sessions x {config.n_homings} re-homings, {config.test_duration:.0f} s tests")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Effects of homing (Fig. 9)", finding=finding, tables=tables,
                              figures=figures)


if __name__ == "__main__":
    main()
