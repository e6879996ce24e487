"""Reduced runs of the directions (Table I) and sparsity (Fig. 5) studies."""

from __future__ import annotations

import numpy as np
import pytest

from studies import directions, sparsity
from studies.common.methods import MethodSettings

TINY = MethodSettings(dnn_seeds=1, dnn_epochs=20)
RUN = {"n_jobs": 1, "backend": "sequential", "progress": False}


@pytest.fixture(scope="module")
def direction_results():
    config = directions.DirectionsConfig(seed=1, directions=("J2-J3", "J1"), sparsities=(1 / 2,),
                                         test_duration=60.0, settings=TINY)
    return directions.run(config, **RUN)


def test_directions_table_i_quantities(direction_results):
    r = direction_results
    assert list(r["rmse"]) == ["J2-J3", "J1"]
    for d, models in r["rmse"].items():
        assert set(models) == set(directions.MODELS)
        raw, fixed = np.array(models["raw"]), np.array(models["fixed_offset"])
        assert np.all(fixed < raw)
        for m in directions.LEARNED:
            assert np.allclose(r["percent_of_fixed_offset"][d][m], 100 * np.array(models[m]) / fixed)
    # independent sessions: the raw errors differ between directions, the calibration times barely
    assert r["rmse"]["J2-J3"]["raw"] != r["rmse"]["J1"]["raw"]
    durations = list(r["calibration_duration_s"].values())
    assert max(durations) - min(durations) < 0.1 * max(durations)
    assert not r["failures"]


def test_directions_finding_and_tables(direction_results):
    line = directions.finding(direction_results)
    assert line.startswith("**Finding (") and "J2-J3" in line and "J1" in line
    sections = "\n".join(directions.tables(direction_results))
    assert "| J2-J3 |" in sections and "0.104 (12.1%)" in sections  # the paper's J2-J3 DNN, joint 1


def test_paper_table_i_ranks_j2_j3_first_by_the_study_measure():
    ranking = directions.overall_ranking(directions.paper_percentages())
    assert ranking[0][0] == "J2-J3" and len(ranking) == 7


def test_directions_config_rejects_unknown_direction():
    with pytest.raises(ValueError, match="directions"):
        directions.DirectionsConfig(directions=("J4",))


@pytest.fixture(scope="module")
def sparsity_results():
    config = sparsity.SparsityConfig(seed=2, sparsities=(1 / 2, 1 / 3), combinations=((1 / 2, 1 / 3),), repeats=2,
                                     test_duration=60.0, settings=TINY)
    return sparsity.run(config, **RUN)


def test_sparsity_training_sets_grow_with_calibration_time(sparsity_results):
    r = sparsity_results
    assert r["training_sets"] == ["1/2", "1/3", "1/2+1/3"]
    t = r["calibration_time_s"]
    assert t["1/2"] < t["1/3"] < t["1/2+1/3"]
    assert t["1/2+1/3"] == pytest.approx(t["1/2"] + t["1/3"], abs=1.0)
    for label in r["training_sets"]:
        for m in sparsity.MODELS:
            assert len(r["rmse_per_session"][label][m]) == 2
            assert np.allclose(r["rmse_mean"][label][m], np.mean(r["rmse_per_session"][label][m], axis=0))
    assert np.all(np.array(r["rmse_mean"]["1/2+1/3"]["linear"]) < np.array(r["rmse_mean"]["1/2+1/3"]["fixed_offset"]))


def test_sparsity_improvement_and_finding():
    results = {"training_sets": ["a", "b"], "calibration_time_s": {"a": 100.0, "b": 900.0},
               "rmse_mean": {"a": {"dnn": [1.0, 1.0, 1.0], "linear": [2.0, 2.0, 2.0], "polynomial": [1.0, 1.0, 1.0],
                                   "fixed_offset": [3.0, 3.0, 3.0]},
                             "b": {"dnn": [0.5, 0.8, 0.9], "linear": [1.0, 1.5, 1.9], "polynomial": [2.0, 1.0, 1.0],
                                   "fixed_offset": [3.0, 2.9, 3.0]}}}
    gain = sparsity.improvement(results)
    assert np.allclose(gain["dnn"], [50.0, 20.0, 10.0]) and np.allclose(gain["polynomial"], [-100.0, 0.0, 0.0])
    assert "AGREES with the paper" in sparsity.finding(results)
    results["rmse_mean"]["b"]["linear"] = [2.5, 1.0, 1.0]
    assert "DOES NOT AGREE" in sparsity.finding(results)


def test_sparsity_config_rejects_unrecorded_combinations():
    with pytest.raises(ValueError, match="not recorded"):
        sparsity.SparsityConfig(sparsities=(1 / 2,), combinations=((1 / 2, 1 / 3),))
