"""CPU time of compiling the numba kernels, as each new process on a fresh clone pays it.

Run:  python benchmarks/bench_compile.py [--repeats 2] [--stages]

Each measurement is a new Python process with an empty numba cache (``NUMBA_CACHE_DIR`` set to a
new temporary folder), which is what every test worker and study process of a fresh clone starts
from. It prints the process's CPU seconds for each kernel group of :mod:`simulation.kernels`:

- ``servo``: homing the virtual RAVEN-II and two seconds of random motion (compiles the 1 kHz
  servo loop and the kinematics it inlines);
- ``identification``: the links' gravity and inertial loads of an identification's samples
  (:func:`simulation.identification.samples._gravity_and_inertia`) on ten rows;
- ``replay``: the discrepancy replay's series of a cable model and of backlash.

Each line gives the median over ``--repeats`` processes, the import time included (about 3 s of
it). Run it on two versions to compare them.

``--stages`` then takes the servo workload's compile apart, in one more new process: the wall
seconds of the numba functions that took longest to compile (numba's compile events; a function's
time includes the callees compiled inside it) and of the servo loop's compile passes (numba's
pipeline timings), so that a cut can be aimed at the stage that costs.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from simulation.kernels import GROUPS
from studies.common.runner import positive_int

ROOT = Path(__file__).resolve().parents[1]

WORKLOADS = {name: f"from simulation.kernels import compile_groups\ncompile_groups([{name!r}])\n" for name in GROUPS}
"""Code compiling each kernel group of :mod:`simulation.kernels` (the servo loop, the identification's
loads, the replay's series), run in a new process."""


STAGES = """
from numba.core import event
with event.install_recorder("numba:compile") as recorder:
""" + "".join("    " + line + "\n" for line in WORKLOADS["servo"].strip().splitlines()) + """
started, spent = {}, {}
for stamp, compile_event in recorder.buffer:
    name = compile_event.data["dispatcher"].py_func.__qualname__
    if compile_event.is_start:
        started[name] = stamp
    else:
        spent[name] = spent.get(name, 0.0) + stamp - started.pop(name, stamp)
for name, seconds in sorted(spent.items(), key=lambda item: -item[1])[:6]:
    print(f"function {name}: {seconds:.1f} s")
from simulation.engine.loop import servo_loop
for signature in servo_loop.signatures:
    for pipeline, passes in servo_loop.get_metadata(signature)["pipeline_times"].items():
        costs = sorted(((t.init + t.run + t.finalize, name.split("_", 1)[1]) for name, t in passes.items()), reverse=True)
        for seconds, name in costs[:5]:
            print(f"servo_loop pass {name}: {seconds:.1f} s")
"""
"""Compile events and the servo loop's pass timings of the servo workload (``--stages``)."""


def _run(code: str) -> str:
    """Standard output of a new process running ``code`` with an empty numba cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1",
                   OPENBLAS_NUM_THREADS="1")
        done = subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"the workload failed: {done.stderr.strip().splitlines()[-1]}")
        return done.stdout


def cpu_seconds(code: str) -> float:
    """CPU seconds (user + system) of a new process running ``code`` with an empty numba cache."""
    script = "import resource\n" + code + (
        "\nu = resource.getrusage(resource.RUSAGE_SELF)\nprint(u.ru_utime + u.ru_stime)\n")
    return float(_run(script).strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=positive_int, default=2, help="new processes per workload")
    parser.add_argument("--stages", action="store_true",
                        help="also take the servo workload's compile apart (functions and the servo loop's passes)")
    args = parser.parse_args()
    for name, code in WORKLOADS.items():
        seconds = sorted(cpu_seconds(code) for _ in range(args.repeats))
        print(f"{name}: {float(np.median(seconds)):.1f} s CPU (runs: {', '.join(f'{s:.1f}' for s in seconds)})")
    if args.stages:
        print(_run(STAGES).rstrip())


if __name__ == "__main__":
    main()
