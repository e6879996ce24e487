"""Speed of the casadi identification, compiled against casadi's virtual machine.

Run:  python benchmarks/bench_identification.py [--seconds 120] [--repeats 3] [--seed 0]

Records ``--seconds`` of random motion on the virtual RAVEN-II (every effect on), identifies the
cable model of the nominal structure on it ``--repeats`` times with the per-sample functions
compiled by the system C compiler and as many times in casadi's virtual machine
(``RAVEN_CALIBRATION_COMPILE=0``), and prints the median seconds of each, the speed-up
(``speedup <ratio>``) and the largest difference between the two fits' estimates, in standard
errors. The first compiled fit includes the compilation; later fits of the same structure reuse it.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from simulation.engine.scenarios import powered_on, record_random_test
from simulation.identification import FITTABLE_EFFECTS, PoorlyIdentifiedWarning, identify
from simulation.identification import compiled
from simulation.model.parameters import RavenParameters


def timed_fits(recording, repeats: int) -> tuple[list[float], object]:
    seconds, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
            result = identify(recording, effects=FITTABLE_EFFECTS)
        seconds.append(time.perf_counter() - started)
    return seconds, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=120.0, help="length of the random-motion record (s)")
    parser.add_argument("--repeats", type=int, default=3, help="identifications per variant")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.seconds <= 0 or args.repeats < 1:
        parser.error("--seconds must be positive and --repeats at least 1")

    robot = powered_on(RavenParameters(), seed=args.seed)
    recording = record_random_test(robot, args.seconds, seed=args.seed)
    fast, fast_result = timed_fits(recording, args.repeats)
    os.environ[compiled.COMPILE_ENV] = "0"
    compiled._CACHE.clear()
    slow, slow_result = timed_fits(recording, args.repeats)
    deviation = max(abs(a.value - b.value) / b.standard_error
                    for a, b in zip(fast_result.estimates, slow_result.estimates) if b.standard_error > 0)
    print(f"samples {fast_result.report.n_samples}, unknowns {len(fast_result.estimates)}, "
          f"IPOPT iterations (last pass) {fast_result.report.iterations} / {slow_result.report.iterations}")
    print(f"compiled: first {fast[0]:.2f} s (with the compilation), median {np.median(fast):.2f} s")
    print(f"virtual machine: median {np.median(slow):.2f} s")
    print(f"speedup {np.median(slow) / np.median(fast):.2f}")
    print(f"largest difference of the estimates: {deviation:.2e} standard errors")


if __name__ == "__main__":
    main()
