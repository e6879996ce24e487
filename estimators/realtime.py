"""Single-sample predictors for a servo loop, built from fitted calibrators.

Each predictor is a plain callable over numpy arrays: ``f(x)`` takes one sample of shape
(n_features,) (float64, in the units the calibrator was trained on) and returns a new array of
shape (n_targets,). Standardization and the raw-position skip of error-trained calibrators are
folded into the weights when the predictor is built, so the hot call is a handful of numpy
operations on preallocated buffers. The hot call validates nothing: checking the input is the
caller's job, once, outside the loop. Because the buffers are reused, one predictor must not be
called from several threads at once; build one per thread.

Window predictors (`WindowAffinePredictor`, `LSTMPredictor`) are stateful: each call appends the
sample to a ring buffer of the last `window` samples, the very first call (or the first after
`reset`) fills the whole window with that sample, exactly as the window calibrators pad the
start of a recording.
"""

from __future__ import annotations

import numpy as np


class AffinePredictor:
    """``f(x) = x @ weight + bias``: fixed offset, linear and error-trained linear calibrators.

    Parameters
    ----------
    weight : ndarray, shape (n_features, n_targets)
    bias : ndarray, shape (n_targets,)
    """

    __slots__ = ("weight", "bias")

    def __init__(self, weight: np.ndarray, bias: np.ndarray):
        self.weight = np.ascontiguousarray(weight, dtype=np.float64)
        self.bias = np.ascontiguousarray(bias, dtype=np.float64)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.dot(x, self.weight) + self.bias


