"""Error metrics of joint-position estimates, per joint, in the units of the data (SI)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np


def _paired(y_true, y_pred) -> tuple[np.ndarray, np.ndarray]:
    """Validate two estimates of the same joints: same shape, finite, at least one sample."""
    truth = np.asarray(y_true, dtype=np.float64)
    estimate = np.asarray(y_pred, dtype=np.float64)
    if truth.ndim == 1:
        truth = truth[:, None]
    if estimate.ndim == 1:
        estimate = estimate[:, None]
    if truth.ndim != 2 or truth.shape != estimate.shape:
        raise ValueError(
            f"y_true and y_pred must have the same shape (n_samples, n_joints); got "
            f"{np.shape(y_true)} and {np.shape(y_pred)}."
        )
    if truth.shape[0] == 0:
        raise ValueError("y_true and y_pred hold no samples.")
    for name, values in (("y_true", truth), ("y_pred", estimate)):
        if not np.all(np.isfinite(values)):
            raise ValueError(f"{name} contains NaN or infinity.")
    return truth, estimate


def rmse_per_joint(y_true, y_pred) -> np.ndarray:
    """Root-mean-square error of each joint (column).

    Parameters
    ----------
    y_true, y_pred : array-like, shape (n_samples, n_joints) or (n_samples,)
        Ground truth and estimate, in the same units (rad for rotational joints, m for
        prismatic ones).

    Returns
    -------
    ndarray, shape (n_joints,)
        RMSE per joint, in the units of the inputs.
    """
    truth, estimate = _paired(y_true, y_pred)
    return np.sqrt(np.mean((estimate - truth) ** 2, axis=0))


def pooled_rmse(y_true, y_pred, columns: Sequence[int] | None = None) -> float:
    """Root-mean-square error over all samples of the chosen joints together.

    Only meaningful for joints of the same unit (e.g. the three wrist joints, in rad).

    Parameters
    ----------
    y_true, y_pred : array-like, shape (n_samples, n_joints)
    columns : sequence of int, optional
        Joints (column indices) to pool; all joints by default.
    """
    truth, estimate = _paired(y_true, y_pred)
    if columns is not None:
        index = np.asarray(columns, dtype=np.intp)
        if index.size == 0 or index.min() < -truth.shape[1] or index.max() >= truth.shape[1]:
            raise ValueError(
                f"columns {list(columns)} are not valid joint indices for {truth.shape[1]} joints."
            )
        truth, estimate = truth[:, index], estimate[:, index]
    return float(np.sqrt(np.mean((estimate - truth) ** 2)))
