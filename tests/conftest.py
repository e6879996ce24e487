"""Settings shared by the whole test suite.

OpenMP threads that wait sleep instead of spinning. torch's CPU kernels run on an OpenMP pool of
one thread per core; ``python -m pytest -n auto`` starts one worker process per core, so the
workers' threads outnumber the cores (and any other busy process does the same). By default an
idle OpenMP thread spins on its core waiting for the next task, taking the core from the other
workers: measured on 2 cores beside a busy process, 50 epochs of the paper's network on 6000 rows
took 36 s instead of 2.5 s, and two xdist workers training at once took 87-98 s each instead of
13.5 s. ``OMP_WAIT_POLICY=PASSIVE`` makes waiting threads sleep. It leaves the number of threads
as it is (tests that check a thread setting is restored still see the library default); it is
read when the OpenMP runtime loads, after this file runs, and passed on to the subprocesses that
tests start. A value the user set is kept.
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
