"""Timing of a path of the positioning joints: constant speed along it, corners blended.

The speed is the Euclidean speed in the normalized workspace (each joint 0..1 over its range, see
:class:`~simulation.trajectories.Workspace`): at 0.063 /s a lane along joint 1 alone sweeps 6.3 %
of joint 1's range per second, a lane along the joint 2-3 diagonal sweeps 4.5 % of each range.
Every zig-zag direction has the same length in these units
(:func:`~simulation.trajectories.zigzag_length`), so one speed gives all directions of a sparsity
the same duration.

Corners of the path (the zig-zag turns by 90 deg between lanes and connecting segments) would
need infinite acceleration at constant speed. The timed path is therefore smoothed by a moving
average over ``blend_time``: for straight segments longer than the window this is exactly a
parabolic blend at every corner (linear segments with parabolic blends), velocity ramps linearly
through each corner within one window, the acceleration stays below ``speed * sqrt(2) /
blend_time`` (normalized), the speed never exceeds ``speed``, and the motion starts and ends at
rest (the window adds ``blend_time`` to the duration). Averaging passes a right-angle corner at
``speed * blend_time * sqrt(2) / 8`` from its vertex (0.011 normalized with the defaults, a ninth
of the lane spacing at sparsity 1/6) and keeps every point inside the convex hull of the path,
so inside the workspace. Positions and velocities are evaluated in closed form (the average of a
piecewise-linear motion), so ``qd`` is the exact derivative of ``q``.
"""

from __future__ import annotations

import numpy as np

from simulation.trajectories.joint_trajectory import DEFAULT_RATE, STORAGE_DTYPE, JointTrajectory
from simulation.trajectories.poses import HOME_TOOL_POSE, N_DOF, N_POSITIONING, tool_pose
from simulation.trajectories.workspace import Workspace, resolve_workspace

DEFAULT_SPEED = 0.063
"""Path speed (normalized workspace units per second). Chosen so that following the zig-zags of
sparsity 1/6, 1/4 and 1/3 of one direction takes 1002 s in total (the paper's longest calibration
combination took 1013 s). Along a J2-J3 lane this moves joint 2 at 2.45 deg/s and joint 3 at
4.0 mm/s, inside the published follower's limits (3 deg/s, 5 mm/s)."""

DEFAULT_BLEND_TIME = 1.0
"""Width of the moving average that blends corners (s)."""

_VERTEX_TOLERANCE = 1e-12
"""Consecutive path points closer than this (normalized) are one point."""


def _validated_path(path, workspace: Workspace) -> np.ndarray:
    points = np.asarray(path, dtype=float)
    if points.ndim != 2 or points.shape[1] != N_POSITIONING or points.shape[0] < 2:
        raise ValueError(
            f"path must have shape (N >= 2, 3) (joint 1 rad, joint 2 rad, joint 3 m), got {points.shape}"
        )
    if not np.all(np.isfinite(points)):
        raise ValueError("path must be finite")
    if not workspace.contains(points, tolerance=1e-9):
        raise ValueError(
            f"path leaves the workspace [{np.round(workspace.lower, 4)}, {np.round(workspace.upper, 4)}] "
            "(SI units: rad, rad, m); pass the workspace it was built for"
        )
    return points


def _positive(value: float, name: str) -> float:
    value = float(value)
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value}")
    return value


