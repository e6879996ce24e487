"""Scores of joint estimates: RMSE per joint and tool-tip RMSE, in the units of the paper's tables.

Inside, everything is SI (rad, m). The paper reports joints 1 and 2 in degrees, joint 3 in
millimetres, and tool-tip errors in millimetres; :func:`joint_rmse_report` and
:func:`cartesian_rmse_report` return exactly those. The tool-tip error follows the paper's
Table IV: forward kinematics of the corrected joints 1-3 with the recorded tool joints J3..J5
taken as exact, minus forward kinematics of the true joints 1-3 with the same tool joints.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from estimators import rmse_per_joint
from kinematics import RavenII, tool_tip_error, tool_tip_rmse, with_exact_tool_joints

from simulation.model.constants import REPORT_SCALE
from studies.common.samples import Samples

JOINT_HEADERS = ("Joint 1 (deg)", "Joint 2 (deg)", "Joint 3 (mm)")
CARTESIAN_HEADERS = ("X (mm)", "Y (mm)", "Z (mm)", "Dist (mm)")
JOINT_UNITS = ("deg", "deg", "mm")


def to_report_units(joint_values_si) -> np.ndarray:
    """Joint 1-3 quantities (rad, rad, m) in the paper's units (deg, deg, mm), shape (..., 3)."""
    values = np.asarray(joint_values_si, dtype=np.float64)
    if values.shape[-1:] != (3,):
        raise ValueError(f"expected joint 1-3 values in the last axis (size 3), got shape {values.shape}")
    return values * REPORT_SCALE


def joint_rmse_report(truth, estimate) -> np.ndarray:
    """RMSE of joints 1, 2, 3 in deg, deg, mm, from SI truth and estimate of shape (N, 3)."""
    return to_report_units(rmse_per_joint(truth, estimate))


def full_joint_vectors(positioning, tool_joints) -> np.ndarray:
    """Controller joint vectors J (N, 6) from joints 1-3 (rad, rad, m) and J3..J5 (rad)."""
    positioning = np.asarray(positioning, dtype=np.float64)
    tool_joints = np.asarray(tool_joints, dtype=np.float64)
    if positioning.ndim != 2 or positioning.shape[1] != 3 or tool_joints.shape != positioning.shape:
        raise ValueError(f"expected two (N, 3) arrays, got {positioning.shape} and {tool_joints.shape}")
    return np.hstack([positioning, tool_joints])


def cartesian_errors(robot: RavenII, truth, estimate, tool_joints) -> np.ndarray:
    """Tool-tip position errors (N, 3) in m of estimated joints 1-3, tool joints taken as exact."""
    q_true = full_joint_vectors(truth, tool_joints)
    q_est = with_exact_tool_joints(np.asarray(estimate, dtype=np.float64), q_true)
    return tool_tip_error(robot, q_true, q_est, check_limits=False)


def cartesian_rmse_report(robot: RavenII, truth, estimate, tool_joints) -> np.ndarray:
    """Tool-tip RMSE along X, Y, Z and of the distance, in mm (the paper's Table IV columns)."""
    rmse = tool_tip_rmse(cartesian_errors(robot, truth, estimate, tool_joints)).in_millimetres()
    return np.array([rmse["X"], rmse["Y"], rmse["Z"], rmse["Dist"]])


@dataclass(frozen=True)
class Scores:
    """Errors of one estimate on one set of samples, in report units.

    Attributes
    ----------
    joint : ndarray (3,)
        RMSE of joints 1, 2, 3 (deg, deg, mm).
    cartesian : ndarray (4,) or None
        Tool-tip RMSE X, Y, Z, Dist (mm); None when the samples carry no RAVEN-II tool joints.
    """

    joint: np.ndarray
    cartesian: np.ndarray | None = None


_ROBOTS: dict[str, RavenII] = {}


def raven_model(arm: str) -> RavenII:
    """The RAVEN-II kinematic model of an arm, without joint-limit checks (estimates may leave them)."""
    if arm not in _ROBOTS:
        _ROBOTS[arm] = RavenII(arm, check_limits=False)
    return _ROBOTS[arm]


def score(estimate, samples: Samples, robot: RavenII | None = None) -> Scores:
    """Joint and tool-tip RMSE of an estimate (N, 3) of the samples' joints 1-3 (SI).

    The tool-tip part needs ``samples.tool_joints``; it uses ``robot`` or the samples' arm model.
    """
    estimate = np.asarray(estimate, dtype=np.float64)
    if estimate.shape != samples.targets.shape:
        raise ValueError(f"estimate has shape {estimate.shape}, the samples' truth {samples.targets.shape}")
    joint = joint_rmse_report(samples.targets, estimate)
    if samples.tool_joints is None:
        return Scores(joint, None)
    model = robot if robot is not None else raven_model(samples.arm)
    return Scores(joint, cartesian_rmse_report(model, samples.targets, estimate, samples.tool_joints))


def mean_scores(scores: list[Scores]) -> Scores:
    """Average of scores over seeds (the paper averaged the RMSE of 5 training seeds)."""
    if not scores:
        raise ValueError("mean_scores needs at least one Scores")
    joint = np.mean([s.joint for s in scores], axis=0)
    cartesian = None if any(s.cartesian is None for s in scores) else np.mean([s.cartesian for s in scores], axis=0)
    return Scores(joint, cartesian)


def std_scores(scores: list[Scores]) -> Scores:
    """Population standard deviation of scores over seeds (zeros for one seed)."""
    if not scores:
        raise ValueError("std_scores needs at least one Scores")
    joint = np.std([s.joint for s in scores], axis=0)
    cartesian = None if any(s.cartesian is None for s in scores) else np.std([s.cartesian for s in scores], axis=0)
    return Scores(joint, cartesian)


def percentage_of(values, reference) -> np.ndarray:
    """``100 * values / reference`` (the paper's Table I percentages relative to fixed offset)."""
    values = np.asarray(values, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    if np.any(reference <= 0):
        raise ValueError("reference RMSE must be positive")
    return 100.0 * values / reference
