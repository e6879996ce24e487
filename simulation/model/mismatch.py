"""Model mismatch: how much of a robot's physics lies outside the model-based filter's class.

The UKF baseline (:mod:`estimators.ukf`, after Haghighipanah et al. 2015) models each positioning
joint as motor, cable and link: cable stretch (with hardening and damping), the gravity load on the
cable, the cable coupling of the joints, and Coulomb and viscous friction at the link. Every other
effect of the simulated robot is outside that class, and :func:`scale_out_of_class` scales all of
them by one factor ``lam``, so a study can ask how the comparison between the filter and the learned
calibrators changes as the robot departs from the filter's model (``lam = 0``: the robot is exactly
of the filter's class; ``lam = 1``: the given robot; ``lam = 2``: twice its unmodelled physics).

Only the *size* of an effect is scaled (:data:`MAGNITUDE_FIELDS`): widths, amplitudes, forces,
rates, offsets and fractional errors. Shape parameters (a hysteresis loop's ``beta``/``gamma``, the
drift's payload gain and reference speed, capstan wrap angles) are kept. The sensors
(``quantization``, ``noise``) are not physics of the transmission and are kept as they are: a
filter and a calibrator read the same encoders. Effects switched off in the given robot stay off,
so ``lam = 1`` returns the given robot unchanged.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from simulation.model.parameters import RavenParameters

FILTER_CLASS = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction")
"""Effects the UKF's process model contains (its identification fits their parameters)."""

SENSOR_EFFECTS = ("quantization", "noise")
"""Measurement effects: the same for every method, not part of the model mismatch."""

MAGNITUDE_FIELDS = {
    "backlash": ("half_width",),
    "hysteresis": ("stiffness",),
    "drift": ("stiffness_loss", "creep_rate"),
    "homing_offset": ("repeatability", "tool_repeatability"),
    "capstan_runout": ("amplitude",),
    "motor_friction": ("coulomb", "gearbox_loss"),
    "capstan_friction": ("mu",),
    "gravity_model_error": ("scale_error",),
    "transmission_error": ("ratio_error",),
    "registration_offset": ("offset", "repeatability"),
}
"""For every effect outside the filter's class, the fields that set its size (SI, per joint)."""


def out_of_class_effects(params: RavenParameters) -> tuple[str, ...]:
    """Names of the effects switched on in ``params`` that the filter's model does not contain."""
    return tuple(name for name in params.enabled_effects if name in MAGNITUDE_FIELDS)


def scale_out_of_class(params: RavenParameters, lam: float) -> RavenParameters:
    """A copy of ``params`` whose effects outside the filter's class are scaled by ``lam``.

    Parameters
    ----------
    params : the robot (its switched-on effects define ``lam = 1``).
    lam : finite factor >= 0 on the magnitude fields (:data:`MAGNITUDE_FIELDS`); 0 switches the
        effects off.

    Raises
    ------
    ValueError
        For a negative or non-finite ``lam``, or a scaled value the effect refuses (e.g. a gearbox
        loss reaching 1, a gearbox that transmits nothing).
    """
    if isinstance(lam, bool) or not isinstance(lam, (int, float, np.integer, np.floating)):
        raise ValueError(f"lam must be a number, got {type(lam).__name__} {lam!r}")
    lam = float(lam)
    if not np.isfinite(lam) or lam < 0.0:
        raise ValueError(f"lam must be finite and >= 0, got {lam}")
    if lam == 1.0:
        return params
    scaled = params
    for name in out_of_class_effects(params):
        effect = params.effect(name)
        if lam == 0.0:
            scaled = scaled.with_effect(effect.with_enabled(False))
            continue
        changes = {f: np.asarray(getattr(effect, f), dtype=float) * lam for f in MAGNITUDE_FIELDS[name]}
        if name == "motor_friction" and np.any(changes["gearbox_loss"] >= 1.0):
            raise ValueError(f"lam = {lam} makes the gearbox loss reach 1 (no torque transmitted); "
                             f"largest allowed here is {1.0 / float(np.max(effect.gearbox_loss)):.3g}")
        scaled = scaled.with_effect(dataclasses.replace(effect, **changes))
    return scaled
