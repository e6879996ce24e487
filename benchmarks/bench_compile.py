"""CPU time of compiling the numba kernels, as each new process on a fresh clone pays it.

Run:  python benchmarks/bench_compile.py [--repeats 2]

Each measurement is a new Python process with an empty numba cache (``NUMBA_CACHE_DIR`` set to a
new temporary folder), which is what every test worker and study process of a fresh clone starts
from. It prints the process's CPU seconds for:

- ``servo``: homing the virtual RAVEN-II and two seconds of random motion (compiles the 1 kHz
  servo loop and the kinematics it inlines);
- ``identification``: the links' gravity and inertial loads of an identification's samples
  (:func:`simulation.identification.samples._gravity_and_inertia`) on ten rows;
- ``replay``: one discrepancy replay of a cable model with every candidate effect's series.

Each line gives the median over ``--repeats`` processes, the import time included (about 3 s of
it). Run it on two versions to compare them.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from studies.common.runner import positive_int

ROOT = Path(__file__).resolve().parents[1]

WORKLOADS = {
    "servo": """
from simulation.engine.scenarios import powered_on, record_random_test
from simulation.model.parameters import RavenParameters
record_random_test(powered_on(RavenParameters(), seed=2), 2.0, seed=3)
""",
    "identification": """
import numpy as np
from simulation.identification.nominal import nominal_parameters
from simulation.identification.samples import _gravity_and_inertia, arm_model
q = np.tile([0.5, 1.6, 0.4], (10, 1))
_gravity_and_inertia(q, np.zeros((10, 3)), arm_model(nominal_parameters("left")).gravity_coefficients(0.0))
""",
    "replay": """
import numpy as np
from simulation.discrepancy.replay import cable_link_series, play_series
n = 100
x = np.linspace(0.0, 1.0, n)
restart = np.zeros(n, dtype=np.bool_)
restart[0] = True
cable_link_series(x, x, np.full(n, 0.1), np.ones(n), 40.0, 0.5, 1.0, 0.7, 0.3, x, restart, 0.01)
play_series(x, 0.01, restart)
""",
}


def cpu_seconds(code: str) -> float:
    """CPU seconds (user + system) of a new process running ``code`` with an empty numba cache."""
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONPATH=str(ROOT), OMP_NUM_THREADS="1",
                   OPENBLAS_NUM_THREADS="1")
        script = "import resource\n" + code + (
            "\nu = resource.getrusage(resource.RUSAGE_SELF)\nprint(u.ru_utime + u.ru_stime)\n")
        done = subprocess.run([sys.executable, "-c", script], env=env, cwd=ROOT, capture_output=True, text=True)
        if done.returncode != 0:
            raise SystemExit(f"the workload failed: {done.stderr.strip().splitlines()[-1]}")
        return float(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=positive_int, default=2, help="new processes per workload")
    args = parser.parse_args()
    for name, code in WORKLOADS.items():
        seconds = sorted(cpu_seconds(code) for _ in range(args.repeats))
        print(f"{name}: {float(np.median(seconds)):.1f} s CPU (runs: {', '.join(f'{s:.1f}' for s in seconds)})")


if __name__ == "__main__":
    main()
