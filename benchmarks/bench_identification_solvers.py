"""The identification's IPOPT against scipy's trust-region least squares on the same problem.

Run:  python benchmarks/bench_identification_solvers.py [--seconds 60] [--seed 0]

Generates the nothing-hidden record of ``python studies/discrepancy.py --hidden-effect none --seed
SEED --duration SECONDS`` and identifies the discrepancy workflow's starting structure on its first
half, as the workflow does (:func:`simulation.identification.identify`: IPOPT with the
Gauss-Newton Hessian, a first pass and a reweighted pass). It then solves the same two passes
with ``scipy.optimize.least_squares(method="trf")`` on the same compiled residuals and Jacobians,
from the same start, within the same bounds, and prints each solver's seconds, its evaluations per
pass, and the final weighted cost of each. The first identification includes the C compilation of
the structure's functions; it is run once before the timing.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from scipy.optimize import least_squares

from simulation.discrepancy.signals import MeasuredSignals
from simulation.discrepancy.workflow import Split
from simulation.identification import fit as identification
from simulation.identification.layout import build_layout
from simulation.identification.samples import prepare_samples
from studies.common.discrepancy_runs import STARTING_STRUCTURE, generate_measured, uninformed_start
from studies.common.runner import non_negative_int, positive_float


def trust_region_passes(samples, base, effects, max_evaluations: int = 200):
    """The identification's two passes (fit, then reweighted fit) by trust-region least squares."""
    velocity_scale = base.effect("coulomb_friction").velocity_scale
    min_speed = np.broadcast_to(identification.MIN_SPEED_FACTOR * velocity_scale, (3,))
    layout = build_layout(effects, identification.DEFAULT_FIXED, base,
                          identification._initial_offsets(samples, base, effects))
    joint_weight, torque_weight = identification._usage_weights(samples, min_speed,
                                                                identification.DERIVATIVE_WINDOW, base)
    used = np.concatenate([joint_weight.sum(axis=0), torque_weight.sum(axis=0)])
    problem = identification._Problem(layout, base, identification._data_matrix(samples, joint_weight,
                                                                                torque_weight))
    lower, upper = layout.bounds()
    xi = np.zeros(len(layout))
    sigma = np.maximum(identification._channel_rms(problem.residuals(xi, np.ones(6)), used),
                       identification.SIGMA_FLOOR)
    passes = []
    for _ in range(2):
        solution = least_squares(lambda x: problem.residuals(x, sigma).ravel(), xi,
                                 jac=lambda x: problem.jacobian(x, sigma).reshape(-1, len(layout)),
                                 bounds=(lower, upper), method="trf", x_scale="jac", xtol=1e-10, ftol=1e-10,
                                 gtol=1e-10, max_nfev=max_evaluations)
        passes.append((solution.nfev, solution.njev, solution.status, 2.0 * solution.cost / len(samples)))
        xi = solution.x
        sigma = np.maximum(sigma * identification._channel_rms(problem.residuals(xi, sigma), used),
                           identification.SIGMA_FLOOR)
    return passes


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=positive_float, default=60.0, help="record length (s)")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of the generated record")
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    dataset, _ = generate_measured((), args.seed, args.seconds)
    split = Split.by_time(MeasuredSignals.from_dataset(dataset), (0.5, 0.25, 0.25))
    base = uninformed_start(dataset.arm)
    samples = prepare_samples(dataset.select(split.fit), base)
    effects = tuple(STARTING_STRUCTURE)
    identification.identify(samples, effects=effects, base=base)     # compiles the structure's functions
    started = time.perf_counter()
    result = identification.identify(samples, effects=effects, base=base, verbose=1)
    ipopt_s = time.perf_counter() - started
    started = time.perf_counter()
    passes = trust_region_passes(samples, base, effects)
    trf_s = time.perf_counter() - started
    print(f"{len(samples)} samples, {len(effects)} effects")
    print(f"IPOPT: {ipopt_s:.2f} s ({result.report.iterations} iterations in the last pass, "
          f"{result.report.solver_status})")
    for k, (nfev, njev, status, cost) in enumerate(passes, 1):
        print(f"trust region pass {k}: {nfev} residual and {njev} Jacobian evaluations, status {status}, "
              f"mean weighted cost {cost:.4g}")
    print(f"trust region: {trf_s:.2f} s; ratio to IPOPT {trf_s / ipopt_s:.1f}")


if __name__ == "__main__":
    main()
