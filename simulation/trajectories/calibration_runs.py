"""Timed zig-zag calibration runs: the trajectories the paper recorded its training data on."""

from __future__ import annotations

from simulation.trajectories.composition import concatenate
from simulation.trajectories.joint_trajectory import DEFAULT_RATE, JointTrajectory
from simulation.trajectories.path_following import DEFAULT_BLEND_TIME, DEFAULT_SPEED, follow
from simulation.trajectories.poses import HOME_TOOL_POSE
from simulation.trajectories.workspace import Workspace
from simulation.trajectories.zigzag import lanes_per_axis, zigzag

PAPER_SPARSITIES = (1 / 6, 1 / 4, 1 / 3)
"""Sparsities combined in the paper's longest calibration run (1013 s)."""


def zigzag_label(direction: str, sparsity: float) -> str:
    """Segment label of a zig-zag run, e.g. ``"zigzag J2-J3 s=1/3"``."""
    return f"zigzag {direction} s=1/{lanes_per_axis(sparsity) - 1}"


def zigzag_trajectory(
    direction: str,
    sparsity: float,
    workspace: Workspace | None = None,
    speed: float = DEFAULT_SPEED,
    rate: float = DEFAULT_RATE,
    tool=HOME_TOOL_POSE,
    blend_time: float = DEFAULT_BLEND_TIME,
) -> JointTrajectory:
    """The zig-zag path of ``direction`` and ``sparsity`` followed at ``speed``.

    See :func:`~simulation.trajectories.zigzag` and :func:`~simulation.trajectories.follow` for
    the parameters; the result is labelled by :func:`zigzag_label`.
    """
    path = zigzag(direction, sparsity, workspace)
    return follow(path, speed, rate, tool, workspace, blend_time, label=zigzag_label(direction, sparsity))


def calibration_run(
    direction: str,
    sparsities=PAPER_SPARSITIES,
    workspace: Workspace | None = None,
    speed: float = DEFAULT_SPEED,
    rate: float = DEFAULT_RATE,
    tool=HOME_TOOL_POSE,
    blend_time: float = DEFAULT_BLEND_TIME,
) -> JointTrajectory:
    """Zig-zag runs of one direction at several sparsities, joined by go-to transitions.

    Returns
    -------
    JointTrajectory
        Segments ``"zigzag <direction> s=1/<n>"`` in the order of ``sparsities``, with ``"go_to"``
        segments between runs that do not end where the next one starts.
    """
    runs = [zigzag_trajectory(direction, s, workspace, speed, rate, tool, blend_time) for s in sparsities]
    if not runs:
        raise ValueError("calibration_run needs at least one sparsity")
    return concatenate(*runs, label=f"calibration {direction}")
