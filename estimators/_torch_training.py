"""Training of the network calibrators in torch, float64, on the CPU.

One trainer serves both networks: `train` splits off the held-out rows, limits torch's threads
and runs `run_epochs` (shuffled mini-batches, early stopping, loss history, progress lines) on a
*trainee*, an object that takes one optimizer step on a batch of rows. Two trainees exist:

- `_MLPTrainee`, the fully connected network of `DNNCalibrator`. The paper's network is small
  (16-100-100-3) and its batch large (1024), so a training step is a few matrix products;
  autograd bookkeeping and per-step allocations would cost as much as the arithmetic. It
  therefore writes the backward pass by hand on preallocated full-batch tensors and uses torch
  only for the matrix products, the activations and its fused Adam kernel, called without the
  optimizer class's per-step overhead (`FusedAdam`). The losses follow Keras,
  the paper's framework: mean squared error over samples and outputs, plus
  ``kernel_l2 * sum(W**2) + kernel_l1 * sum(|W|) + bias_l2 * sum(b**2)`` per layer and
  ``activity_l2 * sum(h**2) / batch`` per hidden layer, added to every batch's loss.
- `_LSTMTrainee`, the window LSTM of `WindowLSTMCalibrator`, with torch's LSTM and autograd;
  its loss is the mean squared error plus ``weight_l2 * sum(W**2)`` over the input, recurrent
  and output weights.

The numpy random generator given to `train` orders the batches; it is the only randomness of
training (the initial weights are drawn by the caller), so a seed gives the same weights.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np
import torch

from estimators._lstm import LSTMWeights

# Keras' Adam epsilon (torch's default, 1e-8, is what the LSTM has always been trained with).
MLP_ADAM_EPSILON = 1e-7

# With verbose=1, a progress line every this many epochs (and on the first and last epoch).
PROGRESS_PERIOD = 10


@dataclass(frozen=True)
class EarlyStopping:
    """Stop when the held-out loss has not improved by `tol` for `n_iter_no_change` epochs.

    Attributes
    ----------
    validation_fraction : float
        Fraction of the rows held out: the last ones, in the given order (as in Keras).
        Consecutive robot samples are strongly correlated, so a random draw would validate on
        near-copies of training rows.
    n_iter_no_change : int
    tol : float
        Improvement of the validation mean squared error (standardized targets) that counts.
    """

    validation_fraction: float
    n_iter_no_change: int
    tol: float

    def n_train(self, n_samples: int) -> int:
        """Number of leading rows used for training."""
        n_validation = int(math.ceil(self.validation_fraction * n_samples))
        if n_validation < 1 or n_samples - n_validation < 1:
            raise ValueError(
                "early stopping needs at least one training and one validation sample; "
                f"validation_fraction={self.validation_fraction} of {n_samples} samples "
                "leaves none."
            )
        return n_samples - n_validation

    def min_samples(self) -> int:
        """Fewest rows that leave at least one training and one validation row."""
        n_samples = 2
        while n_samples - math.ceil(self.validation_fraction * n_samples) < 1:
            n_samples += 1
        return n_samples


@dataclass(frozen=True)
class TrainingSettings:
    """How a network is optimized (see `estimators._network.NetworkCalibrator`).

    Attributes
    ----------
    learning_rate, beta_1, beta_2 : float
        Adam's step size and decay rates.
    batch_size : int
        Rows per optimizer step (capped at the number of training rows).
    max_epochs : int
    early_stopping : EarlyStopping or None
    verbose : int
        0: silent; 1: a progress line every `PROGRESS_PERIOD` epochs; >= 2: every epoch.
    """

    learning_rate: float
    beta_1: float
    beta_2: float
    batch_size: int
    max_epochs: int
    early_stopping: EarlyStopping | None
    verbose: int = 0


@dataclass(frozen=True)
class MLPSettings:
    """Hidden-unit activation and Keras-style penalties of a fully connected network."""

    activation: str
    kernel_l2: float
    kernel_l1: float
    bias_l2: float
    activity_l2: float


@dataclass(frozen=True)
class TrainingResult:
    """Outcome of a training run.

    Attributes
    ----------
    state : object
        Snapshot of the parameters kept (the best validation epoch, or the last epoch):
        ``(weights, biases)`` tuples of float64 arrays for the MLP, `LSTMWeights` for the LSTM.
    loss_curve : ndarray, shape (n_epochs,)
        Mean squared error of the training batches per epoch (standardized targets), before
        each step's update and without the penalties.
    validation_curve : ndarray, shape (n_epochs,) or (0,)
        Mean squared error on the held-out rows per epoch, when early stopping is on.
    best_epoch : int
        1-based epoch of `state`.
    """

    state: object
    loss_curve: np.ndarray
    validation_curve: np.ndarray
    best_epoch: int


class Trainee(Protocol):
    """A network being trained, as `run_epochs` drives it."""

    def step(self, inputs: torch.Tensor, targets: torch.Tensor, index: torch.Tensor) -> float:
        """One optimizer step on the rows `index`; returns the batch's summed squared error."""

    def mean_squared_error(self, inputs: torch.Tensor, targets: torch.Tensor) -> float:
        """Data loss of the current parameters on a whole set (no penalties)."""

    def snapshot(self) -> object:
        """A copy of the current parameters."""


