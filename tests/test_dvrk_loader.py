"""The dVRK loader on small synthetic folders (always) and on the real data (when present)."""

from __future__ import annotations

import numpy as np
import pytest

from simulation.recordings import DvrkDataError, load_dvrk, locate_dvrk_data
from simulation.recordings.dvrk import ENVIRONMENT_VARIABLE, JOINT_NAMES


def write_split(folder, n_samples=20, seed=0, **replace):
    """Write q_des, q_act and t_stamp arrays (overridable) into `folder`."""
    rng = np.random.default_rng(seed)
    arrays = {
        "q_des": rng.normal(size=(n_samples, 6)),
        "q_act": rng.normal(size=(n_samples, 6)),
        "t_stamp": np.cumsum(rng.uniform(0.3, 0.5, n_samples)),
    }
    arrays.update(replace)
    folder.mkdir(parents=True, exist_ok=True)
    for name, array in arrays.items():
        np.save(folder / f"{name}.npy", array)
    return arrays


def test_loads_a_split_from_the_root_or_its_own_folder(tmp_path):
    arrays = write_split(tmp_path / "peg_transfer")
    for location in (tmp_path, tmp_path / "peg_transfer"):
        X, y, t, names = load_dvrk(location, split="peg_transfer")
        np.testing.assert_array_equal(X, arrays["q_des"])
        np.testing.assert_array_equal(y, arrays["q_act"])
        np.testing.assert_array_equal(t, arrays["t_stamp"])
        assert names == tuple(f"q_des.{joint}" for joint in JOINT_NAMES)


def test_history_and_velocity_columns(tmp_path):
    arrays = write_split(tmp_path / "random_unfiltered", n_samples=10)
    data = load_dvrk(tmp_path, history=2, velocity=True)
    q, times = arrays["q_des"], arrays["t_stamp"]
    assert data.X.shape == (8, 24) and data.y.shape == (8, 6)  # first 2 rows lack history
    row = 5  # sample 7 of the recording
    np.testing.assert_array_equal(data.X[row, :6], q[7])
    np.testing.assert_array_equal(data.X[row, 6:12], q[6])
    np.testing.assert_array_equal(data.X[row, 12:18], q[5])
    np.testing.assert_allclose(data.X[row, 18:], (q[7] - q[6]) / (times[7] - times[6]))
    np.testing.assert_array_equal(data.y[row], arrays["q_act"][7])
    assert data.t[row] == times[7]
    assert data.feature_names[6] == "q_des.outer_yaw[t-1]"
    assert data.feature_names[18] == "qd_des.outer_yaw"
    assert data.raw_columns == (0, 1, 2, 3, 4, 5)


def test_velocity_alone_drops_one_sample(tmp_path):
    write_split(tmp_path / "random_unfiltered", n_samples=10)
    assert load_dvrk(tmp_path, velocity=True).X.shape == (9, 12)


def test_arrays_are_read_only(tmp_path):
    write_split(tmp_path / "random_unfiltered")
    data = load_dvrk(tmp_path)
    with pytest.raises(ValueError, match="read-only"):
        data.X[0, 0] = 1.0


def test_environment_variable_locates_the_data(tmp_path, monkeypatch):
    write_split(tmp_path / "random_unfiltered")
    monkeypatch.setenv(ENVIRONMENT_VARIABLE, str(tmp_path))
    assert locate_dvrk_data() == tmp_path
    assert load_dvrk().X.shape == (20, 6)


def test_missing_folder_says_how_to_point_to_the_data(tmp_path):
    with pytest.raises(FileNotFoundError, match=f"set {ENVIRONMENT_VARIABLE}"):
        load_dvrk(tmp_path / "nowhere")


def test_missing_file(tmp_path):
    write_split(tmp_path / "random_unfiltered")
    (tmp_path / "random_unfiltered" / "q_act.npy").unlink()
    with pytest.raises(FileNotFoundError, match="q_act.npy is missing"):
        load_dvrk(tmp_path)


def test_corrupt_file(tmp_path):
    write_split(tmp_path / "random_unfiltered")
    (tmp_path / "random_unfiltered" / "t_stamp.npy").write_bytes(b"\x93NUMPY garbage")
    with pytest.raises(DvrkDataError, match="t_stamp.npy is unreadable or corrupt"):
        load_dvrk(tmp_path)


@pytest.mark.parametrize("replace, message", [
    ({"q_act": np.zeros((19, 6))}, "hold 20, 19 and 20 samples; they must match"),
    ({"q_des": np.zeros((20, 5))}, r"q_des.npy has shape \(20, 5\); expected \(n_samples, 6\)"),
    ({"t_stamp": np.zeros((20, 1))}, r"t_stamp.npy has shape \(20, 1\)"),
])
def test_inconsistent_shapes(tmp_path, replace, message):
    write_split(tmp_path / "random_unfiltered", **replace)
    with pytest.raises(DvrkDataError, match=message):
        load_dvrk(tmp_path)


def test_non_finite_values_name_the_sample(tmp_path):
    q_act = np.zeros((20, 6))
    q_act[7, 4] = np.nan
    write_split(tmp_path / "random_unfiltered", q_act=q_act)
    with pytest.raises(DvrkDataError,
                       match=r"q_act.npy contains NaN or infinity \(first at sample 7\)"):
        load_dvrk(tmp_path)


def test_time_must_increase(tmp_path):
    t = np.arange(20, dtype=float)
    t[5] = t[4]
    write_split(tmp_path / "random_unfiltered", t_stamp=t)
    with pytest.raises(DvrkDataError,
                       match=r"not strictly increasing: t\[5\] = 4.0 after t\[4\] = 4.0"):
        load_dvrk(tmp_path)


@pytest.mark.parametrize("kwargs, message", [
    ({"split": "suturing"}, "split must be one of"),
    ({"history": -1}, "history must be an integer >= 0"),
    ({"history": 30}, "too few for history=30"),
])
def test_bad_arguments(tmp_path, kwargs, message):
    write_split(tmp_path / "random_unfiltered")
    with pytest.raises(ValueError, match=message):
        load_dvrk(tmp_path, **kwargs)


def _real_data_or_skip():
    try:
        return locate_dvrk_data()
    except FileNotFoundError as error:
        pytest.skip(f"real dVRK data not available: {error}")


@pytest.mark.parametrize("split, n_samples", [("random_unfiltered", 5531), ("peg_transfer", 10786)])
def test_real_data_loads(split, n_samples):
    root = _real_data_or_skip()
    data = load_dvrk(root, split=split)
    assert data.X.shape == (n_samples, 6) and data.y.shape == (n_samples, 6)
    assert data.split == split
    steps = np.diff(data.t)
    assert 0.3 < np.median(steps) < 0.5  # "about 0.4 s apart"
    # joints 1-3 agree within a few millimetres / tenths of a degree; wrist errors are degrees
    error = np.abs(data.y - data.X).mean(axis=0)
    assert error[2] < 0.005 and np.all(error[[0, 1]] < np.radians(0.5))
    assert np.all(error[3:] > np.radians(0.5))
