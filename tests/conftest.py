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
