"""Joining trajectories into one scenario whose samples remember which part they belong to."""

from __future__ import annotations

import numpy as np

from simulation.trajectories.joint_trajectory import STORAGE_DTYPE, JointTrajectory, Segment, uniform_times
from simulation.trajectories.point_to_point import go_to

JOIN_TOLERANCE = 1e-6
"""Largest position (rad, m) or velocity (rad/s, m/s) gap treated as continuous at a junction;
above float32 rounding of the stored samples (6e-8 at 1 rad)."""

TRANSITION_LABEL = "go_to"
"""Segment label of the transitions :func:`concatenate` inserts."""


def _gap(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.max(np.abs(a.astype(float) - b.astype(float))))


def _with_transitions(parts: tuple[JointTrajectory, ...]) -> list[JointTrajectory]:
    joined = [parts[0]]
    for index, nxt in enumerate(parts[1:], start=1):
        previous = joined[-1]
        if _gap(previous.q[-1], nxt.q[0]) > JOIN_TOLERANCE:
            at_rest_end = _gap(previous.qd[-1], np.zeros_like(previous.qd[-1])) <= JOIN_TOLERANCE
            at_rest_start = _gap(nxt.qd[0], np.zeros_like(nxt.qd[0])) <= JOIN_TOLERANCE
            if not (at_rest_end and at_rest_start):
                raise ValueError(
                    f"cannot insert a go_to transition before part {index} ({nxt.label!r}): the parts "
                    "meet at different poses and one of them is moving there"
                )
            joined.append(go_to(previous.q[-1], nxt.q[0], rate=previous.rate, label=TRANSITION_LABEL))
        elif _gap(previous.qd[-1], nxt.qd[0]) > JOIN_TOLERANCE:
            raise ValueError(
                f"part {index} ({nxt.label!r}) starts at the pose where the previous part ends but with "
                "a different velocity"
            )
        joined.append(nxt)
    return joined


def concatenate(*trajectories: JointTrajectory, label: str | None = None) -> JointTrajectory:
    """Join trajectories end to start with continuous positions and velocities.

    Where a part ends on the pose the next one starts from (within :data:`JOIN_TOLERANCE`, with
    the same velocity), the shared sample is kept once. Where the poses differ and both parts
    are at rest there, a :func:`~simulation.trajectories.go_to` transition labelled ``"go_to"``
    is inserted. Every part's segments are kept, so :meth:`JointTrajectory.segment_ids` tells
    which part each sample of the result belongs to.

    Parameters
    ----------
    *trajectories : JointTrajectory
        Parts in time order, all at the same rate.
    label : str, optional
        Label of the result; default the parts' labels joined by ``" + "``.

    Returns
    -------
    JointTrajectory

    Raises
    ------
    ValueError
        If no trajectory is given, the rates differ, or two parts meet at different poses while
        moving, or at the same pose with different velocities.
    """
    if not trajectories:
        raise ValueError("concatenate needs at least one trajectory")
    if not all(isinstance(part, JointTrajectory) for part in trajectories):
        raise TypeError("concatenate takes JointTrajectory objects")
    rate = trajectories[0].rate
    if any(part.rate != rate for part in trajectories):
        rates = sorted({part.rate for part in trajectories})
        raise ValueError(f"all parts must share one rate; got {rates} Hz")
    if label is None:
        label = " + ".join(part.label for part in trajectories)

    parts = _with_transitions(trajectories)
    first_kept = [0] + [1] * (len(parts) - 1)
    n_samples = sum(len(part) - skip for part, skip in zip(parts, first_kept))
    q = np.empty((n_samples, parts[0].q.shape[1]), dtype=STORAGE_DTYPE)
    qd = np.empty_like(q)
    segments = []
    offset = 0
    for part, skip in zip(parts, first_kept):
        count = len(part) - skip
        q[offset : offset + count] = part.q[skip:]
        qd[offset : offset + count] = part.qd[skip:]
        for segment in part.segments:
            start, stop = max(segment.start, skip), segment.stop
            if stop > start:
                segments.append(Segment(start - skip + offset, stop - skip + offset, segment.label))
        offset += count
    return JointTrajectory(uniform_times(n_samples, rate), q, qd, rate, label, tuple(segments))
