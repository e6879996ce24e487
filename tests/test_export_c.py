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

void run_rows_{name}(const double *X, double *Y, int n)
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


def compile_and_load(calibrators, directory, flags=("-O2",)):
    """Export every calibrator of ``{name: fitted calibrator}``, compile them as the docs say
    (generated files + the caller's files, -lm) into one shared library, and load it.

    Returns ``{name: (predict over rows, the single-sample function)}``.
    """
    sources = []
    for name in calibrators:
        c_path, _ = export_c(calibrators[name], directory, name=name)
        caller = directory / f"{name}_caller.c"
        caller.write_text(CALLER.format(name=name, NAME=name.upper()))
        sources += [str(c_path), str(caller)]
    library = directory / "libcalibrators.so"
    command = [COMPILER, *flags, "-std=c99", "-Wall", "-Wextra", "-Werror", "-shared", "-fPIC",
               *sources, "-lm", "-o", str(library)]
    result = subprocess.run(command, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr
    handle = ctypes.CDLL(str(library))
    loaded = {}
    for name, calibrator in calibrators.items():
        run_rows = getattr(handle, f"run_rows_{name}")
        run_rows.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double),
                             ctypes.c_int]
        run_rows.restype = None
        single = getattr(handle, name)
        single.argtypes = [ctypes.POINTER(ctypes.c_double), ctypes.POINTER(ctypes.c_double)]
        single.restype = None

        def predict(X, run_rows=run_rows, n_outputs=calibrator.n_outputs_):
            X = np.ascontiguousarray(X, dtype=np.float64)
            Y = np.empty((X.shape[0], n_outputs))
            run_rows(X.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                     Y.ctypes.data_as(ctypes.POINTER(ctypes.c_double)), X.shape[0])
            return Y

        loaded[name] = predict, single
    return loaded


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


SATURATED = ("sigmoid", "tanh", "relu")
FRAME_COLUMNS = ["q_shoulder", "q_elbow", "q_insertion", "tau", "unused"]


@pytest.fixture(scope="module")
def compiled(tmp_path_factory):
    """Every exported variant of this file, fitted, compiled once into one shared library.

    Returns the folder of the generated files, ``{name: fitted calibrator}`` and
    ``{name: (predict over rows, single-sample function)}`` of the compiled code.
    """
    if COMPILER is None:
        pytest.skip("no C compiler (cc) on this system")
    X, y = data()
    calibrators = {case: make().fit(X, y) for case, make in CASES.items()}
    for activation in SATURATED:
        calibrators[f"saturated_{activation}"] = DNNCalibrator(
            raw_columns=[0, 1, 2], activation=activation, hidden_layer_sizes=(16,), max_epochs=5,
            random_state=0, n_threads=1).fit(X, y)
    calibrators["elbow_correction"] = LinearCalibrator(raw_columns=1).fit(
        pd.DataFrame(X, columns=FRAME_COLUMNS), y[:, 1])
    directory = tmp_path_factory.mktemp("export_c")
    return directory, calibrators, compile_and_load(calibrators, directory)


@needs_compiler
@pytest.mark.parametrize("case", list(CASES))
def test_compiled_export_predicts_as_predict(compiled, case):
    _, calibrators, functions = compiled
    calibrator, (predict_c, _) = calibrators[case], functions[case]
    for seed in (1, 2, 3):
        X_new, _ = data(n_samples=200, seed=seed)
        X_new[:, -1] = np.random.default_rng(seed).normal(size=200)  # even off the constant
        assert_agrees(predict_c(X_new), calibrator.predict(X_new))


@needs_compiler
def test_one_dimensional_target_and_dataframe_names(compiled):
    directory, calibrators, functions = compiled
    calibrator, (predict_c, single) = calibrators["elbow_correction"], functions["elbow_correction"]
    X_new, _ = data(seed=4)
    assert_agrees(predict_c(X_new), calibrator.predict(pd.DataFrame(X_new,
                                                                    columns=FRAME_COLUMNS)))
    header = (directory / "elbow_correction.h").read_text()
    assert "#define ELBOW_CORRECTION_N_FEATURES 5" in header
    assert "#define ELBOW_CORRECTION_N_TARGETS 1" in header
    assert "q_shoulder, q_elbow" in header
    # The single-sample function itself, called directly, with its output in place of its input.
    row = np.ascontiguousarray(X_new[7])
    expected = calibrator.predict(pd.DataFrame(row[None, :], columns=FRAME_COLUMNS))
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
@pytest.mark.parametrize("activation", SATURATED)
def test_saturated_units_and_missing_inputs(compiled, activation):
    _, calibrators, functions = compiled
    name = f"saturated_{activation}"
    calibrator, (predict_c, _) = calibrators[name], functions[name]
    # Inputs far outside the training range drive every hidden unit deep into saturation.
    X_far, _ = data(n_samples=100, seed=5)
    X_far *= np.logspace(-8, 3, 100)[:, None]
    assert_agrees(predict_c(X_far), calibrator.predict(X_far))
    X_nan = X_far[:3].copy()
    X_nan[:, 3] = np.nan
    assert np.all(np.isnan(predict_c(X_nan)))
