"""Timing of paths: derivative consistency, rest at the ends, bounded speed, duration vs length."""

from __future__ import annotations

import numpy as np
import pytest

from simulation.trajectories import (
    CALIBRATION_WORKSPACE,
    DEFAULT_SPEED,
    HOME_TOOL_POSE,
    PAPER_SPARSITIES,
    follow,
    zigzag,
    zigzag_length,
    zigzag_trajectory,
)

SPACE = CALIBRATION_WORKSPACE


@pytest.fixture(scope="module")
def timed_zigzag():
    path = zigzag("J2-J3", 1 / 3)
    return path, follow(path, label="zigzag")


def normalized_velocity(trajectory) -> np.ndarray:
    return trajectory.qd[:, :3].astype(float) / SPACE.span


def test_velocity_is_the_derivative_of_position(timed_zigzag):
    _, trajectory = timed_zigzag
    q = trajectory.q.astype(float)
    qd = trajectory.qd.astype(float)
    h = 1.0 / trajectory.rate
    secant = np.diff(q, axis=0) / h
    trapezoid = 0.5 * (qd[1:] + qd[:-1])
    # exact inside each parabolic piece; the acceleration steps at blend edges leave O(h * jump)
    assert np.max(np.abs(secant - trapezoid)) < 5e-3 * np.abs(qd).max()
    integrated = q[0] + np.concatenate([np.zeros((1, 7)), np.cumsum(trapezoid * h, axis=0)])
    assert np.max(np.abs(integrated - q)) < 2e-5


def test_starts_and_ends_at_rest_on_the_path_ends(timed_zigzag):
    path, trajectory = timed_zigzag
    np.testing.assert_array_equal(trajectory.qd[0], 0.0)
    np.testing.assert_array_equal(trajectory.qd[-1], 0.0)
    np.testing.assert_allclose(trajectory.q[0, :3], path[0], atol=1e-6)
    np.testing.assert_allclose(trajectory.q[-1, :3], path[-1], atol=1e-6)


def test_speed_never_exceeds_and_reaches_the_set_speed(timed_zigzag):
    _, trajectory = timed_zigzag
    speed = np.linalg.norm(normalized_velocity(trajectory), axis=1)
    assert speed.max() <= DEFAULT_SPEED * (1 + 1e-6)
    assert np.mean(speed > 0.999 * DEFAULT_SPEED) > 0.8


def test_acceleration_is_bounded_by_the_corner_blend(timed_zigzag):
    _, trajectory = timed_zigzag
    acceleration = np.diff(normalized_velocity(trajectory), axis=0) * trajectory.rate
    bound = DEFAULT_SPEED * np.sqrt(2) / 1.0
    assert np.linalg.norm(acceleration, axis=1).max() <= bound * (1 + 1e-4)


def test_stays_close_to_every_corner_and_inside_the_workspace(timed_zigzag):
    path, trajectory = timed_zigzag
    assert SPACE.contains(trajectory.q[:, :3], tolerance=1e-6)
    visited = SPACE.normalize(trajectory.q[:, :3])
    steps = np.diff(SPACE.normalize(path), axis=0)
    units = steps / np.linalg.norm(steps, axis=1)[:, None]
    turns = np.flatnonzero(np.linalg.norm(np.diff(units, axis=0), axis=1) > 1e-6)
    corners = SPACE.normalize(path)[turns + 1]
    assert corners.shape[0] == 2 * 16 - 2
    distance = np.min(np.linalg.norm(visited[None, :, :] - corners[:, None, :], axis=2), axis=1)
    assert distance.max() <= DEFAULT_SPEED * 1.0 * np.sqrt(2) / 8 + 1e-4


def test_tool_dofs_rest_at_home(timed_zigzag):
    _, trajectory = timed_zigzag
    home = np.broadcast_to(HOME_TOOL_POSE, (len(trajectory), 4))
    np.testing.assert_allclose(trajectory.q[:, 3:], home, atol=1e-7)
    np.testing.assert_array_equal(trajectory.qd[:, 3:], 0.0)


@pytest.mark.parametrize("sparsity", [1 / 2, 1 / 4, 1 / 6])
def test_duration_is_length_over_speed_plus_the_blend(sparsity):
    trajectory = zigzag_trajectory("J1-J3", sparsity, speed=0.1, blend_time=0.5)
    expected = zigzag_length(sparsity) / 0.1 + 0.5
    assert expected <= trajectory.duration < expected + 1.0 / trajectory.rate + 1e-9


def test_duration_scales_with_path_length():
    straight = np.array([SPACE.lower, SPACE.upper])
    short = follow(straight, speed=0.05, blend_time=0.2)
    doubled = follow(np.vstack([straight, straight[:1]]), speed=0.05, blend_time=0.2)
    travel = np.sqrt(3.0) / 0.05
    assert short.duration == pytest.approx(travel + 0.2, abs=0.011)
    assert doubled.duration == pytest.approx(2 * travel + 0.2, abs=0.011)


def test_default_speed_times_the_paper_combination_near_1000_s():
    durations = [zigzag_trajectory("J2-J3", s).duration for s in PAPER_SPARSITIES]
    assert 950.0 < sum(durations) < 1050.0


def test_path_given_in_degrees_is_rejected():
    path = np.rad2deg(zigzag("J1", 1 / 2))
    with pytest.raises(ValueError, match="leaves the workspace"):
        follow(path)


@pytest.mark.parametrize(
    ("path", "message"),
    [
        (np.zeros((10, 2)), "shape"),
        (np.full((1, 3), 0.5), "shape"),
        (np.array([[0.5, 1.2, np.nan], [0.6, 1.2, 0.35]]), "finite"),
        (np.array([[0.5, 1.2, 0.35], [0.5, 1.2, 0.35]]), "zero length"),
    ],
)
def test_bad_paths_are_rejected(path, message):
    with pytest.raises(ValueError, match=message):
        follow(path)


@pytest.mark.parametrize("keyword", ["speed", "rate", "blend_time"])
@pytest.mark.parametrize("value", [0.0, -1.0, float("nan")])
def test_non_positive_timing_parameters_are_rejected(keyword, value):
    with pytest.raises(ValueError, match=keyword):
        follow(zigzag("J1", 1 / 2), **{keyword: value})


def test_tool_pose_outside_its_limits_is_rejected():
    with pytest.raises(ValueError, match="wrist"):
        follow(zigzag("J1", 1 / 2), tool=(0.0, np.deg2rad(80.0), 0.7, 0.7))