# --- the shared trainer ---------------------------------------------------------------------


def train(build: Callable[[int], Trainee], inputs: np.ndarray, targets: np.ndarray,
          settings: TrainingSettings, rng: np.random.Generator,
          n_threads: int | None) -> TrainingResult:
    """Train a network on standardized data.

    Parameters
    ----------
    build : callable
        ``build(batch_size)`` returns the trainee (the network at its initial weights).
    inputs : ndarray, shape (n_samples, ...)
        Standardized inputs, float64 (rows, or windows of rows).
    targets : ndarray, shape (n_samples, n_outputs)
        Standardized targets, float64.
    settings : TrainingSettings
    rng : numpy Generator
        Source of the batch order.
    n_threads : int or None
        Threads for torch during training (None: torch's current setting). The previous
        setting is restored afterwards.
    """
    return with_threads(n_threads, _train, build, inputs, targets, settings, rng)


def _train(build, inputs, targets, settings, rng) -> TrainingResult:
    stopping = settings.early_stopping
    n_samples = inputs.shape[0]
    n_train = n_samples if stopping is None else stopping.n_train(n_samples)
    train_inputs = torch.from_numpy(np.ascontiguousarray(inputs[:n_train]))
    train_targets = torch.from_numpy(np.ascontiguousarray(targets[:n_train]))
    validation_inputs = torch.from_numpy(np.ascontiguousarray(inputs[n_train:]))
    validation_targets = torch.from_numpy(np.ascontiguousarray(targets[n_train:]))
    batch_size = min(settings.batch_size, n_train)
    trainee = build(batch_size)
    return run_epochs(
        n_train, train_targets.numel(), batch_size, settings, rng,
        step=lambda index: trainee.step(train_inputs, train_targets, index),
        snapshot=trainee.snapshot,
        validation_loss=lambda: trainee.mean_squared_error(validation_inputs,
                                                           validation_targets))


