"""Reduced runs of the input-feature (Fig. 8) and training-on-error (Table II) studies."""

from __future__ import annotations

import numpy as np
import pytest

from studies import input_features, train_on_error
from studies.common import paper_numbers as paper
from studies.common.sessions import OperationSessionConfig
from studies.common.methods import MethodSettings

TINY = MethodSettings(dnn_seeds=1, dnn_epochs=15)
SESSION = OperationSessionConfig(seed=5, hours=0.06, sparsities=(1 / 2,), block_hours=0.03, eval_stride=15)
RUN = {"n_jobs": 1, "backend": "sequential", "progress": False}


def test_parameter_counts_match_the_paper():
    # the paper: 16 selected inputs, 138 for all features
    assert input_features.parameter_count("dnn_selected", 16) == 12103
    assert input_features.parameter_count("dnn_all", 138) == 24303
    assert input_features.parameter_count("dnn_large_all", 138) == 585503
    assert input_features.parameter_count("linear_selected", 16) == 17
    assert input_features.parameter_count("linear_all", 138) == 139


def test_input_features_reduced_run():
    config = input_features.InputFeaturesConfig(session=SESSION, n_longest=1, large_dnn_epochs=2, settings=TINY)
    r = input_features.run(config, **RUN)
    assert r["inputs"]["selected"] == 16 and r["inputs"]["all"] > 100
    assert r["parameters"]["dnn_all"] == input_features.parameter_count("dnn_all", r["inputs"]["all"])
    assert set(r["rmse_mean_over_hours"]) == {v[0] for v in input_features.VARIANTS}
    for key, values in r["rmse_mean_over_hours"].items():
        assert np.all(np.isfinite(values)), key
        assert np.allclose(values, np.mean([r["rmse_per_hour"][key][h] for h in r["hours"]], axis=0))
    assert input_features.normalized(r, "fixed_offset") == pytest.approx(1.0)
    assert input_features.finding(r).startswith("**Finding (")
    assert not r["failures"]


def test_train_on_error_reduced_run():
    r = train_on_error.run(train_on_error.TrainOnErrorConfig(session=SESSION, settings=TINY), **RUN)
    assert set(r["rmse"]) == set(train_on_error.MODELS)
    # regression learns the same map either way: identical errors (the paper's Table II rows)
    for model in ("linear", "polynomial"):
        assert np.allclose(r["rmse"][model]["error"], r["rmse"][model]["end_to_end"], rtol=1e-6)
    # a network that must output 0.3 m and 1.5 rad to 1e-4 precision does not get there in few epochs
    assert np.all(np.array(r["rmse"]["dnn"]["end_to_end"]) > np.array(r["rmse"]["dnn"]["error"]))
    table = "\n".join(train_on_error.tables(r))
    assert "| DNN | published | 0.328 | 0.831 |" in table
    assert "AGREES" in train_on_error.finding(r)


def test_published_table_ii_has_identical_regression_columns():
    for model in ("linear", "polynomial"):
        assert paper.TABLE_II[model]["error"] == paper.TABLE_II[model]["end_to_end"]
