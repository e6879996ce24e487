"""Box of the positioning joints inside which a calibration motion runs, and its normalization."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def _bound(values, name: str) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.shape != (3,):
        raise ValueError(
            f"workspace {name} must have 3 entries (joint 1 rad, joint 2 rad, joint 3 m), "
            f"got shape {array.shape}"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"workspace {name} must be finite, got {array}")
    return array


@dataclass(frozen=True)
class Workspace:
    """Axis-aligned box of the positioning joints, SI units.

    Zig-zag paths are built in the normalized workspace, where each joint runs from 0 at
    ``lower`` to 1 at ``upper``; path speeds are measured there too.

    Attributes
    ----------
    lower, upper : tuple of float, length 3
        Bounds of (joint 1 rad, joint 2 rad, joint 3 m); ``lower < upper`` element-wise.

    Raises
    ------
    ValueError
        If a bound has the wrong length, is not finite, or ``lower >= upper`` for a joint.
    """

    lower: tuple[float, float, float]
    upper: tuple[float, float, float]

    def __post_init__(self) -> None:
        lower = _bound(self.lower, "lower")
        upper = _bound(self.upper, "upper")
        if not np.all(lower < upper):
            raise ValueError(f"workspace lower bounds {lower} must be below upper bounds {upper}")
        object.__setattr__(self, "lower", tuple(float(v) for v in lower))
        object.__setattr__(self, "upper", tuple(float(v) for v in upper))

    @property
    def span(self) -> np.ndarray:
        """``upper - lower`` per joint (rad, rad, m), shape (3,)."""
        return np.subtract(self.upper, self.lower)

    @property
    def center(self) -> np.ndarray:
        """Centre of the box (rad, rad, m), shape (3,)."""
        return 0.5 * np.add(self.upper, self.lower)

    def normalize(self, q) -> np.ndarray:
        """Map joint positions (..., 3) in SI to the unit box: 0 at ``lower``, 1 at ``upper``."""
        return (np.asarray(q, dtype=float) - np.asarray(self.lower)) / self.span

    def denormalize(self, x) -> np.ndarray:
        """Inverse of :meth:`normalize`: unit-box coordinates (..., 3) to SI joint positions."""
        return np.asarray(self.lower) + np.asarray(x, dtype=float) * self.span

    def contains(self, q, tolerance: float = 0.0) -> bool:
        """Whether every joint position (..., 3) lies in the box widened by ``tolerance`` (SI)."""
        q = np.asarray(q, dtype=float)
        lower = np.asarray(self.lower) - tolerance
        upper = np.asarray(self.upper) + tolerance
        return bool(np.all(q >= lower) and np.all(q <= upper))


CALIBRATION_WORKSPACE = Workspace(
    lower=(float(np.deg2rad(20.0)), float(np.deg2rad(55.0)), 0.33),
    upper=(float(np.deg2rad(60.0)), float(np.deg2rad(110.0)), 0.42),
)
"""The paper's calibration box: joint 1 20..60 deg, joint 2 55..110 deg, joint 3 0.33..0.42 m
(``traj_generator/run_snake_generator.py`` of ``uw-biorobotics/raven2_CRTK_Python_controller``; the
random test motion uses the same soft limits)."""


def resolve_workspace(workspace: Workspace | None) -> Workspace:
    """Return ``workspace``, or :data:`CALIBRATION_WORKSPACE` when it is None."""
    if workspace is None:
        return CALIBRATION_WORKSPACE
    if not isinstance(workspace, Workspace):
        raise TypeError(f"workspace must be a Workspace, got {type(workspace).__name__}")
    return workspace
