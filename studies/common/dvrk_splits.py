"""Splits of the dVRK recordings of Hwang et al. 2020 into a part to learn from and a held-out part.

``studies/discrepancy.py --measured`` on the dVRK folder fits and chooses on the random motion and
reports on the peg transfer ("random -> peg"). The splits study and the play-widths study run the
same workflow on that split and on others (:data:`SPLITS`), all through :func:`run_split`, so that
every dVRK analysis joins its parts the same way.
"""

from __future__ import annotations

import numpy as np

from simulation.discrepancy import WorkflowSettings
from simulation.recordings.dvrk import WRIST_JOINTS

SPLITS = ("random -> peg", "peg -> random", "random, 1st half -> 2nd half", "peg, 1st half -> 2nd half")
"""Learning part -> held-out part of each split (random: ``random_unfiltered``, peg:
``peg_transfer``; a half is the first or second half of a recording's samples)."""
ISSUE_SPLIT = SPLITS[0]
"""The split of ``studies/discrepancy.py --measured`` on the dVRK folder."""


def check_split(split: str) -> str:
    """``split`` if it names one of :data:`SPLITS`; otherwise a one-line ValueError naming the choices."""
    if split not in SPLITS:
        raise ValueError(f"unknown split {split!r}; choose from {', '.join(SPLITS)}")
    return split


def split_parts(split: str, root=None):
    """(time, X, y) of the part the models learn from and of the held-out part of ``split``.

    ``root`` is the folder holding the recordings (default: as :func:`~simulation.recordings.dvrk.load_dvrk`
    finds it). X are the six commanded joints (``q_des``, what the robot reports) and y the six
    measured ones (rad, m); time in s.
    """
    from simulation.recordings.dvrk import load_dvrk

    check_split(split)
    source, target = split.split(" -> ")
    if "half" in split:
        record = load_dvrk(root, "random_unfiltered" if source.startswith("random") else "peg_transfer")
        cut = len(record.t) // 2
        return ((record.t[:cut], record.X[:cut], record.y[:cut]),
                (record.t[cut:], record.X[cut:], record.y[cut:]))
    names = {"random": "random_unfiltered", "peg": "peg_transfer"}
    learned, held_out = load_dvrk(root, names[source]), load_dvrk(root, names[target])
    return (learned.t, learned.X, learned.y), (held_out.t, held_out.X, held_out.y)


def run_split(split: str, root=None, joints=tuple(WRIST_JOINTS), settings: WorkflowSettings = WorkflowSettings(),
              play_fractions=None, play_drivers: str = "every"):
    """The blind workflow on ``joints`` (0-based) of one split (a name of :data:`SPLITS`).

    The held-out part is appended after the learning part in time, one second after its last
    sample, and is the workflow's held-out part; the learning part holds its fit and validation
    parts. ``play_fractions`` and ``play_drivers`` as in
    :func:`~studies.common.discrepancy_runs.run_on_generic`.

    Returns the workflow's (result, signals, parts) and the split's two parts (time, X, y).
    """
    from simulation.recordings.dvrk import JOINT_NAMES, PRISMATIC_JOINTS
    from studies.common.discrepancy_runs import run_on_generic

    joints = list(joints)
    if not joints or len(set(joints)) != len(joints) or not all(isinstance(j, (int, np.integer)) and 0 <= j < 6
                                                                for j in joints):
        raise ValueError(f"joints must be distinct joint indices 0-5 of the dVRK arm, got {tuple(joints)}")
    (t0, x0, y0), (t1, x1, y1) = split_parts(split, root)
    time = np.concatenate([t0, t1 - t1[0] + t0[-1] + 1.0])
    analysis = run_on_generic(
        time, np.concatenate([x0, x1])[:, joints], np.concatenate([y0, y1])[:, joints],
        tuple(JOINT_NAMES[j] for j in joints), tuple("m" if PRISMATIC_JOINTS[j] else "rad" for j in joints),
        held_out_start=len(t0), settings=settings, play_fractions=play_fractions,
        play_drivers=play_drivers)
    return analysis, ((t0, x0, y0), (t1, x1, y1))