def run_epochs(n_train: int, n_values: int, batch_size: int, settings: TrainingSettings,
               rng: np.random.Generator, step: Callable[[torch.Tensor], float],
               snapshot: Callable[[], object],
               validation_loss: Callable[[], float]) -> TrainingResult:
    """Train for up to ``settings.max_epochs`` epochs of shuffled mini-batches.

    Parameters
    ----------
    n_train : int
        Number of training rows; batches are index tensors into them.
    n_values : int
        Number of target values per epoch (rows x outputs), to turn summed squared errors
        into a mean.
    batch_size : int
    settings : TrainingSettings
        Epochs, early stopping and progress (its optimizer fields are the step's business).
    step : callable
        ``step(index)`` takes one optimizer step on the rows `index` and returns the batch's
        summed squared error.
    snapshot : callable
        Returns a copy of the current parameters.
    validation_loss : callable
        Mean squared error on the held-out rows (called with early stopping only).
    """
    early_stopping, max_epochs = settings.early_stopping, settings.max_epochs
    progress = _Progress(settings.verbose, max_epochs)
    loss_curve, validation_curve = [], []
    best_loss, best_epoch, epochs_without_gain = np.inf, 0, 0
    best_state = None
    for epoch in range(1, max_epochs + 1):
        order = torch.from_numpy(rng.permutation(n_train))
        squared_error = 0.0
        for start in range(0, n_train, batch_size):
            squared_error += step(order[start:start + batch_size])
        loss_curve.append(squared_error / n_values)
        if early_stopping is None:
            progress.epoch(epoch, loss_curve[-1])
            continue
        loss = validation_loss()
        validation_curve.append(loss)
        improved = loss <= best_loss - early_stopping.tol
        epochs_without_gain = 0 if improved else epochs_without_gain + 1
        if loss < best_loss:
            best_loss, best_epoch, best_state = loss, epoch, snapshot()
        stops = epochs_without_gain >= early_stopping.n_iter_no_change
        progress.epoch(epoch, loss_curve[-1], loss, last=stops)
        if stops:
            progress.stopped(epoch, early_stopping.n_iter_no_change, best_epoch)
            break
    if early_stopping is None:
        best_state, best_epoch = snapshot(), len(loss_curve)
    return TrainingResult(best_state, np.asarray(loss_curve), np.asarray(validation_curve),
                          best_epoch)


class _Progress:
    """Progress lines of `run_epochs` on stdout (scikit-learn's `verbose` convention)."""

    def __init__(self, verbose: int, max_epochs: int):
        self.verbose, self.max_epochs = int(verbose), max_epochs
        self.start = time.perf_counter()

    def epoch(self, epoch: int, loss: float, validation_loss: float | None = None,
              last: bool = False) -> None:
        if self.verbose <= 0:
            return
        shown = (self.verbose >= 2 or last or epoch in (1, self.max_epochs)
                 or epoch % PROGRESS_PERIOD == 0)
        if not shown:
            return
        line = f"Epoch {epoch}/{self.max_epochs}, loss = {loss:.8f}"
        if validation_loss is not None:
            line += f", validation loss = {validation_loss:.8f}"
        print(f"{line}, elapsed {time.perf_counter() - self.start:.1f} s", flush=True)

    def stopped(self, epoch: int, n_iter_no_change: int, best_epoch: int) -> None:
        if self.verbose > 0:
            print(f"Validation loss did not improve for {n_iter_no_change} epochs: stopped "
                  f"after epoch {epoch}, keeping epoch {best_epoch}.", flush=True)


def with_threads(n_threads: int | None, function: Callable, *args):
    """Call `function(*args)` with torch limited to `n_threads` threads (None: unchanged),
    restoring the previous thread count afterwards."""
    previous = torch.get_num_threads()
    if n_threads is not None:
        torch.set_num_threads(n_threads)
    try:
        return function(*args)
    finally:
        torch.set_num_threads(previous)


# --- the fully connected network --------------------------------------------------------------


def train_mlp(inputs: np.ndarray, targets: np.ndarray, weights, biases, network: MLPSettings,
              settings: TrainingSettings, rng: np.random.Generator,
              n_threads: int | None) -> TrainingResult:
    """Train a fully connected network from initial `weights` and `biases` (not modified).

    Inputs (n_samples, n_features) and targets are standardized; see `train` for the rest.
    The result's `state` is the kept ``(weights, biases)``.
    """
    # The gradients are written by hand: no autograd bookkeeping (nor version counters, which
    # inference mode also skips) during the whole run.
    with torch.inference_mode():
        return train(
            lambda batch_size: _MLPTrainee(weights, biases, network, settings, batch_size),
            inputs, targets, settings, rng, n_threads)


