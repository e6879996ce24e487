"""JointTrajectory validation, concatenation continuity, segment labels and memory."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from simulation.trajectories import (
    CALIBRATION_WORKSPACE,
    HOME_POSITIONING,
    JointTrajectory,
    Segment,
    calibration_run,
    concatenate,
    go_to,
    idle,
    random_sinusoidal,
    zigzag_trajectory,
)

SPACE = CALIBRATION_WORKSPACE


def samples(n: int = 5) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(n) / 100.0
    q = np.tile(np.array([0.5, 1.2, 0.35, 0.0, 0.0, 0.7, 0.7]), (n, 1))
    return t, q, np.zeros_like(q)


def test_valid_trajectory_exposes_duration_and_read_only_arrays():
    t, q, qd = samples()
    trajectory = JointTrajectory(t, q, qd, 100.0, "hold")
    assert trajectory.duration == pytest.approx(0.04)
    assert trajectory.segment_labels == ("hold",)
    with pytest.raises(ValueError):
        trajectory.q[0, 0] = 1.0
    q[0, 0] = 9.0  # the caller's own array stays writable; validation already happened
    assert trajectory.q.flags.writeable is False


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda t, q, qd: (t + 0.01, q, qd), "start at 0"),
        (lambda t, q, qd: (t[[0, 2, 1, 3, 4]], q, qd), "strictly increasing"),
        (lambda t, q, qd: (np.array([0, 0.01, 0.02, 0.04, 0.05]), q, qd), "uniformly spaced"),
        (lambda t, q, qd: (t[:1], q[:1], qd[:1]), "at least 2"),
        (lambda t, q, qd: (t, q[:, :6], qd), r"q must have shape \(5, 7\)"),
        (lambda t, q, qd: (t, q, qd[:4]), r"qd must have shape \(5, 7\)"),
        (lambda t, q, qd: (t, np.where(np.arange(7) == 2, np.nan, q), qd), "q must be finite"),
        (lambda t, q, qd: (t, q, np.full_like(qd, np.inf)), "qd must be finite"),
        (lambda t, q, qd: (np.where(np.arange(5) == 3, np.nan, t), q, qd), "t must be finite"),
    ],
)
def test_bad_samples_are_rejected(change, message):
    with pytest.raises(ValueError, match=message):
        JointTrajectory(*change(*samples()))


@pytest.mark.parametrize("rate", [0.0, -100.0, float("nan")])
def test_bad_rate_is_rejected(rate):
    t, q, qd = samples()
    with pytest.raises(ValueError, match="rate"):
        JointTrajectory(t, q, qd, rate)


@pytest.mark.parametrize(
    ("segments", "message"),
    [
        ((Segment(0, 2, "a"), Segment(3, 5, "b")), "contiguous"),
        ((Segment(0, 2, "a"), Segment(2, 4, "b")), "cover all 5"),
    ],
)
def test_segments_must_tile_the_samples(segments, message):
    with pytest.raises(ValueError, match=message):
        JointTrajectory(*samples(), segments=segments)


def test_empty_segment_is_rejected():
    with pytest.raises(ValueError, match="start < stop"):
        Segment(3, 3, "empty")


@pytest.fixture(scope="module")
def scenario():
    parts = (
        idle(2.0, HOME_POSITIONING, label="idle"),
        zigzag_trajectory("J2-J3", 1 / 2),
        random_sinusoidal(60.0, seed=4, label="random"),
        idle(1.0, HOME_POSITIONING, label="idle end"),
    )
    return parts, concatenate(*parts, label="scenario")


def test_concatenation_is_continuous_in_position_and_velocity(scenario):
    _, joined = scenario
    q = joined.q.astype(float)
    qd = joined.qd.astype(float)
    h = 1.0 / joined.rate
    jumps = np.abs(np.diff(q, axis=0) / h - 0.5 * (qd[1:] + qd[:-1]))
    assert jumps.max() < 1e-3
    assert np.abs(np.diff(qd, axis=0)).max() < 0.2 * h
    np.testing.assert_allclose(joined.t, np.arange(len(joined)) / joined.rate)


def test_concatenation_inserts_transitions_and_keeps_the_labels(scenario):
    parts, joined = scenario
    assert joined.segment_labels == (
        "idle", "go_to", "zigzag J2-J3 s=1/2", "go_to", "random", "go_to", "idle end",
    )  # fmt: skip
    ids = joined.segment_ids()
    assert ids.shape == (len(joined),)
    labels = np.array(joined.segment_labels)
    for part in parts:
        part_samples = joined.q[labels[ids] == part.label]
        # each part's samples appear in the joined trajectory, in order (a shared first sample once)
        np.testing.assert_array_equal(part_samples, part.q[len(part) - len(part_samples) :])


def test_segment_ids_at_label_a_log_at_another_rate(scenario):
    _, joined = scenario
    log_times = np.arange(0.0, joined.duration, 1 / 30)
    ids = joined.segment_ids_at(log_times)
    starts = np.array([joined.t[s.start] for s in joined.segments])
    expected = np.array([np.flatnonzero(starts <= time).max() for time in log_times])
    np.testing.assert_array_equal(ids, expected)
    with pytest.raises(ValueError, match="times must lie in"):
        joined.segment_ids_at([joined.duration + 1.0])


def test_parts_meeting_at_rest_on_the_same_pose_share_one_sample():
    first = idle(1.0, HOME_POSITIONING, label="a")
    second = idle(2.0, HOME_POSITIONING, label="b")
    joined = concatenate(first, second)
    assert len(joined) == len(first) + len(second) - 1
    assert joined.segment_labels == ("a", "b")
    assert joined.label == "a + b"


def test_a_trajectory_split_while_moving_joins_back_without_a_transition():
    whole = go_to(SPACE.lower, SPACE.upper)
    middle = len(whole) // 2
    head = JointTrajectory.from_samples(whole.q[: middle + 1], whole.qd[: middle + 1], label="head")
    tail = JointTrajectory.from_samples(whole.q[middle:], whole.qd[middle:], label="tail")
    joined = concatenate(head, tail)
    np.testing.assert_array_equal(joined.q, whole.q)
    assert joined.segment_labels == ("head", "tail")


def test_moving_parts_at_different_poses_cannot_be_joined():
    whole = go_to(SPACE.lower, SPACE.upper)
    head = JointTrajectory.from_samples(whole.q[:100], whole.qd[:100])
    with pytest.raises(ValueError, match="moving"):
        concatenate(head, idle(1.0, SPACE.lower))


def test_same_pose_with_different_velocity_cannot_be_joined():
    whole = go_to(SPACE.lower, SPACE.upper)
    head = JointTrajectory.from_samples(whole.q[:100], whole.qd[:100])
    stopped = JointTrajectory.from_samples(whole.q[99:101], np.zeros((2, 7)))
    with pytest.raises(ValueError, match="different velocity"):
        concatenate(head, stopped)


def test_concatenation_rejects_mixed_rates_and_empty_input():
    with pytest.raises(ValueError, match="one rate"):
        concatenate(idle(1.0, HOME_POSITIONING), idle(1.0, HOME_POSITIONING, rate=50.0))
    with pytest.raises(ValueError, match="at least one"):
        concatenate()


def test_calibration_run_joins_three_sparsities_with_transitions():
    run = calibration_run("J1", sparsities=(1 / 2, 1 / 3))
    assert run.segment_labels == ("zigzag J1 s=1/2", "go_to", "zigzag J1 s=1/3")
    alone = zigzag_trajectory("J1", 1 / 3).duration + zigzag_trajectory("J1", 1 / 2).duration
    assert run.duration > alone


def test_six_hour_trajectory_stays_well_under_300_mb():
    tracemalloc.start()
    try:
        six_hours = random_sinusoidal(6 * 3600.0, seed=0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert len(six_hours) == 6 * 3600 * 100 + 1
    assert six_hours.nbytes < 150e6
    assert peak < 250e6
