"""Nominal cable-model parameters: what a researcher knows before identifying a RAVEN-II arm.

The identification and the UKF start from, and hold fixed values at, this set rather than the
simulator's own effect values. It keeps the controller's constants (gear ratios, pulley and
capstan radii, nominal cable coupling, the gravity-compensation masses of ``grav_comp.cpp``),
which any user of the robot has, and puts a round number (one significant digit) on every
effect value, derived below from handbook facts, never from the simulator.
"""

from __future__ import annotations

import numpy as np

from simulation.model.effects import CableStretch, CoulombFriction, Coupling, GravityStretch, ViscousFriction
from simulation.model.parameters import RavenParameters

NOMINAL_STIFFNESS = np.array([400.0, 200.0, 1e5])
"""Cable stiffness at zero tension (N m/rad, N m/rad, N/m), an order of magnitude from EA/L.

A 1.19 mm 7x19 steel wire rope has about half its circle (1.1 mm^2) as metal, 0.55 mm^2, and a
rope modulus of about 100 GPa, so EA is about 5e4 N; over a round 1 m of cable that is 5e4 N/m
per cable, and the antagonistic pair acts in parallel: about 1e5 N/m. Through the joint pulleys
(63 mm and 41 mm, ``raven2-facts``) that is k r^2 = 400 and 170 -> 200 N m/rad; the insertion
cable acts directly: 1e5 N/m."""

NOMINAL_HARDENING = np.array([0.05, 0.07, 0.003])
"""Stretch over which the cable stiffens by half (rad, rad, m): a wire rope's constructional
stretch is a few tenths of a percent of its length, about 3 mm over 1 m, i.e. 3 mm / 63 mm = 0.05
rad, 3 mm / 41 mm = 0.07 rad and 0.003 m."""

NOMINAL_DAMPING = np.array([0.4, 0.2, 100.0])
"""Cable damping (N m s/rad, N m s/rad, N s/m): the nominal stiffness times a round 1 ms
relaxation time (one servo period). Held at this value by default (see
:data:`~.layout.DEFAULT_FIXED`): encoder noise biases a free fit of it low."""

NOMINAL_COULOMB = np.array([0.1, 0.1, 0.1])
"""Joint-side dry friction (N m, N m, N): a round guess of a tenth of a unit, a few percent of the
shoulder's and elbow's gravity torque (about 1-3 N m) and of the tool's weight in its cannula."""

NOMINAL_VELOCITY_SCALE = np.array([1e-3, 1e-3, 1e-4])
"""Speed over which the model's ``tanh`` friction law changes sign (rad/s, rad/s, m/s): a round 1 %
of typical joint speeds during calibration (about 0.1 rad/s and 0.01 m/s)."""

NOMINAL_VISCOUS = np.array([0.1, 0.1, 1.0])
"""Joint-side viscous friction (N m s/rad, N m s/rad, N s/m): a round guess giving about a tenth
of the dry friction at typical speeds (0.1 rad/s, 0.01 m/s) on the rotary joints and the insertion
cannula's grease a tenth too."""


def nominal_parameters(arm: str = "left") -> RavenParameters:
    """The nominal parameter set of one arm: controller constants and round effect values.

    Parameters
    ----------
    arm : "left" (gold) or "right" (green).

    Returns
    -------
    RavenParameters
        The controller's constants and gravity model; the identification's effects
        (:data:`~.layout.FITTABLE_EFFECTS`) on with the round values of this module (gravity
        ``load_scale`` 1: the controller's masses; coupling ``delta`` 0: the controller's
        coefficients); every other effect off.
    """
    if arm not in ("left", "right"):
        raise ValueError(f"arm must be 'left' or 'right', got {arm!r}")
    effects = (
        CableStretch(stiffness=NOMINAL_STIFFNESS, hardening=NOMINAL_HARDENING, damping=NOMINAL_DAMPING),
        GravityStretch(load_scale=np.ones(3)),
        Coupling(delta=np.zeros(3)),
        CoulombFriction(force=NOMINAL_COULOMB, velocity_scale=NOMINAL_VELOCITY_SCALE),
        ViscousFriction(coefficient=NOMINAL_VISCOUS),
    )
    return RavenParameters(arm=arm, effects=effects)
