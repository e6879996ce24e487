"""Mini-batch training of a fully connected network in torch, float64, on the CPU.

The paper's network is small (16-100-100-3) and its batch large (1024), so a training step is a
few matrix products; autograd bookkeeping and per-step allocations would cost as much as the
arithmetic. This module therefore writes the backward pass by hand on preallocated full-batch
tensors and uses torch only for the matrix products, the activations and its fused Adam. The
losses follow Keras, the paper's framework: mean squared error over samples and outputs, plus
``kernel_l2 * sum(W**2) + kernel_l1 * sum(|W|) + bias_l2 * sum(b**2)`` per layer and
``activity_l2 * sum(h**2) / batch`` per hidden layer, added to every batch's loss.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from estimators._training_loop import EarlyStopping, run_epochs, with_threads

# Keras' Adam epsilon (torch's default is 1e-8).
ADAM_EPSILON = 1e-7


@dataclass(frozen=True)
class TrainingConfig:
    """Optimization settings of one training run (see `DNNCalibrator` for their meaning)."""

    activation: str
    kernel_l2: float
    kernel_l1: float
    bias_l2: float
    activity_l2: float
    learning_rate: float
    beta_1: float
    beta_2: float
    batch_size: int
    max_epochs: int
    early_stopping: EarlyStopping | None


@dataclass(frozen=True)
class TrainingResult:
    """Learned weights and the history of one training run.

    Attributes
    ----------
    weights, biases : tuple of ndarray
        float64 layer weights (n_in, n_out) and biases, input layer first.
    loss_curve : ndarray, shape (n_epochs,)
        Mean squared error of the training batches per epoch (standardized targets), without
        the regularization terms.
    validation_curve : ndarray, shape (n_epochs,) or (0,)
        Mean squared error on the held-out rows per epoch, when early stopping is on.
    best_epoch : int
        Epoch (1-based) whose weights were kept.
    """

    weights: tuple
    biases: tuple
    loss_curve: np.ndarray
    validation_curve: np.ndarray
    best_epoch: int


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


class _Network:
    """Parameters, gradients and activation buffers of one network during training.

    All weights and biases are views into one flat parameter vector (and their gradients into
    one flat gradient vector), so each Adam step is a single fused update.
    """

    def __init__(self, weights, biases, config: TrainingConfig, batch_size: int):
        self.config = config
        shapes = [w.shape for w in weights] + [b.shape for b in biases]
        sizes = [int(np.prod(shape)) for shape in shapes]
        self.parameters = torch.tensor(
            np.concatenate([np.ravel(a) for a in (*weights, *biases)]), dtype=torch.float64)
        self.parameters.grad = torch.zeros_like(self.parameters)
        bounds = np.cumsum([0, *sizes])
        values = [self.parameters[a:b].view(shape) for a, b, shape in
                  zip(bounds[:-1], bounds[1:], shapes)]
        grads = [self.parameters.grad[a:b].view(shape) for a, b, shape in
                 zip(bounds[:-1], bounds[1:], shapes)]
        n_layers = len(weights)
        self.weights, self.biases = values[:n_layers], values[n_layers:]
        self.weight_grads, self.bias_grads = grads[:n_layers], grads[n_layers:]
        widths = [weights[0].shape[0]] + [w.shape[1] for w in weights]
        self.outputs = [torch.empty(batch_size, width, dtype=torch.float64) for width in widths]
        self.grads = [torch.empty(batch_size, width, dtype=torch.float64) for width in widths]
        self.optimizer = torch.optim.Adam(
            [self.parameters], lr=config.learning_rate, betas=(config.beta_1, config.beta_2),
            eps=ADAM_EPSILON, fused=True)

    def step(self, inputs: torch.Tensor, targets: torch.Tensor, index: torch.Tensor) -> float:
        """One Adam step on the rows `index`; returns the batch's summed squared error."""
        config, n_batch = self.config, index.shape[0]
        outputs = [buffer[:n_batch] for buffer in self.outputs]
        grads = [buffer[:n_batch] for buffer in self.grads]
        torch.index_select(inputs, 0, index, out=outputs[0])
        n_layers = len(self.weights)
        for layer in range(n_layers):
            torch.addmm(self.biases[layer], outputs[layer], self.weights[layer],
                        out=outputs[layer + 1])
            if layer < n_layers - 1:
                _activate_(config.activation, outputs[layer + 1])
        error = grads[-1]
        torch.sub(outputs[-1], targets.index_select(0, index), out=error)
        squared_error = float(torch.dot(error.view(-1), error.view(-1)))
        error.mul_(2.0 / error.numel())
        for layer in range(n_layers - 1, -1, -1):
            weight, bias = self.weights[layer], self.biases[layer]
            weight_grad, bias_grad = self.weight_grads[layer], self.bias_grads[layer]
            torch.addmm(weight, outputs[layer].T, grads[layer + 1], beta=2.0 * config.kernel_l2,
                        out=weight_grad)
            if config.kernel_l1 > 0:
                weight_grad.add_(torch.sign(weight), alpha=config.kernel_l1)
            torch.sum(grads[layer + 1], dim=0, out=bias_grad)
            if config.bias_l2 > 0:
                bias_grad.add_(bias, alpha=2.0 * config.bias_l2)
            if layer > 0:
                torch.mm(grads[layer + 1], weight.T, out=grads[layer])
                if config.activity_l2 > 0:
                    grads[layer].add_(outputs[layer], alpha=2.0 * config.activity_l2 / n_batch)
                _activation_backward_(config.activation, grads[layer], outputs[layer])
        self.optimizer.step()
        return squared_error

    def mean_squared_error(self, inputs: torch.Tensor, targets: torch.Tensor) -> float:
        """Data loss of the current weights on a whole set (no regularization)."""
        layer = inputs
        for index, (weight, bias) in enumerate(zip(self.weights, self.biases)):
            layer = torch.addmm(bias, layer, weight)
            if index < len(self.weights) - 1:
                _activate_(self.config.activation, layer)
        return float(torch.mean((layer - targets) ** 2))

    def snapshot(self):
        """Copies of the current weights and biases as numpy arrays."""
        return (tuple(w.numpy().copy() for w in self.weights),
                tuple(b.numpy().copy() for b in self.biases))


