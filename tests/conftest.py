"""Settings and data shared by the whole test suite.

Threads under pytest-xdist: ``python -m pytest -n auto`` starts one worker process per core, so a
worker's numerical libraries get one thread each (OpenMP, which torch's CPU kernels use, and the
BLAS libraries). With more, the workers' threads outnumber the cores, and threads that spin while
waiting for a core make torch training tens of times slower (measured: 50 epochs of the paper's
network on 6000 rows, 2.7 s on one thread, 65 s on two threads beside a second busy worker). The
variables are read when the libraries load, which is after this file runs; a variable the user
set is kept.
"""

from __future__ import annotations

import os

if os.environ.get("PYTEST_XDIST_WORKER"):
    for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, "1")
