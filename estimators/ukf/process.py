"""The UKF's process model: the motor-cable-link dynamics, sub-stepped and compiled.

Between two log samples the filter holds the commanded motor torque (zero-order hold, as the
controller holds its command for a servo tick) and integrates, for every sigma point at once,

    s  = A u + offset - q,            T = k x0 sinh(s / x0) + damping (A u' - q')
    M(q) q'' = T - load_scale g(q) - (coulomb tanh(q' / v_s) + viscous q') + d
    J u''    = tau_u - A^T T - b u'

where ``d`` is the disturbance torque at the links (N m, N m, N): zero for the 12-state filter,
the last three states of the 15-state one (a random walk, held over the interval: an unknown
payload's gravity or unmodelled friction, as a Kalman filter's disturbance observer takes it)

with sub-steps of at most ``max_step`` (1 ms, the servo period): semi-implicit Euler for the cable
and motors (as the simulator), and a linearly implicit step for the link friction, whose ``tanh``
law is far too stiff near zero speed for an explicit step (slope coulomb / v_s). Every ``refresh``
sub-steps the inertia, the gravity and the cable law (:func:`~simulation.model.laws.stiffness_tension`
and its slope) are evaluated afresh; in between, the law follows the stretch by the addition
theorem of sinh and cosh with fifth-order series of the small per-step change
(:func:`~simulation.model.laws.advance_hyperbolic`; a sub-step moves the stretch by about a
thousandth of the hardening stretch), which avoids the costly sinh in the 1 kHz loop. Every law is
the model layer's (:mod:`simulation.model.laws`), the parameters are read from its one table layout
(:mod:`simulation.model.layout`); only the integration is this module's.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from kinematics.gravity_closed_form import gravity_torques_fast, mass_matrix_fast
from simulation.model.laws import (
    advance_hyperbolic,
    cable_end,
    cable_stiffness,
    coupled,
    coupled_transpose,
    friction_with_slope,
    gravity_load,
    stiffness_tension,
)
from simulation.model.layout import (
    COULOMB,
    DAMPING,
    HARDENING,
    LOAD_SCALE,
    MOTOR_DAMPING,
    MOTOR_INERTIA,
    OFFSET,
    STIFFNESS,
    VELOCITY_SCALE,
    VISCOUS,
)

from estimators.ukf.model import CableModel

MAX_STEP = 1e-3
"""Longest integration sub-step (s): the RAVEN-II servo period."""
REFRESH = 20
"""Sub-steps between fresh evaluations of the inertia, the gravity and the cable law (20 ms: the
joints move at most a few thousandths of a radian, gravity changes by ~0.1%)."""
STRETCH_LIMIT = 30.0
"""Largest |stretch / hardening| the cable law is evaluated at; keeps far-out sigma points finite."""


FAST_MATH = {"reassoc", "contract", "arcp"}
"""Floating-point licences of the compiled loop: reordering, fused multiply-add and reciprocals, but
not the no-NaN/no-infinity ones, so a diverging sigma point still shows as non-finite."""


@njit(cache=True, inline="always", error_model="numpy")
def _solve_3x3(a, b, out):
    """``a x = b`` for a 3x3 ``a`` by Cramer's rule (the matrices here are symmetric positive definite)."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    inv = 1.0 / (a[0, 0] * c00 - a[0, 1] * c01 + a[0, 2] * c02)
    d12 = b[1] * a[2, 2] - a[1, 2] * b[2]
    d21 = b[1] * a[2, 1] - a[1, 1] * b[2]
    d02 = a[1, 0] * b[2] - b[1] * a[2, 0]
    out[0] = inv * (b[0] * c00 - a[0, 1] * d12 + a[0, 2] * d21)
    out[1] = inv * (a[0, 0] * d12 - b[0] * c01 + a[0, 2] * d02)
    out[2] = inv * (-a[0, 0] * d21 - a[0, 1] * d02 + b[0] * c02)


