"""Order, home pose and safe ranges of the seven DOFs a joint trajectory drives.

A trajectory sample is a vector of seven DOFs of one RAVEN-II arm, SI units:
``[shoulder rad, elbow rad, z_ins m, tool_rot rad, wrist rad, grasp1 rad, grasp2 rad]``
(:data:`simulation.model.constants.DOF_NAMES`, the controller's names).
The first three are the positioning joints (the paper's joints 1, 2, 3); the last four are the
tool DOFs, which the calibration motions hold at the controller's home angles
(``include/raven/defines.h`` of ``uw-biorobotics/raven2``).
"""

from __future__ import annotations

import numpy as np

from simulation.model.constants import DOF_NAMES

N_DOF = len(DOF_NAMES)
N_POSITIONING = 3
"""Number of positioning joints (shoulder, elbow, insertion) at the start of a DOF vector."""

TOOL_ROT_HOME = 0.0
"""TOOL_ROT_HOME_ANGLE of ``defines.h`` (rad)."""
WRIST_HOME = 0.0
"""WRIST_HOME_ANGLE of ``defines.h`` (rad)."""
GRASP_HOME = float(np.pi / 4)
"""GRASP1_HOME_ANGLE and GRASP2_HOME_ANGLE of ``defines.h``: 45 deg (rad)."""

HOME_TOOL_POSE = (TOOL_ROT_HOME, WRIST_HOME, GRASP_HOME, GRASP_HOME)
"""``(tool_rot, wrist, grasp1, grasp2)`` in rad, the pose of tool DOFs that do not move."""

HOME_POSITIONING = (float(np.pi / 6), float(np.pi / 2), 0.4)
"""SHOULDER, ELBOW and Z_INS home values of ``defines.h``: 30 deg, 90 deg, 0.4 m."""

TOOL_LIMITS = (
    (float(np.deg2rad(-182.0)), float(np.deg2rad(182.0))),
    (float(np.deg2rad(-75.0)), float(np.deg2rad(75.0))),
    (float(np.deg2rad(-89.0)), float(np.deg2rad(89.0))),
    (float(np.deg2rad(-89.0)), float(np.deg2rad(89.0))),
)
"""``(lower, upper)`` of tool_rot, wrist, grasp1, grasp2 in rad (``include/raven/tool.h``)."""


def tool_pose(tool) -> np.ndarray:
    """Validate a pose of the four tool DOFs.

    Parameters
    ----------
    tool : array_like, shape (4,)
        ``(tool_rot, wrist, grasp1, grasp2)`` in rad.

    Returns
    -------
    numpy.ndarray, shape (4,)
        The pose as float64.

    Raises
    ------
    ValueError
        If the shape is wrong, a value is not finite, or a DOF lies outside
        :data:`TOOL_LIMITS` (a degree value passed as radians is caught here).
    """
    values = np.asarray(tool, dtype=float)
    if values.shape != (len(TOOL_LIMITS),):
        raise ValueError(
            f"tool pose must have shape (4,) (tool_rot, wrist, grasp1, grasp2), got {values.shape}"
        )
    if not np.all(np.isfinite(values)):
        raise ValueError(f"tool pose must be finite, got {values}")
    for name, value, (low, high) in zip(DOF_NAMES[N_POSITIONING:], values, TOOL_LIMITS):
        if not low <= value <= high:
            raise ValueError(
                f"tool DOF {name} = {value:.4g} rad ({np.rad2deg(value):.4g} deg) is outside its "
                f"limits [{np.rad2deg(low):.0f}, {np.rad2deg(high):.0f}] deg"
            )
    return values


def full_pose(pose, tool=HOME_TOOL_POSE) -> np.ndarray:
    """Complete a DOF vector: a positioning pose gets the tool pose appended.

    Parameters
    ----------
    pose : array_like, shape (3,) or (7,)
        ``(shoulder rad, elbow rad, insertion m)``, or all seven DOFs.
    tool : array_like, shape (4,)
        Tool pose used when ``pose`` has three entries (rad); ignored otherwise.

    Returns
    -------
    numpy.ndarray, shape (7,)
        The full DOF vector, float64.

    Raises
    ------
    ValueError
        If the shape is neither (3,) nor (7,), or a value is not finite, or a tool DOF is
        outside its limits.
    """
    values = np.asarray(pose, dtype=float)
    if values.shape == (N_POSITIONING,):
        values = np.concatenate([values, tool_pose(tool)])
    elif values.shape == (N_DOF,):
        tool_pose(values[N_POSITIONING:])
    else:
        raise ValueError(f"a pose must have shape (3,) or (7,), got {values.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"pose must be finite, got {values}")
    return values
