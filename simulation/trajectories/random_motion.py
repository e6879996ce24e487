"""Random back-and-forth motion of the positioning joints: the paper's 20-minute test motion.

Follows ``python_controller/run_r2_random_joint_movement.py`` of
``uw-biorobotics/raven2_CRTK_Python_controller``: joints 1, 2, 3 move independently; each sweeps
towards a random target near one end of its range (within 5 deg, 10 deg and 20 mm of the
workspace limits), then turns and sweeps towards a new random target near the other end, each
sweep at a new random velocity (1.091-3 deg/s, 1.5-4 deg/s, 2.5-7 mm/s); the first direction is
random; the tool DOFs are not commanded, so they stay at their pose. Where the published script
ramps its velocity up linearly after a turn and slows down proportionally near a target, each
sweep here has a half-sine velocity profile (a half cosine in position) whose peak is the drawn
velocity: velocity is continuous and zero at every turn, and the joint never leaves the
workspace. The last sweep of each joint is shortened (same peak velocity, proportionally shorter
travel) so that it ends at rest on the final sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.trajectories.joint_trajectory import DEFAULT_RATE, STORAGE_DTYPE, JointTrajectory
from simulation.trajectories.poses import HOME_TOOL_POSE, N_DOF, N_POSITIONING, tool_pose
from simulation.trajectories.workspace import Workspace, resolve_workspace


def _three_positive(values, name: str) -> tuple[float, float, float]:
    array = np.asarray(values, dtype=float)
    if array.shape != (N_POSITIONING,) or not np.all(np.isfinite(array) & (array > 0)):
        raise ValueError(
            f"{name} must be 3 positive finite values (joint 1, joint 2, joint 3; SI), got {values}"
        )
    return tuple(float(v) for v in array)


@dataclass(frozen=True)
class RandomMotionRanges:
    """Ranges the random motion draws from, per positioning joint, SI units.

    Attributes
    ----------
    target_band : tuple of float, length 3
        Width of the band at each end of the workspace in which targets are drawn (rad, rad, m).
    velocity_low, velocity_high : tuple of float, length 3
        Range of the peak velocity of a sweep (rad/s, rad/s, m/s).
    """

    target_band: tuple[float, float, float] = (float(np.deg2rad(5.0)), float(np.deg2rad(10.0)), 0.02)
    velocity_low: tuple[float, float, float] = (float(np.deg2rad(1.091)), float(np.deg2rad(1.5)), 0.0025)
    velocity_high: tuple[float, float, float] = (float(np.deg2rad(3.0)), float(np.deg2rad(4.0)), 0.007)

    def __post_init__(self) -> None:
        for name in ("target_band", "velocity_low", "velocity_high"):
            object.__setattr__(self, name, _three_positive(getattr(self, name), name))
        if not np.all(np.less_equal(self.velocity_low, self.velocity_high)):
            raise ValueError(
                f"velocity_low {self.velocity_low} must not exceed velocity_high {self.velocity_high}"
            )


PUBLISHED_RANDOM_RANGES = RandomMotionRanges()
"""The ranges of ``run_r2_random_joint_movement.py``."""

_CHUNK = 1 << 18
"""Samples evaluated at once, which bounds the temporary memory of hour-long motions."""


@dataclass(frozen=True)
class _Sweeps:
    """Sweeps of one joint: start times (s), start and end positions, durations (s)."""

    start_time: np.ndarray
    origin: np.ndarray
    destination: np.ndarray
    duration: np.ndarray

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        index = np.clip(np.searchsorted(self.start_time, t, side="right") - 1, 0, self.start_time.size - 1)
        phase = np.pi * np.clip((t - self.start_time[index]) / self.duration[index], 0.0, 1.0)
        travel = self.destination[index] - self.origin[index]
        position = self.origin[index] + travel * 0.5 * (1.0 - np.cos(phase))
        velocity = travel * 0.5 * np.pi / self.duration[index] * np.sin(phase)
        return position, velocity


def _draw_sweeps(rng, start, lower, upper, band, velocity_range, duration) -> _Sweeps:
    def target(direction: float) -> float:
        offset = rng.random() * band
        return upper - offset if direction > 0 else lower + offset

    rows = []
    time, position = 0.0, start
    direction = 1.0 if rng.standard_normal() >= 0 else -1.0
    while time < duration:
        goal = target(direction)
        if (goal - position) * direction <= 0:
            direction = -direction
            goal = target(direction)
        peak = rng.uniform(*velocity_range)
        sweep_time = 0.5 * np.pi * abs(goal - position) / peak
        if time + sweep_time > duration:
            goal = position + (goal - position) * (duration - time) / sweep_time
            sweep_time = duration - time
        rows.append((time, position, goal, sweep_time))
        time, position, direction = time + sweep_time, goal, -direction
    columns = np.array(rows).T
    return _Sweeps(*columns)


def _generators(seed) -> list[np.random.Generator]:
    if seed is None or isinstance(seed, bool):
        raise ValueError("seed must be an int or a numpy Generator; a random motion is always seeded")
    if not isinstance(seed, (int, np.integer, np.random.Generator)):
        raise TypeError(f"seed must be an int or a numpy Generator, got {type(seed).__name__}")
    return np.random.default_rng(seed).spawn(N_POSITIONING)


def random_sinusoidal(
    duration: float,
    seed,
    workspace: Workspace | None = None,
    ranges: RandomMotionRanges = PUBLISHED_RANDOM_RANGES,
    start=None,
    rate: float = DEFAULT_RATE,
    tool=HOME_TOOL_POSE,
    label: str = "random",
) -> JointTrajectory:
    """Random independent back-and-forth sweeps of joints 1-3 with sinusoidal velocity.

    Parameters
    ----------
    duration : float
        Length of the motion (s), rounded up to a whole sample; the paper's test motions took
        1200 s.
    seed : int or numpy.random.Generator
        Source of randomness; each joint draws from its own child stream, so the same seed gives
        the same trajectory.
    workspace : Workspace, optional
        Box the joints stay in; default the calibration workspace (the published script's soft
        limits).
    ranges : RandomMotionRanges
        Target bands and peak-velocity ranges; default the published ones.
    start : array_like, shape (3,), optional
        Starting positions of joints 1-3 (rad, rad, m) inside ``workspace``; default its centre.
    rate : float
        Sampling rate (Hz).
    tool : array_like, shape (4,)
        Fixed pose of the tool DOFs (rad); default the controller's home pose.
    label : str
        Label of the result.

    Returns
    -------
    JointTrajectory
        Starts and ends at rest; joints 1-3 stay inside ``workspace`` and below the
        ``velocity_high`` bounds; tool DOFs constant.

    Raises
    ------
    ValueError
        On a non-positive duration or rate, a missing seed, a start outside the workspace, or
        target bands wider than half the workspace (the two ends' bands would overlap).
    """
    duration = float(duration)
    if not (np.isfinite(duration) and duration > 0):
        raise ValueError(f"duration must be a positive finite number of seconds, got {duration}")
    rate = float(rate)
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"rate must be a positive finite frequency in Hz, got {rate}")
    generators = _generators(seed)
    space = resolve_workspace(workspace)
    band = np.asarray(ranges.target_band)
    if np.any(band >= 0.5 * space.span):
        raise ValueError(
            f"target bands {band} must be narrower than half the workspace span {0.5 * space.span}"
        )
    start = space.center if start is None else np.asarray(start, dtype=float)
    if start.shape != (N_POSITIONING,) or not np.all(np.isfinite(start)) or not space.contains(start):
        raise ValueError(f"start must be 3 finite joint positions inside the workspace, got {start}")
    tool = tool_pose(tool)

    n_samples = max(2, int(np.ceil(duration * rate - 1e-9)) + 1)
    t = np.arange(n_samples) / rate
    q = np.empty((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    qd = np.zeros((n_samples, N_DOF), dtype=STORAGE_DTYPE)
    for joint, rng in enumerate(generators):
        sweeps = _draw_sweeps(
            rng,
            start[joint],
            space.lower[joint],
            space.upper[joint],
            band[joint],
            (ranges.velocity_low[joint], ranges.velocity_high[joint]),
            t[-1],
        )
        for first in range(0, n_samples, _CHUNK):
            chunk = slice(first, first + _CHUNK)
            q[chunk, joint], qd[chunk, joint] = sweeps.evaluate(t[chunk])
    q[:, N_POSITIONING:] = tool
    return JointTrajectory(t, q, qd, rate, label)