def _activate_(activation: str, values: torch.Tensor) -> None:
    """Apply the hidden-unit activation in place."""
    if activation == "sigmoid":
        values.sigmoid_()
    elif activation == "tanh":
        values.tanh_()
    else:
        values.relu_()


def _activation_backward_(activation: str, grad: torch.Tensor, output: torch.Tensor) -> None:
    """Turn dL/dh into dL/dz in place, from the activation's output h."""
    if activation == "sigmoid":
        torch.ops.aten.sigmoid_backward.grad_input(grad, output, grad_input=grad)
    elif activation == "tanh":
        torch.ops.aten.tanh_backward.grad_input(grad, output, grad_input=grad)
    else:
        grad.mul_(output > 0)


class FusedAdam:
    """Adam on one flat parameter vector: torch's fused CPU kernel, called directly.

    The update is exactly that of ``torch.optim.Adam([parameters], ..., fused=True)`` (same
    kernel, same state: a float32 step count and zero-initialized moments), without the
    per-call bookkeeping of `torch.optim.Optimizer.step` (parameter groups, state lookup,
    profiler hooks), which cost about a tenth of a small network's training step.

    Parameters
    ----------
    parameters : Tensor
        Flat float64 parameter vector, updated in place.
    gradient : Tensor
        Its gradient, same shape, written by the caller before each `step`.
    learning_rate, beta_1, beta_2, epsilon : float
        Adam's settings (torch's ``lr``, ``betas`` and ``eps``).
    """

    def __init__(self, parameters: torch.Tensor, gradient: torch.Tensor, learning_rate: float,
                 beta_1: float, beta_2: float, epsilon: float):
        self.parameters, self.gradient = [parameters], [gradient]
        self.exp_avg = [torch.zeros_like(parameters, memory_format=torch.preserve_format)]
        self.exp_avg_sq = [torch.zeros_like(parameters, memory_format=torch.preserve_format)]
        # torch.optim.Adam keeps a fused optimizer's step count as a float32 scalar tensor.
        self.steps = [torch.zeros((), dtype=torch.float32)]
        self.learning_rate, self.beta_1, self.beta_2 = learning_rate, beta_1, beta_2
        self.epsilon = epsilon

    def step(self) -> None:
        """Update the parameters from the current gradient."""
        torch._foreach_add_(self.steps, 1)
        torch._fused_adam_(
            self.parameters, self.gradient, self.exp_avg, self.exp_avg_sq, [], self.steps,
            amsgrad=False, lr=self.learning_rate, beta1=self.beta_1, beta2=self.beta_2,
            weight_decay=0.0, eps=self.epsilon, maximize=False, grad_scale=None,
            found_inf=None)


