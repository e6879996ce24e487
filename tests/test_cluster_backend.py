"""Sweeps on a Dask cluster give exactly the numbers of local workers.

Every task carries its own seed, so where a task runs must not change its result: the same
comparison run with ``--backend dask`` and with ``--backend loky`` must agree to the last bit.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from kinematics import RavenII
from simulation import powered_on, record_random_test, recording_to_dataset
from studies import compare_sota
from studies.common.data_sources import recorded_comparison
from studies.common.methods import MethodSettings, method_catalogue
from studies.common.sweeps import run_tasks, shared_arguments
from studies.common.training import run_methods

distributed = pytest.importorskip("distributed", reason="the cluster extra is not installed: pip install -e .[cluster]")

pytestmark = pytest.mark.slow

TINY = MethodSettings(dnn_seeds=2, dnn_epochs=5, lstm_epochs=1, forest_trees=5, two_phase_max_samples=400,
                      gpr_subset=100, gpr_hyper_subset=50, lstm_max_samples=400, ukf_tuning="none")


@pytest.fixture(autouse=True)
def _no_ambient_scheduler(monkeypatch):
    monkeypatch.delenv("DASK_SCHEDULER_ADDRESS", raising=False)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A short recorded session (40 s of random motion, 30 Hz) as a dataset file: the runs below
    read it instead of simulating the paper's protocol."""
    recording = record_random_test(powered_on(seed=8), 40.0, seed=1)
    path = tmp_path_factory.mktemp("recorded") / "session.parquet"
    recording_to_dataset(recording, RavenII(recording.arm)).to_parquet(path)
    return path


@pytest.fixture(scope="module")
def cluster():
    """A Dask cluster of two worker processes on this machine, shared by the tests below (each
    worker pays the imports once)."""
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as local:
        yield local


def _joint_rmse(runs, tests) -> dict:
    return {key: [list(run.mean(test).joint) for test in tests] for key, run in runs.items()}


def test_compare_sota_on_a_dask_cluster_matches_loky(recorded, cluster, tmp_path):
    documents = {}
    for backend, scheduler in (("loky", []), ("dask", ["--scheduler", cluster.scheduler_address])):
        documents[backend] = compare_sota.main(["--data", str(recorded), "--quick", "--methods", "fixed_offset,linear",
                                                "--backend", backend, *scheduler, "--jobs", "2", "--no-progress",
                                                "--out", str(tmp_path / backend)])
    loky, dask = documents["loky"], documents["dask"]
    assert loky["tests"] == ["test"]
    for test in loky["tests"]:
        assert set(loky[test]["joint_rmse"]) == {"fixed_offset", "linear"}
        assert dask[test]["joint_rmse"] == loky[test]["joint_rmse"]
        assert dask[test]["cartesian_rmse"] == loky[test]["cartesian_rmse"]
    assert (loky["configuration"]["backend"], dask["configuration"]["backend"]) == ("loky", "dask")


def test_a_sweep_on_an_existing_cluster_matches_this_process_including_a_network(recorded, cluster):
    data = recorded_comparison(recorded)
    catalogue = method_catalogue(TINY)
    methods = [catalogue[key] for key in ("fixed_offset", "linear", "dnn")]
    # torch and BLAS threads are fixed per fit (settings.n_threads), so this process is a fair reference
    local = run_methods(methods, data.train, data.tests, seed=4, n_jobs=1, backend="sequential", progress=False)
    remote = run_methods(methods, data.train, data.tests, seed=4, n_jobs=2, backend="dask",
                         scheduler=cluster.scheduler_address, progress=False)
    # the sweep used the given cluster and left it running
    with distributed.Client(cluster.scheduler_address) as client:
        assert len(client.scheduler_info()["workers"]) == 2
    assert all(run.ok for run in remote.values()) and len(remote["dnn"].outcomes) == 2
    assert _joint_rmse(remote, data.tests) == _joint_rmse(local, data.tests)
    for key in remote:
        for test in data.tests:
            assert np.array_equal(remote[key].predictions(test), local[key].predictions(test))


def test_without_a_scheduler_a_sweep_starts_its_own_local_cluster():
    assert run_tasks(divmod, [(7, 2), (9, 4), (5, 5)], n_jobs=2, backend="dask", progress=False) == \
        [(3, 1), (2, 1), (1, 0)]
    assert os.getpid() not in run_tasks(os.getpid, [(), ()], n_jobs=2, backend="dask", progress=False)


def test_a_missing_engine_is_named_with_its_install_command(monkeypatch):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ValueError, match=r"'distributed' package.*pip install") as caught:
        run_tasks(divmod, [(7, 2)], backend="dask", progress=False)
    assert "\n" not in str(caught.value)


def test_a_scheduler_address_needs_a_cluster_backend():
    with pytest.raises(ValueError, match="scheduler address needs backend 'dask' or 'ray'"):
        run_tasks(divmod, [(7, 2)], backend="loky", scheduler="tcp://127.0.0.1:8786", progress=False)


def test_arguments_shared_by_tasks_are_found_by_identity():
    data, other, method = np.zeros(1000), np.zeros(1000), {"name": "linear"}
    tasks = [(method, 0, data, True), (method, 1, data, True), (method, 2, other, True)]
    assert [id(a) for a in shared_arguments(tasks)] == [id(method), id(data)]
