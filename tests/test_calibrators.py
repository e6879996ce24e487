"""Behaviour every calibrator shares: real-time export, constant columns, determinism, pickling,
error messages on bad input and on bad hyper-parameters."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import torch
from sklearn.model_selection import GridSearchCV, KFold, cross_val_score
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import StandardScaler

from estimators import DNNCalibrator, FixedOffsetCalibrator, GPRCalibrator, LinearCalibrator
from estimators import PolynomialCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator

RAW = [0, 2]  # columns of X holding the uncorrected positions of the two targets
CONSTANT = 3  # a column that never changes (like RAVEN-II's unused DOF slot)


def make(name: str, raw_columns=RAW, random_state=0):
    """A small, fast instance of each calibrator."""
    factories = {
        "fixed": lambda: FixedOffsetCalibrator(raw_columns=raw_columns),
        "linear": lambda: LinearCalibrator(raw_columns=raw_columns),
        "polynomial": lambda: PolynomialCalibrator(raw_columns=raw_columns),
        "dnn": lambda: DNNCalibrator(raw_columns=raw_columns, hidden_layer_sizes=(16, 16),
                                     max_epochs=15, batch_size=64, random_state=random_state,
                                     n_threads=1),
        "gpr": lambda: GPRCalibrator(raw_columns=raw_columns, subset_size=120,
                                     hyperparameter_subset_size=60, max_optimizer_iterations=30,
                                     random_state=random_state, n_threads=1),
        "two_phase": lambda: TwoPhaseCalibrator(
            raw_columns=raw_columns, n_estimators=8, random_state=random_state,
            dnn=DNNCalibrator(hidden_layer_sizes=(8,), max_epochs=10, batch_size=64,
                              n_threads=1)),
        "window_linear": lambda: WindowLinearCalibrator(raw_columns=raw_columns, window=3),
        "window_lstm": lambda: WindowLSTMCalibrator(
            raw_columns=raw_columns, window=3, hidden_size=6, max_epochs=3, batch_size=64,
            random_state=random_state, n_threads=1),
    }
    return factories[name]()


NAMES = ["fixed", "linear", "polynomial", "dnn", "gpr", "two_phase", "window_linear",
         "window_lstm"]
RANDOMIZED = ["dnn", "gpr", "two_phase", "window_lstm"]


def robot_data(n_samples: int = 240, seed: int = 0):
    """Joint-like inputs with large offsets and one constant column; two targets (rad, m)."""
    rng = np.random.default_rng(seed)
    X = np.column_stack([
        rng.uniform(0.3, 1.0, n_samples),          # shoulder (rad)
        rng.normal(0.0, 0.5, n_samples),           # torque (N m)
        0.4 + 0.03 * rng.standard_normal(n_samples),  # insertion (m), offset >> spread
        np.full(n_samples, 2.5),                   # constant column
        rng.normal(100.0, 1e-3, n_samples),        # tiny spread around a large mean
    ])
    y = np.column_stack([
        X[:, 0] + 0.02 * np.sin(3 * X[:, 1]) + 0.01,
        X[:, 2] - 0.002 * X[:, 1] ** 2 + 1e3 * (X[:, 4] - 100.0) * 1e-3,
    ])
    return X, y


@pytest.fixture(scope="module")
def data():
    return robot_data()


@pytest.fixture(scope="module")
def fitted(data):
    """Each calibrator fitted once in error mode, shared by the read-only tests."""
    X, y = data
    return {name: make(name).fit(X, y) for name in NAMES}


def realtime_outputs(predictor, X):
    """Call a real-time predictor on each row in order, as a servo loop would."""
    return np.array([predictor(np.ascontiguousarray(row)) for row in X])


@pytest.mark.parametrize("name", NAMES)
def test_realtime_predictor_matches_predict(fitted, data, name):
    X, _ = data
    calibrator = fitted[name]
    predictor = calibrator.to_realtime()
    outputs = realtime_outputs(predictor, X)
    assert outputs.shape == (X.shape[0], 2)
    np.testing.assert_allclose(outputs, calibrator.predict(X), rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_realtime_output_is_a_new_array_each_call(fitted, data, name):
    X, _ = data
    predictor = fitted[name].to_realtime()
    first = predictor(X[0].copy())
    kept = first.copy()
    predictor(X[1].copy())
    np.testing.assert_array_equal(first, kept)


@pytest.mark.parametrize("name", NAMES)
def test_one_dimensional_target_end_to_end(data, name):
    X, y = data
    calibrator = make(name, raw_columns=None).fit(X, y[:, 0])
    prediction = calibrator.predict(X)
    assert prediction.shape == (X.shape[0],)
    outputs = realtime_outputs(calibrator.to_realtime(), X)
    assert outputs.shape == (X.shape[0], 1)
    np.testing.assert_allclose(outputs[:, 0], prediction, rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
def test_constant_column_is_finite_and_ignored(fitted, data, name):
    X, _ = data
    calibrator = fitted[name]
    moved = X.copy()
    moved[:, CONSTANT] = -7.0  # a value never seen in training
    prediction = calibrator.predict(X)
    assert np.all(np.isfinite(prediction))
    np.testing.assert_allclose(calibrator.predict(moved), prediction, rtol=0, atol=1e-12)
    np.testing.assert_allclose(realtime_outputs(calibrator.to_realtime(), moved), prediction,
                               rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", RANDOMIZED)
def test_random_state_determines_the_fit_without_touching_global_state(data, name):
    X, y = data
    numpy_state = np.random.get_state()[1].copy()
    torch_state = torch.random.get_rng_state().clone()
    threads = torch.get_num_threads()
    first = make(name, random_state=3).fit(X, y).predict(X)
    second = make(name, random_state=3).fit(X, y).predict(X)
    other = make(name, random_state=4).fit(X, y).predict(X)
    np.testing.assert_array_equal(first, second)
    assert not np.allclose(first, other)
    np.testing.assert_array_equal(np.random.get_state()[1], numpy_state)
    assert torch.equal(torch.random.get_rng_state(), torch_state)
    assert torch.get_num_threads() == threads


@pytest.mark.parametrize("name", NAMES)
def test_fitted_calibrator_and_realtime_predictor_pickle(fitted, data, name):
    X, _ = data
    calibrator = pickle.loads(pickle.dumps(fitted[name]))
    np.testing.assert_array_equal(calibrator.predict(X), fitted[name].predict(X))
    predictor = pickle.loads(pickle.dumps(fitted[name].to_realtime()))
    np.testing.assert_allclose(predictor(X[0].copy()), fitted[name].predict(X[:1])[0],
                               rtol=0, atol=1e-6)


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("where, value, message", [
    ("X", np.nan, "Input X contains NaN"),
    ("X", np.inf, "Input X contains infinity"),
    ("y", np.nan, "Input y contains NaN"),
])
def test_non_finite_training_data_is_refused(data, name, where, value, message):
    X, y = (array.copy() for array in data)
    (X if where == "X" else y)[5, 0] = value
    with pytest.raises(ValueError, match=message):
        make(name).fit(X, y)


@pytest.mark.parametrize("name", NAMES)
def test_wrong_number_of_features_at_predict(fitted, data, name):
    X, _ = data
    with pytest.raises(ValueError, match="X has 4 features, but .* is expecting 5 features"):
        fitted[name].predict(X[:, :4])


@pytest.mark.parametrize("name", NAMES)
def test_target_length_mismatch(data, name):
    X, y = data
    with pytest.raises(ValueError, match="inconsistent numbers of samples"):
        make(name).fit(X, y[:-1])


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("raw_columns, error, message", [
    ([0, 5], ValueError, "raw_columns index 5 is out of range for X with 5 feature"),
    ([0, -1], ValueError, "raw_columns index -1 is out of range"),
    ([0], ValueError, "raw_columns has 1 entries but y has 2 target column"),
    ([0, 1.5], TypeError, "raw_columns must hold integers"),
    ("ab", TypeError, "raw_columns must be None, an int or a sequence of ints"),
])
def test_bad_raw_columns(data, name, raw_columns, error, message):
    X, y = data
    with pytest.raises(error, match=message):
        make(name, raw_columns=raw_columns).fit(X, y)


@pytest.mark.parametrize("calibrator, error, message", [
    (LinearCalibrator(alpha=-1.0), ValueError, "alpha must be finite and >= 0"),
    (PolynomialCalibrator(degree=0), ValueError, "degree must be >= 1"),
    (PolynomialCalibrator(degree=2.0), TypeError, "degree must be an integer"),
    (DNNCalibrator(hidden_layer_sizes=(10, 0)), ValueError,
     "hidden_layer_sizes entries must be >= 1"),
    (DNNCalibrator(activation="softmax"), ValueError, "activation must be one of"),
    (DNNCalibrator(kernel_l2=-1e-3), ValueError, "kernel_l2 must be finite and >= 0"),
    (DNNCalibrator(learning_rate=0.0), ValueError, "learning_rate must lie in"),
    (DNNCalibrator(beta_2=1.0), ValueError, "beta_2 must lie in"),
    (DNNCalibrator(batch_size=0), ValueError, "batch_size must be >= 1"),
    (DNNCalibrator(n_threads=0), ValueError, "n_threads must be >= 1"),
    (DNNCalibrator(early_stopping=True, validation_fraction=0.999, max_epochs=1), ValueError,
     r"needs at least 1000 samples to hold out validation_fraction=0.999 .* got 20 samples"),
    (GPRCalibrator(subset_size=0), ValueError, "subset_size must be >= 1"),
    (GPRCalibrator(length_scale_bounds=(1.0, 0.1)), ValueError, "length_scale_bounds must satisfy"),
    (TwoPhaseCalibrator(dnn=DNNCalibrator(raw_columns=[0])), ValueError,
     "dnn.raw_columns must be None"),
    (TwoPhaseCalibrator(dnn=LinearCalibrator()), TypeError, "dnn must be a DNNCalibrator"),
    (TwoPhaseCalibrator(n_estimators=0), ValueError, "n_estimators must be >= 1"),
    (WindowLinearCalibrator(window=0), ValueError, "window must be >= 1"),
    (WindowLSTMCalibrator(hidden_size=0), ValueError, "hidden_size must be >= 1"),
    (WindowLSTMCalibrator(validation_fraction=1.5), ValueError, "validation_fraction must lie in"),
])
def test_bad_hyper_parameters_are_named(data, calibrator, error, message):
    X, y = data
    with pytest.raises(error, match=message):
        calibrator.fit(X[:20], y[:20])


def test_calibrators_work_inside_scikit_learn_model_selection(data):
    X, y = data
    search = GridSearchCV(make_pipeline(StandardScaler(), PolynomialCalibrator()),
                          {"polynomialcalibrator__alpha": [0.0, 1e3]}, cv=3)
    search.fit(X, y)
    assert search.best_params_ == {"polynomialcalibrator__alpha": 0.0}
    scores = cross_val_score(make("dnn"), X, y, cv=KFold(3))
    assert scores.shape == (3,) and np.all(np.isfinite(scores))


# --- progress (verbose) -------------------------------------------------------------------

@pytest.mark.parametrize("name", RANDOMIZED)
def test_verbose_zero_prints_nothing_and_verbose_changes_no_result(data, name, capsys):
    X, y = data
    quiet = make(name).fit(X, y)
    assert capsys.readouterr().out == ""
    talkative = make(name).set_params(verbose=2).fit(X, y)
    assert capsys.readouterr().out.strip()
    np.testing.assert_array_equal(talkative.predict(X), quiet.predict(X))


def test_verbose_network_prints_one_line_per_reported_epoch(data, capsys):
    X, y = data
    make("dnn").set_params(max_epochs=25, verbose=1).fit(X, y)
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(",")[0] for line in lines] == [
        "Epoch 1/25", "Epoch 10/25", "Epoch 20/25", "Epoch 25/25"]
    assert all("loss = " in line and "elapsed" in line for line in lines)
    make("window_lstm").set_params(max_epochs=4, verbose=2).fit(X, y)
    assert len(capsys.readouterr().out.splitlines()) == 4


def test_verbose_network_reports_validation_loss_and_early_stop(data, capsys):
    X, y = data
    dnn = make("dnn").set_params(max_epochs=500, early_stopping=True, n_iter_no_change=2,
                                 tol=1e3, verbose=1).fit(X, y)
    lines = capsys.readouterr().out.splitlines()
    assert dnn.n_epochs_ == 3  # a gain of 1e3 never comes: stop after 2 epochs without one
    assert all("validation loss = " in line for line in lines[:-1])
    assert lines[-2].startswith("Epoch 3/500")
    assert lines[-1] == ("Validation loss did not improve for 2 epochs: stopped after epoch 3, "
                         f"keeping epoch {dnn.best_epoch_}.")


def test_verbose_gpr_reports_the_optimizer_run_and_its_iterations(data, capsys):
    X, y = data
    make("gpr").set_params(verbose=1).fit(X, y)
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 2
    assert lines[0].startswith("GPR kernel fit on 60 points:") and "L-BFGS-B iterations" in lines[0]
    assert lines[1].startswith("GPR posterior weights on 120 support points")
    n_iterations = int(lines[0].split(": ")[1].split()[0])
    make("gpr").set_params(verbose=2).fit(X, y)
    lines = capsys.readouterr().out.splitlines()
    assert sum("GPR kernel fit iteration" in line for line in lines) == n_iterations


def test_verbose_two_phase_reports_both_phases_and_the_network(data, capsys):
    X, y = data
    make("two_phase").set_params(verbose=1).fit(X, y)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("Epoch 1/10")
    assert lines[-2].startswith("Phase 1: network trained")
    assert lines[-1].startswith("Phase 2: forest of 8 trees fitted")


@pytest.mark.parametrize("name", RANDOMIZED)
@pytest.mark.parametrize("verbose, error, message", [
    (-1, ValueError, "verbose must be >= 0"),
    (1.5, TypeError, "verbose must be an integer"),
])
def test_bad_verbose_is_named(data, name, verbose, error, message):
    X, y = data
    with pytest.raises(error, match=message):
        make(name).set_params(verbose=verbose).fit(X[:20], y[:20])
