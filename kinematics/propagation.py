"""From joint errors to tool-tip errors: exact, first-order, and summary statistics.

A calibrator is judged in joint space (deg, mm) and at the tool tip. This module
turns joint estimates into tool-tip position errors with the arm's kinematics:

* :func:`tool_tip_error`: exact error, forward kinematics of the estimate minus that
  of the truth;
* :func:`linearized_tool_tip_error` and :func:`tool_tip_covariance`: first-order
  propagation through the tool-position Jacobian (``J dq`` and ``J S J^T``);
* :func:`tool_tip_rmse`: the paper's Table IV columns X, Y, Z and Dist, in metres,
  with :meth:`ToolTipRmse.in_millimetres` for reports;
* :func:`with_exact_tool_joints`: full joint vectors where only J0..J2 are estimated
  and the tool joints are taken as exact, the paper's assumption for Table IV.

Every function takes a ``robot`` (:class:`kinematics.raven_ii.RavenII`) and its
``check_limits`` argument; estimates may leave the joint range, so pass
``check_limits=False`` (or build the robot with it) to evaluate them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinematics.joint_limits import N_JOINTS, as_joint_array, as_real_array

N_POSITIONING = 3
"""J0..J2 (shoulder, elbow, insertion) position the tool tip; the others orient it."""


def _same_shape(q_true: np.ndarray, q_est: np.ndarray) -> None:
    if q_true.shape != q_est.shape:
        raise ValueError(
            f"q_true and q_est must have the same shape, got {q_true.shape} and {q_est.shape}"
        )


def tool_tip_error(robot, q_true, q_est, *, check_limits: bool | None = None) -> np.ndarray:
    """Exact tool-tip position error of estimated joints.

    Parameters
    ----------
    robot : RavenII
    q_true, q_est : array_like, shape (6,) or (N, 6)
        True and estimated controller joint vectors J (rad, m).
    check_limits : bool, optional
        Reject joints outside their range; default: the robot's setting.

    Returns
    -------
    numpy.ndarray, shape (3,) or (N, 3)
        ``p(q_est) - p(q_true)`` in base-frame axes (m).
    """
    q_true2d, single = as_joint_array(q_true, name="q_true")
    q_est2d, _ = as_joint_array(q_est, name="q_est")
    _same_shape(np.asarray(q_true), np.asarray(q_est))
    error = robot.tool_position(q_est2d, check_limits=check_limits) - robot.tool_position(
        q_true2d, check_limits=check_limits
    )
    return error[0] if single else error


def linearized_tool_tip_error(robot, q, dq, *, check_limits: bool | None = None) -> np.ndarray:
    """First-order tool-tip error ``J_v(q) dq`` of a joint error ``dq``.

    Parameters
    ----------
    robot : RavenII
    q : array_like, shape (6,) or (N, 6)
        Configurations at which to linearize (rad, m).
    dq : array_like, same shape as ``q``
        Joint errors (rad, m).
    check_limits : bool, optional
        Applies to ``q``; default: the robot's setting.

    Returns
    -------
    numpy.ndarray, shape (3,) or (N, 3)
        Tool-tip error (m), base-frame axes.
    """
    q2d, single = as_joint_array(q, name="q")
    dq2d, _ = as_joint_array(dq, name="dq")
    _same_shape(np.asarray(q), np.asarray(dq))
    jac = robot.jacobian(q2d, check_limits=check_limits)[:, :3, :]
    error = np.einsum("nij,nj->ni", jac, dq2d)
    return error[0] if single else error


def _as_covariance(covariance, n_configs: int) -> np.ndarray:
    """Validate a joint covariance; return shape (n_configs, k, k) with k in (3, 6)."""
    cov = as_real_array(covariance, "joint_covariance", "rad^2, m^2, rad m")
    if cov.ndim == 2:
        cov = np.broadcast_to(cov, (n_configs, *cov.shape))
    if cov.ndim != 3 or cov.shape[1] != cov.shape[2] or cov.shape[1] not in (
        N_POSITIONING,
        N_JOINTS,
    ):
        raise ValueError(
            "joint_covariance must have shape (k, k) or (N, k, k) with k = 3 (J0..J2) "
            f"or 6, got {np.shape(covariance)}"
        )
    if cov.shape[0] != n_configs:
        raise ValueError(
            f"joint_covariance holds {cov.shape[0]} matrices for {n_configs} configurations"
        )
    if not np.all(np.isfinite(cov)):
        raise ValueError("joint_covariance holds NaN or inf")
    scale = max(float(np.max(np.abs(cov))), np.finfo(float).tiny)
    if np.max(np.abs(cov - np.swapaxes(cov, 1, 2))) > 1e-12 * scale:
        raise ValueError("joint_covariance must be symmetric")
    if np.min(np.linalg.eigvalsh(cov)) < -1e-12 * scale:
        raise ValueError("joint_covariance must be positive semi-definite")
    return cov


def tool_tip_covariance(
    robot, q, joint_covariance, *, check_limits: bool | None = None
) -> np.ndarray:
    """First-order tool-tip position covariance ``J_v S J_v^T``.

    Parameters
    ----------
    robot : RavenII
    q : array_like, shape (6,) or (N, 6)
        Configurations (rad, m).
    joint_covariance : array_like, shape (k, k) or (N, k, k)
        Covariance of the joint errors in SI units (rad^2, m^2, rad m), either of
        all six joints (k = 6) or of J0..J2 only (k = 3, tool joints exact). One
        matrix is shared by all configurations.
    check_limits : bool, optional
        Applies to ``q``; default: the robot's setting.

    Returns
    -------
    numpy.ndarray, shape (3, 3) or (N, 3, 3)
        Tool-tip position covariance (m^2), base-frame axes.
    """
    q2d, single = as_joint_array(q, name="q")
    cov = _as_covariance(joint_covariance, q2d.shape[0])
    jac = robot.jacobian(q2d, check_limits=check_limits)[:, :3, : cov.shape[1]]
    out = jac @ cov @ np.swapaxes(jac, 1, 2)
    return out[0] if single else out


def _as_errors(errors) -> np.ndarray:
    err = as_real_array(errors, "errors", "m")
    if err.ndim != 2 or err.shape[1] != 3 or err.shape[0] == 0:
        raise ValueError(f"errors must have shape (N, 3) with N >= 1, got {err.shape}")
    if not np.all(np.isfinite(err)):
        raise ValueError("errors hold NaN or inf")
    return err


def per_axis_rmse(errors) -> np.ndarray:
    """Root-mean-square of tool-tip errors per base-frame axis.

    Parameters
    ----------
    errors : array_like, shape (N, 3)
        Tool-tip errors (m).

    Returns
    -------
    numpy.ndarray, shape (3,)
        RMSE along x, y, z (m).
    """
    err = _as_errors(errors)
    return np.sqrt(np.mean(err**2, axis=0))


def distance_rmse(errors) -> float:
    """Root-mean-square of the Euclidean tool-tip error ``sqrt(mean(|e|^2))`` (m)."""
    err = _as_errors(errors)
    return float(np.sqrt(np.mean(np.sum(err**2, axis=1))))


@dataclass(frozen=True)
class ToolTipRmse:
    """Tool-tip RMSE per axis and of the distance (the paper's Table IV columns).

    Attributes
    ----------
    x, y, z : float
        RMSE along the base-frame axes (m).
    distance : float
        RMSE of the Euclidean error (m).
    """

    x: float
    y: float
    z: float
    distance: float

    def in_millimetres(self) -> dict[str, float]:
        """The four values in mm, keyed by the Table IV column names."""
        return {
            "X": 1e3 * self.x,
            "Y": 1e3 * self.y,
            "Z": 1e3 * self.z,
            "Dist": 1e3 * self.distance,
        }


def tool_tip_rmse(errors) -> ToolTipRmse:
    """Per-axis and distance RMSE of tool-tip errors (m), shape (N, 3) input."""
    x, y, z = per_axis_rmse(errors)
    return ToolTipRmse(float(x), float(y), float(z), distance_rmse(errors))


def with_exact_tool_joints(q_positioning_est, q_true_full) -> np.ndarray:
    """Full joint vectors from estimated J0..J2 and the true tool joints J3..J5.

    Parameters
    ----------
    q_positioning_est : array_like, shape (3,) or (N, 3)
        Estimated shoulder (rad), elbow (rad), insertion (m).
    q_true_full : array_like, shape (6,) or (N, 6)
        True joint vectors; their tool joints are taken as exact.

    Returns
    -------
    numpy.ndarray, shape (6,) or (N, 6)
        A new array: the estimate in columns 0-2, the truth in columns 3-5.
    """
    est, single_est = as_joint_array(q_positioning_est, N_POSITIONING, "q_positioning_est")
    true, single_true = as_joint_array(q_true_full, N_JOINTS, "q_true_full")
    if single_est != single_true or est.shape[0] != true.shape[0]:
        raise ValueError(
            "q_positioning_est and q_true_full must hold the same number of configurations, "
            f"got shapes {np.shape(q_positioning_est)} and {np.shape(q_true_full)}"
        )
    out = true.copy()
    out[:, :N_POSITIONING] = est
    return out[0] if single_est else out
