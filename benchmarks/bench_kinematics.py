"""Speed of the RAVEN-II kinematics: single calls, batches, and the compiled gravity path.

Run:  python benchmarks/bench_kinematics.py [--arm left] [--repeat 5]

Prints the best-of-``repeat`` wall time of each operation. The batched forward
kinematics of 100 000 configurations has a target of 0.5 s (2 cores).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from numba import njit

from kinematics import RavenII, gravity_torques_fast, mass_matrix_fast
from studies.common.runner import positive_int

FK_100K_TARGET_S = 0.5


def best_time(func, repeat: int, number: int = 1) -> float:
    """Best mean time of ``number`` calls over ``repeat`` rounds (s)."""
    func()
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            func()
        best = min(best, (time.perf_counter() - start) / number)
    return best


@njit
def _gravity_loop(q3s, coeffs):
    total = np.zeros(3)
    for n in range(q3s.shape[0]):
        total += gravity_torques_fast(q3s[n], coeffs)
    return total


@njit
def _mass_loop(q3s, coeffs):
    total = np.zeros((3, 3))
    for n in range(q3s.shape[0]):
        total += mass_matrix_fast(q3s[n], coeffs)
    return total


def _row(label: str, seconds: float, per: int = 1) -> None:
    per_item = seconds / per
    print(f"  {label:<46s} {seconds * 1e3:10.3f} ms   ({per_item * 1e6:9.3f} us/config)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arm", choices=("left", "right"), default="left")
    parser.add_argument("--repeat", type=positive_int, default=5)
    args = parser.parse_args()

    robot = RavenII(args.arm)
    rng = np.random.default_rng(0)
    lower, upper = robot.joint_limits
    q_all = rng.uniform(lower, upper, size=(100_000, 6))
    q1 = q_all[0]

    print(f"RAVEN-II {args.arm} arm, best of {args.repeat}")
    print("single configuration (Pinocchio path, input checks and limit check included):")
    for name in ("forward_kinematics", "jacobian", "gravity_torques", "mass_matrix"):
        method = getattr(robot, name)
        _row(f"{name}(q)", best_time(lambda: method(q1), args.repeat, 2000))

    print("batched (vectorized numpy path):")
    for n in (1_000, 10_000, 100_000):
        q = q_all[:n]
        for name in ("forward_kinematics", "jacobian"):
            method = getattr(robot, name)
            _row(f"{name}(q), N={n}", best_time(lambda: method(q), args.repeat), n)
    q = q_all[:1_000]
    _row(
        "forward_kinematics(q), N=1000, Pinocchio loop",
        best_time(lambda: robot.forward_kinematics(q, backend="pinocchio"), args.repeat),
        1_000,
    )

    coeffs = robot.gravity_coefficients(payload_kg=0.1)
    q3 = np.ascontiguousarray(q_all[:, :3])
    print("compiled closed form (numba):")
    _row("gravity_torques_fast, called from Python",
         best_time(lambda: gravity_torques_fast(q3[0], coeffs), args.repeat, 20_000))
    _row("gravity_torques_fast, inside @njit loop, N=100000",
         best_time(lambda: _gravity_loop(q3, coeffs), args.repeat), len(q3))
    _row("mass_matrix_fast, inside @njit loop, N=100000",
         best_time(lambda: _mass_loop(q3, coeffs), args.repeat), len(q3))

    fk_100k = best_time(lambda: robot.forward_kinematics(q_all), args.repeat)
    verdict = "met" if fk_100k <= FK_100K_TARGET_S else "MISSED"
    print(
        f"FK of 100000 configurations: {fk_100k:.3f} s "
        f"(target <= {FK_100K_TARGET_S} s: {verdict}, {FK_100K_TARGET_S / fk_100k:.1f}x margin)"
    )


if __name__ == "__main__":
    main()
