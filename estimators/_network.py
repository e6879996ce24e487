"""The base class of the network calibrators: their training hyper-parameters, checks and state.

`DNNCalibrator` and `WindowLSTMCalibrator` are trained the same way (Adam on mini-batches of
standardized data, optional early stopping on the last rows, seeded, on a given number of torch
threads), so those hyper-parameters, their validation, the standardization, the training
history and its saved form live here once, as scikit-learn's `BaseMultilayerPerceptron` does for
its two networks. A subclass supplies its network: initial weights and training
(`_train_network`), forward pass (`_network_output`) and its learned arrays.

Training runs in torch (`estimators._torch_training`), imported only inside `fit`: prediction,
saving and real-time export need numpy only.
"""

from __future__ import annotations

import numpy as np

from estimators._base import CalibratorBase
from estimators._randomness import make_generator
from estimators._standardization import Standardizer
from estimators._validation import (
    check_n_threads,
    check_non_negative_float,
    check_open_interval,
    check_positive_int,
    check_verbose,
)


class NetworkCalibrator(CalibratorBase):
    """Base class of the torch-trained calibrators (not used directly).

    The hyper-parameters it holds (`raw_columns`, `learning_rate`, `beta_1`, `beta_2`,
    `batch_size`, `max_epochs`, `early_stopping`, `validation_fraction`, `n_iter_no_change`,
    `tol`, `random_state`, `n_threads`, `verbose`) and the fitted attributes it sets (the
    standardization `x_mean_`, `x_scale_`, `target_mean_`, `target_scale_` and the history
    `loss_curve_`, `validation_loss_curve_`, `n_epochs_`, `best_epoch_`) are documented on
    each network calibrator. Progress (`verbose`) is printed by `estimators._torch_training`
    and changes no result.
    """

    def __init__(self, *, raw_columns, learning_rate, beta_1, beta_2, batch_size, max_epochs,
                 early_stopping, validation_fraction, n_iter_no_change, tol, random_state,
                 n_threads, verbose):
        self.raw_columns = raw_columns
        self.learning_rate = learning_rate
        self.beta_1 = beta_1
        self.beta_2 = beta_2
        self.batch_size = batch_size
        self.max_epochs = max_epochs
        self.early_stopping = early_stopping
        self.validation_fraction = validation_fraction
        self.n_iter_no_change = n_iter_no_change
        self.tol = tol
        self.random_state = random_state
        self.n_threads = n_threads
        self.verbose = verbose

    def _check_params(self):
        check_open_interval(self.learning_rate, "learning_rate", 0.0, np.inf)
        check_open_interval(self.beta_1, "beta_1", 0.0, 1.0)
        check_open_interval(self.beta_2, "beta_2", 0.0, 1.0)
        check_positive_int(self.batch_size, "batch_size")
        check_positive_int(self.max_epochs, "max_epochs")
        check_open_interval(self.validation_fraction, "validation_fraction", 0.0, 1.0)
        check_positive_int(self.n_iter_no_change, "n_iter_no_change")
        check_non_negative_float(self.tol, "tol")
        check_n_threads(self.n_threads)
        check_verbose(self.verbose)

    def _min_samples(self, n_features):
        stopping = self._training_settings().early_stopping
        if stopping is None:
            return 2, "to train a network (on one sample every feature is constant)"
        return stopping.min_samples(), (
            f"to hold out validation_fraction={stopping.validation_fraction} of them for early "
            "stopping and train on the rest")

    def _training_settings(self):
        """The optimizer settings handed to the torch trainer."""
        from estimators._torch_training import EarlyStopping, TrainingSettings

        stopping = (EarlyStopping(float(self.validation_fraction), int(self.n_iter_no_change),
                                  float(self.tol)) if self.early_stopping else None)
        return TrainingSettings(
            learning_rate=float(self.learning_rate), beta_1=float(self.beta_1),
            beta_2=float(self.beta_2), batch_size=int(self.batch_size),
            max_epochs=int(self.max_epochs), early_stopping=stopping,
            verbose=int(self.verbose))

    def _fit_correction(self, X, correction):
        x_scaler, target_scaler = Standardizer.fit_inputs(X), Standardizer.fit_targets(correction)
        rng = make_generator(self.random_state)
        result = self._train_network(x_scaler.transform(X), target_scaler.transform(correction),
                                     rng)
        self.x_mean_, self.x_scale_ = x_scaler.mean, x_scaler.scale
        self.target_mean_, self.target_scale_ = target_scaler.mean, target_scaler.scale
        self.loss_curve_ = result.loss_curve
        self.validation_loss_curve_ = result.validation_curve
        self.n_epochs_ = len(result.loss_curve)
        self.best_epoch_ = result.best_epoch

    def _predict_correction(self, X):
        return self._network_output(X) * self.target_scale_ + self.target_mean_

    def _fitted_arrays(self):
        arrays = self._network_arrays()
        arrays.update(x_mean=self.x_mean_, x_scale=self.x_scale_,
                      target_mean=self.target_mean_, target_scale=self.target_scale_,
                      loss_curve=self.loss_curve_,
                      validation_loss_curve=self.validation_loss_curve_,
                      best_epoch=np.asarray(self.best_epoch_))
        return arrays

    def _restore_fitted_arrays(self, arrays):
        self._restore_network_arrays(arrays)
        self.x_mean_, self.x_scale_ = arrays["x_mean"], arrays["x_scale"]
        self.target_mean_, self.target_scale_ = arrays["target_mean"], arrays["target_scale"]
        self.loss_curve_ = arrays["loss_curve"]
        self.validation_loss_curve_ = arrays["validation_loss_curve"]
        self.n_epochs_ = len(self.loss_curve_)
        self.best_epoch_ = int(arrays["best_epoch"])

    def _train_network(self, inputs: np.ndarray, targets: np.ndarray, rng: np.random.Generator):
        """Draw the initial weights from `rng`, train on standardized inputs and targets, keep
        the learned weights; return the `estimators._torch_training.TrainingResult`."""
        raise NotImplementedError

    def _network_output(self, X: np.ndarray) -> np.ndarray:
        """Standardized correction predicted for raw inputs X."""
        raise NotImplementedError

    def _network_arrays(self) -> dict[str, np.ndarray]:
        """The learned weights as named arrays (for `persistence`)."""
        raise NotImplementedError

    def _restore_network_arrays(self, arrays: dict[str, np.ndarray]) -> None:
        """Inverse of `_network_arrays` (`arrays` may hold other entries too)."""
        raise NotImplementedError
