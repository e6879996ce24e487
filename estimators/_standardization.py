"""Per-column standardization that tolerates constant columns.

Real robot feature sets contain columns that never change (RAVEN-II's unused DOF slot, a joint
held still during a recording). Dividing by their zero standard deviation would produce NaN.

- Input columns that were constant during fitting carry no information a model could learn
  from: they get an infinite scale, so their standardized value is exactly 0 whatever the
  input, during training and prediction alike, and folded weights become exactly 0.
- Target columns that were constant keep a scale of 1, so the inverse map stays finite.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A column whose spread is below this fraction of its magnitude is treated as constant: the
# spread is then floating-point noise of the mean, not information.
_RELATIVE_CONSTANT_TOLERANCE = 1e3 * np.finfo(np.float64).eps


def _constant_columns(data: np.ndarray, mean: np.ndarray, spread: np.ndarray) -> np.ndarray:
    return spread <= _RELATIVE_CONSTANT_TOLERANCE * np.maximum(np.abs(mean), 1.0)


@dataclass(frozen=True)
class Standardizer:
    """Affine map ``z = (x - mean) / scale`` fitted per column.

    Attributes
    ----------
    mean : ndarray, shape (n_columns,)
        Column means, in the units of the data.
    scale : ndarray, shape (n_columns,)
        Column standard deviations; +inf for constant input columns (z = 0), 1 for constant
        target columns.
    """

    mean: np.ndarray
    scale: np.ndarray

    @classmethod
    def fit_inputs(cls, data: np.ndarray) -> "Standardizer":
        """Fit to input columns (finite 2-D array, >= 1 row): constant columns map to 0."""
        mean, spread = data.mean(axis=0), data.std(axis=0)
        return cls(mean=mean, scale=np.where(_constant_columns(data, mean, spread), np.inf, spread))

    @classmethod
    def fit_targets(cls, data: np.ndarray) -> "Standardizer":
        """Fit to target columns (finite 2-D array, >= 1 row): constant columns keep scale 1."""
        mean, spread = data.mean(axis=0), data.std(axis=0)
        return cls(mean=mean, scale=np.where(_constant_columns(data, mean, spread), 1.0, spread))

    @property
    def inverse_scale(self) -> np.ndarray:
        """1 / scale (exactly 0 for constant input columns)."""
        return 1.0 / self.scale

    def transform(self, data: np.ndarray) -> np.ndarray:
        """Standardize `data` (a new C-contiguous float64 array)."""
        return np.ascontiguousarray((data - self.mean) * self.inverse_scale)

    def inverse_transform(self, standardized: np.ndarray) -> np.ndarray:
        """Map standardized targets back to the units of the data (finite scales only)."""
        return standardized * self.scale + self.mean
