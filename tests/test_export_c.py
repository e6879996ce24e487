"""C export of calibrators: compiled with the system compiler, it predicts as `predict` does."""

from __future__ import annotations

import ctypes
import os
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from sklearn.exceptions import NotFittedError

from estimators import (
    DNNCalibrator,
    FixedOffsetCalibrator,
    GPRCalibrator,
    LinearCalibrator,
    PolynomialCalibrator,
    WindowLinearCalibrator,
)
from estimators.export_c import export_c

COMPILER = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc") or shutil.which(
    "clang")
needs_compiler = pytest.mark.skipif(COMPILER is None, reason="no C compiler (cc) on this system")

# The caller's own code: it includes the generated header and runs the function over rows.
CALLER = """
#include "{name}.h"

void run_rows(const double *X, double *Y, int n)
{{
    int k;
    for (k = 0; k < n; ++k) {name}(X + k * {NAME}_N_FEATURES, Y + k * {NAME}_N_TARGETS);
}}
"""


def data(n_samples=300, n_features=5, n_targets=3, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n_samples, n_features)) * np.array([0.3, 1.0, 0.02, 5.0, 1.0])[
        :n_features]
    X[:, -1] = 0.25  # a constant column: infinite standardization scale, folded weight 0
    y = X[:, :n_targets] + 0.05 * np.sin(X[:, 1:1 + n_targets]) + 0.01 * X[:, [3]] ** 2
    return X, y


def compile_and_load(calibrator, directory, name="calibrator", flags=("-O2",)):
    """Export, compile as the docs say (generated file + caller's file, -lm) and load."""
    c_path, h_path = export_c(calibrator, directory, name=name)
    caller = directory / "caller.c"
    caller.write_text(CALLER.format(name=name, NAME=name.upper()))
    library = directory / f"lib{name}.so"
    command = [COMPILER, *flags, "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC",
               str(c_path), str(caller), "-lm", "-o", str(library)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    handle = ctypes.CDLL(str(library))
    run_rows = handle.run_rows
    run_rows.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double),
                         ctypes.c_int]
    run_rows.restype = None
    single = getattr(handle, name)
    single.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double)]
    single.restype = None

    def predict(X):
        X = np.ascontiguousarray(X, dtype=np.float64)
        Y = np.empty((X.shape[0], calibrator.n_outputs_))
        run_rows(X.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                 Y.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), X.shape[0])
        return Y

    return predict, single


def assert_agrees(c_output, expected):
    expected = expected.reshape(c_output.shape)
    np.testing.assert_allclose(c_output, expected, rtol=1e-6, atol=1e-12)


CASES = {
    "fixed_offset_raw": lambda: FixedOffsetCalibrator(raw_columns=[0, 1, 2]),
    "fixed_offset": lambda: FixedOffsetCalibrator(),
    "linear": lambda: LinearCalibrator(),
    "linear_raw": lambda: LinearCalibrator(raw_columns=[0, 1, 2], alpha=0.1),
    "polynomial": lambda: PolynomialCalibrator(degree=2),
    "polynomial_raw": lambda: PolynomialCalibrator(raw_columns=[2, 0, 1], degree=3, alpha=1e-3),
    "dnn_sigmoid": lambda: DNNCalibrator(hidden_layer_sizes=(12, 9), max_epochs=30,
                                         random_state=0, n_threads=1),
    "dnn_sigmoid_raw": lambda: DNNCalibrator(raw_columns=[0, 1, 2], hidden_layer_sizes=(12, 9),
                                             max_epochs=30, random_state=1, n_threads=1),
    "dnn_tanh_raw": lambda: DNNCalibrator(raw_columns=[0, 1, 2], activation="tanh",
                                          hidden_layer_sizes=(8,), max_epochs=20,
                                          random_state=2, n_threads=1),
    "dnn_relu": lambda: DNNCalibrator(activation="relu", hidden_layer_sizes=(10, 6, 4),
                                      max_epochs=20, random_state=3, n_threads=1),
}


