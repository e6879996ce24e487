"""Cost of the discrepancy workflow's objective: one replay of a candidate and its weighted residual.

Run:  python benchmarks/bench_discrepancy.py [--seconds 120] [--seed 0] [--hidden hysteresis] [--evaluations 300]

Generates ``--seconds`` of the virtual RAVEN-II with ``--hidden`` effect on top of the starting
structure, writes and reads it back as the analysis does, identifies the starting structure on the
fit part, and times the objective of several library candidates (the weighted sum of squares of
their residual on the fit part) in CPU time, three ways:

- ``new point``: every evaluation at a new parameter vector, as a line search does (all three
  joints' cable series run);
- ``gradient``: one parameter of one joint perturbed at a time, as the forward differences of a fit
  do (the other joints' series come from the series memo);
- ``series``: the compiled cable series alone, three joints, no memo.

It prints milliseconds per evaluation, the share of ``new point`` spent outside the compiled series
(``python share``), and the CPU seconds of one structure check (the cross-validated sparse fit that
every analysis runs on its final residual), here on the starting model's residual over the fit and
validation parts.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from kinematics import RavenII
from simulation.discrepancy import MeasuredSignals, Split
from simulation.discrepancy.fitting import ChannelWeights, residual
from simulation.discrepancy.replay import _SERIES, cable_link_series
from simulation.discrepancy.signals import report_scale
from simulation.discrepancy.signature import residual_structure
from studies.common.discrepancy_runs import (
    HIDDEN_CHOICES,
    STARTING_STRUCTURE,
    generate_measured,
    raven_base_identifier,
    raven_library,
    read_measured,
    write_measured,
)
from studies.common.runner import non_negative_int, positive_float, positive_int

CANDIDATES = ("hysteresis", "backlash", "capstan_friction", "motor_friction", "payload", "transmission_error")


def cpu_ms(function, evaluations: int) -> float:
    """CPU milliseconds per call of ``function(k)`` over ``evaluations`` calls (after one untimed call)."""
    function(0)
    started = time.process_time()
    for k in range(evaluations):
        function(k)
    return 1000.0 * (time.process_time() - started) / evaluations


def series_inputs(model, signals):
    """The three joints' inputs of the compiled cable series of one replay, captured from the memo."""
    captured = []
    original = _SERIES.series

    def capture(*args):
        captured.append(args)
        return original(*args)

    _SERIES.series = capture
    try:
        model.replay(signals)
    finally:
        del _SERIES.series
    return captured


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=positive_float, default=120.0, help="length of the generated record (s)")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument("--hidden", default="hysteresis", choices=HIDDEN_CHOICES, help="effect hidden in the data")
    parser.add_argument("--evaluations", type=positive_int, default=300, help="evaluations timed per candidate and way")
    args = parser.parse_args()

    hidden = () if args.hidden == "none" else (args.hidden,)
    with tempfile.TemporaryDirectory() as folder:
        dataset = read_measured(write_measured(generate_measured(hidden, seed=args.seed, duration=args.seconds)[0],
                                               folder))
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    model = raven_base_identifier(dataset, split.fit).identify(tuple(STARTING_STRUCTURE), None)
    robot = RavenII(signals.arm, check_limits=False)
    start = residual(model, signals, robot, mask=split.fit)
    weights = ChannelWeights.from_residual(start.joints, start.torque, 1e-3 / report_scale(signals.units))
    head = signals.head(int(np.flatnonzero(split.fit)[-1]) + 1)
    candidates = {c.name: c for c in raven_library(signals)}
    rng = np.random.default_rng(args.seed)

    print(f"{args.hidden} hidden, seed {args.seed}: {len(signals)} samples, {int(split.fit.sum())} in the fit part")
    print(f"{'candidate':<20} {'new point ms':>12} {'gradient ms':>12} {'series ms':>10} {'python share':>13}")
    for name in CANDIDATES:
        if name not in candidates:
            continue
        candidate = candidates[name]
        lower, upper, scale, typical = candidate.bounds()
        centre = np.clip(np.where(typical != 0, typical, 0.5 * scale), lower, upper)
        points = np.clip(centre * (1.0 + 0.2 * rng.standard_normal((args.evaluations + 1, centre.size))), lower, upper)

        def new_point(k):
            return residual(candidate.apply(model, points[k]), signals, robot, mask=split.fit).chi_square(weights)

        def gradient(k):
            theta = centre.copy()
            theta[k % theta.size] += 1e-5 * scale[k % theta.size]
            return residual(candidate.apply(model, theta), signals, robot, mask=split.fit).chi_square(weights)

        inputs = series_inputs(candidate.apply(model, centre), head)

        def series(k):
            for args_ in inputs:
                cable_link_series(*args_[:-1])  # the memo's last input, the lag, is only its key

        point_ms = cpu_ms(new_point, args.evaluations)
        gradient_ms = cpu_ms(gradient, args.evaluations)
        series_ms = cpu_ms(series, args.evaluations)
        print(f"{name:<20} {point_ms:>12.3f} {gradient_ms:>12.3f} {series_ms:>10.3f} "
              f"{1.0 - series_ms / point_ms:>13.2f}")

    part = split.fit | split.validation
    left = residual(model, signals, robot, mask=part).joints
    started = time.process_time()
    residual_structure(signals.select(part), left, folds=8)
    print(f"structure check on {int(part.sum())} samples: {time.process_time() - started:.2f} s CPU")


if __name__ == "__main__":
    main()
