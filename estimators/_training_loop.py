"""The epoch loop shared by the torch-trained calibrators: shuffling, early stopping, history."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch


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


@dataclass(frozen=True)
class LoopResult:
    """Outcome of `run_epochs`.

    Attributes
    ----------
    state : object
        Snapshot of the parameters kept (the best validation epoch, or the last epoch).
    loss_curve : ndarray, shape (n_epochs,)
        Mean squared error of the training batches per epoch, before each step's update.
    validation_curve : ndarray, shape (n_epochs,) or (0,)
    best_epoch : int
        1-based epoch of `state`.
    """

    state: object
    loss_curve: np.ndarray
    validation_curve: np.ndarray
    best_epoch: int


def run_epochs(n_train: int, n_values: int, batch_size: int, max_epochs: int,
               rng: np.random.Generator, step: Callable[[torch.Tensor], float],
               snapshot: Callable[[], object], validation_loss: Callable[[], float] | None,
               early_stopping: EarlyStopping | None) -> LoopResult:
    """Train for up to `max_epochs` epochs of shuffled mini-batches.

    Parameters
    ----------
    n_train : int
        Number of training rows; batches are index tensors into them.
    n_values : int
        Number of target values per epoch (rows x outputs), to turn summed squared errors
        into a mean.
    step : callable
        ``step(index)`` takes one optimizer step on the rows `index` and returns the batch's
        summed squared error.
    snapshot : callable
        Returns a copy of the current parameters.
    validation_loss : callable or None
        Mean squared error on the held-out rows (needed with early stopping).
    early_stopping : EarlyStopping or None
    """
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
            continue
        loss = validation_loss()
        validation_curve.append(loss)
        improved = loss <= best_loss - early_stopping.tol
        epochs_without_gain = 0 if improved else epochs_without_gain + 1
        if loss < best_loss:
            best_loss, best_epoch, best_state = loss, epoch, snapshot()
        if epochs_without_gain >= early_stopping.n_iter_no_change:
            break
    if early_stopping is None:
        best_state, best_epoch = snapshot(), len(loss_curve)
    return LoopResult(best_state, np.asarray(loss_curve), np.asarray(validation_curve),
                      best_epoch)


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