class _TimedPolyline:
    """Piecewise-linear motion through normalized points at constant speed, held at both ends.

    Offers the position ``x(tau)`` and its running integral ``X(tau) = int_0^tau x`` in closed
    form, relative to the first point to keep the integral small.
    """

    def __init__(self, points: np.ndarray, speed: float) -> None:
        steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
        keep = np.concatenate([[True], steps > _VERTEX_TOLERANCE])
        self.origin = points[0]
        self.points = points[keep] - self.origin
        if self.points.shape[0] < 2:
            raise ValueError("path has zero length: all points coincide")
        lengths = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        self.knots = np.concatenate([[0.0], np.cumsum(lengths)]) / speed
        self.durations = np.diff(self.knots)
        segment_integrals = 0.5 * (self.points[:-1] + self.points[1:]) * self.durations[:, None]
        self.integral_at_knots = np.concatenate([np.zeros((1, 3)), np.cumsum(segment_integrals, axis=0)])

    @property
    def end_time(self) -> float:
        return float(self.knots[-1])

    def _locate(self, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        index = np.clip(np.searchsorted(self.knots, tau, side="right") - 1, 0, self.durations.size - 1)
        elapsed = np.clip(tau - self.knots[index], 0.0, self.durations[index])
        return index, elapsed

    def position(self, tau: np.ndarray) -> np.ndarray:
        index, elapsed = self._locate(tau)
        slope = (self.points[index + 1] - self.points[index]) / self.durations[index, None]
        return self.points[index] + slope * elapsed[:, None]

    def integral(self, tau: np.ndarray) -> np.ndarray:
        index, elapsed = self._locate(tau)
        slope = (self.points[index + 1] - self.points[index]) / self.durations[index, None]
        inside = (
            self.integral_at_knots[index]
            + self.points[index] * elapsed[:, None]
            + 0.5 * slope * (elapsed**2)[:, None]
        )
        after_end = np.maximum(tau - self.end_time, 0.0)
        return inside + self.points[-1] * after_end[:, None]


def follow(
    path,
    speed: float = DEFAULT_SPEED,
    rate: float = DEFAULT_RATE,
    tool=HOME_TOOL_POSE,
    workspace: Workspace | None = None,
    blend_time: float = DEFAULT_BLEND_TIME,
    label: str = "",
) -> JointTrajectory:
    """Time a path of the positioning joints at constant speed, with blended corners.

    Parameters
    ----------
    path : array_like, shape (N, 3)
        Joint positions ``[joint 1 rad, joint 2 rad, joint 3 m]`` in order, e.g. from
        :func:`zigzag`; all inside ``workspace``.
    speed : float
        Speed along the path in normalized workspace units per second (see the module text).
    rate : float
        Sampling rate of the result (Hz).
    tool : array_like, shape (4,)
        Fixed ``(tool_rot, wrist, grasp1, grasp2)`` (rad); default the controller's home pose.
    workspace : Workspace, optional
        Box that defines the normalized units; default the calibration workspace.
    blend_time : float
        Width of the corner-blending moving average (s); adds ``blend_time`` to the duration.
    label : str
        Label of the result.

    Returns
    -------
    JointTrajectory
        Starts at rest at ``path[0]``, ends at rest at ``path[-1]``, lasts
        ``length / speed + blend_time`` rounded up to a whole sample; tool DOFs constant.

    Raises
    ------
    ValueError
        On a path of wrong shape, non-finite, of zero length or outside ``workspace``; on a
        non-positive speed, rate or blend time; on a tool pose outside the tool limits.
    """
    space = resolve_workspace(workspace)
    points = _validated_path(path, space)
    speed = _positive(speed, "speed")
    rate = _positive(rate, "rate")
    blend_time = _positive(blend_time, "blend_time")
    tool = tool_pose(tool)

    motion = _TimedPolyline(space.normalize(points), speed)
    n_samples = int(np.ceil((motion.end_time + blend_time) * rate)) + 1
    t = np.arange(n_samples) / rate
    averaged = (motion.integral(t) - motion.integral(t - blend_time)) / blend_time
    rate_of_change = (motion.position(t) - motion.position(t - blend_time)) / blend_time

    q = np.empty((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    qd = np.zeros((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    q[:, :N_POSITIONING] = space.denormalize(motion.origin + averaged)
    q[:, N_POSITIONING:] = tool
    qd[:, :N_POSITIONING] = rate_of_change * space.span
    return JointTrajectory(t, q, qd, rate, label)
