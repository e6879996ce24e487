"""Gaussian-process calibrator after Mahler et al. (CASE 2014)."""

from __future__ import annotations

import time

import numpy as np
from threadpoolctl import threadpool_limits

from estimators import _gaussian_process as gp
from estimators._base import CalibratorBase
from estimators._randomness import make_generator
from estimators.realtime import KernelPredictor
from estimators._standardization import Standardizer
from estimators._validation import (
    check_bounds,
    check_n_threads,
    check_positive_int,
    check_verbose,
)


class GPRCalibrator(CalibratorBase):
    """Gaussian-process regression of the joint correction on a random subset of the data.

    Mahler et al. (2014) calibrated RAVEN-II with Gaussian-process regression and found joint
    velocities an important input (add them as columns of X). Exact GP regression costs
    O(n^3), so this calibrator uses the subset-of-data approximation: the posterior mean is
    computed from `subset_size` samples drawn without replacement, and the kernel
    hyper-parameters are fitted by maximum marginal likelihood on the first
    `hyperparameter_subset_size` of them. With the defaults, 30k samples train in seconds.

    The kernel is squared-exponential with one length scale per standardized feature (ARD),
    plus white noise, shared by all outputs; targets are standardized per column. Constant
    features standardize to 0 and do not affect the kernel.

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y (error mode).
    subset_size : int, default=2000
        Number of support points of the posterior mean (all samples if fewer).
    hyperparameter_subset_size : int, default=500
        Number of those points used to fit the kernel hyper-parameters.
    length_scale_bounds : (float, float), default=(1e-2, 1e3)
        Bounds of the length scales, in standard deviations of each feature.
    noise_level_bounds : (float, float), default=(1e-6, 1.0)
        Bounds of the noise variance, in variances of the standardized targets.
    max_optimizer_iterations : int, default=200
        L-BFGS-B iterations of the hyper-parameter fit.
    random_state : None, int, RandomState or Generator, default=None
        Seeds the choice of the subset.
    n_threads : int or None, default=None
        BLAS threads during `fit` (None: the current setting). On a CPU shared with other
        busy processes, 1 avoids threads waiting on each other.
    verbose : int, default=0
        0: silent; 1: on stdout, one line when the hyper-parameter optimization ends (its
        iterations, final negative log marginal likelihood and elapsed time) and one when the
        posterior weights are solved; 2 or more: also one line per L-BFGS-B iteration. There is
        a single optimizer run (no restarts). It does not change the result.

    Attributes
    ----------
    support_ : ndarray, shape (n_support, n_features)
        Standardized support points.
    dual_coef_ : ndarray, shape (n_support, n_outputs)
        Posterior-mean weights of the support points (standardized targets).
    length_scale_ : ndarray, shape (n_features,)
    signal_variance_, noise_variance_ : float
    x_mean_, x_scale_, target_mean_, target_scale_ : ndarray
        Standardization of inputs and of the learned correction;
        an input column that was constant in training has scale +inf and is ignored.
    """

    def __init__(self, *, raw_columns=None, subset_size=2000, hyperparameter_subset_size=500,
                 length_scale_bounds=(1e-2, 1e3), noise_level_bounds=(1e-6, 1.0),
                 max_optimizer_iterations=200, random_state=None, n_threads=None, verbose=0):
        self.raw_columns = raw_columns
        self.subset_size = subset_size
        self.hyperparameter_subset_size = hyperparameter_subset_size
        self.length_scale_bounds = length_scale_bounds
        self.noise_level_bounds = noise_level_bounds
        self.max_optimizer_iterations = max_optimizer_iterations
        self.random_state = random_state
        self.n_threads = n_threads
        self.verbose = verbose

    def _check_params(self):
        check_positive_int(self.subset_size, "subset_size")
        check_positive_int(self.hyperparameter_subset_size, "hyperparameter_subset_size")
        check_bounds(self.length_scale_bounds, "length_scale_bounds")
        check_bounds(self.noise_level_bounds, "noise_level_bounds")
        check_positive_int(self.max_optimizer_iterations, "max_optimizer_iterations")
        check_n_threads(self.n_threads)
        check_verbose(self.verbose)

    def _min_samples(self, n_features):
        return 2, "to fit a Gaussian process (on one sample every feature is constant)"

    def _fit_correction(self, X, correction):
        with threadpool_limits(limits=self.n_threads, user_api="blas"):
            self._fit_subset(X, correction)

    def _fit_subset(self, X, correction):
        x_scaler, target_scaler = Standardizer.fit_inputs(X), Standardizer.fit_targets(correction)
        rng = make_generator(self.random_state)
        n_support = min(int(self.subset_size), X.shape[0])
        chosen = rng.choice(X.shape[0], size=n_support, replace=False)
        support = x_scaler.transform(X[chosen])
        targets = target_scaler.transform(correction[chosen])
        n_hyper = min(int(self.hyperparameter_subset_size), n_support)
        initial = gp.KernelParameters(
            length_scale=np.full(X.shape[1], np.sqrt(X.shape[1])), signal_variance=1.0,
            noise_variance=0.1)
        verbose, start = check_verbose(self.verbose), time.perf_counter()
        params, report = gp.optimize_kernel(
            support[:n_hyper], targets[:n_hyper], initial,
            check_bounds(self.length_scale_bounds, "length_scale_bounds"),
            check_bounds(self.noise_level_bounds, "noise_level_bounds"),
            int(self.max_optimizer_iterations),
            callback=_IterationPrinter(start) if verbose >= 2 else None)
        if verbose:
            print(f"GPR kernel fit on {n_hyper} points: {report.nit} L-BFGS-B iterations, "
                  f"negative log-likelihood = {report.fun:.6f}, "
                  f"elapsed {time.perf_counter() - start:.1f} s", flush=True)
        self.support_ = support
        self.dual_coef_ = gp.solve_weights(support, targets, params)
        if verbose:
            print(f"GPR posterior weights on {n_support} support points, "
                  f"elapsed {time.perf_counter() - start:.1f} s", flush=True)
        self.length_scale_ = params.length_scale
        self.signal_variance_ = params.signal_variance
        self.noise_variance_ = params.noise_variance
        self.x_mean_, self.x_scale_ = x_scaler.mean, x_scaler.scale
        self.target_mean_, self.target_scale_ = target_scaler.mean, target_scaler.scale

    def _kernel_parameters(self) -> gp.KernelParameters:
        return gp.KernelParameters(self.length_scale_, self.signal_variance_,
                                   self.noise_variance_)

    def _predict_correction(self, X):
        standardized = Standardizer(self.x_mean_, self.x_scale_).transform(X)
        kernel = gp.signal_kernel(standardized, self.support_, self._kernel_parameters())
        return (kernel @ self.dual_coef_) * self.target_scale_ + self.target_mean_

    def _build_realtime(self):
        inverse_length = 1.0 / (self.length_scale_ * self.x_scale_)
        # (support * scale + mean) / (length * scale), finite for constant columns (scale inf)
        scaled_points = self.support_ / self.length_scale_ + self.x_mean_ * inverse_length
        return KernelPredictor(
            scaled_points=scaled_points,
            inverse_length=inverse_length,
            weight=self.signal_variance_ * self.dual_coef_ * self.target_scale_,
            bias=self.target_mean_,
            raw_index=self.raw_columns_,
        )

    def _fitted_arrays(self):
        return {"support": self.support_, "dual_coef": self.dual_coef_,
                "length_scale": self.length_scale_,
                "signal_variance": np.asarray(self.signal_variance_),
                "noise_variance": np.asarray(self.noise_variance_),
                "x_mean": self.x_mean_, "x_scale": self.x_scale_,
                "target_mean": self.target_mean_, "target_scale": self.target_scale_}

    def _restore_fitted_arrays(self, arrays):
        self.support_ = arrays["support"]
        self.dual_coef_ = arrays["dual_coef"]
        self.length_scale_ = arrays["length_scale"]
        self.signal_variance_ = float(arrays["signal_variance"])
        self.noise_variance_ = float(arrays["noise_variance"])
        self.x_mean_, self.x_scale_ = arrays["x_mean"], arrays["x_scale"]
        self.target_mean_, self.target_scale_ = arrays["target_mean"], arrays["target_scale"]


class _IterationPrinter:
    """L-BFGS-B callback printing each iteration's negative log-likelihood (verbose >= 2)."""

    def __init__(self, start: float):
        self.start, self.iteration = start, 0

    def __call__(self, intermediate_result):
        self.iteration += 1
        print(f"GPR kernel fit iteration {self.iteration}, negative log-likelihood = "
              f"{intermediate_result.fun:.6f}, elapsed {time.perf_counter() - self.start:.1f} s",
              flush=True)
