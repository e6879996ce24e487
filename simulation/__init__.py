"""The virtual RAVEN-II: trajectories, the 1 kHz servo loop, named cable effects, recorded state.

Quick start::

    from simulation import paper_protocol
    runs = paper_protocol(seed=0)          # homing, J2-J3 zig-zags, 20-min random tests
    runs.calibration.channel("jpos")       # what the robot reports (30 Hz)
    runs.calibration.truth                 # what the external joint encoders measure (100 Hz)

Layers: :mod:`~simulation.constants` (controller facts), :mod:`~simulation.effects` (named
physics), :mod:`~simulation.parameters` (an immutable parameter set), :mod:`~simulation.cable_model`
(pure model functions shared with the estimators), :mod:`~simulation.engine` (the compiled loop),
:mod:`~simulation.robot` (one arm), :mod:`~simulation.scenarios` (the paper's experiments),
:mod:`~simulation.recording`, :mod:`~simulation.ravenstate`, :mod:`~simulation.dataset` and
:mod:`~simulation.io` (what is recorded and how it is stored).
"""

from simulation.effects import EFFECT_NAMES, Effect, effect_type
from simulation.parameters import RavenParameters
from simulation.recording import Recording, recording_to_dataset
from simulation.robot import Motion, VirtualRaven
from simulation.scenarios import (
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
