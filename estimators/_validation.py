"""Checks of calibrator hyper-parameters and of the mapping between raw inputs and targets.

Array validation (shapes, NaN/inf, dtypes, feature counts) is scikit-learn's `validate_data`;
this module holds only what scikit-learn cannot know: which columns of X hold the uncorrected
joint positions, and the numeric ranges of hyper-parameters. Every check raises a `ValueError`
(or `TypeError` for a wrong type) that names the parameter and the offending value.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np


def resolve_raw_columns(raw_columns, n_features: int, n_targets: int) -> np.ndarray | None:
    """Return `raw_columns` as an int array after checking it against the data.

    Parameters
    ----------
    raw_columns : None, int or sequence of int
        Indices of the columns of X that hold the uncorrected value of each target column of y,
        in y's column order. None means the calibrator learns y end-to-end.
    n_features : int
        Number of columns of X.
    n_targets : int
        Number of columns of y (1 for a one-dimensional y).

    Returns
    -------
    ndarray of int, shape (n_targets,), or None

    Raises
    ------
    TypeError
        If an index is not an integer.
    ValueError
        If the number of indices differs from the number of targets, an index lies outside
        ``[0, n_features)``, or an index is repeated.
    """
    if raw_columns is None:
        return None
    if isinstance(raw_columns, numbers.Integral) and not isinstance(raw_columns, bool):
        entries = [raw_columns]
    elif isinstance(raw_columns, (Sequence, np.ndarray)) and not isinstance(raw_columns, str):
        entries = list(raw_columns)
    else:
        raise TypeError(
            f"raw_columns must be None, an int or a sequence of ints; got {raw_columns!r}."
        )
    for index in entries:
        if not isinstance(index, numbers.Integral) or isinstance(index, bool):
            raise TypeError(f"raw_columns must hold integers; got {index!r}.")
    if len(entries) != n_targets:
        raise ValueError(
            f"raw_columns has {len(entries)} entries but y has {n_targets} target column(s); "
            "give one column of X per target."
        )
    columns = np.asarray(entries, dtype=np.intp)
    out_of_range = columns[(columns < 0) | (columns >= n_features)]
    if out_of_range.size:
        raise ValueError(
            f"raw_columns index {int(out_of_range[0])} is out of range for X with "
            f"{n_features} feature(s); indices must lie in [0, {n_features})."
        )
    unique, counts = np.unique(columns, return_counts=True)
    if np.any(counts > 1):
        raise ValueError(
            f"raw_columns repeats column {int(unique[counts > 1][0])} "
            f"({[int(c) for c in columns]}); each target needs its own column of X holding "
            "its uncorrected value."
        )
    return columns


def check_n_samples(estimator: str, n_samples: int, needed: int, reason: str) -> None:
    """Raise a ValueError if `n_samples` rows are fewer than the `needed` ones.

    Parameters
    ----------
    estimator : str
        Name of the calibrator, for the message.
    n_samples : int
        Rows of X given to `fit`.
    needed : int
        Smallest number of rows the calibrator can be fitted on.
    reason : str
        Why, e.g. "to determine its 17 parameters per target (16 weights and an intercept)".
    """
    if n_samples < needed:
        plural = "" if n_samples == 1 else "s"
        raise ValueError(
            f"{estimator} needs at least {needed} samples {reason}; got {n_samples} "
            f"sample{plural}."
        )


def check_positive_int(value, name: str, minimum: int = 1) -> int:
    """Return `value` as int if it is an integer >= `minimum`, else raise."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool):
        raise TypeError(f"{name} must be an integer; got {value!r}.")
    if value < minimum:
        raise ValueError(f"{name} must be >= {minimum}; got {value}.")
    return int(value)


def check_n_threads(value) -> int | None:
    """Return `n_threads` (None: leave the library's setting) if it is None or an int >= 1."""
    return None if value is None else check_positive_int(value, "n_threads")


def check_verbose(value) -> int:
    """Return `verbose` as int if it is an integer (or bool) >= 0, scikit-learn's convention."""
    if isinstance(value, bool):
        return int(value)
    return check_positive_int(value, "verbose", minimum=0)


def check_non_negative_float(value, name: str) -> float:
    """Return `value` as float if it is a finite real >= 0, else raise."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"{name} must be a real number; got {value!r}.")
    if not np.isfinite(value) or value < 0:
        raise ValueError(f"{name} must be finite and >= 0; got {value}.")
    return float(value)


def check_open_interval(value, name: str, low: float, high: float) -> float:
    """Return `value` as float if ``low < value < high``, else raise."""
    if not isinstance(value, numbers.Real) or isinstance(value, bool):
        raise TypeError(f"{name} must be a real number; got {value!r}.")
    if not low < value < high:
        raise ValueError(f"{name} must lie in ({low}, {high}); got {value}.")
    return float(value)


def check_choice(value, name: str, choices: Sequence[str]) -> str:
    """Return `value` if it is one of `choices`, else raise."""
    if value not in choices:
        raise ValueError(f"{name} must be one of {sorted(choices)}; got {value!r}.")
    return value


def check_layer_sizes(value, name: str) -> tuple[int, ...]:
    """Return a tuple of positive layer widths (may be empty for no hidden layer)."""
    if isinstance(value, numbers.Integral) and not isinstance(value, bool):
        value = (value,)
    if not isinstance(value, (Sequence, np.ndarray)) or isinstance(value, str):
        raise TypeError(f"{name} must be a sequence of positive integers; got {value!r}.")
    return tuple(check_positive_int(width, f"{name} entries") for width in value)


def check_bounds(value, name: str) -> tuple[float, float]:
    """Return a (low, high) pair with ``0 < low <= high < inf``."""
    try:
        low, high = (float(v) for v in value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a pair (low, high); got {value!r}.") from None
    if not (0 < low <= high < np.inf):
        raise ValueError(f"{name} must satisfy 0 < low <= high < inf; got {value!r}.")
    return low, high
