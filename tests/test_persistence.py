"""Saving and loading calibrators: exact round trip, no pickle, clear refusals."""

from __future__ import annotations

import io
import json
import zipfile

import numpy as np
import pandas as pd
import pytest

from estimators import (
    DNNCalibrator,
    FixedOffsetCalibrator,
    GPRCalibrator,
    LinearCalibrator,
    PolynomialCalibrator,
    TwoPhaseCalibrator,
    WindowLinearCalibrator,
    WindowLSTMCalibrator,
    load_calibrator,
    save_calibrator,
)
from estimators.persistence import FORMAT_VERSION

NAMES = ("shoulder", "elbow", "insertion", "tau_shoulder")

CALIBRATORS = [
    FixedOffsetCalibrator(raw_columns=[0, 1]),
    LinearCalibrator(raw_columns=[0, 1], alpha=0.1),
    PolynomialCalibrator(degree=3),
    DNNCalibrator(raw_columns=[0, 1], hidden_layer_sizes=(6, 5), activation="tanh",
                  max_epochs=3, random_state=0, n_threads=1),
    GPRCalibrator(subset_size=60, hyperparameter_subset_size=30, random_state=0, n_threads=1),
    TwoPhaseCalibrator(raw_columns=[0, 1], n_estimators=4, random_state=np.random.RandomState(1),
                       dnn=DNNCalibrator(hidden_layer_sizes=(4,), max_epochs=2, n_threads=1)),
    WindowLinearCalibrator(raw_columns=[0, 1], window=3),
    WindowLSTMCalibrator(window=2, hidden_size=3, max_epochs=2, random_state=0, n_threads=1),
]


def data(n_samples=120, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n_samples, 4))
    X[:, 3] = 1.0  # constant column: infinite scale in the saved standardization
    y = X[:, :2] + 0.1 * np.sin(X[:, 1:3])
    return X, y


@pytest.fixture
def saved_linear(tmp_path):
    X, y = data()
    path = save_calibrator(LinearCalibrator(raw_columns=[0, 1]).fit(X, y),
                           tmp_path / "linear.rcal", feature_names=NAMES)
    return path


@pytest.mark.parametrize("calibrator", CALIBRATORS, ids=lambda c: type(c).__name__)
def test_round_trip_predicts_identically(tmp_path, calibrator):
    X, y = data()
    calibrator.fit(X, y)
    loaded = load_calibrator(save_calibrator(calibrator, tmp_path / "model.rcal"), n_features=4)
    assert type(loaded) is type(calibrator)
    np.testing.assert_array_equal(loaded.predict(X), calibrator.predict(X))
    X_new, _ = data(seed=1)
    predictor, original = loaded.to_realtime(), calibrator.to_realtime()
    np.testing.assert_array_equal([predictor(row) for row in X_new],
                                  [original(row) for row in X_new])


def test_file_holds_json_metadata_and_plain_arrays(saved_linear):
    with zipfile.ZipFile(saved_linear) as archive:
        assert sorted(archive.namelist()) == ["metadata.json", "state.npz"]
        document = json.loads(archive.read("metadata.json"))
        with np.load(io.BytesIO(archive.read("state.npz")), allow_pickle=False) as state:
            assert sorted(state.files) == ["coef", "intercept"]
    assert document["class"] == "LinearCalibrator"
    assert document["format_version"] == FORMAT_VERSION
    assert document["feature_names_in"]["names"] == list(NAMES)
    assert document["params"] == {"alpha": 0.0, "raw_columns": [0, 1]}


def test_hyper_parameters_survive_including_tuples_and_nested_networks(tmp_path):
    X, y = data()
    calibrator = TwoPhaseCalibrator(n_estimators=3, random_state=2,
                                    dnn=DNNCalibrator(hidden_layer_sizes=(4, 3), max_epochs=2,
                                                      n_threads=1)).fit(X, y)
    loaded = load_calibrator(save_calibrator(calibrator, tmp_path / "two.rcal"))
    assert loaded.dnn.hidden_layer_sizes == (4, 3)
    assert loaded.get_params()["dnn__max_epochs"] == 2
    assert loaded.random_state == 2


def test_unsaveable_random_generator_is_recorded_not_pickled(tmp_path):
    X, y = data()
    calibrator = GPRCalibrator(subset_size=30, random_state=np.random.RandomState(0),
                               n_threads=1).fit(X, y)
    path = save_calibrator(calibrator, tmp_path / "gpr.rcal")
    with zipfile.ZipFile(path) as archive:
        assert json.loads(archive.read("metadata.json"))["unsaved_params"] == ["random_state"]
    assert load_calibrator(path).random_state is None


