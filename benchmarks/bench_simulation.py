"""Speed and memory of the virtual RAVEN-II's 1 kHz servo loop.

Simulates 10 minutes of unloaded random motion (the paper's test motion) after homing, with every
effect on, and prints the compile time, the wall time and, as its last line,
``realtime_factor <simulated seconds per wall second>``. With ``--hours H`` it also runs H hours of
unloaded operation logged at 30 Hz and prints the peak resident memory of the process.

    python benchmarks/bench_simulation.py
    python benchmarks/bench_simulation.py --hours 6
"""

from __future__ import annotations

import argparse
import resource
import time

from simulation.engine.robot import VirtualRaven
from simulation.engine.scenarios import long_operation, powered_on
from simulation.trajectories import random_sinusoidal
from studies.common.runner import positive_float, positive_int


def peak_memory_mb() -> float:
    """Peak resident set size of this process (MB; Linux reports kB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=positive_float, default=10.0, help="simulated minutes of random motion")
    parser.add_argument("--hours", type=positive_float, default=0.0, help="also run this many hours of operation")
    parser.add_argument("--repeat", type=positive_int, default=3, help="timed repetitions (best is reported)")
    args = parser.parse_args()

    start = time.perf_counter()
    warm = VirtualRaven(seed=0)
    warm.hold(0.01)
    compile_s = time.perf_counter() - start
    print(f"compile (or load from numba cache): {compile_s:.2f} s")

    duration = args.minutes * 60.0
    motion = random_sinusoidal(duration, seed=1)
    best = float("inf")
    for r in range(args.repeat):
        robot = powered_on(seed=r)
        robot.move_to(motion.q[0])
        tick = time.perf_counter()
        recording = robot.run(motion, segment="random")
        elapsed = time.perf_counter() - tick
        best = min(best, elapsed)
        print(f"run {r}: {duration:.0f} s simulated in {elapsed:.2f} s "
              f"({len(recording)} state samples, {len(recording.truth_time)} truth samples)")

    if args.hours > 0:
        robot = powered_on(seed=7)
        tick = time.perf_counter()
        operation = long_operation(robot, "unloaded", args.hours, seed=7)
        elapsed = time.perf_counter() - tick
        print(f"{args.hours:g} h of unloaded operation in {elapsed:.1f} s "
              f"({args.hours * 3600 / elapsed:.0f}x real time), {len(operation)} state samples, "
              f"{operation.values.nbytes / 1e6:.0f} MB of recorded channels")
        print(f"peak memory {peak_memory_mb():.0f} MB")
    print(f"realtime_factor {duration / best:.1f}")


if __name__ == "__main__":
    main()
