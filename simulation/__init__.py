"""The virtual RAVEN-II: trajectories, the 1 kHz servo loop, named cable effects, recorded state.

Quick start::

    from simulation import paper_protocol
    runs = paper_protocol(seed=0)          # homing, J2-J3 zig-zags, 20-min random tests
    runs.calibration.channel("jpos")       # what the robot reports (30 Hz)
    runs.calibration.truth                 # what the external joint encoders measure (100 Hz)

Layers: :mod:`~simulation.model.constants` (controller facts), :mod:`~simulation.model.effects` (named
physics), :mod:`~simulation.model.parameters` (an immutable parameter set), :mod:`~simulation.model.laws`
(pure model functions shared with the estimators), :mod:`~simulation.engine.loop` (the compiled loop),
:mod:`~simulation.engine.robot` (one arm), :mod:`~simulation.engine.scenarios` (the paper's experiments),
:mod:`~simulation.recordings.recording`, :mod:`~simulation.recordings.ravenstate`, :mod:`~simulation.recordings.dataset` and
:mod:`~simulation.recordings` (what is recorded and how it is stored).
"""

from simulation.model.effects import EFFECT_NAMES, Effect, effect_type
from simulation.model.parameters import RavenParameters
from simulation.recordings.recording import Recording, recording_to_dataset
from simulation.engine.robot import Motion, VirtualRaven
from simulation.engine.scenarios import (
    ProtocolRecordings,
    long_operation,
    paper_protocol,
    powered_on,
    record_calibration,
    record_random_test,
    rehome,
)

__all__ = [
    "EFFECT_NAMES",
    "Effect",
    "Motion",
    "ProtocolRecordings",
    "RavenParameters",
    "Recording",
    "VirtualRaven",
    "effect_type",
    "long_operation",
    "paper_protocol",
    "powered_on",
    "record_calibration",
    "record_random_test",
    "recording_to_dataset",
    "rehome",
]
