"""Random sinusoidal test motion, go-to and idle motions."""

from __future__ import annotations

import numpy as np
import pytest

from simulation.trajectories import (
    CALIBRATION_WORKSPACE,
    GO_TO_MAX_VELOCITY,
    HOME_POSITIONING,
    HOME_TOOL_POSE,
    PUBLISHED_RANDOM_RANGES,
    RandomMotionRanges,
    Workspace,
    go_to,
    idle,
    random_sinusoidal,
)

SPACE = CALIBRATION_WORKSPACE


@pytest.fixture(scope="module")
def test_motion():
    return random_sinusoidal(1200.0, seed=7)


def assert_velocity_is_derivative(trajectory, tolerance: float) -> None:
    q = trajectory.q.astype(float)
    qd = trajectory.qd.astype(float)
    h = 1.0 / trajectory.rate
    trapezoid = 0.5 * (qd[1:] + qd[:-1])
    assert np.max(np.abs(np.diff(q, axis=0) / h - trapezoid)) < 5e-3 * max(np.abs(qd).max(), 1e-12)
    integrated = q[0] + np.concatenate([np.zeros((1, 7)), np.cumsum(trapezoid * h, axis=0)])
    assert np.max(np.abs(integrated - q)) < tolerance


def test_random_motion_stays_inside_the_workspace(test_motion):
    assert SPACE.contains(test_motion.q[:, :3], tolerance=1e-6)
    narrow = Workspace(lower=(0.5, 1.2, 0.34), upper=(0.7, 1.5, 0.40))
    ranges = RandomMotionRanges(target_band=(0.02, 0.05, 0.01))
    other = random_sinusoidal(300.0, seed=1, workspace=narrow, ranges=ranges)
    assert narrow.contains(other.q[:, :3], tolerance=1e-6)


def test_random_motion_sweeps_between_the_target_bands(test_motion):
    band = np.array(PUBLISHED_RANDOM_RANGES.target_band)
    q = test_motion.q[:, :3].astype(float)
    qd = test_motion.qd[:, :3].astype(float)
    for joint in range(3):
        turns = np.flatnonzero(np.sign(qd[1:-1, joint]) != np.sign(qd[2:, joint])) + 1
        turns = turns[(qd[turns, joint] != 0) | (qd[turns + 1, joint] != 0)]
        positions = q[turns, joint]
        near_low = positions <= SPACE.lower[joint] + band[joint] + 1e-4
        near_high = positions >= SPACE.upper[joint] - band[joint] - 1e-4
        assert positions.size >= 10
        assert np.all(near_low | near_high)
        assert near_low.any() and near_high.any()


def test_random_motion_respects_the_velocity_ranges(test_motion):
    qd = np.abs(test_motion.qd[:, :3].astype(float))
    assert np.all(qd.max(axis=0) <= np.array(PUBLISHED_RANDOM_RANGES.velocity_high) * (1 + 1e-6))
    assert np.all(qd.max(axis=0) >= np.array(PUBLISHED_RANDOM_RANGES.velocity_low))


def test_random_motion_is_smooth_and_starts_and_ends_at_rest(test_motion):
    assert_velocity_is_derivative(test_motion, tolerance=2e-5)
    np.testing.assert_array_equal(test_motion.qd[0], 0.0)
    np.testing.assert_allclose(test_motion.qd[-1], 0.0, atol=1e-9)
    np.testing.assert_allclose(test_motion.q[0, :3], SPACE.center, atol=1e-6)
    assert test_motion.duration == pytest.approx(1200.0)


def test_random_motion_keeps_the_tool_at_home(test_motion):
    home = np.broadcast_to(HOME_TOOL_POSE, (len(test_motion), 4))
    np.testing.assert_allclose(test_motion.q[:, 3:], home, atol=1e-7)
    np.testing.assert_array_equal(test_motion.qd[:, 3:], 0.0)


def test_same_seed_same_motion_and_different_seeds_differ(test_motion):
    again = random_sinusoidal(1200.0, seed=7)
    np.testing.assert_array_equal(again.q, test_motion.q)
    np.testing.assert_array_equal(again.qd, test_motion.qd)
    other = random_sinusoidal(1200.0, seed=8)
    assert np.max(np.abs(other.q - test_motion.q)) > 0.05


def test_generator_seed_is_reproducible():
    first = random_sinusoidal(60.0, seed=np.random.default_rng(3))
    second = random_sinusoidal(60.0, seed=np.random.default_rng(3))
    np.testing.assert_array_equal(first.q, second.q)


def test_random_motion_starts_where_asked():
    start = np.array([SPACE.upper[0] - 0.01, SPACE.lower[1] + 0.01, 0.4])
    motion = random_sinusoidal(120.0, seed=2, start=start)
    np.testing.assert_allclose(motion.q[0, :3], start, atol=1e-6)
    assert SPACE.contains(motion.q[:, :3], tolerance=1e-6)


