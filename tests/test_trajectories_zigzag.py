"""Zig-zag calibration paths: volume, lanes, length, step, workspace, published structure."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from simulation.trajectories import (
    CALIBRATION_WORKSPACE,
    CUBE_SIDE,
    DEFAULT_STEP,
    DIRECTIONS,
    Workspace,
    lanes_per_axis,
    zigzag,
    zigzag_length,
    zigzag_normalized,
)

SPARSITIES = (1 / 2, 1 / 3, 1 / 4, 1 / 6)


def straight_runs(points: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Split a polyline into maximal straight runs; returns (start point, end point) of each."""
    steps = np.diff(points, axis=0)
    units = steps / np.linalg.norm(steps, axis=1, keepdims=True)
    turns = np.flatnonzero(np.linalg.norm(np.diff(units, axis=0), axis=1) > 1e-6) + 1
    bounds = np.concatenate([[0], turns, [len(steps)]])
    return [(points[a], points[b]) for a, b in zip(bounds[:-1], bounds[1:])]


def lanes(points: np.ndarray, lane_length: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Straight runs as long as a lane (within 1 %)."""
    runs = straight_runs(points)
    return [(a, b) for a, b in runs if abs(np.linalg.norm(b - a) - lane_length) < 0.01 * lane_length]


def path_length(points: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_every_direction_covers_the_same_volume_around_the_same_centre(direction):
    points = zigzag_normalized(direction, 1 / 3)
    hull = ConvexHull(points)
    assert hull.volume == pytest.approx(3.0**-1.5, rel=1e-6)
    vertices = points[hull.vertices]
    np.testing.assert_allclose(0.5 * (vertices.min(axis=0) + vertices.max(axis=0)), 0.5, atol=1e-9)


@pytest.mark.parametrize(
    ("direction", "expected_span"),
    [
        ("J1", [1, 1, 1]),
        ("J2", [1, 1, 1]),
        ("J3", [1, 1, 1]),
        ("J1-J2", [np.sqrt(2), np.sqrt(2), 1]),
        ("J2-J3", [1, np.sqrt(2), np.sqrt(2)]),
        ("J1-J3", [np.sqrt(2), 1, np.sqrt(2)]),
    ],
)
def test_per_joint_span_is_the_edge_or_face_diagonal_of_the_cube(direction, expected_span):
    points = zigzag_normalized(direction, 1 / 4)
    span = points.max(axis=0) - points.min(axis=0)
    np.testing.assert_allclose(span, np.array(expected_span) / np.sqrt(3), atol=1e-9)


def test_triple_direction_spans_close_to_the_whole_workspace():
    points = zigzag_normalized("J1-J2-J3", 1 / 4)
    span = points.max(axis=0) - points.min(axis=0)
    assert span.max() == pytest.approx(1.0, abs=1e-9)
    assert np.all(span > 0.9)


@pytest.mark.parametrize(
    ("direction", "moving"),
    [
        ("J1", [0]),
        ("J2", [1]),
        ("J3", [2]),
        ("J1-J2", [0, 1]),
        ("J2-J3", [1, 2]),
        ("J1-J3", [0, 2]),
        ("J1-J2-J3", [0, 1, 2]),
    ],
)
def test_lanes_move_exactly_the_named_joints_equally(direction, moving):
    points = zigzag_normalized(direction, 1 / 2)
    found = lanes(points, CUBE_SIDE)
    assert len(found) == 9
    for start, stop in found:
        change = np.abs(stop - start)
        still = [j for j in range(3) if j not in moving]
        np.testing.assert_allclose(change[still], 0.0, atol=1e-12)
        np.testing.assert_allclose(change[moving], CUBE_SIDE / np.sqrt(len(moving)), rtol=1e-9)


@pytest.mark.parametrize("direction", ["J1", "J2-J3", "J1-J2-J3"])
@pytest.mark.parametrize("sparsity", SPARSITIES)
def test_lane_count_and_path_length_follow_the_sparsity(direction, sparsity):
    points = zigzag_normalized(direction, sparsity)
    n_lanes = len(lanes(points, CUBE_SIDE))
    per_axis = round(1 / sparsity) + 1
    assert n_lanes == per_axis**2
    # every lane, plus one inner sweep per outer level and one outer sweep, each a cube side long
    expected = (n_lanes + np.sqrt(n_lanes) + 1) * CUBE_SIDE
    assert path_length(points) == pytest.approx(expected, rel=1e-9)
    assert zigzag_length(sparsity) == pytest.approx(expected, rel=1e-12)


def test_path_length_grows_with_the_number_of_lanes():
    lengths = [path_length(zigzag_normalized("J1-J3", s)) for s in SPARSITIES]
    assert np.all(np.diff(lengths) > 0)


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_consecutive_points_are_at_most_one_step_apart(direction):
    points = zigzag_normalized(direction, 1 / 6)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    assert steps.max() <= DEFAULT_STEP * CUBE_SIDE * (1 + 1e-9)
    assert steps.min() > 0.5 * DEFAULT_STEP * CUBE_SIDE


@pytest.mark.parametrize("direction", DIRECTIONS)
def test_all_points_lie_inside_the_workspace(direction):
    narrow = Workspace(lower=(0.5, 1.0, 0.30), upper=(0.6, 1.5, 0.35))
    for space in (CALIBRATION_WORKSPACE, narrow):
        path = zigzag(direction, 1 / 3, space)
        assert np.all(path >= np.array(space.lower)) and np.all(path <= np.array(space.upper))
        np.testing.assert_allclose(space.normalize(path), zigzag_normalized(direction, 1 / 3), atol=1e-12)


def test_j1_at_half_sparsity_is_the_published_snake():
    points = zigzag_normalized("J1", 1 / 2)
    found = lanes(points, CUBE_SIDE)
    low, high = 0.5 - CUBE_SIDE / 2, 0.5 + CUBE_SIDE / 2
    middle = 0.5
    # joint 2 stepped inside joint 3, reversing after each joint 3 step; joint 1 alternates
    expected_j2_j3 = [
        (low, low), (middle, low), (high, low),
        (high, middle), (middle, middle), (low, middle),
        (low, high), (middle, high), (high, high),
    ]  # fmt: skip
    np.testing.assert_allclose([a[1:] for a, _ in found], expected_j2_j3, atol=1e-12)
    np.testing.assert_allclose([np.sign(b[0] - a[0]) for a, b in found], [1, -1] * 4 + [1])
    np.testing.assert_allclose(points[0], [low, low, low], atol=1e-12)
    np.testing.assert_allclose(points[-1], [high, high, high], atol=1e-12)


# Lanes of the published generator's paths, (start, end) of each straight run one cube side long,
# in normalized coordinates (CALIBRATION_WORKSPACE.normalize), rounded to 1e-6. Read from
# traj_generator/generated_trajs/<file> of github.com/uw-biorobotics/raven2_CRTK_Python_controller
# (commit c83e669a15029d99f9d5574686b8b4d002eb7f7e) with `lanes(path, CUBE_SIDE)` below; the
# first lane starts at the path's first point.
PUBLISHED_LANES = {
    "zigzag_traj_dir_x_0.3333.csv": (
        (0.211325, 0.211325, 0.211325), (0.788675, 0.211325, 0.211325),
        (0.788675, 0.404160, 0.211325), (0.211325, 0.404160, 0.211325),
        (0.211325, 0.596995, 0.211325), (0.788675, 0.596995, 0.211325),
        (0.788675, 0.789830, 0.211325), (0.211325, 0.789830, 0.211325),
        (0.211325, 0.789830, 0.404160), (0.788675, 0.789830, 0.404160),
        (0.788675, 0.596995, 0.404160), (0.211325, 0.596995, 0.404160),
        (0.211325, 0.404160, 0.404160), (0.788675, 0.404160, 0.404160),
        (0.788675, 0.211325, 0.404160), (0.211325, 0.211325, 0.404160),
        (0.211325, 0.211325, 0.596995), (0.788675, 0.211325, 0.596995),
        (0.788675, 0.404160, 0.596995), (0.211325, 0.404160, 0.596995),
        (0.211325, 0.596995, 0.596995), (0.788675, 0.596995, 0.596995),
        (0.788675, 0.789830, 0.596995), (0.211325, 0.789830, 0.596995),
        (0.211325, 0.789830, 0.789830), (0.788675, 0.789830, 0.789830),
        (0.788675, 0.596995, 0.789830), (0.211325, 0.596995, 0.789830),
        (0.211325, 0.404160, 0.789830), (0.788675, 0.404160, 0.789830),
        (0.788675, 0.211325, 0.789830), (0.211325, 0.211325, 0.789830),
    ),
    "zigzag_traj_dir_x_0.25.csv": (
        (0.211325, 0.211325, 0.211325), (0.788675, 0.211325, 0.211325),
        (0.788675, 0.355662, 0.211325), (0.211325, 0.355662, 0.211325),
        (0.211325, 0.500000, 0.211325), (0.788675, 0.500000, 0.211325),
        (0.788675, 0.644338, 0.211325), (0.211325, 0.644338, 0.211325),
        (0.211325, 0.788675, 0.211325), (0.788675, 0.788675, 0.211325),
        (0.788675, 0.788675, 0.355662), (0.211325, 0.788675, 0.355662),
        (0.211325, 0.644338, 0.355662), (0.788675, 0.644338, 0.355662),
        (0.788675, 0.500000, 0.355662), (0.211325, 0.500000, 0.355662),
        (0.211325, 0.355662, 0.355662), (0.788675, 0.355662, 0.355662),
        (0.788675, 0.211325, 0.355662), (0.211325, 0.211325, 0.355662),
        (0.211325, 0.211325, 0.500000), (0.788675, 0.211325, 0.500000),
        (0.788675, 0.355662, 0.500000), (0.211325, 0.355662, 0.500000),
        (0.211325, 0.500000, 0.500000), (0.788675, 0.500000, 0.500000),
        (0.788675, 0.644338, 0.500000), (0.211325, 0.644338, 0.500000),
        (0.211325, 0.788675, 0.500000), (0.788675, 0.788675, 0.500000),
        (0.788675, 0.788675, 0.644338), (0.211325, 0.788675, 0.644338),
        (0.211325, 0.644338, 0.644338), (0.788675, 0.644338, 0.644338),
        (0.788675, 0.500000, 0.644338), (0.211325, 0.500000, 0.644338),
        (0.211325, 0.355662, 0.644338), (0.788675, 0.355662, 0.644338),
        (0.788675, 0.211325, 0.644338), (0.211325, 0.211325, 0.644338),
        (0.211325, 0.211325, 0.788675), (0.788675, 0.211325, 0.788675),
        (0.788675, 0.355662, 0.788675), (0.211325, 0.355662, 0.788675),
        (0.211325, 0.500000, 0.788675), (0.788675, 0.500000, 0.788675),
        (0.788675, 0.644338, 0.788675), (0.211325, 0.644338, 0.788675),
        (0.211325, 0.788675, 0.788675), (0.788675, 0.788675, 0.788675),
    ),
    "zigzag_traj_dir_xy_0.3333.csv": (
        (0.500000, 0.091752, 0.211325), (0.908248, 0.500000, 0.211325),
        (0.771893, 0.636355, 0.211325), (0.363645, 0.228107, 0.211325),
        (0.227290, 0.364462, 0.211325), (0.635538, 0.772710, 0.211325),
        (0.499184, 0.909065, 0.211325), (0.090935, 0.500816, 0.211325),
        (0.090935, 0.500816, 0.404160), (0.499184, 0.909065, 0.404160),
        (0.635538, 0.772710, 0.404160), (0.227290, 0.364462, 0.404160),
        (0.363645, 0.228107, 0.404160), (0.771893, 0.636355, 0.404160),
        (0.908248, 0.500000, 0.404160), (0.500000, 0.091752, 0.404160),
        (0.500000, 0.091752, 0.596995), (0.908248, 0.500000, 0.596995),
        (0.771893, 0.636355, 0.596995), (0.363645, 0.228107, 0.596995),
        (0.227290, 0.364462, 0.596995), (0.635538, 0.772710, 0.596995),
        (0.499184, 0.909065, 0.596995), (0.090935, 0.500816, 0.596995),
        (0.090935, 0.500816, 0.789830), (0.499184, 0.909065, 0.789830),
        (0.635538, 0.772710, 0.789830), (0.227290, 0.364462, 0.789830),
        (0.363645, 0.228107, 0.789830), (0.771893, 0.636355, 0.789830),
        (0.908248, 0.500000, 0.789830), (0.500000, 0.091752, 0.789830),
    ),
}
PUBLISHED_ROUNDING = 1e-6


def published_lanes(name: str) -> list[tuple[np.ndarray, np.ndarray]]:
    flat = np.asarray(PUBLISHED_LANES[name], dtype=float)
    return [(start, end) for start, end in zip(flat[0::2], flat[1::2])]


@pytest.mark.parametrize(
    ("file_name", "direction", "sparsity"),
    [
        ("zigzag_traj_dir_x_0.3333.csv", "J1", 0.3333),
        ("zigzag_traj_dir_x_0.25.csv", "J1", 0.25),
        ("zigzag_traj_dir_xy_0.3333.csv", "J1-J2", 0.3333),
    ],
)
def test_matches_the_lanes_of_the_published_generator(file_name, direction, sparsity):
    published = published_lanes(file_name)
    ours = zigzag_normalized(direction, sparsity)
    our_lanes = lanes(ours, CUBE_SIDE)
    assert len(our_lanes) == len(published) == lanes_per_axis(sparsity) ** 2
    # the published generator accumulates 1e-3 steps, so its lanes sit up to 0.002 cube sides off
    np.testing.assert_allclose(
        [a for a, _ in our_lanes], [a for a, _ in published], atol=0.003 * CUBE_SIDE
    )
    np.testing.assert_allclose(
        [b for _, b in our_lanes], [b for _, b in published], atol=0.003 * CUBE_SIDE
    )
    np.testing.assert_allclose(ours[0], published[0][0], atol=PUBLISHED_ROUNDING)


@pytest.mark.parametrize("direction", ["J4", "j1", "dir_x", "J3-J1", ""])
def test_unknown_direction_is_rejected(direction):
    with pytest.raises(ValueError, match="unknown zig-zag direction"):
        zigzag(direction, 1 / 3)


@pytest.mark.parametrize("sparsity", [0.0, -0.25, 1.5, float("nan"), float("inf")])
def test_sparsity_outside_unit_interval_is_rejected(sparsity):
    with pytest.raises(ValueError, match=r"sparsity must be a number in \(0, 1\]"):
        zigzag("J1", sparsity)


@pytest.mark.parametrize("sparsity", [0.3, 0.4, 0.15])
def test_sparsity_that_is_not_one_over_an_integer_is_rejected(sparsity):
    with pytest.raises(ValueError, match="1/n for an integer n"):
        zigzag("J1", sparsity)


def test_published_rounded_sparsities_are_read_as_exact_fractions():
    assert lanes_per_axis(0.3333) == lanes_per_axis(1 / 3) == 4
    assert lanes_per_axis(0.1666) == lanes_per_axis(1 / 6) == 7


def test_step_larger_than_the_lane_spacing_is_rejected():
    with pytest.raises(ValueError, match="step must be in"):
        zigzag("J1", 1 / 4, step=0.3)


@pytest.mark.parametrize(
    ("lower", "upper", "message"),
    [
        ((np.nan, 1.0, 0.33), (1.0, 2.0, 0.42), "finite"),
        ((0.3, 1.0, 0.33), (1.0, 2.0, np.inf), "finite"),
        ((0.3, 1.0, 0.42), (1.0, 2.0, 0.33), "below"),
        ((0.3, 1.0), (1.0, 2.0), "3 entries"),
    ],
)
def test_bad_workspace_is_rejected(lower, upper, message):
    with pytest.raises(ValueError, match=message):
        Workspace(lower=lower, upper=upper)


def test_workspace_of_the_wrong_type_is_rejected():
    with pytest.raises(TypeError, match="Workspace"):
        zigzag("J1", 1 / 3, workspace=((0, 0, 0), (1, 1, 1)))