def train_mlp(inputs: np.ndarray, targets: np.ndarray, weights, biases, config: TrainingConfig,
              rng: np.random.Generator, n_threads: int | None) -> TrainingResult:
    """Train a network from initial weights on standardized data.

    Parameters
    ----------
    inputs : ndarray, shape (n_samples, n_features)
        Standardized inputs, float64.
    targets : ndarray, shape (n_samples, n_outputs)
        Standardized targets, float64.
    weights, biases : sequences of ndarray
        Initial parameters (not modified).
    config : TrainingConfig
    rng : numpy Generator
        Source of the batch order; the only randomness of training.
    n_threads : int or None
        Threads for torch during training (None: torch's current setting). The previous
        setting is restored afterwards.

    Returns
    -------
    TrainingResult
    """
    return with_threads(n_threads, _train, inputs, targets, weights, biases, config, rng)


@torch.no_grad()
def _train(inputs, targets, weights, biases, config, rng) -> TrainingResult:
    n_samples = inputs.shape[0]
    stopping = config.early_stopping
    n_train = n_samples if stopping is None else stopping.n_train(n_samples)
    train_inputs = torch.from_numpy(np.ascontiguousarray(inputs[:n_train]))
    train_targets = torch.from_numpy(np.ascontiguousarray(targets[:n_train]))
    validation_inputs = torch.from_numpy(np.ascontiguousarray(inputs[n_train:]))
    validation_targets = torch.from_numpy(np.ascontiguousarray(targets[n_train:]))
    batch_size = min(config.batch_size, n_train)
    network = _Network(weights, biases, config, batch_size)
    result = run_epochs(
        n_train, train_targets.numel(), batch_size, config.max_epochs, rng,
        step=lambda index: network.step(train_inputs, train_targets, index),
        snapshot=network.snapshot,
        validation_loss=lambda: network.mean_squared_error(validation_inputs,
                                                           validation_targets),
        early_stopping=stopping)
    weights, biases = result.state
    return TrainingResult(weights=weights, biases=biases, loss_curve=result.loss_curve,
                          validation_curve=result.validation_curve,
                          best_epoch=result.best_epoch)
