"""The one row layout of the per-joint parameters of the motor-cable-link model.

Compiled loops read the model's parameters from a ``(N_ROWS, 3)`` float table: one named row per
parameter, one column per positioning joint (``shoulder``, ``elbow``, ``z_ins``; rad, rad, m).
:func:`joint_table` packs it from a :class:`~simulation.model.parameters.RavenParameters` and the
session's joint offsets; the row constants (``STIFFNESS``, ``HARDENING``, ...) index it. The UKF's
:class:`~estimators.ukf.model.CableModel` holds this table, and the engine's table
(:mod:`simulation.engine.tables`) embeds it as one block, so both read a parameter from the same
named row.

A row of an effect that is off is zero (the effect contributes nothing), except the rows that
divide (``hardening``, ``velocity_scale``, ``reference_speed``): they keep their values so a table
never divides by zero. Units are the joint units of :mod:`simulation.model.effects`; the motor rows
are on the motor coordinates ``u = motor angle / transmission ratio`` (``J ratio^2``, ``b ratio^2``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.model.constants import POSITIONING_NAMES
from simulation.model.parameters import RavenParameters

__all__ = [
    "COLUMN_NAMES",
    "N_ROWS",
    "ROWS",
    "ROW_NAMES",
    "Row",
    "joint_table",
    "row_index",
]


@dataclass(frozen=True)
class Row:
    """One row of the table: the effect field it packs (empty ``effect`` for non-effect rows)."""

    name: str
    effect: str
    field: str
    kept_when_off: bool = False
    unit: str = ""


ROWS = (
    Row("stiffness", "cable_stretch", "stiffness", unit="N m/rad, N m/rad, N/m"),
    Row("hardening", "cable_stretch", "hardening", kept_when_off=True, unit="rad, rad, m"),
    Row("damping", "cable_stretch", "damping", unit="N m s/rad, N m s/rad, N s/m"),
    Row("load_scale", "gravity_stretch", "load_scale", unit="1"),
    Row("coulomb", "coulomb_friction", "force", unit="N m, N m, N"),
    Row("velocity_scale", "coulomb_friction", "velocity_scale", kept_when_off=True, unit="rad/s, rad/s, m/s"),
    Row("viscous", "viscous_friction", "coefficient", unit="N m s/rad, N m s/rad, N s/m"),
    Row("backlash", "backlash", "half_width", unit="rad, rad, m"),
    Row("hysteresis_stiffness", "hysteresis", "stiffness", unit="N m/rad, N m/rad, N/m"),
    Row("hysteresis_beta", "hysteresis", "beta", unit="1/rad, 1/rad, 1/m"),
    Row("hysteresis_gamma", "hysteresis", "gamma", unit="1/rad, 1/rad, 1/m"),
    Row("hysteresis_response_time", "hysteresis", "response_time", unit="s"),
    Row("stiffness_loss", "drift", "stiffness_loss", unit="1/h"),
    Row("creep_rate", "drift", "creep_rate", unit="rad/h, rad/h, m/h"),
    Row("payload_gain", "drift", "payload_gain", unit="1/kg"),
    Row("reference_speed", "drift", "reference_speed", kept_when_off=True, unit="rad/s, rad/s, m/s"),
    Row("runout", "capstan_runout", "amplitude", unit="rad, rad, m"),
    Row("capstan_coefficient", "capstan_friction", "coefficient", unit="1"),
    Row("gravity_model_error", "gravity_model_error", "scale_error", unit="1"),
    Row("registration_offset", "registration_offset", "offset", unit="rad, rad, m"),
    Row("registration_repeatability", "registration_offset", "repeatability", unit="rad, rad, m"),
    Row("offset", "", "", unit="rad, rad, m"),
    Row("motor_inertia", "", "", unit="kg m^2, kg m^2, kg"),
    Row("motor_damping", "", "", unit="N m s/rad, N m s/rad, N s/m"),
)
"""The rows in table order."""

ROW_NAMES = tuple(row.name for row in ROWS)
COLUMN_NAMES = POSITIONING_NAMES
N_ROWS = len(ROWS)

(STIFFNESS, HARDENING, DAMPING, LOAD_SCALE, COULOMB, VELOCITY_SCALE, VISCOUS, BACKLASH, HYSTERESIS_STIFFNESS,
 HYSTERESIS_BETA, HYSTERESIS_GAMMA, HYSTERESIS_RESPONSE_TIME, STIFFNESS_LOSS, CREEP_RATE, PAYLOAD_GAIN,
 REFERENCE_SPEED, RUNOUT, CAPSTAN_COEFFICIENT, GRAVITY_MODEL_ERROR, REGISTRATION_OFFSET,
 REGISTRATION_REPEATABILITY, OFFSET, MOTOR_INERTIA, MOTOR_DAMPING) = range(N_ROWS)


def row_index(name: str) -> int:
    """Index of the row called ``name``, with a clear error for an unknown name."""
    try:
        return ROW_NAMES.index(name)
    except ValueError:
        raise ValueError(f"unknown row {name!r}; rows are {', '.join(ROW_NAMES)}") from None


def joint_table(params: RavenParameters, offsets=None) -> np.ndarray:
    """The ``(N_ROWS, 3)`` table of a parameter set and the session's joint offsets.

    Parameters
    ----------
    params : the arm's constants and effects.
    offsets : (3,) joint offsets added to the cable ends (rad, rad, m); zeros when None.

    Raises
    ------
    ValueError
        ``offsets`` are not three finite numbers.
    """
    offsets = np.zeros(3) if offsets is None else np.asarray(offsets, dtype=float)
    if offsets.shape != (3,) or not np.all(np.isfinite(offsets)):
        raise ValueError(f"offsets must be 3 finite values (rad, rad, m), got {offsets!r}")
    table = np.zeros((N_ROWS, 3))
    for index, row in enumerate(ROWS):
        if not row.effect:
            continue
        effect = params.effect(row.effect)
        table[index] = getattr(effect, row.field) if effect.enabled or row.kept_when_off else 0.0
    c = params.constants
    ratio = c.transmission_ratio[:3]
    table[OFFSET] = offsets
    table[MOTOR_INERTIA] = c.motor_inertia[:3] * ratio ** 2
    table[MOTOR_DAMPING] = c.motor_damping[:3] * ratio ** 2
    return table
