"""The motor-cable-link model of a RAVEN-II arm: vocabulary, constants, effects, parameters, laws.

Everything that describes the robot, and nothing that runs it. The engine's plant step, the UKF's
process model, the identification's residuals and the discrepancy workflow's replay all take
their physics from here, so a new effect is written once.

Modules
-------
:mod:`~simulation.model.constants`
    The joint vocabulary (:data:`DOF_NAMES`, :data:`POSITIONING_NAMES`: the controller's names
    ``shoulder``, ``elbow``, ``z_ins``, ``tool_rot``, ``wrist``, ``grasp1``, ``grasp2``) and the
    hardware and controller constants read from the RAVEN-II sources (:class:`RavenConstants`,
    :func:`coupling_matrix`).
:mod:`~simulation.model.effects`
    The named physical effects, each an immutable parameter object with an on/off switch
    (:data:`EFFECT_NAMES`, :class:`Effect`, :func:`effect_type`).
:mod:`~simulation.model.parameters`
    :class:`RavenParameters`: one arm's constants plus its effects, immutable.
:mod:`~simulation.model.laws`
    The laws as numba scalar functions (cable tension and its inverse, tangent stiffness,
    friction and its slope, gravity load, coupling, Bouc-Wen hysteresis, play, fatigue), inlined
    into the compiled loops that call them, plus numpy forms for whole time series.
:mod:`~simulation.model.laws_casadi`
    The same laws as casadi expressions, for the identification (tested equal to the numba form).
:mod:`~simulation.model.layout`
    The one row layout of the per-joint parameters in compiled loops (:data:`ROW_NAMES`,
    :func:`joint_table`).

The names listed in ``__all__`` are importable from here; :mod:`~simulation.model.laws` (numba)
and :mod:`~simulation.model.laws_casadi` (casadi) load on first access (PEP 562 ``__getattr__``),
so reading constants or parameters loads neither compiler.
"""

from __future__ import annotations

import importlib

from simulation.model.constants import DOF_NAMES, POSITIONING_NAMES, RavenConstants, coupling_matrix
from simulation.model.effects import EFFECT_NAMES, Effect, effect_type
from simulation.model.layout import N_ROWS, ROW_NAMES, joint_table
from simulation.model.parameters import RavenParameters

__all__ = [
    "DOF_NAMES",
    "EFFECT_NAMES",
    "Effect",
    "N_ROWS",
    "POSITIONING_NAMES",
    "ROW_NAMES",
    "RavenConstants",
    "RavenParameters",
    "coupling_matrix",
    "effect_type",
    "joint_table",
    "laws",
    "laws_casadi",
]

_LAZY_MODULES = ("laws", "laws_casadi")


def __getattr__(name: str):
    """Import the :mod:`~simulation.model.laws` or :mod:`~simulation.model.laws_casadi` module on first access."""
    if name in _LAZY_MODULES:
        return importlib.import_module(f"simulation.model.{name}")
    raise AttributeError(f"module 'simulation.model' has no attribute {name!r}")
