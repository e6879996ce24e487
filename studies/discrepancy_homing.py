"""Why a hidden homing offset leaves more than the no-effect gap once it is named.

With a homing offset hidden, the session re-homes once and each homing registers the encoders off
by the effect's repeatability; the workflow names the per-homing offset first on every seed, then a
wrong second name follows on most. This study measures where the rest comes from. For each seed
and each size of the registration error it generates the data (as ``studies/discrepancy.py
--hidden-effect homing_offset`` does), writes them to a file and analyses the file three ways,
each with the per-homing offset as a constant per homing:

* **oracle**: the workflow's own fit of the true structure (the starting structure re-identified
  around the per-homing offset by its backfit);
* **first homing's base**: the starting structure identified on the fit part's first homing alone,
  then one constant per later homing, the mean of that homing's fit-part residual;
* **both homings' base**: the starting structure identified on the whole fit part with those
  constants removed from the joints, then the same constants.

For each it reports the spread of the joint residual within each homing (its standard deviation,
the homing's own mean removed) and the held-out RMSE, in degrees and millimetres. If the first
homing's base leaves the no-effect spread in both homings, a constant per homing is the right
structure and what is left comes from identifying the cable model across the jump.

Run: ``python studies/discrepancy_homing.py [--seed 8] [--seeds 1] [--sizes 1,1e-6] [--duration 240]``
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass

import numpy as np

from studies.common import reporting
from studies.common.discrepancy_runs import record_length
from studies.common.runner import StudyRun, positive_float, positive_int, say, study_parser
from studies.common.sweeps import run_tasks

STUDY = "discrepancy_homing"
HIDDEN = ("homing_offset",)
METHODS = ("oracle", "first homing's base", "both homings' base")


@dataclass(frozen=True)
class HomingConfig:
    """Seeds, record length (s) and sizes of the registration error (multiples of its default)."""

    seeds: tuple[int, ...] = (8,)
    duration: float = 240.0
    sizes: tuple[float, ...] = (1.0, 1e-6)

    def __post_init__(self) -> None:
        if not self.sizes or any(not (np.isfinite(s) and s > 0) for s in self.sizes):
            raise ValueError(f"sizes must be positive numbers, got {self.sizes}")


def _sizes(text: str) -> tuple[float, ...]:
    try:
        return tuple(positive_float(part) for part in text.split(","))
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}") from None


def _spread_and_gap(model, signals, split, robot, homings) -> dict:
    """Per-homing standard deviation of the joint residual and the held-out RMSE (deg, deg, mm)."""
    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.signals import report_scale

    scale = report_scale(signals.units)
    everything = np.ones(len(signals.time), dtype=bool)
    joints = residual(model, signals, robot, offsets=np.zeros(3), mask=everything).joints
    held_out = joints[split.held_out]
    return {"spread": [(joints[signals.homing == h].std(axis=0) * scale).tolist() for h in homings],
            "held_out": (np.sqrt(np.mean(held_out ** 2, axis=0)) * scale).tolist()}


def analyse(seed: int, duration: float, size: float) -> dict:
    """One seed and size: generate, write, then analyse the file the three ways."""
    from kinematics import RavenII
    from simulation.discrepancy import MeasuredSignals, Split
    from simulation.discrepancy.fitting import residual
    from studies.common.discrepancy_runs import (
        STARTING_STRUCTURE, generate_measured, oracle, raven_base_identifier, read_measured, write_measured)

    dataset, _ = generate_measured(HIDDEN, seed, duration, size_factor=size)
    with tempfile.TemporaryDirectory() as folder:
        path = write_measured(dataset, folder)
        measured = read_measured(path)
        result = oracle(path, HIDDEN)
    signals = MeasuredSignals.from_dataset(measured)
    split = Split.by_time(signals)
    robot = RavenII(signals.arm, check_limits=False)
    homings = [int(h) for h in np.unique(signals.homing)]
    first, later = homings[0], homings[1:]
    rows = {"oracle": _spread_and_gap(result.model_after, signals, split, robot, homings)}

    first_fit = split.fit & (signals.homing == first)
    model = raven_base_identifier(measured, first_fit, STARTING_STRUCTURE).identify(STARTING_STRUCTURE, None)
    model = model.with_offsets(model.offsets + residual(model, signals, robot, mask=first_fit).joint_offsets)
    constants = {h: residual(model, signals, robot, offsets=np.zeros(3), mask=split.fit & (signals.homing == h)
                             ).joints.mean(axis=0) for h in later}
    rows[METHODS[1]] = _spread_and_gap(model.with_homing_offsets(constants, "homing_offset"), signals, split, robot,
                                       homings)

    share = np.zeros_like(signals.truth)
    for h, value in constants.items():
        share[signals.homing == h] = value
    base = raven_base_identifier(measured, split.fit, STARTING_STRUCTURE)
    model = base.identify(STARTING_STRUCTURE, (share, np.zeros_like(share)), 0.0)
    model = model.with_homing_offsets(constants, "homing_offset")
    model = model.with_offsets(model.offsets + residual(model, signals, robot, mask=split.fit).joint_offsets)
    rows[METHODS[2]] = _spread_and_gap(model, signals, split, robot, homings)
    return {"seed": seed, "size": size, "homings": homings, "jump": [float(v) for v in constants[later[0]]],
            "methods": rows}


def run(config: HomingConfig, n_jobs: int = -1, backend: str = "loky", scheduler=None, progress: bool = True) -> dict:
    tasks = [(seed, config.duration, size) for seed in config.seeds for size in config.sizes]
    runs = run_tasks(analyse, tasks, n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress,
                     description="seeds x sizes")
    return {"duration_s": config.duration, "sizes": list(config.sizes), "seeds": list(config.seeds), "runs": runs}


def tables(results: dict) -> list[str]:
    rows = []
    for r in results["runs"]:
        for method in METHODS:
            m = r["methods"][method]
            rows.append([str(r["seed"]), f"{r['size']:g}", method,
                         *[f"{spread[1]:.4f}" for spread in m["spread"]],
                         ", ".join(f"{v:.4f}" for v in m["held_out"])])
    n_homings = max(len(r["homings"]) for r in results["runs"])
    headers = ["seed", "size", "model", *[f"elbow spread, homing {k + 1} (deg)" for k in range(n_homings)],
               "held-out RMSE (shoulder deg, elbow deg, z_ins mm)"]
    jumps = [[str(r["seed"]), f"{r['size']:g}", f"{np.degrees(r['jump'][0]):.4f}", f"{np.degrees(r['jump'][1]):.4f}",
              f"{1e3 * r['jump'][2]:.4f}"] for r in results["runs"]]
    return [f"## Hidden homing offset, {results['duration_s']:.0f} s records", "",
            reporting.markdown_table(headers, rows), "",
            "Spread: the standard deviation of the elbow's residual within each homing, the homing's own mean "
            "removed. Size: the registration error's repeatability as a multiple of its default.", "",
            "## The registration jump between the homings (first homing's base)", "",
            reporting.markdown_table(["seed", "size", "shoulder deg", "elbow deg", "z_ins mm"], jumps)]


def finding(results: dict) -> str:
    parts = []
    for r in results["runs"]:
        spread = {m: max(s[1] for s in r["methods"][m]["spread"]) for m in METHODS}
        parts.append(f"seed {r['seed']}, size {r['size']:g}: largest elbow spread "
                     + ", ".join(f"{m} {v:.4f} deg" for m, v in spread.items()))
    return "; ".join(parts) + "."


def configure(args) -> HomingConfig:
    if args.quick:
        return HomingConfig(seeds=(args.seed,), duration=120.0, sizes=args.sizes)
    return HomingConfig(seeds=tuple(range(args.seed, args.seed + args.seeds)), duration=args.duration,
                        sizes=args.sizes)


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.set_defaults(seed=8)
    parser.add_argument("--seeds", type=positive_int, default=1, help="how many seeds, from --seed on")
    parser.add_argument("--duration", type=record_length, default=240.0, help="record length (s, at most six hours)")
    parser.add_argument("--sizes", type=_sizes, default=(1.0, 1e-6),
                        help="comma-separated multiples of the registration error's default size")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"hidden homing offset: {len(config.seeds)} seeds x {len(config.sizes)} sizes, "
            f"{config.duration:.0f} s records")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Discrepancy workflow: the homing offset's leftover",
                              finding=finding, tables=tables, figures=lambda results, out: [])


if __name__ == "__main__":
    main()