@njit(cache=True, fastmath=FAST_MATH, error_model="numpy")
def propagate_states(states, motor_torque, duration, max_step, refresh, table, coupling, gravity_coefficients, out):
    """Integrate each row of ``states`` (m, 12 or 15) over ``duration`` seconds into ``out`` (same shape).

    With 15 columns the last three are the disturbance torques at the links, held constant.

    ``motor_torque`` (3,) is held on the motor coordinates (N m, N m, N). ``table``, ``coupling`` and
    ``gravity_coefficients`` are a :class:`~estimators.ukf.model.CableModel`'s arrays.
    """
    n_sub = max(1, int(np.ceil(duration / max_step - 1e-9)))
    h = duration / n_sub
    stiffness, hardening, damping = table[STIFFNESS], table[HARDENING], table[DAMPING]
    coulomb, viscous, load_scale = table[COULOMB], table[VISCOUS], table[LOAD_SCALE]
    offset, motor_damping = table[OFFSET], table[MOTOR_DAMPING]
    inverse_scale = 1.0 / table[VELOCITY_SCALE]
    step_over_inertia = h / table[MOTOR_INERTIA]
    u = np.empty(3)
    ud = np.empty(3)
    q = np.empty(3)
    qd = np.empty(3)
    tension = np.empty(3)
    rhs = np.empty(3)
    dv = np.empty(3)
    lhs = np.empty((3, 3))
    disturbance = np.zeros(3)
    has_disturbance = states.shape[1] > 12
    mass = np.eye(3)
    gravity = np.zeros(3)
    law_sinh = np.empty(3)      # sinh and cosh of stretch / hardening, followed between refreshes
    law_cosh = np.empty(3)
    law_arg = np.empty(3)
    for j in range(states.shape[0]):
        for i in range(3):
            u[i] = states[j, i]
            ud[i] = states[j, 3 + i]
            q[i] = states[j, 6 + i]
            qd[i] = states[j, 9 + i]
            if has_disturbance:
                disturbance[i] = states[j, 12 + i]
        for sub in range(n_sub):
            fresh = sub % refresh == 0
            if fresh:
                mass = mass_matrix_fast(q, gravity_coefficients)
                gravity = gravity_torques_fast(q, gravity_coefficients)
            for i in range(3):
                end = cable_end(coupling, u, offset[i], i)
                end_rate = coupled(coupling, ud, i)
                x0 = hardening[i]
                limit = STRETCH_LIMIT * x0
                stretch = min(max(end - q[i], -limit), limit)
                if fresh:
                    scale = stiffness[i] * x0
                    law_sinh[i] = stiffness_tension(stretch, stiffness[i], x0) / scale
                    law_cosh[i] = cable_stiffness(stretch, stiffness[i], x0) / stiffness[i]
                else:
                    law_sinh[i], law_cosh[i] = advance_hyperbolic(law_sinh[i], law_cosh[i], stretch / x0 - law_arg[i])
                law_arg[i] = stretch / x0
                tension[i] = stiffness[i] * x0 * law_sinh[i] + damping[i] * (end_rate - qd[i])
            for a in range(3):
                for b in range(3):
                    lhs[a, b] = mass[a, b]
            for i in range(3):
                friction, slope = friction_with_slope(qd, inverse_scale, coulomb, viscous, i)
                lhs[i, i] += h * slope
                rhs[i] = h * (tension[i] - gravity_load(gravity[i], load_scale[i]) - friction + disturbance[i])
            _solve_3x3(lhs, rhs, dv)
            for i in range(3):
                qd[i] += dv[i]
                q[i] += h * qd[i]
            for i in range(3):
                load = coupled_transpose(coupling, tension, i)
                ud[i] += step_over_inertia[i] * (motor_torque[i] - load - motor_damping[i] * ud[i])
                u[i] += h * ud[i]
        for i in range(3):
            out[j, i] = u[i]
            out[j, 3 + i] = ud[i]
            out[j, 6 + i] = q[i]
            out[j, 9 + i] = qd[i]
            if has_disturbance:
                out[j, 12 + i] = disturbance[i]


class ProcessModel:
    """``fx`` of the UKF: the identified cable model integrated over one log interval.

    Parameters
    ----------
    model : the identified model.
    max_step : longest sub-step (s).
    refresh : sub-steps between inertia and gravity evaluations.
    """

    def __init__(self, model: CableModel, max_step: float = MAX_STEP, refresh: int = REFRESH):
        if not (np.isfinite(max_step) and max_step > 0):
            raise ValueError(f"max_step must be a positive number of seconds, got {max_step}")
        if int(refresh) < 1:
            raise ValueError(f"refresh must be >= 1, got {refresh}")
        self.model = model
        self.max_step = float(max_step)
        self.refresh = int(refresh)

    def batch(self, states: np.ndarray, dt: float, motor_torque: np.ndarray) -> np.ndarray:
        """All sigma points (m, 12 or 15) at once: the states ``dt`` seconds later."""
        states = np.ascontiguousarray(states, dtype=float)
        out = np.empty_like(states)
        propagate_states(states, np.ascontiguousarray(motor_torque, dtype=float), float(dt), self.max_step, self.refresh,
                         self.model.table, self.model.coupling, self.model.gravity_coefficients, out)
        return out

    def single(self, state: np.ndarray, dt: float, motor_torque: np.ndarray) -> np.ndarray:
        """One sigma point (12 or 15,): filterpy's plain ``fx(x, dt, **fx_args)`` signature."""
        return self.batch(np.reshape(state, (1, -1)), dt, motor_torque)[0]
