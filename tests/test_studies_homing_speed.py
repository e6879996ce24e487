"""Reduced runs of the homing (Fig. 9) and speed (Table V) studies."""

from __future__ import annotations

import numpy as np
import pytest

from studies import homing, speed
from studies.common.methods import MethodSettings

TINY = MethodSettings(dnn_seeds=1, dnn_epochs=15)
HOMING = homing.HomingConfig(seed=6, sparsities=(1 / 2, 1 / 3), n_homings=2, test_duration=40.0, settings=TINY)


def test_seen_one_homing_splits_the_training_data_around_the_first_rehoming():
    train0, tests0 = homing.homing_session(0, 21, HOMING)
    train1, tests1 = homing.homing_session(1, 21, HOMING)
    assert np.unique(train0.labels["homing_count"]).size == 1
    counts = np.unique(train1.labels["homing_count"])
    assert counts.size == 2 and counts[1] == counts[0] + 1
    assert len(train1.recordings()) == 2
    # same sparsities and length either way
    assert train1.duration == pytest.approx(train0.duration, rel=0.05)
    for tests in (tests0, tests1):
        assert list(tests) == ["homing 0", "homing 1", "homing 2"]
        first = [int(t.labels["homing_count"][0]) for t in tests.values()]
        assert np.all(np.diff(first) == 1)


def test_homing_reduced_run_and_finding():
    r = homing.run(HOMING, n_jobs=1, backend="sequential", progress=False)
    assert set(r["rmse"]) == {"seen 0", "seen 1"} and r["homings"] == ["homing 0", "homing 1", "homing 2"]
    j2 = homing.joint2_after_homing(r)
    values = [r["rmse"]["seen 0"]["dnn"][h][1] for h in r["homings"]]
    assert j2["seen 0"]["after_mean"] == pytest.approx(np.mean(values[1:]))
    assert homing.finding(r).startswith("**Finding (")
    with pytest.raises(ValueError, match="at least 2"):
        homing.HomingConfig(sparsities=(1 / 3,))


def test_speed_reduced_run():
    config = speed.SpeedConfig(sparsities=(1 / 2,), n_train=1500, methods=("linear", "dnn", "window_linear"),
                               number=50, repeat=2, settings=TINY)
    r = speed.run(config, progress=False)
    assert r["n_train"] == 1500 and r["n_features"] == 16
    for key in config.methods:
        t = r["timings"][key]
        assert t["fit_s"] > 0 and t["realtime_us"] > 0 and t["predict_us"] > 0
    assert speed.speedup(r) == pytest.approx(r["timings"]["dnn"]["realtime_us"] / r["timings"]["linear"]["realtime_us"])
    assert "published" in "\n".join(speed.tables(r))
    with pytest.raises(ValueError, match="methods"):
        speed.SpeedConfig(methods=("ukf",))