class MLPPredictor:
    """Fully connected network ``t_i = act(t_{i-1} @ W_i + b_i)``, linear output layer.

    Parameters
    ----------
    weights, biases : lists of ndarray
        Layer weights (n_in, n_out) and biases (n_out,), input layer first, output layer last,
        already in the units of the raw input and output.
    activation : {"tanh", "relu"}
        Hidden-unit activation. Sigmoid networks are converted to tanh form when built
        (`from_sigmoid_network`), which saves one array operation per layer.
    raw_index : ndarray of int or None
        Columns of x added to the output (error-trained calibrators).
    """

    __slots__ = ("_hidden", "_activation", "_out_weight", "_out_bias", "_raw_index")

    def __init__(self, weights, biases, activation: str, raw_index: np.ndarray | None):
        if activation not in ("tanh", "relu"):
            raise ValueError(f"activation must be 'tanh' or 'relu'; got {activation!r}.")
        self._hidden = [
            (np.ascontiguousarray(w, dtype=np.float64), np.ascontiguousarray(b, dtype=np.float64),
             np.empty(w.shape[1]))
            for w, b in zip(weights[:-1], biases[:-1])
        ]
        self._activation = activation
        self._out_weight = np.ascontiguousarray(weights[-1], dtype=np.float64)
        self._out_bias = np.ascontiguousarray(biases[-1], dtype=np.float64)
        self._raw_index = None if raw_index is None else np.asarray(raw_index, dtype=np.intp)

    @classmethod
    def from_sigmoid_network(cls, weights, biases, raw_index):
        """Build from a sigmoid network, rewritten exactly with tanh units.

        ``sigmoid(z) = (1 + tanh(z / 2)) / 2``: the halvings and the constant half move into the
        weights and biases of the layer that consumes the unit, so every hidden layer becomes
        ``tanh(t @ W' + b')``.
        """
        new_weights, new_biases = [], []
        input_factor, input_offset = 1.0, None  # previous layer output h = factor * t + offset
        for index, (w, b) in enumerate(zip(weights, biases)):
            is_output = index == len(weights) - 1
            effective_b = b if input_offset is None else b + input_offset @ w
            half = 1.0 if is_output else 0.5
            new_weights.append(half * input_factor * w)
            new_biases.append(half * effective_b)
            input_factor, input_offset = 0.5, np.full(w.shape[1], 0.5)
        return cls(new_weights, new_biases, "tanh", raw_index)

    @property
    def layers(self) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Weights (n_in, n_out) and biases of every layer, input layer first, in raw units
        (the arrays the predictor uses: do not modify them). Used by `estimators.export_c`."""
        weights = [weight for weight, _, _ in self._hidden] + [self._out_weight]
        biases = [bias for _, bias, _ in self._hidden] + [self._out_bias]
        return weights, biases

    @property
    def activation(self) -> str:
        """Hidden-unit activation, "tanh" or "relu"."""
        return self._activation

    @property
    def raw_index(self) -> np.ndarray | None:
        """Columns of x added to the output, or None."""
        return self._raw_index

    def __call__(self, x: np.ndarray) -> np.ndarray:
        layer_input = x
        for weight, bias, buffer in self._hidden:
            np.dot(layer_input, weight, out=buffer)
            buffer += bias
            if self._activation == "tanh":
                np.tanh(buffer, out=buffer)
            else:
                np.maximum(buffer, 0.0, out=buffer)
            layer_input = buffer
        output = np.dot(layer_input, self._out_weight) + self._out_bias
        if self._raw_index is not None:
            output += x[self._raw_index]
        return output


class MonomialPredictor:
    """``f(x) = monomials(x) @ weight + bias`` for a polynomial calibrator.

    Parameters
    ----------
    parents, factors : lists of ndarray of int
        For degree k >= 2: monomial j of degree k is monomial ``parents[k-2][j]`` of degree
        k - 1 times ``x[factors[k-2][j]]``. Degree-1 monomials are x itself.
    weight : ndarray, shape (n_monomials, n_targets)
        Weights over all monomials, degree 1 first, in raw input units.
    bias : ndarray, shape (n_targets,)
    """

    __slots__ = ("_levels", "_features", "_weight", "_bias")

    def __init__(self, parents, factors, weight: np.ndarray, bias: np.ndarray):
        self._weight = np.ascontiguousarray(weight, dtype=np.float64)
        self._bias = np.ascontiguousarray(bias, dtype=np.float64)
        self._features = np.empty(weight.shape[0])
        n_features = weight.shape[0] - sum(len(p) for p in parents)
        self._levels = []
        start, previous_start = n_features, 0
        for parent, factor in zip(parents, factors):
            stop = start + len(parent)
            self._levels.append((np.asarray(parent, dtype=np.intp) + previous_start,
                                 np.asarray(factor, dtype=np.intp), start, stop))
            previous_start, start = start, stop

    @property
    def weight(self) -> np.ndarray:
        """Weights over all monomials (n_monomials, n_targets), degree 1 first, raw units."""
        return self._weight

    @property
    def bias(self) -> np.ndarray:
        return self._bias

    @property
    def levels(self) -> list[tuple[np.ndarray, np.ndarray, int, int]]:
        """For each degree k >= 2: (parent, factor, start, stop), meaning monomials
        ``start:stop`` are ``monomials[parent] * x[factor]`` (parent indexes all monomials).
        Used by `estimators.export_c`."""
        return list(self._levels)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        features = self._features
        features[: x.shape[0]] = x
        for parent, factor, start, stop in self._levels:
            np.multiply(features[parent], x[factor], out=features[start:stop])
        return np.dot(features, self._weight) + self._bias


class KernelPredictor:
    """Squared-exponential kernel expansion ``f(x) = exp(-|P - x * s|^2 / 2) @ weight + bias``.

    Parameters
    ----------
    scaled_points : ndarray, shape (n_points, n_features)
        Support points divided by their length scales (raw units / length).
    inverse_length : ndarray, shape (n_features,)
        1 / length scale per feature, in raw units.
    weight : ndarray, shape (n_points, n_targets)
        Kernel weights, signal variance and output scale folded in.
    bias : ndarray, shape (n_targets,)
    raw_index : ndarray of int or None
    """

    __slots__ = ("_points", "_half_norms", "_inverse_length", "_weight", "_bias", "_raw_index",
                 "_buffer")

    def __init__(self, scaled_points, inverse_length, weight, bias, raw_index):
        self._points = np.ascontiguousarray(scaled_points, dtype=np.float64)
        self._half_norms = 0.5 * np.einsum("ij,ij->i", self._points, self._points)
        self._inverse_length = np.ascontiguousarray(inverse_length, dtype=np.float64)
        self._weight = np.ascontiguousarray(weight, dtype=np.float64)
        self._bias = np.ascontiguousarray(bias, dtype=np.float64)
        self._raw_index = None if raw_index is None else np.asarray(raw_index, dtype=np.intp)
        self._buffer = np.empty(self._points.shape[0])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        scaled = x * self._inverse_length
        buffer = self._buffer
        # -|p - u|^2 / 2 = p.u - |p|^2 / 2 - |u|^2 / 2
        np.dot(self._points, scaled, out=buffer)
        buffer -= self._half_norms
        buffer -= 0.5 * np.dot(scaled, scaled)
        np.minimum(buffer, 0.0, out=buffer)
        np.exp(buffer, out=buffer)
        output = np.dot(buffer, self._weight) + self._bias
        if self._raw_index is not None:
            output += x[self._raw_index]
        return output


class ForestPredictor:
    """Average of regression trees stored as flat node arrays (see `estimators._forest`).

    Leaves point to themselves, so every tree is walked for the same number of steps, all trees
    at once. Inputs are rounded to float32 before the comparisons, as scikit-learn's trees do.
    """

    __slots__ = ("_feature", "_threshold", "_left", "_right", "_value", "_roots", "_depth")

    def __init__(self, forest):
        self._feature = forest.feature
        self._threshold = forest.threshold
        self._left = forest.left
        self._right = forest.right
        self._value = forest.value
        self._roots = forest.roots
        self._depth = forest.depth

    def __call__(self, x: np.ndarray) -> np.ndarray:
        rounded = x.astype(np.float32)
        nodes = self._roots
        for _ in range(self._depth):
            goes_left = rounded[self._feature[nodes]] <= self._threshold[nodes]
            nodes = np.where(goes_left, self._left[nodes], self._right[nodes])
        return self._value[nodes].mean(axis=0)


class SumPredictor:
    """Sum of several predictors' outputs (e.g. a network plus a forest on its residual)."""

    __slots__ = ("_parts",)

    def __init__(self, parts):
        self._parts = tuple(parts)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        output = self._parts[0](x)
        for part in self._parts[1:]:
            output += part(x)
        return output


