"""Results as a function of model mismatch: when does a learned calibrator overtake the UKF?

The model-based filter (the UKF of Haghighipanah et al. 2015) models motor, cable and link; the
virtual RAVEN-II has more physics than that (:mod:`simulation.model.mismatch`). This study scales
every effect outside the filter's class by ``lam`` (0: the robot is of the filter's class; 1: the
default robot; 2: twice its unmodelled physics), and for each ``lam`` and each simulation seed
records the paper's protocol (calibration zig-zags, an independent unloaded random test), trains
every method on the calibration and scores it on the test. Each seed is a new simulated robot
session (new homing, new motion); the training seeds follow the simulation seed.

Reported per method, ``lam`` and joint: the mean RMSE over seeds with its 95 % Student-t interval,
and per joint the ``lam`` at which each learned calibrator's mean RMSE falls below the UKF's
(linear interpolation between grid points; "none in range" when it does not cross).

Run: ``python studies/model_mismatch.py [--quick] [--lams 0,0.5,1,2] [--seeds N] [--out DIR]
[--jobs N] [--backend loky|ray|dask]``
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy import stats

from simulation.model.mismatch import FILTER_CLASS, out_of_class_effects, scale_out_of_class
from simulation.model.parameters import RavenParameters
from simulation.trajectories import PAPER_SPARSITIES
from studies.common import plots, reporting
from studies.common.data_sources import simulated_comparison
from studies.common.evaluation import JOINT_HEADERS
from studies.common.methods import MethodSettings, method_catalogue
from studies.common.runner import StudyRun, positive_int, robot_parameters, say, study_parser
from studies.common.sessions import spawn_seeds
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "model_mismatch"
LAMS = (0.0, 0.25, 0.5, 1.0, 2.0)
MODEL_BASED = ("ukf", "ukf_disturbance", "ukf_hybrid")
LEARNED = ("linear", "dnn", "window_linear")
METHODS = ("raw", "fixed_offset", "linear", "dnn", "window_linear", "ukf", "ukf_disturbance", "ukf_hybrid")
"""Methods of the study, in table order; those missing from the catalogue are left out."""
TEST = "unloaded"


@dataclass(frozen=True)
class MismatchConfig:
    """Grid of the study.

    Attributes
    ----------
    seed : base seed; the simulation seeds are spawned from it.
    lams : factors on the effects outside the filter's class (>= 0).
    seeds : simulation seeds per ``lam`` (>= 2 for an interval).
    sparsities, test_duration : calibration zig-zags and the random test (s).
    settings : training budgets (one network seed per simulation seed).
    """

    seed: int = 0
    lams: tuple[float, ...] = LAMS
    seeds: int = 5
    sparsities: tuple[float, ...] = PAPER_SPARSITIES
    test_duration: float = 600.0
    settings: MethodSettings = field(default_factory=lambda: MethodSettings(dnn_seeds=1))

    def __post_init__(self) -> None:
        if not self.lams or any(not np.isfinite(v) or v < 0 for v in self.lams):
            raise ValueError(f"lams must be finite and >= 0, got {self.lams}")
        if int(self.seeds) != self.seeds or self.seeds < 1:
            raise ValueError(f"seeds must be a positive integer, got {self.seeds}")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "MismatchConfig":
        """``lam`` in {0, 1, 2}, 2 seeds, one sparsity (1/3), 4-minute tests, quick training budgets."""
        return cls(**{"seed": seed, "lams": (0.0, 1.0, 2.0), "seeds": 2, "sparsities": (1 / 3,),
                      "test_duration": 240.0, "settings": MethodSettings.quick(), **changes})


def mismatch_session(lam: float, seed: int, sparsities: tuple[float, ...], test_duration: float,
                     robot: RavenParameters | None = None):
    """The protocol's training and unloaded test samples on ``robot`` (default: the virtual RAVEN-II)
    with its physics outside the filter's class scaled by ``lam``."""
    params = scale_out_of_class(RavenParameters() if robot is None else robot, lam)
    data = simulated_comparison(seed, "J2-J3", sparsities, test_duration, params=params)
    return data.train, {TEST: data.tests[TEST]}