@pytest.mark.parametrize("seed", [None, True])
def test_random_motion_needs_a_seed(seed):
    with pytest.raises(ValueError, match="seed"):
        random_sinusoidal(10.0, seed=seed)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"duration": 0.0}, "duration"),
        ({"duration": float("nan")}, "duration"),
        ({"rate": -100.0}, "rate"),
        ({"start": (0.0, 1.0, 0.35)}, "inside the workspace"),
        ({"ranges": RandomMotionRanges(target_band=(0.5, 0.1, 0.01))}, "narrower than half"),
    ],
)
def test_random_motion_rejects_bad_input(kwargs, message):
    arguments = {"duration": 10.0, "seed": 0} | kwargs
    with pytest.raises(ValueError, match=message):
        random_sinusoidal(**arguments)


def test_random_ranges_reject_inverted_velocities():
    with pytest.raises(ValueError, match="must not exceed"):
        RandomMotionRanges(velocity_low=(0.1, 0.1, 0.01), velocity_high=(0.05, 0.2, 0.02))


@pytest.fixture(scope="module")
def long_move():
    start = np.array([*SPACE.lower, 0.0, 0.0, 0.5, 0.5])
    target = np.array([*SPACE.upper, 1.0, -0.8, 1.2, -0.3])
    return start, target, go_to(start, target)


def test_go_to_arrives_on_the_target_at_rest(long_move):
    start, target, move = long_move
    np.testing.assert_allclose(move.q[0], start, atol=1e-7)
    np.testing.assert_allclose(move.q[-1], target, atol=1e-7)
    np.testing.assert_array_equal(move.qd[0], 0.0)
    np.testing.assert_allclose(move.qd[-1], 0.0, atol=1e-9)
    assert_velocity_is_derivative(move, tolerance=1e-5)


def test_go_to_cruises_at_its_velocity_and_slows_near_the_target(long_move):
    start, target, move = long_move
    speed = np.abs(move.qd.astype(float))
    np.testing.assert_allclose(speed.max(axis=0), GO_TO_MAX_VELOCITY, rtol=1e-5)
    remaining = np.abs(target - move.q.astype(float))
    after_ramp = move.t > 0.5
    for dof in range(7):
        # the published controller slows down within max_velocity / gain (gain 1/s) of the target
        slowing = remaining[:, dof] < 0.9 * GO_TO_MAX_VELOCITY[dof]
        far = (remaining[:, dof] > 1.1 * GO_TO_MAX_VELOCITY[dof]) & after_ramp
        assert far.any() and slowing.any()
        np.testing.assert_allclose(speed[far, dof], GO_TO_MAX_VELOCITY[dof], rtol=1e-5)
        assert np.all(speed[slowing, dof] < 0.999 * GO_TO_MAX_VELOCITY[dof])


def test_go_to_duration_is_set_by_the_slowest_dof(long_move):
    start, target, move = long_move
    per_dof = np.abs(target - start) / np.array(GO_TO_MAX_VELOCITY) + 0.5 * (0.5 + 2.0)
    assert per_dof.max() <= move.duration < per_dof.max() + 0.01 + 1e-9


def test_short_go_to_keeps_both_ramps_at_a_lower_peak():
    start = np.array(HOME_POSITIONING)
    target = start + np.array([np.deg2rad(0.5), 0.0, 0.0])
    move = go_to(start, target)
    assert move.duration == pytest.approx(2.5, abs=0.011)
    assert np.abs(move.qd[:, 0]).max() < GO_TO_MAX_VELOCITY[0]
    np.testing.assert_allclose(move.q[-1, :3], target, atol=1e-7)


def test_go_to_the_same_pose_is_two_samples_at_rest():
    move = go_to(HOME_POSITIONING, HOME_POSITIONING)
    assert len(move) == 2
    np.testing.assert_array_equal(move.qd, 0.0)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"target": (0.5, 1.0)}, "shape"),
        ({"target": (0.5, np.nan, 0.35)}, "finite"),
        ({"target": (0.5, 1.0, 0.35, 0.0, 2.0, 0.7, 0.7)}, "wrist"),
        ({"max_velocity": (0.05,) * 6}, "max_velocity"),
        ({"max_velocity": (0.05, 0.05, 0.0, 0.2, 0.2, 0.2, 0.2)}, "max_velocity"),
        ({"gain": 0.0}, "gain"),
        ({"accel_time": -1.0}, "accel_time"),
    ],
)
def test_go_to_rejects_bad_input(kwargs, message):
    arguments = {"start": HOME_POSITIONING, "target": (0.5, 1.0, 0.35)} | kwargs
    with pytest.raises(ValueError, match=message):
        go_to(**arguments)


def test_idle_holds_the_pose_at_rest():
    pose = (0.5, 1.2, 0.35, 0.1, -0.1, 0.6, 0.7)
    rest = idle(2.5, pose)
    assert rest.duration == pytest.approx(2.5)
    assert len(rest) == 251
    np.testing.assert_allclose(rest.q, np.broadcast_to(pose, (251, 7)), atol=1e-7)
    np.testing.assert_array_equal(rest.qd, 0.0)
    np.testing.assert_allclose(idle(1.0, pose[:3]).q[0, 3:], HOME_TOOL_POSE, atol=1e-7)


@pytest.mark.parametrize("duration", [0.0, -5.0, float("inf")])
def test_idle_rejects_a_bad_duration(duration):
    with pytest.raises(ValueError, match="duration"):
        idle(duration, HOME_POSITIONING)
