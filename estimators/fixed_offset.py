"""The paper's baseline: add the mean training bias to each joint."""

from __future__ import annotations

import numpy as np

from estimators._base import CalibratorBase
from estimators.realtime import AffinePredictor


class FixedOffsetCalibrator(CalibratorBase):
    """Fixed offset compensation: the mean error of each joint over the training data.

    With ``raw_columns`` the prediction is ``X[:, raw_columns] + mean(y - X[:, raw_columns])``,
    the paper's baseline. With the default ``raw_columns=None`` nothing is read from X and the
    prediction is the mean of y (a constant regressor), which is all a bias model can be without
    knowing the raw positions.

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y.

    Attributes
    ----------
    offset_ : ndarray, shape (n_outputs,)
        Mean correction added to the raw positions (or the mean of y), in y's units.
    """

    def __init__(self, *, raw_columns=None):
        self.raw_columns = raw_columns

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        # A constant bias cannot follow an arbitrary regression target, by design.
        tags.regressor_tags.poor_score = True
        return tags

    def _fit_correction(self, X, correction):
        self.offset_ = correction.mean(axis=0)

    def _predict_correction(self, X):
        return np.broadcast_to(self.offset_, (X.shape[0], self.n_outputs_)).copy()

    def _build_realtime(self):
        return AffinePredictor(self._raw_selection(), self.offset_)

    def _fitted_arrays(self):
        return {"offset": self.offset_}

    def _restore_fitted_arrays(self, arrays):
        self.offset_ = arrays["offset"]
