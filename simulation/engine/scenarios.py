"""The experiments of the paper as reproducible runs of the virtual RAVEN-II.

Each function powers on a :class:`~simulation.engine.robot.VirtualRaven`, homes it as the real robot
is homed before data collection, and records the paper's motions: zig-zag calibration runs, the
independent 20-minute random test, hours of idle, unloaded or loaded (500 g) operation, and
re-homing. Every run is determined by its ``seed``; recordings carry the labels ``payload_kg``,
``operating_hours``, ``homing_count`` and ``segment``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.model.parameters import RavenParameters
from simulation.recordings.recording import Recording
from simulation.engine.robot import VirtualRaven
from simulation.trajectories import PAPER_SPARSITIES, calibration_run, random_sinusoidal

TEST_DURATION = 1200.0
"""The paper's independent test motions lasted 20 minutes."""
LOADED_PAYLOAD_KG = 0.5
"""The paper's loaded configuration: a 500 g weight hanging at the end-effector."""


def _seeds(seed: int, n: int) -> list[int]:
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(seed).spawn(n)]


def powered_on(params: RavenParameters | None = None, seed: int = 0, **robot_options) -> VirtualRaven:
    """A virtual arm after start-up, homed and ready for data collection.

    Start-up homes twice: once from wherever the arm rests at power-on, and once more from the
    home pose. Where a homing starts changes the order and timing in which the joints reach their
    hard stops, and through the cable coupling the registration (by up to ~0.5 mm on the insertion
    joint); re-homing from the home pose, as every later re-homing in the scenarios does, makes the
    homings of a session comparable, so their differences are the registration repeatability.
    """
    robot = VirtualRaven(params, seed=seed, **robot_options)
    robot.home()
    rehome(robot)
    robot.start_operating_clock()
    return robot


def rehome(robot: VirtualRaven) -> Recording:
    """Return to the home pose and home again (re-homing, e.g. after a tool change or e-stop)."""
    back = robot.move_to(robot.params.constants.home_pose, segment="go_to")
    return Recording.concatenate([back, robot.home()])


def record_calibration(robot: VirtualRaven, direction: str = "J2-J3", sparsities=PAPER_SPARSITIES,
                       **trajectory_options) -> Recording:
    """Zig-zag calibration runs of one direction at the given sparsities, as one recording.

    Segments are named by the trajectories (``"zigzag J2-J3 s=1/6"`` ...); the move to the start
    is recorded as ``"go_to"``.
    """
    trajectory = calibration_run(direction, tuple(sparsities), **trajectory_options)
    start = robot.move_to(trajectory.q[0], segment="go_to")
    parts = [start]
    for segment in trajectory.segments:
        part = _slice_trajectory(trajectory, segment.start, segment.stop)
        parts.append(robot.run(part, segment=segment.label))
    return Recording.concatenate(parts).operating()


def record_random_test(robot: VirtualRaven, duration: float = TEST_DURATION, seed: int = 0,
                       segment: str = "test") -> Recording:
    """The paper's independent random test motion, preceded by a move to its start."""
    motion = random_sinusoidal(duration, seed)
    start = robot.move_to(motion.q[0], segment="go_to")
    return Recording.concatenate([start, robot.run(motion, segment=segment)]).operating()


@dataclass(frozen=True)
class ProtocolRecordings:
    """The recordings of :func:`paper_protocol`.

    ``calibration_loaded`` is None unless the protocol was asked to repeat the calibration
    zig-zags with the payload hung at the tool tip.
    """

    calibration: Recording
    test_unloaded: Recording
    test_loaded: Recording
    calibration_loaded: Recording | None = None


def paper_protocol(params: RavenParameters | None = None, seed: int = 0, direction: str = "J2-J3",
                   sparsities=PAPER_SPARSITIES, test_duration: float = TEST_DURATION,
                   loaded_payload_kg: float = LOADED_PAYLOAD_KG, loaded_calibration: bool = False,
                   **robot_options) -> ProtocolRecordings:
    """Calibration zig-zags, then an independent random test unloaded, then the same loaded.

    The paper's main protocol (section II-E, Tables I and III): train on the zig-zags of one
    direction at its sparsities, evaluate on an independent 20-minute random motion. The loaded
    test hangs ``loaded_payload_kg`` at the tool tip for a second, independent random motion.

    With ``loaded_calibration`` the same zig-zags are recorded a second time right after the
    first, with the payload hung at the tool tip (what a user who wants a calibration valid under
    load would record before operating), and the payload is taken off again before the tests.
    """
    s_robot, s_unloaded, s_loaded = _seeds(seed, 3)
    robot = powered_on(params, s_robot, **robot_options)
    calibration = record_calibration(robot, direction, sparsities)
    calibration_loaded = None
    if loaded_calibration:
        robot.set_payload(loaded_payload_kg)
        calibration_loaded = record_calibration(robot, direction, sparsities)
        robot.set_payload(0.0)
    unloaded = record_random_test(robot, test_duration, s_unloaded, "test unloaded")
    robot.set_payload(loaded_payload_kg)
    loaded = record_random_test(robot, test_duration, s_loaded, "test loaded")
    robot.set_payload(0.0)
    return ProtocolRecordings(calibration=calibration, test_unloaded=unloaded, test_loaded=loaded,
                              calibration_loaded=calibration_loaded)


def long_operation(robot: VirtualRaven, kind: str = "unloaded", hours: float = 6.0, seed: int = 0,
                   block: float = TEST_DURATION, payload_kg: float = LOADED_PAYLOAD_KG) -> Recording:
    """Hours of continuous operation after calibration (paper II-G).

    ``kind`` is ``"idle"`` (holding the home pose), ``"unloaded"`` (random motion) or ``"loaded"``
    (random motion with ``payload_kg`` at the tool tip). The motion is recorded in blocks of
    ``block`` seconds of independent random motion, so memory grows only with the 30 Hz log.
    ``operating_hours`` labels count from the robot's operating clock.
    """
    if kind not in ("idle", "unloaded", "loaded"):
        raise ValueError(f"kind must be 'idle', 'unloaded' or 'loaded', got {kind!r}")
    if not (np.isfinite(hours) and hours > 0):
        raise ValueError(f"hours must be positive, got {hours}")
    n_blocks = int(np.ceil(hours * 3600.0 / block))
    seeds = _seeds(seed, n_blocks)
    robot.set_payload(payload_kg if kind == "loaded" else 0.0)
    parts = []
    remaining = hours * 3600.0
    for i in range(n_blocks):
        duration = min(block, remaining)
        if kind == "idle":
            part = robot.hold(duration, segment=kind)
        else:
            part = record_random_test(robot, duration, seeds[i], segment=kind)
        # keep only the operating samples of each block: the whole log is then copied once, not thrice
        parts.append(part.operating())
        remaining -= duration
    robot.set_payload(0.0)
    return Recording.concatenate(parts)


def _slice_trajectory(trajectory, start: int, stop: int):
    """Samples ``start..stop`` (inclusive of the joint sample) of a trajectory as a motion."""
    from simulation.engine.robot import Motion

    stop = min(stop + 1, trajectory.q.shape[0])
    return Motion(q=trajectory.q[start:stop], qd=trajectory.qd[start:stop], rate=trajectory.rate)
