"""Kinematic and dynamic model of the RAVEN-II surgical robot arm.

Main entry points:

* :class:`RavenII` -- Pinocchio model of one arm: ``forward_kinematics``,
  ``tool_position``, ``jacobian``, ``gravity_torques``, ``mass_matrix``,
  ``gravity_coefficients``, ``joint_limits``, ``check_joint_limits``, ``to_urdf``, ``home_pose``;
* :func:`gravity_torques_fast`, :func:`mass_matrix_fast` -- compiled (numba) closed
  forms for the 1 kHz simulator;
* :mod:`kinematics.propagation` -- joint errors to tool-tip errors.

Joint vectors are the controller's ``J`` (rad, rad, m, rad, rad, rad); see
:mod:`kinematics.joint_limits`.
"""

from kinematics.arm_parameters import (
    LinkMass,
    ModifiedDHTable,
    RavenArmParameters,
    raven_arm_parameters,
)
from kinematics.gravity_closed_form import (
    gravity_torques_fast,
    gravity_torques_fast_batch,
    mass_matrix_fast,
)
from kinematics.joint_limits import (
    CONTROLLER_JOINT_LIMITS,
    HOME_POSE,
    JOINT_NAMES,
    JOINT_UNITS,
    JointLimits,
    check_joint_limits,
)
from kinematics.mounting import DEFAULT_GRAVITY, gravity_from_accelerometer
from kinematics.propagation import (
    ToolTipRmse,
    distance_rmse,
    linearized_tool_tip_error,
    per_axis_rmse,
    tool_tip_covariance,
    tool_tip_error,
    tool_tip_rmse,
    with_exact_tool_joints,
)
from kinematics.raven_ii import RavenII

__all__ = [
    "CONTROLLER_JOINT_LIMITS",
    "DEFAULT_GRAVITY",
    "HOME_POSE",
    "JOINT_NAMES",
    "JOINT_UNITS",
    "JointLimits",
    "LinkMass",
    "ModifiedDHTable",
    "RavenArmParameters",
    "RavenII",
    "ToolTipRmse",
    "check_joint_limits",
    "distance_rmse",
    "gravity_from_accelerometer",
    "gravity_torques_fast",
    "gravity_torques_fast_batch",
    "linearized_tool_tip_error",
    "mass_matrix_fast",
    "per_axis_rmse",
    "raven_arm_parameters",
    "tool_tip_covariance",
    "tool_tip_error",
    "tool_tip_rmse",
    "with_exact_tool_joints",
]
