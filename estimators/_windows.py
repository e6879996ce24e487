"""Temporal windows over the rows of X, for the calibrators after Hwang et al. (RA-L 2020).

The window of row t is rows ``t - window + 1, ..., t`` of X in the order given, oldest first,
so it holds the current sample and the ``window - 1`` before it. The first ``window - 1`` rows
have no full history; their window is padded by repeating row 0 (as if the robot had rested
at its first state), so every row gets a prediction and `predict` returns one row per input
row. The real-time predictors pad the same way on their first call (`estimators.realtime`).
"""

from __future__ import annotations

import numpy as np


def window_rows(n_samples: int, window: int) -> np.ndarray:
    """Row indices of each window, shape (n_samples, window), oldest first, padded with 0."""
    lags = np.arange(window - 1, -1, -1)
    return np.maximum(np.arange(n_samples)[:, None] - lags[None, :], 0)


def stack_windows(X: np.ndarray, window: int) -> np.ndarray:
    """Windows of the rows of X, shape (n_samples, window, n_features), oldest first."""
    return X[window_rows(X.shape[0], window)]