def test_dataframe_feature_names_are_restored(tmp_path):
    X, y = data()
    frame = pd.DataFrame(X, columns=list(NAMES))
    calibrator = LinearCalibrator(raw_columns=[0, 1]).fit(frame, y)
    loaded = load_calibrator(save_calibrator(calibrator, tmp_path / "frame.rcal"),
                             feature_names=NAMES)
    assert list(loaded.feature_names_in_) == list(NAMES)
    with pytest.raises(ValueError, match="feature names"):
        loaded.predict(frame[list(reversed(NAMES))])


@pytest.mark.parametrize("kwargs, message", [
    ({"n_features": 5}, "was made for 4 features, but the data has 5"),
    ({"feature_names": ["shoulder", "elbow", "insertion", "tau_elbow"]},
     r"made for another feature set.*missing \['tau_shoulder'\], unexpected \['tau_elbow'\]"),
    ({"feature_names": list(reversed(NAMES))}, "same names in another order"),
])
def test_other_feature_set_is_refused(saved_linear, kwargs, message):
    with pytest.raises(ValueError, match=message):
        load_calibrator(saved_linear, **kwargs)


def test_feature_count_is_checked_when_names_were_not_recorded(tmp_path):
    X, y = data()
    path = save_calibrator(LinearCalibrator().fit(X, y), tmp_path / "anonymous.rcal")
    load_calibrator(path, feature_names=["a", "b", "c", "d"])
    with pytest.raises(ValueError, match=r"made for 4 features \(names not recorded\)"):
        load_calibrator(path, feature_names=["a", "b", "c"])


def _rewrite(path, metadata=None, state=None):
    """Copy of a saved file with its metadata document and/or state arrays replaced."""
    with zipfile.ZipFile(path) as archive:
        document = json.loads(archive.read("metadata.json"))
        state_bytes = archive.read("state.npz")
    if metadata is not None:
        document = metadata(document)
    if state is not None:
        with np.load(io.BytesIO(state_bytes)) as arrays:
            buffer = io.BytesIO()
            np.savez(buffer, **state(dict(arrays)))
            state_bytes = buffer.getvalue()
    target = path.with_name("edited.rcal")
    with zipfile.ZipFile(target, "w") as archive:
        archive.writestr("metadata.json", json.dumps(document))
        archive.writestr("state.npz", state_bytes)
    return target


def test_other_format_version_is_refused_with_both_versions_named(saved_linear):
    edited = _rewrite(saved_linear, metadata=lambda d: {**d, "format_version": FORMAT_VERSION + 1})
    with pytest.raises(ValueError, match=rf"format version {FORMAT_VERSION + 1}.*reads format "
                                         rf"version {FORMAT_VERSION} only"):
        load_calibrator(edited)


@pytest.mark.parametrize("metadata, state, message", [
    (lambda d: {**d, "class": "MagicCalibrator"}, None,
     "unknown calibrator class 'MagicCalibrator'"),
    (lambda d: {**d, "format": "something-else"}, None, "not a calibrator file"),
    (None, lambda s: {"coef": s["coef"]}, "do not match the metadata"),
    (None, lambda s: {**s, "coef": s["coef"][:2]}, "array 'coef' has shape"),
    (None, lambda s: {**s, "coef": np.full_like(s["coef"], np.nan)}, "contains NaN"),
    (lambda d: {**d, "n_features_in": 3, "feature_names_in": None}, None,
     "corrupt: its state does not fit a LinearCalibrator"),
])
def test_inconsistent_files_are_refused(saved_linear, metadata, state, message):
    with pytest.raises(ValueError, match=message):
        load_calibrator(_rewrite(saved_linear, metadata, state))


def test_other_files_are_refused(tmp_path):
    text = tmp_path / "notes.rcal"
    text.write_text("not a model")
    with pytest.raises(ValueError, match="not a calibrator file \\(not a zip archive\\)"):
        load_calibrator(text)
    archive = tmp_path / "other.zip"
    with zipfile.ZipFile(archive, "w") as handle:
        handle.writestr("data.csv", "1,2")
    with pytest.raises(ValueError, match="lacks metadata.json or state.npz"):
        load_calibrator(archive)


def test_unfitted_calibrator_cannot_be_saved(tmp_path):
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        save_calibrator(LinearCalibrator(), tmp_path / "empty.rcal")


def test_feature_names_must_match_the_fitted_feature_count(tmp_path):
    X, y = data()
    with pytest.raises(ValueError,
                       match="feature_names has 2 names but the calibrator was fitted on 4"):
        save_calibrator(LinearCalibrator().fit(X, y), tmp_path / "m.rcal", feature_names=["a", "b"])
