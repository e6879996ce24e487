"""Parallel sweeps of independent tasks with joblib, on one machine or on a Ray or Dask cluster.

A study turns its grid (directions x sparsities x seeds x models...) into a list of tasks, each a
call of one module-level function with its own explicit seed, and runs them with
:func:`run_tasks`. Results come back in task order whatever the order of completion, so a sweep
gives the same numbers on 1 core, 2 cores or a cluster. The backend is joblib's:

* ``"loky"`` (default): worker processes on this machine;
* ``"threading"`` or ``"sequential"``: in this process (debugging, profiling);
* ``"ray"``: a Ray cluster (``pip install ray``; ``ray.init(address=...)`` is read from the
  ``RAY_ADDRESS`` environment variable, else a local Ray is started);
* ``"dask"``: a Dask cluster (``pip install dask distributed``; the scheduler address comes
  from ``--scheduler`` or ``DASK_SCHEDULER_ADDRESS``, else a local cluster is started).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable, Sequence
from contextlib import contextmanager
from typing import Any

import joblib
from tqdm.auto import tqdm

BACKENDS = ("loky", "threading", "sequential", "ray", "dask")


@contextmanager
def _backend(backend: str, scheduler: str | None):
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if backend == "ray":
        try:
            from ray.util.joblib import register_ray
        except ImportError as error:
            raise RuntimeError("the 'ray' backend needs Ray: pip install 'ray[default]'") from error
        register_ray()
        with joblib.parallel_config(backend="ray"):
            yield
    elif backend == "dask":
        try:
            from dask.distributed import Client
        except ImportError as error:
            raise RuntimeError("the 'dask' backend needs Dask: pip install dask distributed") from error
        address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS")
        with Client(address) if address else Client(processes=True), joblib.parallel_config(backend="dask"):
            yield
    else:
        with joblib.parallel_config(backend=backend):
            yield


def run_tasks(function: Callable[..., Any], tasks: Sequence[tuple], *, n_jobs: int = -1,
              backend: str = "loky", scheduler: str | None = None, progress: bool = True,
              description: str = "tasks") -> list[Any]:
    """``[function(*task) for task in tasks]``, run in parallel, results in task order.

    Parameters
    ----------
    function : a module-level function (workers import it by name).
    tasks : argument tuples, one per call; each should carry its own seed.
    n_jobs : parallel workers (joblib's convention: -1 = all cores).
    backend : one of :data:`BACKENDS`.
    scheduler : address of a Dask scheduler (``"tcp://host:8786"``), for ``backend="dask"``.
    progress : show a progress bar on stderr.
    description : label of the progress bar.
    """
    tasks = list(tasks)
    if not tasks:
        return []
    if n_jobs == 0:
        raise ValueError("n_jobs must not be 0")
    results: list[Any] = [None] * len(tasks)
    with _backend(backend, scheduler):
        parallel = joblib.Parallel(n_jobs=n_jobs, return_as="generator_unordered")
        stream = parallel(joblib.delayed(_indexed)(function, index, task) for index, task in enumerate(tasks))
        bar = tqdm(total=len(tasks), desc=description, disable=not progress, file=sys.stderr,
                   dynamic_ncols=True)
        with bar:
            for index, result in stream:
                results[index] = result
                bar.update(1)
    return results


def _indexed(function: Callable[..., Any], index: int, task: tuple) -> tuple[int, Any]:
    return index, function(*task)
