"""Temporal-window calibrators: how windows are formed, padded, buffered and computed."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from estimators import WindowLinearCalibrator, WindowLSTMCalibrator
from estimators._lstm import LSTMWeights, forward
from estimators.realtime import WindowBuffer
from estimators._windows import window_rows


def lagged_system(n_samples=400, seed=0):
    """y_t = x_t + 0.3 * x_{t-1} - 0.2 * x_{t-2} + 0.05 (rows before 0 repeat row 0)."""
    rng = np.random.default_rng(seed)
    X = np.cumsum(rng.normal(size=(n_samples, 2)), axis=0) * 0.1
    previous = X[np.maximum(np.arange(n_samples) - 1, 0)]
    before = X[np.maximum(np.arange(n_samples) - 2, 0)]
    y = X[:, :1] + 0.3 * previous[:, 1:] - 0.2 * before[:, :1] + 0.05
    return X, y


def test_window_rows_are_oldest_first_and_padded_with_the_first_row():
    np.testing.assert_array_equal(window_rows(4, 3), [[0, 0, 0], [0, 0, 1], [0, 1, 2], [1, 2, 3]])


def test_ring_buffer_returns_the_last_rows_oldest_first():
    buffer = WindowBuffer(window=3, width=1)
    seen = [buffer.push(np.array([float(value)])).ravel().tolist() for value in range(6)]
    assert seen == [[0, 0, 0], [0, 0, 1], [0, 1, 2], [1, 2, 3], [2, 3, 4], [3, 4, 5]]
    buffer.reset()
    assert buffer.push(np.array([9.0])).ravel().tolist() == [9, 9, 9]


def test_window_linear_recovers_a_lagged_system_exactly():
    X, y = lagged_system()
    calibrator = WindowLinearCalibrator(raw_columns=[0], window=3).fit(X, y)
    np.testing.assert_allclose(calibrator.predict(X), y, atol=1e-10)
    # coef_[lag] is oldest first: lag 0 is x_{t-2}, lag 2 is x_t (raw column excluded)
    np.testing.assert_allclose(calibrator.coef_[:, :, 0], [[-0.2, 0.0], [0.0, 0.3], [0.0, 0.0]],
                               atol=1e-10)


def test_window_predictions_depend_on_row_order():
    X, y = lagged_system()
    calibrator = WindowLinearCalibrator(raw_columns=[0], window=3).fit(X, y)
    order = np.random.default_rng(1).permutation(len(X))
    assert not np.allclose(calibrator.predict(X[order]), calibrator.predict(X)[order])


@pytest.mark.parametrize("calibrator", [
    WindowLinearCalibrator(raw_columns=[0], window=4),
    WindowLSTMCalibrator(raw_columns=[0], window=4, hidden_size=5, max_epochs=2,
                         random_state=0, n_threads=1),
])
def test_realtime_ring_buffer_replays_each_recording_from_its_start(calibrator):
    X, y = lagged_system()
    first, second = X[:150], X[150:]
    calibrator.fit(X, y)
    predictor = calibrator.to_realtime()
    outputs = np.array([predictor(row.copy()) for row in first])
    np.testing.assert_allclose(outputs, calibrator.predict(first), atol=1e-9)
    predictor.reset()  # a new recording starts: its first sample fills the window
    outputs = np.array([predictor(row.copy()) for row in second])
    np.testing.assert_allclose(outputs, calibrator.predict(second), atol=1e-9)


def test_lstm_forward_matches_torch():
    rng = np.random.default_rng(2)
    weights = LSTMWeights.initial(n_features=3, hidden=4, n_outputs=2, rng=rng)
    windows = rng.normal(size=(6, 5, 3))
    lstm = torch.nn.LSTM(3, 4, batch_first=True, dtype=torch.float64)
    head = torch.nn.Linear(4, 2, dtype=torch.float64)
    with torch.no_grad():
        lstm.weight_ih_l0.copy_(torch.from_numpy(weights.input_weight.T.copy()))
        lstm.weight_hh_l0.copy_(torch.from_numpy(weights.recurrent_weight.T.copy()))
        lstm.bias_ih_l0.copy_(torch.from_numpy(weights.gate_bias))
        lstm.bias_hh_l0.zero_()
        head.weight.copy_(torch.from_numpy(weights.out_weight.T.copy()))
        head.bias.copy_(torch.from_numpy(weights.out_bias))
        sequence, _ = lstm(torch.from_numpy(windows))
        expected = head(sequence[:, -1]).numpy()
    np.testing.assert_allclose(forward(windows, weights), expected, atol=1e-12)


def test_window_lstm_learns_a_history_dependent_error():
    X, y = lagged_system(n_samples=800)
    calibrator = WindowLSTMCalibrator(raw_columns=[0], window=3, hidden_size=16, max_epochs=40,
                                      batch_size=64, learning_rate=1e-2, random_state=0,
                                      n_threads=1).fit(X, y)
    error_before = np.std(y[:, 0] - X[:, 0])
    error_after = np.std(y[:, 0] - calibrator.predict(X)[:, 0])
    assert error_after < 0.2 * error_before