def interval95(values: np.ndarray) -> np.ndarray:
    """(n_columns, 2) Student-t 95 % interval of the column means of ``values`` (rows: seeds)."""
    values = np.asarray(values, dtype=float)
    mean = values.mean(axis=0)
    if values.shape[0] < 2:
        return np.column_stack([mean, mean])
    half = stats.t.ppf(0.975, values.shape[0] - 1) * values.std(axis=0, ddof=1) / np.sqrt(values.shape[0])
    return np.column_stack([mean - half, mean + half])


def crossover(lams: np.ndarray, learned: np.ndarray, model_based: np.ndarray) -> float | None:
    """The ``lam`` from which ``learned`` stays at or below ``model_based`` (linear interpolation).

    The filter's error need not grow monotonically with ``lam`` (one diverging seed raises a mean),
    so this is where the learned calibrator overtakes for good on the grid: ``None`` when it is
    above at the largest ``lam``, ``lams[0]`` when it is never above.
    """
    difference = np.asarray(learned, dtype=float) - np.asarray(model_based, dtype=float)
    if not np.all(np.isfinite(difference)):
        return None
    above = np.flatnonzero(difference > 0)
    if above.size == 0:
        return float(lams[0])
    k = int(above[-1])
    if k == len(lams) - 1:
        return None
    a, b = difference[k], difference[k + 1]
    return float(lams[k] + (lams[k + 1] - lams[k]) * a / (a - b))


def run(config: MismatchConfig, *, robot: RavenParameters | None = None, n_jobs: int = -1, backend: str = "loky",
        scheduler: str | None = None, progress: bool = True) -> dict:
    """Simulate every (lam, seed) session, train and score every method; the numbers of ``results.json``.

    ``robot`` is the robot at lam = 1 (default: the virtual RAVEN-II).
    """
    robot = RavenParameters() if robot is None else robot
    catalogue = method_catalogue(config.settings)
    methods = tuple(m for m in METHODS if m in catalogue)
    seeds = spawn_seeds(config.seed, config.seeds)
    scale_out_of_class(robot, max(config.lams))  # a lam the robot cannot take fails before any simulation
    grid = [(lam, s) for lam in config.lams for s in seeds]
    sessions = run_tasks(mismatch_session, [(lam, s, tuple(config.sparsities), config.test_duration, robot)
                                            for lam, s in grid],
                         n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress,
                         description="sessions")
    outcomes = {}
    for s in seeds:
        cells = [GridCell((lam, s, m), catalogue[m], train, tests)
                 for (lam, s_), (train, tests) in zip(grid, sessions) if s_ == s for m in methods]
        outcomes.update(fit_grid(cells, seed=s, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                                 progress=progress, description=f"training (seed {s})"))
    per_seed = {m: [[mean_joint_rmse(outcomes[(lam, s, m)], TEST).tolist() for s in seeds] for lam in config.lams]
                for m in methods}
    mean = {m: [np.nanmean(rows, axis=0).tolist() for rows in per_seed[m]] for m in methods}
    ci95 = {m: [interval95(np.asarray(rows)).tolist() for rows in per_seed[m]] for m in methods}
    lams = np.asarray(config.lams, dtype=float)
    order = np.argsort(lams)
    crossings = {}
    for learned in (m for m in LEARNED if m in methods):
        for based in (m for m in MODEL_BASED if m in methods):
            crossings[f"{learned}<{based}"] = [
                crossover(lams[order], np.asarray(mean[learned])[order, j], np.asarray(mean[based])[order, j])
                for j in range(3)]
    return {
        "lams": list(config.lams),
        "methods": list(methods),
        "filter_class": list(FILTER_CLASS),
        "scaled_effects": list(out_of_class_effects(robot)),
        "default_robot_lam": 1.0,
        "simulation_seeds": seeds,
        "test": TEST,
        "rmse_mean": mean,
        "rmse_ci95": ci95,
        "rmse_per_seed": per_seed,
        "crossover_lam": crossings,
        "failures": failures(outcomes),
    }


def _lam_text(value: float | None) -> str:
    return "none in range" if value is None else f"{value:.2f}"