@needs_compiler
@pytest.mark.parametrize("case", list(CASES))
def test_compiled_export_predicts_as_predict(tmp_path, case):
    X, y = data()
    calibrator = CASES[case]().fit(X, y)
    predict_c, _ = compile_and_load(calibrator, tmp_path)
    for seed in (1, 2, 3):
        X_new, _ = data(n_samples=200, seed=seed)
        X_new[:, -1] = np.random.default_rng(seed).normal(size=200)  # even off the constant
        assert_agrees(predict_c(X_new), calibrator.predict(X_new))


@needs_compiler
def test_one_dimensional_target_and_dataframe_names(tmp_path):
    X, y = data()
    frame = pd.DataFrame(X, columns=["q_shoulder", "q_elbow", "q_insertion", "tau", "unused"])
    calibrator = LinearCalibrator(raw_columns=1).fit(frame, y[:, 1])
    predict_c, single = compile_and_load(calibrator, tmp_path, name="elbow_correction")
    X_new, _ = data(seed=4)
    assert_agrees(predict_c(X_new), calibrator.predict(pd.DataFrame(X_new,
                                                                    columns=frame.columns)))
    header = (tmp_path / "elbow_correction.h").read_text()
    assert "#define ELBOW_CORRECTION_N_FEATURES 5" in header
    assert "#define ELBOW_CORRECTION_N_TARGETS 1" in header
    assert "q_shoulder, q_elbow" in header
    # The single-sample function itself, called directly, with its output in place of its input.
    row = np.ascontiguousarray(X_new[7])
    expected = calibrator.predict(pd.DataFrame(row[None, :], columns=frame.columns))
    single(row.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
           row.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
    assert_agrees(row[:1], expected)


def test_weights_are_written_in_full_precision(tmp_path):
    X, y = data()
    calibrator = LinearCalibrator().fit(X, y)
    c_path, _ = export_c(calibrator, tmp_path, name="lin")
    text = c_path.read_text()
    block = text[text.index("lin_weight[") : text.index("};", text.index("lin_weight["))]
    numbers = [float(v) for v in block.split("{", 1)[1].replace("\n", " ").split(",")]
    expected = calibrator.to_realtime().weight.reshape(-1)
    np.testing.assert_array_equal(numbers, expected)


@pytest.mark.parametrize("calibrator", [
    GPRCalibrator(subset_size=30, n_threads=1),
    WindowLinearCalibrator(window=3),
])
def test_unsupported_calibrators_are_refused(tmp_path, calibrator):
    X, y = data(n_samples=80)
    calibrator.fit(X, y)
    with pytest.raises(TypeError, match="export_c supports FixedOffsetCalibrator, "
                                        f"LinearCalibrator.*; got {type(calibrator).__name__}"):
        export_c(calibrator, tmp_path)
    assert not list(tmp_path.iterdir())


def test_unfitted_calibrators_and_bad_names_are_refused(tmp_path):
    with pytest.raises(NotFittedError):
        export_c(LinearCalibrator(), tmp_path)
    X, y = data(n_samples=50)
    calibrator = LinearCalibrator().fit(X, y)
    for name in ("3d", "my-model", "double", "tanh", "", "a b"):
        with pytest.raises(ValueError, match="name must be a C identifier"):
            export_c(calibrator, tmp_path, name=name)
    assert not list(tmp_path.iterdir())


@needs_compiler
@pytest.mark.parametrize("activation", ["sigmoid", "tanh", "relu"])
def test_saturated_units_and_missing_inputs(tmp_path, activation):
    X, y = data()
    calibrator = DNNCalibrator(raw_columns=[0, 1, 2], activation=activation,
                               hidden_layer_sizes=(16,), max_epochs=5, random_state=0,
                               n_threads=1).fit(X, y)
    # Inputs far outside the training range drive every hidden unit deep into saturation.
    X_far, _ = data(n_samples=100, seed=5)
    X_far *= np.logspace(-8, 3, 100)[:, None]
    predict_c, _ = compile_and_load(calibrator, tmp_path)
    assert_agrees(predict_c(X_far), calibrator.predict(X_far))
    X_nan = X_far[:3].copy()
    X_nan[:, 3] = np.nan
    assert np.all(np.isnan(predict_c(X_nan)))
