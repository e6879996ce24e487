"""Moves to a pose and rests at a pose: the paper's "go-to joint position" and idle motions.

The published go-to controller (``raven_py_controller.go_to_jr`` of
``uw-biorobotics/raven2_CRTK_Python_controller``) commands every DOF independently with the
velocity ``clip(gain * error, -max_velocity, max_velocity)``, gain 1 /s: constant velocity far
from the target, slowing down within ``max_velocity / gain`` of it, and stops once every DOF is
within its tolerance (1 deg, 5 mm). As a desired motion this has a velocity step at the start, an
exponential tail that never arrives, and a velocity step where it stops. :func:`go_to` keeps its
shape and makes it smooth: each DOF ramps up along a half cosine over ``accel_time``, cruises at
``max_velocity``, and slows down over the controller's slow-down distance ``max_velocity / gain``
along a half cosine (which takes ``2 / gain`` seconds), arriving exactly on the target at rest,
so within any tolerance. A move too short to reach ``max_velocity`` keeps both ramps with a lower
peak. DOFs move simultaneously and independently; each rests at its target once there.
"""

from __future__ import annotations

import numpy as np

from simulation.trajectories.joint_trajectory import DEFAULT_RATE, STORAGE_DTYPE, JointTrajectory
from simulation.trajectories.poses import HOME_TOOL_POSE, N_DOF, full_pose

GO_TO_MAX_VELOCITY = (
    float(np.deg2rad(3.0)),
    float(np.deg2rad(3.0)),
    0.01,
    float(np.deg2rad(15.0)),
    float(np.deg2rad(15.0)),
    float(np.deg2rad(15.0)),
    float(np.deg2rad(15.0)),
)
"""Cruise velocity per DOF (rad/s, insertion m/s): ``go_to_jr``'s defaults."""

GO_TO_GAIN = 1.0
"""Proportional gain of the published go-to controller (1/s); sets the slow-down distance."""

GO_TO_ACCEL_TIME = 0.5
"""Duration of the start ramp (s); the published controller starts with a velocity step."""


def _positive(value: float, name: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value}")
    return value


def _sample_count(duration: float, rate: float) -> int:
    return max(2, int(np.ceil(duration * rate - 1e-9)) + 1)


def _ramped_move(t: np.ndarray, distance: float, peak: float, accel_time: float, decel_time: float):
    """Distance covered and speed of a half-cosine ramp up, cruise, half-cosine ramp down."""
    cruise_time = max(0.0, (distance - 0.5 * peak * (accel_time + decel_time)) / peak)
    cruise_start = accel_time
    decel_start = accel_time + cruise_time
    end = decel_start + decel_time
    t = np.clip(t, 0.0, end)

    in_accel = t < cruise_start
    in_decel = t >= decel_start
    in_cruise = ~in_accel & ~in_decel
    covered = np.empty_like(t)
    speed = np.empty_like(t)

    phase = np.pi * t[in_accel] / accel_time
    covered[in_accel] = 0.5 * peak * (t[in_accel] - np.sin(phase) * accel_time / np.pi)
    speed[in_accel] = 0.5 * peak * (1.0 - np.cos(phase))

    covered[in_cruise] = 0.5 * peak * accel_time + peak * (t[in_cruise] - cruise_start)
    speed[in_cruise] = peak

    elapsed = t[in_decel] - decel_start
    phase = np.pi * elapsed / decel_time
    decel_start_covered = distance - 0.5 * peak * decel_time
    covered[in_decel] = decel_start_covered + 0.5 * peak * (elapsed + np.sin(phase) * decel_time / np.pi)
    speed[in_decel] = 0.5 * peak * (1.0 + np.cos(phase))
    return covered, speed


