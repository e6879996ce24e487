"""Numpy side of the fully connected networks: initialization and batch forward pass.

Training runs in torch (`estimators._torch_training`); the learned weights are plain float64
arrays, so prediction, saving and real-time export need numpy only.
"""

from __future__ import annotations

import numpy as np
from scipy.special import expit

ACTIVATIONS = ("sigmoid", "tanh", "relu")


def glorot_uniform(sizes: tuple[int, ...], rng: np.random.Generator):
    """Glorot-uniform weights and zero biases for layers of widths `sizes` (Keras' default).

    Returns
    -------
    weights : list of ndarray, shapes (sizes[i], sizes[i + 1])
    biases : list of ndarray, shapes (sizes[i + 1],)
    """
    weights, biases = [], []
    for fan_in, fan_out in zip(sizes[:-1], sizes[1:]):
        limit = np.sqrt(6.0 / (fan_in + fan_out))
        weights.append(rng.uniform(-limit, limit, size=(fan_in, fan_out)))
        biases.append(np.zeros(fan_out))
    return weights, biases


def activate(values: np.ndarray, activation: str) -> np.ndarray:
    """Apply a hidden-unit activation elementwise (new array)."""
    if activation == "sigmoid":
        return expit(values)
    if activation == "tanh":
        return np.tanh(values)
    return np.maximum(values, 0.0)


def forward(inputs: np.ndarray, weights, biases, activation: str) -> np.ndarray:
    """Network output for a batch: hidden layers with `activation`, linear output layer."""
    layer = inputs
    for weight, bias in zip(weights[:-1], biases[:-1]):
        layer = activate(layer @ weight + bias, activation)
    return layer @ weights[-1] + biases[-1]
