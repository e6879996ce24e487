"""The paper's deep neural network calibrator (torch training, numpy inference)."""

from __future__ import annotations

from sklearn.utils.validation import check_is_fitted

from estimators import _mlp as mlp
from estimators._network import NetworkCalibrator
from estimators._standardization import Standardizer
from estimators._validation import check_choice, check_layer_sizes, check_non_negative_float
from estimators.realtime import MLPPredictor

# The paper's larger network for the 138 "all features" input (3 hidden layers).
LARGE_HIDDEN_LAYER_SIZES = (600, 500, 400)

# The paper applied kernel L1 and L2, bias L2 and activity L2 to the larger network, but their
# values are lost from the available text. Chosen here: the usual Keras orders of magnitude, set
# so that at Glorot initialization each penalty stays well below the data loss of standardized
# targets (~1) although the network has ~48x more weights than the small one (585k vs 12k).
LARGE_REGULARIZATION = {
    "kernel_l1": 1e-6,
    "kernel_l2": 1e-5,
    "bias_l2": 1e-5,
    "activity_l2": 1e-6,
}


class DNNCalibrator(NetworkCalibrator):
    """Fully connected network from robot state to joint correction.

    Defaults are the paper's network: 2 hidden layers of 100 sigmoid units, mean squared error,
    L2 of 5e-4 on the weights (Keras convention: ``5e-4 * sum(W**2)`` per layer added to the
    batch loss), Adam with learning rate 1e-3 and betas 0.9/0.999, batches of 1024 and 200
    epochs. `large` gives the paper's 600-500-400 network. Inputs and targets (the error, in
    error mode) are standardized inside, constant columns included; the network trains and
    predicts in float64 on the CPU. Training is deterministic for a given `random_state` and
    thread count, and touches no global random state.

    Parameters
    ----------
    raw_columns : None, int or sequence of int, default=None
        Columns of X holding the uncorrected value of each column of y. Setting it (error mode)
        is the paper's recommendation for networks: better accuracy, fewer epochs.
    hidden_layer_sizes : tuple of int, default=(100, 100)
        Width of each hidden layer.
    activation : {"sigmoid", "tanh", "relu"}, default="sigmoid"
    kernel_l2 : float, default=5e-4
        L2 penalty on the weights of every layer.
    kernel_l1 : float, default=0.0
        L1 penalty on the weights of every layer.
    bias_l2 : float, default=0.0
        L2 penalty on the biases of every layer.
    activity_l2 : float, default=0.0
        L2 penalty on the hidden-unit outputs, averaged over the batch.
    learning_rate : float, default=1e-3
    beta_1, beta_2 : float, default=0.9, 0.999
        Adam's exponential decay rates of the first and second moment estimates.
    batch_size : int, default=1024
    max_epochs : int, default=200
        Epochs to train (all of them unless early stopping ends training sooner).
    early_stopping : bool, default=False
        Hold out the last `validation_fraction` of the rows (in the given order), stop when
        their loss has not improved by `tol` for `n_iter_no_change` epochs, and keep the best
        epoch's weights. Off by default: the paper trained a fixed 200 epochs.
    validation_fraction : float, default=0.1
    n_iter_no_change : int, default=10
    tol : float, default=1e-4
        Improvement of the validation mean squared error (standardized targets) that counts.
    random_state : None, int, RandomState or Generator, default=None
        Seeds the initial weights and the batch order.
    n_threads : int or None, default=None
        Torch threads during `fit` (None: torch's current setting); restored afterwards.
    verbose : int, default=0
        0: silent; 1: a line with the training loss (and validation loss), and the elapsed
        time, on stdout every 10 epochs and on the first and last one; 2 or more: every epoch.

    Attributes
    ----------
    coefs_, intercepts_ : list of ndarray
        Layer weights (n_in, n_out) and biases, in standardized units.
    x_mean_, x_scale_ : ndarray, shape (n_features,)
        Input standardization;
        an input column that was constant in training has scale +inf and is ignored.
    target_mean_, target_scale_ : ndarray, shape (n_outputs,)
        Standardization of the learned correction.
    loss_curve_ : ndarray, shape (n_epochs_,)
        Training mean squared error per epoch (standardized targets).
    validation_loss_curve_ : ndarray
        Validation mean squared error per epoch (empty without early stopping).
    n_epochs_ : int
        Epochs run.
    best_epoch_ : int
        Epoch whose weights were kept.
    """

    def __init__(self, *, raw_columns=None, hidden_layer_sizes=(100, 100), activation="sigmoid",
                 kernel_l2=5e-4, kernel_l1=0.0, bias_l2=0.0, activity_l2=0.0,
                 learning_rate=1e-3, beta_1=0.9, beta_2=0.999, batch_size=1024, max_epochs=200,
                 early_stopping=False, validation_fraction=0.1, n_iter_no_change=10, tol=1e-4,
                 random_state=None, n_threads=None, verbose=0):
        super().__init__(
            raw_columns=raw_columns, learning_rate=learning_rate, beta_1=beta_1, beta_2=beta_2,
            batch_size=batch_size, max_epochs=max_epochs, early_stopping=early_stopping,
            validation_fraction=validation_fraction, n_iter_no_change=n_iter_no_change,
            tol=tol, random_state=random_state, n_threads=n_threads, verbose=verbose)
        self.hidden_layer_sizes = hidden_layer_sizes
        self.activation = activation
        self.kernel_l2 = kernel_l2
        self.kernel_l1 = kernel_l1
        self.bias_l2 = bias_l2
        self.activity_l2 = activity_l2

    @classmethod
    def large(cls, **overrides) -> "DNNCalibrator":
        """The paper's larger network: 600-500-400 sigmoid units with kernel L1/L2, bias L2 and
        activity L2 (values in `LARGE_REGULARIZATION`, chosen here). Keyword arguments override
        any parameter."""
        params = {"hidden_layer_sizes": LARGE_HIDDEN_LAYER_SIZES, **LARGE_REGULARIZATION}
        params.update(overrides)
        return cls(**params)

    def _check_params(self):
        check_layer_sizes(self.hidden_layer_sizes, "hidden_layer_sizes")
        check_choice(self.activation, "activation", mlp.ACTIVATIONS)
        for name in ("kernel_l2", "kernel_l1", "bias_l2", "activity_l2"):
            check_non_negative_float(getattr(self, name), name)
        super()._check_params()

    def _train_network(self, inputs, targets, rng):
        # torch is needed for training only: prediction and real-time export stay numpy-only.
        from estimators._torch_training import MLPSettings, train_mlp

        sizes = (inputs.shape[1], *check_layer_sizes(self.hidden_layer_sizes,
                                                     "hidden_layer_sizes"), targets.shape[1])
        weights, biases = mlp.glorot_uniform(sizes, rng)
        network = MLPSettings(
            activation=self.activation, kernel_l2=float(self.kernel_l2),
            kernel_l1=float(self.kernel_l1), bias_l2=float(self.bias_l2),
            activity_l2=float(self.activity_l2))
        result = train_mlp(inputs, targets, weights, biases, network, self._training_settings(),
                           rng, self.n_threads)
        weights, biases = result.state
        self.coefs_, self.intercepts_ = list(weights), list(biases)
        return result

    def _network_output(self, X):
        return mlp.forward((X - self.x_mean_) / self.x_scale_, self.coefs_, self.intercepts_,
                           self.activation)

    def _build_realtime(self):
        return self.network_predictor(self.raw_columns_)

    def network_predictor(self, raw_index) -> MLPPredictor:
        """Real-time form of the fitted network, adding ``x[raw_index]`` (None: nothing)."""
        check_is_fitted(self)
        weights, biases = fold_standardization(
            self.coefs_, self.intercepts_, Standardizer(self.x_mean_, self.x_scale_),
            Standardizer(self.target_mean_, self.target_scale_))
        if self.activation == "sigmoid":
            return MLPPredictor.from_sigmoid_network(weights, biases, raw_index)
        return MLPPredictor(weights, biases, self.activation, raw_index)

    def _network_arrays(self):
        arrays = {f"coef.{i}": w for i, w in enumerate(self.coefs_)}
        arrays.update({f"intercept.{i}": b for i, b in enumerate(self.intercepts_)})
        return arrays

    def _restore_network_arrays(self, arrays):
        n_layers = sum(name.startswith("coef.") for name in arrays)
        self.coefs_ = [arrays[f"coef.{i}"] for i in range(n_layers)]
        self.intercepts_ = [arrays[f"intercept.{i}"] for i in range(n_layers)]


def fold_standardization(weights, biases, inputs: Standardizer, outputs: Standardizer):
    """Rewrite a network on standardized data as one on raw data.

    The first layer absorbs ``z = (x - mean) / scale``; the linear output layer absorbs
    ``y = t * scale + mean``. Returns new lists; the inputs are not modified.
    """
    weights, biases = list(weights), list(biases)
    first = weights[0]
    weights[0] = first / inputs.scale[:, None]
    biases[0] = biases[0] - (inputs.mean / inputs.scale) @ first
    weights[-1] = weights[-1] * outputs.scale
    biases[-1] = biases[-1] * outputs.scale + outputs.mean
    return weights, biases
