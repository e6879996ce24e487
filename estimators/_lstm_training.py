"""Training of the window LSTM in torch (autograd, float64, CPU)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from estimators._lstm import LSTMWeights
from estimators._training_loop import EarlyStopping, LoopResult, run_epochs, with_threads


@dataclass(frozen=True)
class LSTMTrainingConfig:
    """Optimization settings (see `WindowLSTMCalibrator`)."""

    learning_rate: float
    beta_1: float
    beta_2: float
    weight_l2: float
    batch_size: int
    max_epochs: int
    early_stopping: EarlyStopping | None


class _Model(torch.nn.Module):
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


def train_lstm(windows: np.ndarray, targets: np.ndarray, initial: LSTMWeights,
               config: LSTMTrainingConfig, rng: np.random.Generator,
               n_threads: int | None) -> LoopResult:
    """Train on standardized windows (n, window, n_features) and targets (n, n_outputs).

    Returns a `LoopResult` whose `state` is the kept `LSTMWeights`. The loss is the mean
    squared error plus ``weight_l2 * sum(W**2)`` over the input, recurrent and output weights.
    """
    return with_threads(n_threads, _train, windows, targets, initial, config, rng)


def _train(windows, targets, initial, config, rng) -> LoopResult:
    stopping = config.early_stopping
    n_samples = windows.shape[0]
    n_train = n_samples if stopping is None else stopping.n_train(n_samples)
    train_windows = torch.from_numpy(np.ascontiguousarray(windows[:n_train]))
    train_targets = torch.from_numpy(np.ascontiguousarray(targets[:n_train]))
    validation_windows = torch.from_numpy(np.ascontiguousarray(windows[n_train:]))
    validation_targets = torch.from_numpy(np.ascontiguousarray(targets[n_train:]))
    model = _Model(initial)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate,
                                 betas=(config.beta_1, config.beta_2), fused=True)

    def step(index: torch.Tensor) -> float:
        error = model(train_windows[index]) - train_targets[index]
        squared_error = torch.sum(error**2)
        loss = squared_error / error.numel()
        if config.weight_l2 > 0:
            loss = loss + config.weight_l2 * sum(torch.sum(k**2) for k in model.kernels())
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        optimizer.step()
        return float(squared_error.detach())

    def validation_loss() -> float:
        with torch.no_grad():
            return float(torch.mean((model(validation_windows) - validation_targets) ** 2))

    return run_epochs(n_train, train_targets.numel(), min(config.batch_size, n_train),
                      config.max_epochs, rng, step=step, snapshot=model.to_weights,
                      validation_loss=validation_loss, early_stopping=stopping)
