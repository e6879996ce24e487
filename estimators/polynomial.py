"""Polynomial regression calibrator (the paper's 2nd-order model)."""

from __future__ import annotations

import math

from estimators._base import CalibratorBase
from estimators._least_squares import fit_affine, least_squares_min_samples
from estimators._monomials import MonomialPlan
from estimators.realtime import MonomialPredictor
from estimators._standardization import Standardizer
from estimators._validation import check_non_negative_float, check_positive_int


class PolynomialCalibrator(CalibratorBase):
    """Least squares on all monomials of the standardized features up to `degree`.

    The paper's 2nd-order model: with 16 features it has 152 monomials (+1 intercept) per joint
    and, on short calibration recordings, overfits and varies strongly between recordings; use
    `alpha` to regularize.

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y (error mode).
    degree : int, default=2
        Highest total degree of the monomials.
    alpha : float, default=0.0
        Ridge penalty on the monomial coefficients (standardized features).

    Attributes
    ----------
    coef_ : ndarray, shape (n_monomials, n_outputs)
        Coefficients of the monomials of the standardized features, ordered as
        `monomial_terms_`.
    intercept_ : ndarray, shape (n_outputs,)
    monomial_terms_ : tuple of tuple of int
        Feature indices multiplied in each monomial.
    x_mean_, x_scale_ : ndarray, shape (n_features,)
        Standardization of the inputs;
        an input column that was constant in training has scale +inf and is ignored.
    """

    def __init__(self, *, raw_columns=None, degree=2, alpha=0.0):
        self.raw_columns = raw_columns
        self.degree = degree
        self.alpha = alpha

    def _check_params(self):
        check_positive_int(self.degree, "degree")
        check_non_negative_float(self.alpha, "alpha")

    def _min_samples(self, n_features):
        degree = int(self.degree)
        n_monomials = math.comb(n_features + degree, degree) - 1
        return least_squares_min_samples(
            n_monomials + 1, float(self.alpha),
            f"{n_monomials} monomials of degree 1 to {degree} of {n_features} features, and an "
            "intercept")

    def _plan(self) -> MonomialPlan:
        return MonomialPlan.build(self.n_features_in_, int(self.degree))

    def _fit_correction(self, X, correction):
        scaler = Standardizer.fit_inputs(X)
        plan = self._plan()
        self.coef_, self.intercept_ = fit_affine(
            plan.evaluate(scaler.transform(X)), correction, float(self.alpha))
        self.x_mean_, self.x_scale_ = scaler.mean, scaler.scale
        self.monomial_terms_ = plan.terms

    def _predict_correction(self, X):
        standardized = Standardizer(self.x_mean_, self.x_scale_).transform(X)
        return self._plan().evaluate(standardized) @ self.coef_ + self.intercept_

    def _build_realtime(self):
        plan = self._plan()
        coef, intercept = plan.reexpand(self.coef_, self.intercept_, 1.0 / self.x_scale_,
                                        -self.x_mean_ / self.x_scale_)
        coef[: self.n_features_in_] += self._raw_selection()
        return MonomialPredictor(plan.parents, plan.factors, coef, intercept)

    def _fitted_arrays(self):
        return {"coef": self.coef_, "intercept": self.intercept_, "x_mean": self.x_mean_,
                "x_scale": self.x_scale_}

    def _restore_fitted_arrays(self, arrays):
        self.coef_ = arrays["coef"]
        self.intercept_ = arrays["intercept"]
        self.x_mean_ = arrays["x_mean"]
        self.x_scale_ = arrays["x_scale"]
        self.monomial_terms_ = self._plan().terms