class _MLPTrainee:
    """Parameters, gradients and activation buffers of a fully connected network in training.

    Its methods expect to run without autograd (under ``torch.inference_mode()``, as in
    `train_mlp`). All weights and biases are views into one flat parameter vector (and their
    gradients into one flat gradient vector), so each Adam step is a single fused update.
    """

    def __init__(self, weights, biases, network: MLPSettings, settings: TrainingSettings,
                 batch_size: int):
        self.network = network
        shapes = [w.shape for w in weights] + [b.shape for b in biases]
        sizes = [int(np.prod(shape)) for shape in shapes]
        self.parameters = torch.tensor(
            np.concatenate([np.ravel(a) for a in (*weights, *biases)]), dtype=torch.float64)
        self.gradient = torch.zeros_like(self.parameters)
        bounds = np.cumsum([0, *sizes])
        values = [self.parameters[a:b].view(shape) for a, b, shape in
                  zip(bounds[:-1], bounds[1:], shapes)]
        grads = [self.gradient[a:b].view(shape) for a, b, shape in
                 zip(bounds[:-1], bounds[1:], shapes)]
        n_layers = len(weights)
        self.weights, self.biases = values[:n_layers], values[n_layers:]
        self.weight_grads, self.bias_grads = grads[:n_layers], grads[n_layers:]
        widths = [weights[0].shape[0]] + [w.shape[1] for w in weights]
        self.outputs = [torch.empty(batch_size, width, dtype=torch.float64) for width in widths]
        self.grads = [torch.empty(batch_size, width, dtype=torch.float64) for width in widths]
        self.batch_targets = torch.empty(batch_size, widths[-1], dtype=torch.float64)
        self.batch_size = batch_size
        self.optimizer = FusedAdam(self.parameters, self.gradient, settings.learning_rate,
                                   settings.beta_1, settings.beta_2, MLP_ADAM_EPSILON)

    def step(self, inputs: torch.Tensor, targets: torch.Tensor, index: torch.Tensor) -> float:
        """One Adam step on the rows `index`; returns the batch's summed squared error."""
        network, n_batch = self.network, index.shape[0]
        outputs, grads, batch_targets = self.outputs, self.grads, self.batch_targets
        if n_batch < self.batch_size:
            outputs = [buffer[:n_batch] for buffer in outputs]
            grads = [buffer[:n_batch] for buffer in grads]
            batch_targets = batch_targets[:n_batch]
        torch.index_select(inputs, 0, index, out=outputs[0])
        torch.index_select(targets, 0, index, out=batch_targets)
        n_layers = len(self.weights)
        for layer in range(n_layers):
            torch.addmm(self.biases[layer], outputs[layer], self.weights[layer],
                        out=outputs[layer + 1])
            if layer < n_layers - 1:
                _activate_(network.activation, outputs[layer + 1])
        error = grads[-1]
        torch.sub(outputs[-1], batch_targets, out=error)
        squared_error = float(torch.dot(error.view(-1), error.view(-1)))
        error.mul_(2.0 / error.numel())
        for layer in range(n_layers - 1, -1, -1):
            weight, bias = self.weights[layer], self.biases[layer]
            weight_grad, bias_grad = self.weight_grads[layer], self.bias_grads[layer]
            torch.sum(grads[layer + 1], dim=0, out=bias_grad)
            if network.bias_l2 > 0:
                bias_grad.add_(bias, alpha=2.0 * network.bias_l2)
            torch.addmm(weight, outputs[layer].T, grads[layer + 1], beta=2.0 * network.kernel_l2,
                        out=weight_grad)
            if network.kernel_l1 > 0:
                weight_grad.add_(torch.sign(weight), alpha=network.kernel_l1)
            if layer > 0:
                torch.mm(grads[layer + 1], weight.T, out=grads[layer])
                if network.activity_l2 > 0:
                    grads[layer].add_(outputs[layer], alpha=2.0 * network.activity_l2 / n_batch)
                _activation_backward_(network.activation, grads[layer], outputs[layer])
        self.optimizer.step()
        return squared_error

    def mean_squared_error(self, inputs: torch.Tensor, targets: torch.Tensor) -> float:
        """Data loss of the current weights on a whole set (no regularization)."""
        layer = inputs
        for index, (weight, bias) in enumerate(zip(self.weights, self.biases)):
            layer = torch.addmm(bias, layer, weight)
            if index < len(self.weights) - 1:
                _activate_(self.network.activation, layer)
        return float(torch.mean((layer - targets) ** 2))

    def snapshot(self):
        """Copies of the current weights and biases as numpy arrays."""
        return (tuple(w.numpy().copy() for w in self.weights),
                tuple(b.numpy().copy() for b in self.biases))


# --- the window LSTM ------------------------------------------------------------------------


