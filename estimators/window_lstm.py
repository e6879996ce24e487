"""LSTM calibrator over a temporal window of robot states (Hwang et al., RA-L 2020)."""

from __future__ import annotations

from estimators import _lstm as lstm
from estimators._network import NetworkCalibrator
from estimators._standardization import Standardizer
from estimators._validation import check_non_negative_float, check_positive_int
from estimators._windows import stack_windows
from estimators.realtime import LSTMPredictor


class WindowLSTMCalibrator(NetworkCalibrator):
    """One-layer LSTM run over the last `window` rows of X; its last output is the correction.

    Hwang et al. (2020) fed a dVRK's recent commanded joint positions (the current one and 4
    before it) to an LSTM (about 100 units) to predict the wrist joints' actual positions.
    Each window is processed from zero state, independently of the others.

    The rows of X must be consecutive samples of one recording in time order: row t is
    predicted from rows t - window + 1 ... t, and the first window - 1 rows are padded by
    repeating row 0 (see `estimators._windows`). Hence a prediction depends on the rows before
    it, and predicting a subset or a shuffled X changes it, by design. `to_realtime` returns a
    predictor that keeps the last `window` samples in a ring buffer (call its ``reset()`` at the
    start of a new recording). Inputs and targets are standardized inside; training runs in
    float64 on the CPU and is deterministic for a given `random_state` and thread count.

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y; the raw value of the
        current row is used (error mode).
    window : int, default=5
        Number of rows in the window, the current one included.
    hidden_size : int, default=100
        LSTM units.
    weight_l2 : float, default=0.0
        L2 penalty on the input, recurrent and output weights.
    learning_rate : float, default=1e-3
    beta_1, beta_2 : float, default=0.9, 0.999
        Adam's decay rates.
    batch_size : int, default=128
    max_epochs : int, default=30
        About Hwang et al.'s 1000 steps of 100 samples on their recordings of a few thousand
        samples.
    early_stopping : bool, default=False
        Hold out the last `validation_fraction` of the rows and keep the best epoch, stopping
        after `n_iter_no_change` epochs without an improvement of `tol`.
    validation_fraction : float, default=0.1
    n_iter_no_change : int, default=10
    tol : float, default=1e-4
    random_state : None, int, RandomState or Generator, default=None
    n_threads : int or None, default=None
        Torch threads during `fit` (None: torch's current setting); restored afterwards.
    verbose : int, default=0
        0: silent; 1: a line with the training loss (and validation loss), and the elapsed
        time, on stdout every 10 epochs and on the first and last one; 2 or more: every epoch.

    Attributes
    ----------
    weights_ : estimators._lstm.LSTMWeights
        Learned parameters (standardized units).
    x_mean_, x_scale_, target_mean_, target_scale_ : ndarray
        Standardization of inputs and of the learned correction;
        an input column that was constant in training has scale +inf and is ignored.
    loss_curve_, validation_loss_curve_ : ndarray
    n_epochs_, best_epoch_ : int
    """

    def __init__(self, *, raw_columns=None, window=5, hidden_size=100, weight_l2=0.0,
                 learning_rate=1e-3, beta_1=0.9, beta_2=0.999, batch_size=128, max_epochs=30,
                 early_stopping=False, validation_fraction=0.1, n_iter_no_change=10, tol=1e-4,
                 random_state=None, n_threads=None, verbose=0):
        super().__init__(
            raw_columns=raw_columns, learning_rate=learning_rate, beta_1=beta_1, beta_2=beta_2,
            batch_size=batch_size, max_epochs=max_epochs, early_stopping=early_stopping,
            validation_fraction=validation_fraction, n_iter_no_change=n_iter_no_change,
            tol=tol, random_state=random_state, n_threads=n_threads, verbose=verbose)
        self.window = window
        self.hidden_size = hidden_size
        self.weight_l2 = weight_l2

    def _check_params(self):
        check_positive_int(self.window, "window")
        check_positive_int(self.hidden_size, "hidden_size")
        check_non_negative_float(self.weight_l2, "weight_l2")
        super()._check_params()

    def _min_samples(self, n_features):
        needed, reason = super()._min_samples(n_features)
        window = int(self.window)
        if window >= needed:
            return window, f"for one full window of {window} rows"
        return needed, reason

    def _train_network(self, inputs, targets, rng):
        # torch is needed for training only: prediction and real-time export stay numpy-only.
        from estimators._torch_training import train_lstm

        initial = lstm.LSTMWeights.initial(inputs.shape[1], int(self.hidden_size),
                                           targets.shape[1], rng)
        result = train_lstm(stack_windows(inputs, int(self.window)), targets, initial,
                            float(self.weight_l2), self._training_settings(), rng,
                            self.n_threads)
        self.weights_ = result.state
        return result

    def _network_output(self, X):
        standardized = Standardizer(self.x_mean_, self.x_scale_).transform(X)
        return lstm.forward(stack_windows(standardized, int(self.window)), self.weights_)

    def _build_realtime(self):
        w = self.weights_
        return LSTMPredictor(
            input_weight=w.input_weight / self.x_scale_[:, None],
            recurrent_weight=w.recurrent_weight,
            gate_bias=w.gate_bias - (self.x_mean_ / self.x_scale_) @ w.input_weight,
            out_weight=w.out_weight * self.target_scale_,
            out_bias=w.out_bias * self.target_scale_ + self.target_mean_,
            window=int(self.window),
            raw_index=self.raw_columns_,
        )

    def _network_arrays(self):
        return {f"lstm.{name}": value for name, value in self.weights_.arrays().items()}

    def _restore_network_arrays(self, arrays):
        self.weights_ = lstm.LSTMWeights(
            **{name[5:]: value for name, value in arrays.items() if name.startswith("lstm.")})
