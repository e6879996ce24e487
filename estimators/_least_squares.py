"""Affine least squares with an optional ridge penalty, shared by the regression calibrators."""

from __future__ import annotations

import numpy as np


def fit_affine(features: np.ndarray, targets: np.ndarray,
               alpha: float) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``min |features @ coef + intercept - targets|^2 + alpha |coef|^2``.

    The intercept is not penalized. Rank-deficient features (constant or duplicated columns)
    get the minimum-norm solution, so a constant column receives a zero coefficient.

    Parameters
    ----------
    features : ndarray, shape (n_samples, n_features)
    targets : ndarray, shape (n_samples, n_targets)
    alpha : float
        Ridge penalty, >= 0, in the units of the (usually standardized) features.

    Returns
    -------
    coef : ndarray, shape (n_features, n_targets)
    intercept : ndarray, shape (n_targets,)
    """
    feature_mean = features.mean(axis=0)
    target_mean = targets.mean(axis=0)
    design = features - feature_mean
    rhs = targets - target_mean
    if alpha > 0:
        n_features = features.shape[1]
        design = np.vstack([design, np.sqrt(alpha) * np.eye(n_features)])
        rhs = np.vstack([rhs, np.zeros((n_features, targets.shape[1]))])
    # numpy's cutoff (eps * max(n_samples, n_features) relative to the largest singular value)
    # removes the null space of constant monomials; scipy's default cutoff (eps) can miss it.
    coef = np.linalg.lstsq(design, rhs, rcond=None)[0]
    intercept = target_mean - feature_mean @ coef
    return coef, intercept


def least_squares_min_samples(n_parameters: int, alpha: float, parameters: str) -> tuple[int, str]:
    """Fewest rows a least-squares calibrator is fitted on, and why (see `CalibratorBase`).

    Without a penalty the fit of `n_parameters` per target (described by `parameters`, e.g.
    "16 weights and an intercept") is undetermined on fewer rows: the minimum-norm solution
    would be returned without a word. A ridge penalty (`alpha` > 0) determines it on any
    number of rows, but on a single row every feature is constant, so 2 are required.
    """
    if alpha > 0:
        return 2, "for a ridge fit (on one sample every feature is constant)"
    return n_parameters, (f"to determine its {n_parameters} parameters per target ({parameters}) "
                          "by least squares (with a ridge penalty alpha > 0: 2)")
