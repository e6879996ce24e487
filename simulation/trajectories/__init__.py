"""Desired joint motions of one RAVEN-II arm for the simulator.

Zig-zag calibration paths (paper section II-B), their timing at constant speed, the random
sinusoidal test motion, go-to and idle motions, and their concatenation into labelled scenarios.
Every motion is a :class:`JointTrajectory`: uniformly sampled positions and velocities of the
seven DOFs ``[shoulder, elbow, insertion, tool_rot, wrist, grasp1, grasp2]`` in SI units.
"""

from simulation.trajectories.calibration_runs import PAPER_SPARSITIES, calibration_run, zigzag_label, zigzag_trajectory
from simulation.trajectories.composition import JOIN_TOLERANCE, TRANSITION_LABEL, concatenate
from simulation.trajectories.joint_trajectory import DEFAULT_RATE, STORAGE_DTYPE, JointTrajectory, Segment, uniform_times
from simulation.trajectories.path_following import DEFAULT_BLEND_TIME, DEFAULT_SPEED, follow
from simulation.trajectories.point_to_point import GO_TO_ACCEL_TIME, GO_TO_GAIN, GO_TO_MAX_VELOCITY, go_to, idle
from simulation.trajectories.poses import (
    DOF_NAMES,
    GRASP_HOME,
    HOME_POSITIONING,
    HOME_TOOL_POSE,
    N_DOF,
    N_POSITIONING,
    TOOL_LIMITS,
    TOOL_ROT_HOME,
    WRIST_HOME,
    full_pose,
    tool_pose,
)
from simulation.trajectories.random_motion import PUBLISHED_RANDOM_RANGES, RandomMotionRanges, random_sinusoidal
from simulation.trajectories.workspace import CALIBRATION_WORKSPACE, Workspace
from simulation.trajectories.zigzag import (
    CUBE_SIDE,
    DEFAULT_STEP,
    DIRECTIONS,
    lane_axes,
    lanes_per_axis,
    snake_in_unit_cube,
    zigzag,
    zigzag_length,
    zigzag_normalized,
)

__all__ = [
    "CALIBRATION_WORKSPACE",
    "CUBE_SIDE",
    "DEFAULT_BLEND_TIME",
    "DEFAULT_RATE",
    "DEFAULT_SPEED",
    "DEFAULT_STEP",
    "DIRECTIONS",
    "DOF_NAMES",
    "GO_TO_ACCEL_TIME",
    "GO_TO_GAIN",
    "GO_TO_MAX_VELOCITY",
    "GRASP_HOME",
    "HOME_POSITIONING",
    "HOME_TOOL_POSE",
    "JOIN_TOLERANCE",
    "JointTrajectory",
    "N_DOF",
    "N_POSITIONING",
    "PAPER_SPARSITIES",
    "PUBLISHED_RANDOM_RANGES",
    "RandomMotionRanges",
    "STORAGE_DTYPE",
    "Segment",
    "TOOL_LIMITS",
    "TOOL_ROT_HOME",
    "TRANSITION_LABEL",
    "WRIST_HOME",
    "Workspace",
    "calibration_run",
    "concatenate",
    "follow",
    "full_pose",
    "go_to",
    "idle",
    "lane_axes",
    "lanes_per_axis",
    "random_sinusoidal",
    "snake_in_unit_cube",
    "tool_pose",
    "uniform_times",
    "zigzag",
    "zigzag_label",
    "zigzag_length",
    "zigzag_normalized",
    "zigzag_trajectory",
]