def train_lstm(windows: np.ndarray, targets: np.ndarray, initial: LSTMWeights, weight_l2: float,
               settings: TrainingSettings, rng: np.random.Generator,
               n_threads: int | None) -> TrainingResult:
    """Train the window LSTM from `initial` on standardized windows (n, window, n_features)
    and targets (n, n_outputs); see `train` for the rest. The result's `state` is the kept
    `LSTMWeights`."""
    return train(lambda batch_size: _LSTMTrainee(initial, weight_l2, settings),
                 windows, targets, settings, rng, n_threads)


class _LSTMModule(torch.nn.Module):
    """torch LSTM + linear head holding the numpy `LSTMWeights` (transposed to torch layout)."""

    def __init__(self, weights: LSTMWeights):
        super().__init__()
        n_features, gates = weights.input_weight.shape
        hidden = gates // 4
        # torch's default initialization draws from its global generator; the draws are
        # overwritten below, and fork_rng restores the generator so the caller sees no change.
        with torch.random.fork_rng(devices=[]):
            self.lstm = torch.nn.LSTM(n_features, hidden, batch_first=True, dtype=torch.float64)
            self.head = torch.nn.Linear(hidden, weights.out_weight.shape[1], dtype=torch.float64)
        with torch.no_grad():
            self.lstm.weight_ih_l0.copy_(torch.from_numpy(weights.input_weight.T.copy()))
            self.lstm.weight_hh_l0.copy_(torch.from_numpy(weights.recurrent_weight.T.copy()))
            self.lstm.bias_ih_l0.copy_(torch.from_numpy(weights.gate_bias))
            self.lstm.bias_hh_l0.zero_()
            self.head.weight.copy_(torch.from_numpy(weights.out_weight.T.copy()))
            self.head.bias.copy_(torch.from_numpy(weights.out_bias))

    def forward(self, windows: torch.Tensor) -> torch.Tensor:
        sequence, _ = self.lstm(windows)
        return self.head(sequence[:, -1])

    def kernels(self):
        return (self.lstm.weight_ih_l0, self.lstm.weight_hh_l0, self.head.weight)

    def to_weights(self) -> LSTMWeights:
        with torch.no_grad():
            return LSTMWeights(
                input_weight=self.lstm.weight_ih_l0.numpy().T.copy(),
                recurrent_weight=self.lstm.weight_hh_l0.numpy().T.copy(),
                gate_bias=(self.lstm.bias_ih_l0 + self.lstm.bias_hh_l0).numpy().copy(),
                out_weight=self.head.weight.numpy().T.copy(),
                out_bias=self.head.bias.numpy().copy(),
            )


class _LSTMTrainee:
    """The window LSTM and its Adam optimizer during training (autograd)."""

    def __init__(self, initial: LSTMWeights, weight_l2: float, settings: TrainingSettings):
        self.weight_l2 = weight_l2
        self.model = _LSTMModule(initial)
        self.optimizer = torch.optim.Adam(self.model.parameters(), lr=settings.learning_rate,
                                          betas=(settings.beta_1, settings.beta_2), fused=True)

    def step(self, windows: torch.Tensor, targets: torch.Tensor, index: torch.Tensor) -> float:
        """One Adam step on the windows `index`; returns the batch's summed squared error."""
        error = self.model(windows[index]) - targets[index]
        squared_error = torch.sum(error**2)
        loss = squared_error / error.numel()
        if self.weight_l2 > 0:
            loss = loss + self.weight_l2 * sum(torch.sum(k**2) for k in self.model.kernels())
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        self.optimizer.step()
        return float(squared_error.detach())

    def mean_squared_error(self, windows: torch.Tensor, targets: torch.Tensor) -> float:
        """Data loss of the current weights on a whole set (no penalty)."""
        with torch.no_grad():
            return float(torch.mean((self.model(windows) - targets) ** 2))

    def snapshot(self) -> LSTMWeights:
        return self.model.to_weights()
