"""The two equation errors of the motor-cable-link model, per log sample, as casadi functions.

With the ground-truth joints ``q`` (and their derivatives) known, the links say which tension the
cables carry,

    T = M(q) q'' + load_scale * g(q) + coulomb * tanh(q' / v_s) + viscous * q',

and two measurements check it:

* the joints: the motors, through the coupling ``A`` and the offsets ``o``, put the cable ends at
  ``p = A u + o`` (with ``transmission_error`` in the model, ``A`` scaled column by column by
  ``1 / (1 + ratio_error)``: the true ratio of each motor's transmission is the nominal one times
  ``1 + ratio_error``); a cable carrying the elastic tension ``T - damping * s'`` is stretched by
  ``s = x0 asinh((T - damping s') / (k x0))`` (:func:`simulation.model.laws.stretch_from_tension`),
  so the joints sit at ``p - s``; residual ``q - (p - s)`` (rad, rad, m);
* the motor torques: the motors feel the cables through ``A^T``,
  ``tau_u = J_u u'' + b_u u' + A^T T`` (plus, with ``motor_friction`` in the model, the motors'
  and gearboxes' friction ``(c_m r + l |A^T T|) tanh(u' / v_m)``,
  :func:`simulation.model.laws.motor_friction`); residual in N m, N m, N.

The joint error fixes the cable law and the coupling, the torque error fixes the loads in absolute
units (the gravity scale and the friction); together they separate the stiffness from the load.
Each residual is divided by its channel's noise level and multiplied by a weight (0 drops it).
The laws are the model layer's, in their casadi form (:mod:`simulation.model.laws_casadi`).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from simulation.model import laws_casadi as law
from simulation.model.laws import MOTOR_STICTION_SPEED
from simulation.model.constants import RavenConstants
from simulation.identification.layout import (
    COULOMB,
    COUPLING_DELTA,
    DAMPING,
    GEARBOX_LOSS,
    HARDENING,
    LOAD_SCALE,
    MOTOR_COULOMB,
    OFFSETS,
    RATIO_ERROR,
    STIFFNESS,
    VISCOUS,
    ParameterLayout,
)

# Rows of the per-sample data matrix (each block is 3 wide).
D_Q, D_QD, D_INERTIAL, D_GRAVITY, D_U, D_UD, D_UDD, D_TAU, D_WQ, D_WT = (slice(3 * i, 3 * i + 3) for i in range(10))
N_DATA = 30
N_RESIDUALS = 6


def residual_function(layout: ParameterLayout, constants: RavenConstants, velocity_scale: np.ndarray) -> ca.Function:
    """casadi function ``(xi, d, sigma, references) -> r``: the 6 weighted, scaled residuals of one sample.

    ``xi`` are the layout's unknowns, ``d`` the sample's data column (rows ``D_*``), ``sigma`` the
    noise level of each residual channel (3 joint, 3 torque), ``references`` the layout's
    :meth:`~.layout.ParameterLayout.references` (the values the unknowns are measured from).
    """
    xi = ca.SX.sym("xi", len(layout))
    d = ca.SX.sym("d", N_DATA)
    sigma = ca.SX.sym("sigma", N_RESIDUALS)
    references = ca.SX.sym("references", 2 * len(layout))
    slots = layout.symbolic_slots(xi, references)
    k, x0, damping = slots[STIFFNESS], slots[HARDENING], slots[DAMPING]
    coulomb, viscous, load_scale = slots[COULOMB], slots[VISCOUS], slots[LOAD_SCALE]
    nominal = np.asarray(constants.cable_coupling, dtype=float)
    delta = slots[COUPLING_DELTA]
    a = law.coupling_matrix(nominal[0] + delta[0], nominal[1] + delta[1], nominal[2] + delta[2])
    if "transmission_error" in layout.effects:
        a = a @ ca.diag(1.0 / (1.0 + slots[RATIO_ERROR]))
    q, qd = d[D_Q], d[D_QD]
    u, ud, udd = d[D_U], d[D_UD], d[D_UDD]
    tension = law.link_tension(d[D_INERTIAL], d[D_GRAVITY], qd, load_scale, coulomb, ca.DM(velocity_scale), viscous)
    cable_end = law.cable_ends(a, u, slots[OFFSETS])
    if layout.rigid:
        predicted = cable_end
    else:
        elastic = tension - damping * (a @ ud - qd)
        predicted = cable_end - law.stretch_from_tension(elastic, k, x0)
    motor_inertia = ca.DM(constants.motor_inertia[:3] * constants.transmission_ratio[:3] ** 2)
    motor_damping = ca.DM(constants.motor_damping[:3] * constants.transmission_ratio[:3] ** 2)
    transmitted = law.motor_load(a, tension)
    torque = motor_inertia * udd + motor_damping * ud + transmitted
    if "motor_friction" in layout.effects:
        ratio = ca.DM(constants.transmission_ratio[:3])
        torque = torque + law.motor_friction(ud, slots[MOTOR_COULOMB] * ratio, slots[GEARBOX_LOSS], transmitted,
                                             ca.DM(MOTOR_STICTION_SPEED))
    residual = ca.vertcat(d[D_WQ] * (q - predicted), d[D_WT] * (d[D_TAU] - torque)) / sigma
    return ca.Function("cable_residual", [xi, d, sigma, references], [residual])
