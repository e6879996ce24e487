"""Numpy side of the one-layer LSTM used by `WindowLSTMCalibrator`: initialization and forward.

Gate order is torch's: input, forget, cell, output. Weights are stored for right
multiplication: ``gates = x @ input_weight + h @ recurrent_weight + gate_bias``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import expit


@dataclass(frozen=True)
class LSTMWeights:
    """Parameters of a one-layer LSTM with a linear output layer.

    Attributes
    ----------
    input_weight : ndarray, shape (n_features, 4 * hidden)
    recurrent_weight : ndarray, shape (hidden, 4 * hidden)
    gate_bias : ndarray, shape (4 * hidden,)
    out_weight : ndarray, shape (hidden, n_outputs)
    out_bias : ndarray, shape (n_outputs,)
    """

    input_weight: np.ndarray
    recurrent_weight: np.ndarray
    gate_bias: np.ndarray
    out_weight: np.ndarray
    out_bias: np.ndarray

    @classmethod
    def initial(cls, n_features: int, hidden: int, n_outputs: int,
                rng: np.random.Generator) -> "LSTMWeights":
        """torch's LSTM initialization U(-1/sqrt(hidden), 1/sqrt(hidden)); Glorot-uniform
        output layer with zero bias."""
        bound = 1.0 / np.sqrt(hidden)
        limit = np.sqrt(6.0 / (hidden + n_outputs))
        return cls(
            input_weight=rng.uniform(-bound, bound, (n_features, 4 * hidden)),
            recurrent_weight=rng.uniform(-bound, bound, (hidden, 4 * hidden)),
            gate_bias=rng.uniform(-bound, bound, 4 * hidden),
            out_weight=rng.uniform(-limit, limit, (hidden, n_outputs)),
            out_bias=np.zeros(n_outputs),
        )

    def arrays(self) -> dict[str, np.ndarray]:
        return {"input_weight": self.input_weight, "recurrent_weight": self.recurrent_weight,
                "gate_bias": self.gate_bias, "out_weight": self.out_weight,
                "out_bias": self.out_bias}


def forward(windows: np.ndarray, weights: LSTMWeights) -> np.ndarray:
    """Output after the last step of each window, from zero state.

    Parameters
    ----------
    windows : ndarray, shape (n_samples, window, n_features)

    Returns
    -------
    ndarray, shape (n_samples, n_outputs)
    """
    n_samples, n_steps, _ = windows.shape
    size = weights.recurrent_weight.shape[0]
    projected = windows @ weights.input_weight + weights.gate_bias
    hidden = np.zeros((n_samples, size))
    cell = np.zeros((n_samples, size))
    for step in range(n_steps):
        gates = projected[:, step] + hidden @ weights.recurrent_weight
        input_gate = expit(gates[:, :size])
        forget_gate = expit(gates[:, size: 2 * size])
        cell_gate = np.tanh(gates[:, 2 * size: 3 * size])
        output_gate = expit(gates[:, 3 * size:])
        cell = forget_gate * cell + input_gate * cell_gate
        hidden = output_gate * np.tanh(cell)
    return hidden @ weights.out_weight + weights.out_bias
