"""Settings shared by the whole test suite.

OpenMP threads that wait sleep instead of spinning. torch's CPU kernels run on an OpenMP pool of
one thread per core; ``python -m pytest -n auto`` starts one worker process per core, so the
workers' threads outnumber the cores (and any other busy process does the same). By default an
idle OpenMP thread spins on its core waiting for the next task, taking the core from the other
workers: measured on 2 cores beside a busy process, 50 epochs of the paper's network on 6000 rows
took 36 s instead of 2.5 s, and two xdist workers training at once took 87-98 s each instead of
13.5 s. ``OMP_WAIT_POLICY=PASSIVE`` makes waiting threads sleep, and ``OMP_NUM_THREADS=1``
gives each worker one OpenMP thread: even sleeping, a worker's second thread waits for a core the
other worker holds (measured on 2 cores: the whole suite took 302 s with torch's default two
threads per worker and 251 s with one; the compare_sota module's fixture 59 s and 25 s). Both are
read when the OpenMP runtime loads, after this file runs, and passed on to the subprocesses that
tests start. A value the user set is kept.

NumPy's and SciPy's linear algebra (OpenBLAS) runs on one thread per test process. Its threads
wait by spinning, not under OpenMP's control: measured on 2 cores beside busy processes, a
least-squares fit of 6000 x 969 took 11 s of CPU time on OpenBLAS's default two threads and
0.75 s on one. ``python -m pytest -n auto`` already keeps every core busy with one worker each,
so more threads per worker only compete for the same cores. Read when NumPy loads, after this
file runs; passed on to subprocesses and to the workers of the cluster tests. A value the user
set is kept. Fits that choose their own thread count (``n_threads``) still do.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")


# The numba kernels, compiled once ahead of the workers ---------------------------------------

KERNEL_WARMUPS = (("servo",), ("identification", "replay", "plant_replay"))
"""Kernel groups (:mod:`simulation.kernels`) compiled ahead of ``pytest -n N``'s workers, one new
process per tuple, started with the run. On a fresh clone every worker would otherwise compile the
same kernels in its first tests (the servo loop some 15 s to 30 s of CPU each, the others about
15 s); compiled once, while the workers start and collect, they are loaded from numba's cache. A
worker waits for them after collecting, before its first test, at most :data:`KERNEL_WAIT_S`,
whether its tests need them or not: a run of a few quick tests is quicker without ``-n``, and
without workers nothing is compiled ahead."""

KERNEL_WAIT_S = 300.0
"""Longest wait of a worker for the kernels compiled ahead (s); after it the worker compiles what it
needs itself, as it would without them."""

_KERNELS_READY = "RAVEN_TEST_KERNELS_READY"
"""Environment variable naming the files that say the kernels compiled ahead are ready (separated
by the path separator); set by the run's controlling process, inherited by its workers."""


def _distributes(config) -> bool:
    """Is this the controlling process of a run that starts xdist workers?"""
    option = config.option
    return (not hasattr(config, "workerinput") and not getattr(option, "collectonly", False)
            and bool(getattr(option, "numprocesses", 0)) and getattr(option, "dist", "no") != "no")


def pytest_configure(config):
    import subprocess
    import sys
    import tempfile
    from pathlib import Path

    if not _distributes(config) or _KERNELS_READY in os.environ:
        return
    folder = Path(tempfile.mkdtemp(prefix="raven-kernels-"))
    ready = [folder / f"{'-'.join(groups)}.done" for groups in KERNEL_WARMUPS]
    config._kernel_warmups = [
        subprocess.Popen([sys.executable, "-m", "simulation.kernels", *groups, "--done", str(done)],
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        for groups, done in zip(KERNEL_WARMUPS, ready)]
    config._kernel_folder = folder
    os.environ[_KERNELS_READY] = os.pathsep.join(str(done) for done in ready)


def pytest_collection_finish(session):
    import time
    from pathlib import Path

    if not hasattr(session.config, "workerinput") or not os.environ.get(_KERNELS_READY):
        return
    ready = [Path(p) for p in os.environ[_KERNELS_READY].split(os.pathsep)]
    deadline = time.monotonic() + KERNEL_WAIT_S
    while not all(p.exists() for p in ready) and time.monotonic() < deadline:
        time.sleep(0.2)


def pytest_unconfigure(config):
    import shutil

    for process in getattr(config, "_kernel_warmups", ()):
        if process.poll() is None:
            process.kill()
        process.wait()
    if hasattr(config, "_kernel_folder"):
        shutil.rmtree(config._kernel_folder, ignore_errors=True)
        # a process started after the run must not wait for files that are gone
        os.environ.pop(_KERNELS_READY, None)
