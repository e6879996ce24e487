"""The scikit-learn skeleton every calibrator shares: validation, error mode, 1-D targets.

A calibrator maps one row of robot state X (any units, any robot) to corrected joint positions y.
With ``raw_columns`` set, columns of X hold the uncorrected joint positions that match y's
columns, and the model learns only the error ``y - X[:, raw_columns]`` (the paper's
recommended mode: faster convergence and better accuracy for networks). Without it the model
learns y end-to-end, so a default-constructed calibrator is an ordinary scikit-learn regressor.

Subclasses implement three hooks on the *correction* (the error in error mode, y otherwise):
`_fit_correction`, `_predict_correction` and `_build_realtime`, plus `_fitted_arrays` /
`_restore_fitted_arrays` for persistence, and `_min_samples`, the fewest rows their model can be
fitted on (a least-squares fit needs as many rows as it has parameters, a window model one full
window). Everything else, including input validation with scikit-learn's messages, lives here
once.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, RegressorMixin
from sklearn.utils.validation import check_is_fitted, validate_data

from estimators._validation import check_n_samples, resolve_raw_columns


class CalibratorBase(RegressorMixin, BaseEstimator):
    """Base class of the learned calibrators (not used directly).

    Attributes
    ----------
    n_features_in_ : int
        Number of columns of X seen in `fit`.
    feature_names_in_ : ndarray of str
        Column names of X, when X was a DataFrame with string column names.
    n_outputs_ : int
        Number of target columns (1 for a one-dimensional y).
    raw_columns_ : ndarray of int or None
        Validated `raw_columns`.
    """

    def fit(self, X, y):
        """Fit the calibrator.

        Parameters
        ----------
        X : array-like, shape (n_samples, n_features)
            Robot state, one row per sample, in the robot's units (SI recommended).
        y : array-like, shape (n_samples,) or (n_samples, n_targets)
            Ground-truth joint positions (or any regression target).

        Returns
        -------
        self
        """
        X, y = validate_data(self, X, y, multi_output=True, y_numeric=True, dtype=np.float64)
        self._check_params()
        targets = y.reshape(y.shape[0], -1)
        self.raw_columns_ = resolve_raw_columns(self.raw_columns, X.shape[1], targets.shape[1])
        check_n_samples(type(self).__name__, X.shape[0], *self._min_samples(X.shape[1]))
        self.n_outputs_ = targets.shape[1]
        self._y_is_1d = y.ndim == 1
        correction = targets if self.raw_columns_ is None else targets - X[:, self.raw_columns_]
        self._fit_correction(X, np.ascontiguousarray(correction))
        return self

    def predict(self, X):
        """Predict corrected joint positions.

        Parameters
        ----------
        X : array-like, shape (n_samples, n_features)

        Returns
        -------
        ndarray, shape (n_samples,) or (n_samples, n_targets)
            Same dimensionality as the y given to `fit`.
        """
        check_is_fitted(self)
        X = validate_data(self, X, reset=False, dtype=np.float64)
        prediction = self._predict_correction(X)
        if self.raw_columns_ is not None:
            prediction = prediction + X[:, self.raw_columns_]
        return prediction.ravel() if self._y_is_1d else prediction

    def to_realtime(self):
        """Export a dependency-light single-sample predictor.

        Returns
        -------
        callable
            ``f(x)`` with x a float64 array of shape (n_features,) in the units of `fit`,
            returning a new array of shape (n_targets,) equal to `predict` within 1e-6. It uses
            numpy only, has standardization folded into its weights and validates nothing (see
            `estimators.realtime`).
        """
        check_is_fitted(self)
        return self._build_realtime()

    def __sklearn_tags__(self):
        tags = super().__sklearn_tags__()
        tags.target_tags.multi_output = True
        tags.target_tags.single_output = True
        return tags

    def _set_fitted_layout(self, *, n_features_in: int, n_outputs: int, raw_columns,
                           y_is_1d: bool, feature_names_in=None) -> None:
        """Restore the shared fitted attributes (used when loading a saved calibrator)."""
        self.n_features_in_ = int(n_features_in)
        if feature_names_in is not None:
            self.feature_names_in_ = np.asarray(feature_names_in, dtype=object)
        self.n_outputs_ = int(n_outputs)
        self.raw_columns_ = resolve_raw_columns(raw_columns, self.n_features_in_, self.n_outputs_)
        self._y_is_1d = bool(y_is_1d)

    def _raw_selection(self) -> np.ndarray:
        """Matrix S (n_features, n_outputs) with ``x @ S == x[raw_columns_]`` (zero if None)."""
        selection = np.zeros((self.n_features_in_, self.n_outputs_))
        if self.raw_columns_ is not None:
            selection[self.raw_columns_, np.arange(self.n_outputs_)] = 1.0
        return selection

    def _check_params(self) -> None:
        """Validate hyper-parameters at fit time; subclasses extend."""

    def _min_samples(self, n_features: int) -> tuple[int, str]:
        """Fewest rows `fit` accepts for X with `n_features` columns, and why (a phrase that
        follows "needs at least N samples"). Called after `_check_params`."""
        return 1, "to estimate anything"

    def _fit_correction(self, X: np.ndarray, correction: np.ndarray) -> None:
        raise NotImplementedError

    def _predict_correction(self, X: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _build_realtime(self):
        """The real-time predictor of the full output (raw columns included)."""
        raise NotImplementedError

    def _fitted_arrays(self) -> dict[str, np.ndarray]:
        """Learned state specific to the subclass, as named arrays (for `persistence`)."""
        raise NotImplementedError

    def _restore_fitted_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of `_fitted_arrays`."""
        raise NotImplementedError
