"""The virtual RAVEN-II: trajectories, the 1 kHz servo loop, named cable effects, recorded state.

Quick start::

    from simulation import paper_protocol
    runs = paper_protocol(seed=0)          # homing, J2-J3 zig-zags, 20-min random tests
    runs.calibration.channel("jpos")       # what the robot reports (30 Hz)
    runs.calibration.truth                 # what the external joint encoders measure (100 Hz)

Layers, imported one way (each uses only those above it):

* :mod:`simulation.model`: the motor-cable-link model: joint names, constants, named effects, an
  immutable parameter set, the laws (numba and casadi forms) and the one parameter table layout;
* :mod:`simulation.recordings`: what a robot records and how it is stored (ravenstate, datasets,
  bags, tables, dVRK);
* :mod:`simulation.identification`: casadi fits of the model to logs;
* :mod:`simulation.trajectories` and :mod:`simulation.engine`: desired motions, and the compiled
  servo loop, one arm and the paper's experiments;
* :mod:`simulation.discrepancy`: the model-discrepancy workflow.

The names below are loaded on first use (a module ``__getattr__``, PEP 562): importing a light
part such as :mod:`simulation.model` does not load the engine, the trajectories or the bag readers.
"""

from __future__ import annotations

import importlib

from simulation.numba_cache import clear_stale_caches

clear_stale_caches()

__all__ = [
    "CalibrationDataset",
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

_HOMES = {
    "CalibrationDataset": "simulation.recordings.dataset",
    "EFFECT_NAMES": "simulation.model.effects",
    "Effect": "simulation.model.effects",
    "effect_type": "simulation.model.effects",
    "RavenParameters": "simulation.model.parameters",
    "Recording": "simulation.recordings.recording",
    "recording_to_dataset": "simulation.recordings.recording",
    "Motion": "simulation.engine.robot",
    "VirtualRaven": "simulation.engine.robot",
    "ProtocolRecordings": "simulation.engine.scenarios",
    "long_operation": "simulation.engine.scenarios",
    "paper_protocol": "simulation.engine.scenarios",
    "powered_on": "simulation.engine.scenarios",
    "record_calibration": "simulation.engine.scenarios",
    "record_random_test": "simulation.engine.scenarios",
    "rehome": "simulation.engine.scenarios",
}
"""Module that defines each exported name."""


def __getattr__(name: str):
    """Import the module that defines ``name`` on first access (PEP 562) and return the name."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module 'simulation' has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
