"""Two-phase calibrator after Seita et al. (ICRA 2018): a network, then a forest on its residual."""

from __future__ import annotations

import time

import numpy as np
from sklearn.base import clone
from sklearn.ensemble import RandomForestRegressor

from estimators._base import CalibratorBase
from estimators.dnn import DNNCalibrator
from estimators._forest import FlatForest
from estimators._randomness import make_generator
from estimators.realtime import ForestPredictor, SumPredictor
from estimators._validation import check_positive_int, check_verbose

_SEED_LIMIT = np.iinfo(np.int32).max


class TwoPhaseCalibrator(CalibratorBase):
    """Coarse network correction refined by a random forest fitted to the network's residual.

    Seita et al. (2018) calibrated a cable-driven da Vinci with a deep network (phase 1) and a
    random forest that learned what the network still got wrong (phase 2). Here phase 1 is a
    `DNNCalibrator` trained on the correction (the error in error mode), phase 2 a
    scikit-learn `RandomForestRegressor` trained on the raw X against the phase-1 residual of
    the training data. The forest is kept as flat numpy arrays (`estimators._forest`).

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y (error mode).
    dnn : DNNCalibrator or None, default=None
        Template of the phase-1 network (None: the paper's network, ``DNNCalibrator()``). It
        is cloned; its `raw_columns` must be None (this calibrator handles them) and its
        `random_state` is replaced by one drawn from `random_state`.
    n_estimators : int, default=100
        Trees of the phase-2 forest.
    max_depth : int or None, default=None
    min_samples_leaf : int, default=5
        Smallest number of training samples in a leaf; the default (not scikit-learn's 1)
        keeps the forest from memorizing the residual's noise.
    max_features : float, default=1.0
        Fraction of the features tried at each split.
    random_state : None, int, RandomState or Generator, default=None
        Seeds both phases.
    n_jobs : int or None, default=None
        Parallel jobs of the forest fit (scikit-learn's convention).
    verbose : int, default=0
        0: silent; 1 or more: one line on stdout at the end of each phase (elapsed time, and
        the RMS of the phase-1 residual the forest learns), and the phase-1 network trains
        with at least this `verbose` (its progress lines). It does not change the result.

    Attributes
    ----------
    dnn_ : DNNCalibrator
        Fitted phase-1 network (end-to-end on the correction).
    forest_ : FlatForest
        Fitted phase-2 forest on the phase-1 residual.
    """

    def __init__(self, *, raw_columns=None, dnn=None, n_estimators=100, max_depth=None,
                 min_samples_leaf=5, max_features=1.0, random_state=None, n_jobs=None,
                 verbose=0):
        self.raw_columns = raw_columns
        self.dnn = dnn
        self.n_estimators = n_estimators
        self.max_depth = max_depth
        self.min_samples_leaf = min_samples_leaf
        self.max_features = max_features
        self.random_state = random_state
        self.n_jobs = n_jobs
        self.verbose = verbose

    def _check_params(self):
        if self.dnn is not None:
            if not isinstance(self.dnn, DNNCalibrator):
                raise TypeError(f"dnn must be a DNNCalibrator or None; got {self.dnn!r}.")
            if self.dnn.raw_columns is not None:
                raise ValueError(
                    "dnn.raw_columns must be None: set raw_columns on the TwoPhaseCalibrator, "
                    "which passes the correction to its network.")
        check_positive_int(self.n_estimators, "n_estimators")
        check_positive_int(self.min_samples_leaf, "min_samples_leaf")
        if self.max_depth is not None:
            check_positive_int(self.max_depth, "max_depth")
        check_verbose(self.verbose)

    def _min_samples(self, n_features):
        network = self._network_template()
        network._check_params()
        return network._min_samples(n_features)

    def _fit_correction(self, X, correction):
        rng = make_generator(self.random_state)
        template = self._network_template()
        verbose, start = check_verbose(self.verbose), time.perf_counter()
        dnn = clone(template).set_params(random_state=int(rng.integers(_SEED_LIMIT)))
        if verbose > check_verbose(dnn.verbose):
            dnn.set_params(verbose=verbose)
        dnn.fit(X, correction)
        residual = correction - dnn.predict(X)
        if verbose:
            rms = ", ".join(f"{value:.6g}" for value in np.sqrt(np.mean(residual**2, axis=0)))
            print(f"Phase 1: network trained in {time.perf_counter() - start:.1f} s; RMS of its "
                  f"residual per output, in the units of y: {rms}", flush=True)
        forest = RandomForestRegressor(
            n_estimators=int(self.n_estimators), max_depth=self.max_depth,
            min_samples_leaf=int(self.min_samples_leaf), max_features=self.max_features,
            random_state=int(rng.integers(_SEED_LIMIT)), n_jobs=self.n_jobs)
        # a single-output forest expects a 1-D target (a column would warn)
        forest.fit(X, residual[:, 0] if residual.shape[1] == 1 else residual)
        if verbose:
            print(f"Phase 2: forest of {forest.n_estimators} trees fitted, elapsed "
                  f"{time.perf_counter() - start:.1f} s", flush=True)
        self.dnn_ = dnn
        self.forest_ = FlatForest.from_sklearn(forest)

    def _network_template(self) -> DNNCalibrator:
        """The phase-1 network as configured (not fitted, not to be modified)."""
        return DNNCalibrator() if self.dnn is None else self.dnn

    def _predict_correction(self, X):
        return self.dnn_.predict(X) + self.forest_.predict(X)

    def _build_realtime(self):
        network = self.dnn_.network_predictor(self.raw_columns_)
        return SumPredictor([network, ForestPredictor(self.forest_)])

    def _fitted_arrays(self):
        arrays = {f"dnn.{name}": value for name, value in self.dnn_._fitted_arrays().items()}
        arrays.update({f"forest.{name}": value for name, value in self.forest_.arrays().items()})
        return arrays

    def _restore_fitted_arrays(self, arrays):
        dnn = clone(self._network_template())
        dnn._set_fitted_layout(n_features_in=self.n_features_in_, n_outputs=self.n_outputs_,
                               raw_columns=None, y_is_1d=False)
        dnn._restore_fitted_arrays(
            {name[4:]: value for name, value in arrays.items() if name.startswith("dnn.")})
        self.dnn_ = dnn
        self.forest_ = FlatForest.from_arrays(
            {name[7:]: value for name, value in arrays.items() if name.startswith("forest.")})