def finding(results: dict) -> str:
    crossings = results["crossover_lam"]
    key = next((k for k in ("linear<ukf", "dnn<ukf") if k in crossings), None)
    if key is None:
        return "Finding (test, no paper number): the UKF or the learned calibrators did not run."
    per_joint = ", ".join(f"{joint.split(' (')[0]} {_lam_text(v)}" for joint, v in zip(JOINT_HEADERS, crossings[key]))
    return (f"Finding (test; the paper has no such experiment): {key.split('<')[0]} regression overtakes the UKF at "
            f"lam = {per_joint} (lam = 1 is the default virtual RAVEN-II; {len(results['simulation_seeds'])} "
            "simulation seeds per lam).")


def tables(results: dict) -> list[str]:
    sections = []
    labels = method_catalogue().copy()
    for j, joint in enumerate(JOINT_HEADERS):
        rows = []
        for m in results["methods"]:
            cells = []
            for k in range(len(results["lams"])):
                value = results["rmse_mean"][m][k][j]
                low, high = results["rmse_ci95"][m][k][j]
                cells.append(f"{reporting.format_value(value)} [{reporting.format_value(low)}, "
                             f"{reporting.format_value(high)}]")
            rows.append([labels[m].label if m in labels else m, *cells])
        sections += [f"## {joint}, {results['test']} test", "", reporting.markdown_table(
            ["Method", *[f"lam = {lam:g}" for lam in results["lams"]]], rows), ""]
    rows = [[pair, *[_lam_text(v) for v in values]] for pair, values in results["crossover_lam"].items()]
    sections += ["## Crossover: lam from which the learned calibrator's mean RMSE stays at or below the filter's", "",
                 reporting.markdown_table(["learned < model-based", *JOINT_HEADERS], rows), "",
                 f"Mean [95 % Student-t interval] over {len(results['simulation_seeds'])} simulation seeds per lam. "
                 f"Scaled effects (outside the filter's class): {', '.join(results['scaled_effects'])}; the filter "
                 f"models {', '.join(results['filter_class'])}. lam = 1 is the default robot."]
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    labels = method_catalogue()
    series = {}
    # the raw encoders and the fixed offset are ten times above the rest: they stay in the tables
    for m in (m for m in results["methods"] if m not in ("raw", "fixed_offset")):
        mean = np.asarray(results["rmse_mean"][m])
        ci = np.asarray(results["rmse_ci95"][m])
        series[labels[m].label if m in labels else m] = (mean, (ci[:, :, 1] - ci[:, :, 0]) / 2)
    return [plots.lines_with_spread(results["lams"], series, JOINT_HEADERS, out / "rmse_against_mismatch.png",
                                    "RMSE of the calibrated joints against model mismatch lam "
                                    "(mean and 95 % interval over seeds; lam = 1: the default robot)",
                                    "lam (physics outside the UKF's model)")]


def _lams(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--lams must be comma-separated numbers, got {text!r}") from None
    if not values or any(not np.isfinite(v) or v < 0 for v in values):
        raise argparse.ArgumentTypeError(f"--lams must be finite numbers >= 0, got {text!r}")
    return tuple(sorted(set(values)))


def configure(args) -> MismatchConfig:
    config = (MismatchConfig.quick if args.quick else MismatchConfig)(seed=args.seed)
    if args.lams is not None:
        config = replace(config, lams=args.lams)
    if args.seeds is not None:
        config = replace(config, seeds=args.seeds)
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--lams", type=_lams, default=None, help="comma-separated factors lam >= 0")
    parser.add_argument("--seeds", type=positive_int, default=None, help="simulation seeds per lam")
    parser.add_argument("--robot-params", type=robot_parameters, default=None, metavar="FILE.json",
                        help="the robot at lam = 1 (RavenParameters.to_json); default: the virtual RAVEN-II")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"lam {list(config.lams)} x {config.seeds} simulation seeds, {len(config.sparsities)} sparsities, "
            f"{config.test_duration:.0f} s tests")
        results = run(config, robot=study.args.robot_params, **study.parallel)
        return study.conclude(results, title="Results as a function of model mismatch", finding=finding,
                              tables=tables, figures=figures)


if __name__ == "__main__":
    main()
