"""Exact Gaussian-process regression with a squared-exponential ARD kernel, in numpy/scipy.

The kernel is ``k(a, b) = signal * exp(-sum_d (a_d - b_d)^2 / (2 length_d^2)) + noise * [a == b]``,
shared by all output columns (as scikit-learn does for multi-output targets). Hyper-parameters
maximize the log marginal likelihood with L-BFGS-B over their logarithms. The gradient with
respect to every length scale comes from one matrix product, ``M @ X`` with
``M = (alpha alpha^T - p K^-1) * K_signal``, instead of one n x n matrix per length scale, which
is what makes a 16-feature fit take seconds rather than minutes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg
import scipy.optimize

# Added to the kernel diagonal, relative to the signal variance, so the Cholesky factorization
# survives duplicated inputs when the noise variance is at its lower bound.
_JITTER = 1e-10


@dataclass(frozen=True)
class KernelParameters:
    """Hyper-parameters of the squared-exponential kernel (standardized units).

    Attributes
    ----------
    length_scale : ndarray, shape (n_features,)
    signal_variance : float
    noise_variance : float
    """

    length_scale: np.ndarray
    signal_variance: float
    noise_variance: float

    def to_log_vector(self) -> np.ndarray:
        return np.concatenate([np.log(self.length_scale),
                               [np.log(self.signal_variance), np.log(self.noise_variance)]])

    @classmethod
    def from_log_vector(cls, vector: np.ndarray) -> "KernelParameters":
        return cls(np.exp(vector[:-2]), float(np.exp(vector[-2])), float(np.exp(vector[-1])))


def squared_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pairwise squared Euclidean distances between the rows of a and b (clipped at 0)."""
    distances = (np.einsum("ij,ij->i", a, a)[:, None] + np.einsum("ij,ij->i", b, b)[None, :]
                 - 2.0 * a @ b.T)
    return np.maximum(distances, 0.0)


def signal_kernel(a: np.ndarray, b: np.ndarray, params: KernelParameters) -> np.ndarray:
    """Noise-free kernel matrix between the rows of a and b."""
    return params.signal_variance * np.exp(
        -0.5 * squared_distances(a / params.length_scale, b / params.length_scale))


def negative_log_likelihood(log_vector: np.ndarray, X: np.ndarray,
                            Y: np.ndarray) -> tuple[float, np.ndarray]:
    """Negative log marginal likelihood of targets Y (n, p) at inputs X, and its gradient.

    Parameters
    ----------
    log_vector : ndarray
        Logarithms of the length scales, the signal variance and the noise variance.
    """
    params = KernelParameters.from_log_vector(log_vector)
    n, p = Y.shape
    signal = signal_kernel(X, X, params)
    covariance = signal + (params.noise_variance + _JITTER * params.signal_variance) * np.eye(n)
    try:
        factor = scipy.linalg.cho_factor(covariance, lower=True, check_finite=False)
    except np.linalg.LinAlgError:
        return np.inf, np.zeros_like(log_vector)
    alpha = scipy.linalg.cho_solve(factor, Y, check_finite=False)
    log_det = 2.0 * np.sum(np.log(np.diag(factor[0])))
    value = 0.5 * np.sum(Y * alpha) + 0.5 * p * log_det + 0.5 * n * p * np.log(2.0 * np.pi)

    inverse = scipy.linalg.cho_solve(factor, np.eye(n), check_finite=False)
    weight = alpha @ alpha.T - p * inverse  # d(log likelihood) = 0.5 tr(weight dK)
    masked = weight * signal
    scaled = X / params.length_scale
    row_sums = masked.sum(axis=1)
    # tr(weight * dK/dlog l_d) = sum_ij masked_ij (s_id - s_jd)^2
    length_terms = 2.0 * (scaled**2).T @ row_sums - 2.0 * np.einsum(
        "id,id->d", scaled, masked @ scaled)
    gradient = -0.5 * np.concatenate([
        length_terms,
        [np.sum(masked), params.noise_variance * np.trace(weight)],
    ])
    return float(value), gradient


def optimize_kernel(X: np.ndarray, Y: np.ndarray, initial: KernelParameters,
                    length_bounds: tuple[float, float], noise_bounds: tuple[float, float],
                    max_iterations: int,
                    callback=None) -> tuple[KernelParameters, scipy.optimize.OptimizeResult]:
    """Maximize the log marginal likelihood from `initial` within the bounds.

    Parameters
    ----------
    callback : callable, optional
        ``callback(intermediate_result)`` after every L-BFGS-B iteration, with the current
        negative log-likelihood in ``intermediate_result.fun`` (for progress; it cannot change
        the result).

    Returns
    -------
    params : KernelParameters
        The optimum (`initial`, clipped to the bounds, if the optimizer found no finite value).
    result : scipy.optimize.OptimizeResult
        The optimizer's report (iterations, final negative log-likelihood, message).
    """
    n_features = X.shape[1]
    bounds = ([tuple(np.log(length_bounds))] * n_features
              + [(np.log(1e-3), np.log(1e3)), tuple(np.log(noise_bounds))])
    start = np.clip(initial.to_log_vector(), [b[0] for b in bounds], [b[1] for b in bounds])
    result = scipy.optimize.minimize(
        negative_log_likelihood, start, args=(X, Y), jac=True, method="L-BFGS-B",
        bounds=bounds, options={"maxiter": max_iterations}, callback=callback)
    best = result.x if np.isfinite(result.fun) else start
    return KernelParameters.from_log_vector(best), result


def solve_weights(X: np.ndarray, Y: np.ndarray, params: KernelParameters) -> np.ndarray:
    """Weights ``(K + noise I)^-1 Y`` of the posterior mean at the support points X."""
    covariance = signal_kernel(X, X, params)
    covariance[np.diag_indices_from(covariance)] += (params.noise_variance
                                                      + _JITTER * params.signal_variance)
    factor = scipy.linalg.cho_factor(covariance, lower=True, check_finite=False)
    return scipy.linalg.cho_solve(factor, Y, check_finite=False)
