"""Parallel sweeps of independent tasks with joblib, on one machine or on a Dask or Ray cluster.

A study turns its grid (directions x sparsities x seeds x models...) into a list of tasks, each a
call of one module-level function with its own explicit seed, and runs them with
:func:`run_tasks`. Results come back in task order whatever the order of completion, so a sweep
gives the same numbers on 1 core, 2 cores or a cluster. The backend is joblib's:

* ``"loky"`` (default): worker processes on this machine;
* ``"threading"`` or ``"sequential"``: in this process (debugging, profiling);
* ``"dask"``: Dask distributed (``pip install -e ".[cluster]"``). With a scheduler address
  (``scheduler="tcp://host:8786"``, else the ``DASK_SCHEDULER_ADDRESS`` environment variable) the
  tasks go to that existing cluster, whose workers must have this project installed; without
  one, a :class:`distributed.LocalCluster` of worker processes (one per job, one thread each) is
  started for the sweep and closed after it;
* ``"ray"``: a Ray cluster (``pip install -e ".[ray]"``); ``scheduler`` (else ``RAY_ADDRESS``)
  is the address given to ``ray.init``, else a local Ray is started for the sweep.
"""

from __future__ import annotations

import logging
import os
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from typing import Any

import joblib
from tqdm.auto import tqdm

BACKENDS = ("loky", "threading", "sequential", "ray", "dask")

_INSTALL = {"dask": ("distributed", 'pip install "raven-calibration[cluster]" (or pip install "dask[distributed]")'),
            "ray": ("ray", 'pip install "raven-calibration[ray]" (or pip install "ray[default]")')}


def _require(backend: str) -> None:
    """A one-line ValueError naming the missing package when a cluster engine is not installed."""
    package, command = _INSTALL[backend]
    try:
        __import__(package)
    except ImportError:
        raise ValueError(f"backend {backend!r} needs the {package!r} package, which is not installed: "
                         f"{command}") from None


def local_workers(n_jobs: int) -> int:
    """Worker processes of a local cluster for ``n_jobs`` (joblib's convention: -1 = all cores)."""
    if n_jobs == 0:
        raise ValueError("n_jobs must not be 0")
    return n_jobs if n_jobs > 0 else max(1, joblib.cpu_count() + 1 + n_jobs)


def shared_arguments(tasks: Sequence[tuple]) -> list[Any]:
    """The arguments passed as the same object to more than one task (data sets, method objects).

    A cluster receives each of them once (scattered to the workers) instead of once per task.
    """
    seen: set[int] = set()
    shared: dict[int, Any] = {}
    for task in tasks:
        for argument in task:
            if isinstance(argument, (int, float, complex, str, bytes, bool, type(None))):
                continue
            if id(argument) in seen:
                shared.setdefault(id(argument), argument)
            seen.add(id(argument))
    return list(shared.values())


@contextmanager
def _dask(scheduler: str | None, n_jobs: int, scatter: list[Any]) -> Iterator[None]:
    _require("dask")
    from distributed import Client, LocalCluster

    address = scheduler or os.environ.get("DASK_SCHEDULER_ADDRESS")
    with ExitStack() as stack:
        if address:
            stack.enter_context(Client(address))
        else:
            cluster = stack.enter_context(LocalCluster(n_workers=local_workers(n_jobs), threads_per_worker=1,
                                                       processes=True, dashboard_address=None,
                                                       silence_logs=logging.ERROR))
            stack.enter_context(Client(cluster))
        stack.enter_context(joblib.parallel_config(backend="dask", scatter=scatter or None,
                                                   wait_for_workers_timeout=60))
        # a task's own data (e.g. the full robot state of a model-based method) has to travel once;
        # Dask's advice to load it with Dask instead is no action for the user of a study
        stack.enter_context(warnings.catch_warnings())
        warnings.filterwarnings("ignore", message="Sending large graph", category=UserWarning)
        yield


@contextmanager
def _ray(scheduler: str | None) -> Iterator[None]:
    _require("ray")
    import ray
    from ray.util.joblib import register_ray

    started = False
    if not ray.is_initialized():
        ray.init(address=scheduler or os.environ.get("RAY_ADDRESS"), logging_level=logging.ERROR)
        started = True
    register_ray()
    try:
        with joblib.parallel_config(backend="ray"):
            yield
    finally:
        if started:
            ray.shutdown()


@contextmanager
def _backend(backend: str, scheduler: str | None, n_jobs: int = -1, scatter: list[Any] | None = None
             ) -> Iterator[None]:
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if scheduler and backend not in ("dask", "ray"):
        raise ValueError(f"a scheduler address needs backend 'dask' or 'ray', got backend {backend!r}")
    if backend == "dask":
        with _dask(scheduler, n_jobs, scatter or []):
            yield
    elif backend == "ray":
        with _ray(scheduler):
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
    scheduler : address of an existing cluster: a Dask scheduler (``"tcp://host:8786"``) for
        ``backend="dask"``, a Ray address for ``backend="ray"``; None starts a local one.
    progress : show a progress bar on stderr.
    description : label of the progress bar.
    """
    if backend not in BACKENDS:
        raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
    if n_jobs == 0:
        raise ValueError("n_jobs must not be 0")
    tasks = list(tasks)
    if not tasks:
        return []
    results: list[Any] = [None] * len(tasks)
    with _backend(backend, scheduler, n_jobs, shared_arguments(tasks) if backend == "dask" else None):
        parallel = joblib.Parallel(n_jobs=n_jobs, return_as="generator_unordered")
        stream = parallel(joblib.delayed(_indexed)(function, index, *task) for index, task in enumerate(tasks))
        bar = tqdm(total=len(tasks), desc=description, disable=not progress, file=sys.stderr,
                   dynamic_ncols=True)
        with bar:
            for index, result in stream:
                results[index] = result
                bar.update(1)
    return results


def _indexed(function: Callable[..., Any], index: int, *arguments: Any) -> tuple[int, Any]:
    # the task's arguments are passed one by one so that a cluster backend can match the shared ones
    return index, function(*arguments)