def go_to(
    start,
    target,
    max_velocity=GO_TO_MAX_VELOCITY,
    gain: float = GO_TO_GAIN,
    accel_time: float = GO_TO_ACCEL_TIME,
    rate: float = DEFAULT_RATE,
    tool=HOME_TOOL_POSE,
    label: str = "go_to",
) -> JointTrajectory:
    """Move every DOF from ``start`` to ``target``: cruise far away, slow down near it, stop on it.

    Parameters
    ----------
    start, target : array_like, shape (3,) or (7,)
        Poses, SI (rad, m); a positioning pose (3,) gets ``tool`` appended.
    max_velocity : array_like, shape (7,)
        Cruise velocity per DOF (rad/s, m/s); default the published controller's.
    gain : float
        Proportional gain of the controller (1/s): slowing down starts ``max_velocity / gain``
        before the target and lasts ``2 / gain`` seconds.
    accel_time : float
        Duration of the start ramp (s).
    rate : float
        Sampling rate (Hz).
    tool : array_like, shape (4,)
        Tool pose for positioning-only poses (rad).
    label : str
        Label of the result.

    Returns
    -------
    JointTrajectory
        Starts at rest on ``start``, ends at rest exactly on ``target`` (at least two samples
        even when the poses coincide). The duration is that of the slowest DOF,
        ``accel_time + cruise + 2 / gain``, rounded up to a whole sample.

    Raises
    ------
    ValueError
        On poses of wrong shape or non-finite, tool DOFs outside their limits, or non-positive
        velocities, gain, ramp time or rate.
    """
    start = full_pose(start, tool)
    target = full_pose(target, tool)
    velocity = np.asarray(max_velocity, dtype=float)
    if velocity.shape != (N_DOF,) or not np.all(np.isfinite(velocity) & (velocity > 0)):
        raise ValueError(f"max_velocity must be 7 positive finite values, got {max_velocity}")
    decel_time = 2.0 / _positive(gain, "gain")
    accel_time = _positive(accel_time, "accel_time")
    rate = _positive(rate, "rate")

    distance = np.abs(target - start)
    peak = np.minimum(velocity, 2.0 * distance / (accel_time + decel_time))
    moving = distance > 0
    ramp_time = accel_time + decel_time
    cruise = np.where(moving, np.maximum(distance / np.where(moving, peak, 1.0) - 0.5 * ramp_time, 0.0), 0.0)
    duration = float(np.max(np.where(moving, accel_time + cruise + decel_time, 0.0)))

    n_samples = _sample_count(duration, rate)
    t = np.arange(n_samples) / rate
    q = np.empty((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    qd = np.zeros((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    direction = np.sign(target - start)
    for dof in range(N_DOF):
        if not moving[dof]:
            q[:, dof] = start[dof]
            continue
        covered, speed = _ramped_move(t, distance[dof], peak[dof], accel_time, decel_time)
        q[:, dof] = start[dof] + direction[dof] * covered
        qd[:, dof] = direction[dof] * speed
    q[-1] = target
    return JointTrajectory(t, q, qd, rate, label)


def idle(
    duration: float, pose, rate: float = DEFAULT_RATE, tool=HOME_TOOL_POSE, label: str = "idle"
) -> JointTrajectory:
    """Rest at ``pose`` for ``duration`` seconds.

    Parameters
    ----------
    duration : float
        Length (s), rounded up to a whole sample; at least one sample step.
    pose : array_like, shape (3,) or (7,)
        Pose held (rad, m); a positioning pose gets ``tool`` appended.
    rate : float
        Sampling rate (Hz).
    tool : array_like, shape (4,)
        Tool pose for a positioning-only pose (rad).
    label : str
        Label of the result.

    Raises
    ------
    ValueError
        On a non-positive duration or rate, or a bad pose.
    """
    duration = _positive(duration, "duration")
    rate = _positive(rate, "rate")
    pose = full_pose(pose, tool)
    n_samples = _sample_count(duration, rate)
    q = np.empty((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    q[:] = pose
    return JointTrajectory(np.arange(n_samples) / rate, q, np.zeros_like(q), rate, label)
