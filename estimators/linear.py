"""Linear regression calibrator: the paper's real-time choice."""

from __future__ import annotations

from estimators._base import CalibratorBase
from estimators._least_squares import fit_affine, least_squares_min_samples
from estimators.realtime import AffinePredictor
from estimators._standardization import Standardizer
from estimators._validation import check_non_negative_float


class LinearCalibrator(CalibratorBase):
    """Affine map from robot state to joint correction, fitted by least squares.

    The paper's linear model has 17 parameters per joint for its 16 selected features (joint
    positions and motor torques) and is fast enough for RAVEN-II's 1 kHz servo loop. Inputs are
    standardized inside (constant columns get a zero weight), which only matters for `alpha`.

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y; when given, the model
        learns the error (see `estimators._base`).
    alpha : float, default=0.0
        Ridge penalty on the weights of the standardized features (0: ordinary least squares,
        as in the paper).

    Attributes
    ----------
    coef_ : ndarray, shape (n_features, n_outputs)
        Weights in raw input units: correction = X @ coef_ + intercept_.
    intercept_ : ndarray, shape (n_outputs,)
    """

    def __init__(self, *, raw_columns=None, alpha=0.0):
        self.raw_columns = raw_columns
        self.alpha = alpha

    def _check_params(self):
        check_non_negative_float(self.alpha, "alpha")

    def _min_samples(self, n_features):
        return least_squares_min_samples(n_features + 1, float(self.alpha),
                                         f"{n_features} weights and an intercept")

    def _fit_correction(self, X, correction):
        scaler = Standardizer.fit_inputs(X)
        coef, intercept = fit_affine(scaler.transform(X), correction, float(self.alpha))
        self.coef_ = coef / scaler.scale[:, None]
        self.intercept_ = intercept - (scaler.mean / scaler.scale) @ coef

    def _predict_correction(self, X):
        return X @ self.coef_ + self.intercept_

    def _build_realtime(self):
        return AffinePredictor(self.coef_ + self._raw_selection(), self.intercept_)

    def _fitted_arrays(self):
        return {"coef": self.coef_, "intercept": self.intercept_}

    def _restore_fitted_arrays(self, arrays):
        self.coef_ = arrays["coef"]
        self.intercept_ = arrays["intercept"]
