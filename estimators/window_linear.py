"""Linear calibrator over a temporal window of robot states (Hwang et al., RA-L 2020)."""

from __future__ import annotations

import numpy as np

from estimators._base import CalibratorBase
from estimators._least_squares import fit_affine, least_squares_min_samples
from estimators.realtime import WindowAffinePredictor
from estimators._standardization import Standardizer
from estimators._validation import check_non_negative_float, check_positive_int
from estimators._windows import stack_windows


class WindowLinearCalibrator(CalibratorBase):
    """Affine map from the last `window` rows of X to the correction of the current row.

    Hwang et al. (2020) found that the wrist errors of a dVRK depend on the motion history
    (cable stretch, coupling and hysteresis in the tool) and predicted them from the current
    and the previous commanded joint positions (4 previous ones: ``window=5``).

    The rows of X must be consecutive samples of one recording in time order: row t is
    predicted from rows t - window + 1 ... t, and the first window - 1 rows are padded by
    repeating row 0 (see `estimators._windows`). Hence a prediction depends on the rows before
    it, and predicting a subset or a shuffled X changes it, by design. For a servo loop,
    `to_realtime` returns a predictor that keeps the last `window` samples in a ring buffer
    (call its ``reset()`` at the start of a new recording).

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y; the raw value of the
        current row is used (error mode).
    window : int, default=5
        Number of rows in the window, the current one included.
    alpha : float, default=0.0
        Ridge penalty on the weights of the standardized window.

    Attributes
    ----------
    coef_ : ndarray, shape (window, n_features, n_outputs)
        Weights of each lag in raw units, oldest row first.
    intercept_ : ndarray, shape (n_outputs,)
    """

    def __init__(self, *, raw_columns=None, window=5, alpha=0.0):
        self.raw_columns = raw_columns
        self.window = window
        self.alpha = alpha

    def _check_params(self):
        check_positive_int(self.window, "window")
        check_non_negative_float(self.alpha, "alpha")

    def _min_samples(self, n_features):
        window = int(self.window)
        needed, reason = least_squares_min_samples(
            window * n_features + 1, float(self.alpha),
            f"{window} rows x {n_features} weights and an intercept")
        if window >= needed:
            return window, f"for one full window of {window} rows"
        return needed, reason

    def _fit_correction(self, X, correction):
        window = int(self.window)
        scaler = Standardizer.fit_inputs(X)
        features = stack_windows(scaler.transform(X), window).reshape(X.shape[0], -1)
        coef, intercept = fit_affine(features, correction, float(self.alpha))
        coef = coef.reshape(window, X.shape[1], -1)
        self.coef_ = coef / scaler.scale[None, :, None]
        self.intercept_ = intercept - np.einsum("f,lfo->o", scaler.mean / scaler.scale, coef)

    def _predict_correction(self, X):
        windows = stack_windows(X, self.coef_.shape[0]).reshape(X.shape[0], -1)
        return windows @ self.coef_.reshape(-1, self.n_outputs_) + self.intercept_

    def _build_realtime(self):
        weight = self.coef_.copy()
        weight[-1] += self._raw_selection()
        return WindowAffinePredictor(weight.reshape(-1, self.n_outputs_), self.intercept_,
                                     self.coef_.shape[0])

    def _fitted_arrays(self):
        return {"coef": self.coef_, "intercept": self.intercept_}

    def _restore_fitted_arrays(self, arrays):
        self.coef_ = arrays["coef"]
        self.intercept_ = arrays["intercept"]