class WindowBuffer:
    """Ring buffer of the last `window` rows, readable as one contiguous (window, width) view.

    Each row is stored twice, at ``head`` and ``head + window``, so the rows oldest to newest are
    always the contiguous slice ``[head + 1, head + window]``: no copy per call.
    """

    __slots__ = ("_rows", "_window", "_head", "_empty")

    def __init__(self, window: int, width: int):
        self._rows = np.empty((2 * window, width))
        self._window = window
        self._head = window - 1
        self._empty = True

    def reset(self) -> None:
        """Forget the history: the next pushed row fills the whole window."""
        self._head = self._window - 1
        self._empty = True

    def push(self, row: np.ndarray) -> np.ndarray:
        """Append `row`; return the window, oldest row first (a view, valid until next push)."""
        if self._empty:
            self._rows[:] = row
            self._empty = False
        else:
            self._head = (self._head + 1) % self._window
            self._rows[self._head] = row
            self._rows[self._head + self._window] = row
        return self._rows[self._head + 1: self._head + 1 + self._window]


class WindowAffinePredictor:
    """``f(x_t) = [x_{t-k+1}, ..., x_t] @ weight + bias`` over a ring buffer of past samples.

    Parameters
    ----------
    weight : ndarray, shape (window * n_features, n_targets)
        Weights of the flattened window, oldest sample first, in raw input units.
    bias : ndarray, shape (n_targets,)
    window : int
    """

    __slots__ = ("_weight", "_bias", "_buffer")

    def __init__(self, weight: np.ndarray, bias: np.ndarray, window: int):
        self._weight = np.ascontiguousarray(weight, dtype=np.float64)
        self._bias = np.ascontiguousarray(bias, dtype=np.float64)
        self._buffer = WindowBuffer(window, weight.shape[0] // window)

    def reset(self) -> None:
        """Start a new recording: forget the buffered samples."""
        self._buffer.reset()

    def __call__(self, x: np.ndarray) -> np.ndarray:
        window = self._buffer.push(x)
        return np.dot(window.ravel(), self._weight) + self._bias


class LSTMPredictor:
    """One-layer LSTM over the window of the last `window` samples, linear output layer.

    The input projection ``x @ W_ih + b`` of each sample does not depend on the window, so it is
    computed once when the sample arrives and kept in the ring buffer; a call then runs only the
    recurrence over the window, from zero state, as the window calibrator does.

    Parameters
    ----------
    input_weight : ndarray, shape (n_features, 4 * hidden)
        Input weights in raw input units, gate order (input, forget, cell, output).
    recurrent_weight : ndarray, shape (hidden, 4 * hidden)
    gate_bias : ndarray, shape (4 * hidden,)
    out_weight : ndarray, shape (hidden, n_targets)
    out_bias : ndarray, shape (n_targets,)
    window : int
    raw_index : ndarray of int or None
    """

    __slots__ = ("_input_weight", "_recurrent_weight", "_gate_bias", "_gate_scale", "_gate_shift",
                 "_out_weight", "_out_bias", "_raw_index", "_buffer", "_projection", "_gates",
                 "_hidden", "_cell", "_product", "_size")

    def __init__(self, input_weight, recurrent_weight, gate_bias, out_weight, out_bias, window,
                 raw_index):
        size = recurrent_weight.shape[0]
        # sigmoid(z) = (1 + tanh(z / 2)) / 2: halve the pre-activations of the sigmoid gates
        # here, so one tanh over all gates serves both nonlinearities.
        sigmoid_gate = np.ones(4 * size, dtype=bool)
        sigmoid_gate[2 * size: 3 * size] = False
        pre_scale = np.where(sigmoid_gate, 0.5, 1.0)
        self._input_weight = np.ascontiguousarray(input_weight * pre_scale, dtype=np.float64)
        self._recurrent_weight = np.ascontiguousarray(recurrent_weight * pre_scale,
                                                      dtype=np.float64)
        self._gate_bias = np.ascontiguousarray(gate_bias * pre_scale, dtype=np.float64)
        self._gate_scale = pre_scale
        self._gate_shift = np.where(sigmoid_gate, 0.5, 0.0)
        self._out_weight = np.ascontiguousarray(out_weight, dtype=np.float64)
        self._out_bias = np.ascontiguousarray(out_bias, dtype=np.float64)
        self._raw_index = None if raw_index is None else np.asarray(raw_index, dtype=np.intp)
        self._size = size
        self._buffer = WindowBuffer(window, 4 * size)
        self._projection = np.empty(4 * size)
        self._gates = np.empty(4 * size)
        self._hidden = np.empty(size)
        self._cell = np.empty(size)
        self._product = np.empty(size)

    def reset(self) -> None:
        """Start a new recording: forget the buffered samples."""
        self._buffer.reset()

    def __call__(self, x: np.ndarray) -> np.ndarray:
        np.dot(x, self._input_weight, out=self._projection)
        self._projection += self._gate_bias
        window = self._buffer.push(self._projection)
        size, gates, hidden, cell = self._size, self._gates, self._hidden, self._cell
        input_gate, forget_gate = gates[:size], gates[size: 2 * size]
        cell_gate, output_gate = gates[2 * size: 3 * size], gates[3 * size:]
        hidden.fill(0.0)
        cell.fill(0.0)
        for row in window:
            np.dot(hidden, self._recurrent_weight, out=gates)
            gates += row
            np.tanh(gates, out=gates)
            gates *= self._gate_scale
            gates += self._gate_shift
            cell *= forget_gate
            np.multiply(input_gate, cell_gate, out=self._product)
            cell += self._product
            np.tanh(cell, out=hidden)
            hidden *= output_gate
        output = np.dot(hidden, self._out_weight) + self._out_bias
        if self._raw_index is not None:
            output += x[self._raw_index]
        return output
