"""Pure functions of the motor-cable-link model of one RAVEN-II positioning joint.

These are the physics the virtual robot integrates, written once and shared: the simulator's
engine calls them every servo tick, the UKF's process model every 1 ms sub-step, the replay of the
model-discrepancy workflow sample by sample, and the identification fits their parameters through
the same laws written as casadi expressions (:mod:`simulation.model.laws_casadi`, tested equal to
these). All are numba-compiled scalar functions in joint units (rad or m for positions, N m or N for
tensions) so they run inside compiled loops and from Python alike.

The model of one joint ``i``::

    p = A u + offset                         cable end (coupling A, motor coordinates u)
    s = play(p) - creep - q                  cable stretch
    T = k x0 sinh(s / x0) + damping s'       cable tension (hardening spring)
    M(q) q'' = T - load_scale g(q) - F(q')   link,  F = coulomb tanh(q' / v_s) + viscous q'
    J u'' = tau - A^T T - b u'               motors

Every function is compiled with ``inline="always"``: numba pastes its body into the caller before
LLVM sees it, so a compiled loop with its own floating-point flags evaluates exactly the
expression written here, in the order written here. The integrators differ between callers (the
plant sub-steps, the UKF takes 1 ms steps, the replay is quasi-static); the laws do not.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simulation.model.constants import coupling_matrix

__all__ = [
    "advance_hyperbolic",
    "bouc_wen_rate",
    "bouc_wen_slope",
    "cable_end",
    "cable_stiffness",
    "cable_stiffness_curve",
    "cable_stretch_curve",
    "cable_tension_curve",
    "coulomb_friction",
    "coupled",
    "coupled_transpose",
    "coupling_matrix",
    "fatigue_rate",
    "friction_force",
    "friction_with_slope",
    "gravity_load",
    "link_tension",
    "motor_friction",
    "play",
    "stiffness_tension",
    "stretch_from_tension",
]


# ---- the cable -------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def stiffness_tension(stretch: float, stiffness: float, hardening: float) -> float:
    """Elastic cable tension for a stretch: ``k x0 sinh(s / x0)`` (N m or N).

    ``stiffness`` k is the stiffness at zero tension (N m/rad, N/m); ``hardening`` x0 is the
    stretch over which the stiffness ``k cosh(s / x0)`` grows by half again (rad, m).
    """
    return stiffness * hardening * np.sinh(stretch / hardening)


@njit(cache=True, inline="always")
def stretch_from_tension(tension: float, stiffness: float, hardening: float) -> float:
    """Stretch of the cable carrying ``tension``, the closed-form inverse ``x0 asinh(T / (k x0))``."""
    return hardening * np.arcsinh(tension / (stiffness * hardening))


@njit(cache=True, inline="always")
def cable_stiffness(stretch: float, stiffness: float, hardening: float) -> float:
    """Tangent stiffness dT/ds of the cable at a stretch (N m/rad, N/m)."""
    return stiffness * np.cosh(stretch / hardening)


@njit(cache=True, inline="always")
def advance_hyperbolic(sinh_a: float, cosh_a: float, b: float) -> tuple[float, float]:
    """``(sinh(a + b), cosh(a + b))`` from ``sinh a``, ``cosh a`` and a small step ``b``.

    The addition theorem with fifth-order (sinh) and fourth-order (cosh) series of the step: for
    ``|b| < 1e-2`` the error is below 1e-14 relative, and no transcendental function is evaluated.
    A compiled loop that follows the cable law ``sinh(s / x0)`` from one 1 ms step to the next
    (the stretch moves by about a thousandth of ``x0``) uses it instead of a fresh ``sinh``.
    """
    b2 = b * b
    sinh_b = b * (1.0 + b2 * (1.0 / 6.0 + b2 / 120.0))
    cosh_b = 1.0 + b2 * (0.5 + b2 / 24.0)
    return sinh_a * cosh_b + cosh_a * sinh_b, cosh_a * cosh_b + sinh_a * sinh_b


# ---- the links -------------------------------------------------------------------------------

@njit(cache=True, inline="always")
def coulomb_friction(velocity: float, coulomb: float, velocity_scale: float) -> float:
    """Smoothed dry friction opposing motion: ``coulomb tanh(v / v_s)`` (N m or N)."""
    return coulomb * np.tanh(velocity / velocity_scale)


@njit(cache=True, inline="always")
def friction_force(velocity: float, coulomb: float, velocity_scale: float, viscous: float) -> float:
    """Joint-side friction opposing motion: ``coulomb tanh(v / v_s) + viscous v`` (N m or N)."""
    return coulomb_friction(velocity, coulomb, velocity_scale) + viscous * velocity


@njit(cache=True, inline="always")
def friction_with_slope(velocity: np.ndarray, inverse_scale: np.ndarray, coulomb: np.ndarray, viscous: np.ndarray,
                        joint: int) -> tuple[float, float]:
    """:func:`friction_force` of joint ``joint`` and its slope dF/dv, sharing one ``tanh``.

    Takes the per-joint arrays of a compiled loop (velocities, ``1 / v_s``, Coulomb forces,
    viscous coefficients) and the joint's index: such a loop takes the reciprocal of the velocity
    scale once, and reads the parameters after the ``tanh`` as the loop it replaced did, which
    keeps its floating-point results unchanged under fast-math. The slope
    ``coulomb / v_s (1 - tanh^2) + viscous`` is what a linearly implicit step needs: near zero
    speed the friction is far too stiff for an explicit one.
    """
    th = np.tanh(velocity[joint] * inverse_scale[joint])
    force = coulomb[joint] * th + viscous[joint] * velocity[joint]
    slope = coulomb[joint] * inverse_scale[joint] * (1.0 - th * th) + viscous[joint]
    return force, slope


@njit(cache=True, inline="always")
def gravity_load(gravity_torque: float, load_scale: float) -> float:
    """Load of the link's weight on its cable: ``load_scale * g(q)`` (N m or N).

    ``gravity_torque`` is the kinematics layer's gravity holding torque of the joint;
    ``load_scale`` the share of it the cable carries (1 for the real arm, identified).
    """
    return load_scale * gravity_torque


@njit(cache=True, inline="always")
def link_tension(inertial: float, gravity_torque: float, velocity: float, load_scale: float, coulomb: float,
                 velocity_scale: float, viscous: float) -> float:
    """Cable tension that moves the link as observed: ``M q'' + load_scale g + F(q')`` (N m or N).

    The link's equation of motion solved for the tension, given its inertial force ``M(q) q''``
    (``inertial``), gravity holding torque and velocity.
    """
    return (inertial + gravity_load(gravity_torque, load_scale) + coulomb_friction(velocity, coulomb, velocity_scale)
            + viscous * velocity)


# ---- the coupling ----------------------------------------------------------------------------

@njit(cache=True, inline="always")
def coupled(coupling: np.ndarray, vector: np.ndarray, row: int) -> float:
    """Row ``row`` of ``A v``: a joint's cable-side position (or rate) of motor coordinates ``v``."""
    return coupling[row, 0] * vector[0] + coupling[row, 1] * vector[1] + coupling[row, 2] * vector[2]


@njit(cache=True, inline="always")
def cable_end(coupling: np.ndarray, motor: np.ndarray, offset: float, row: int) -> float:
    """Cable-end position ``(A u)[row] + offset`` of joint ``row`` (rad, rad, m)."""
    return coupled(coupling, motor, row) + offset


@njit(cache=True, inline="always")
def coupled_transpose(coupling: np.ndarray, tension: np.ndarray, column: int) -> float:
    """Entry ``column`` of ``A^T T``: the load the cable tensions put on one motor coordinate."""
    return coupling[0, column] * tension[0] + coupling[1, column] * tension[1] + coupling[2, column] * tension[2]


# ---- history effects -------------------------------------------------------------------------

@njit(cache=True, inline="always")
def bouc_wen_rate(z: float, stretch_rate: float, beta: float, gamma: float) -> float:
    """Rate of the Bouc-Wen hysteresis state (n = 1, A = 1): ``s' - beta |s'| z - gamma s' |z|``."""
    return stretch_rate - beta * abs(stretch_rate) * z - gamma * stretch_rate * abs(z)


@njit(cache=True, inline="always")
def bouc_wen_slope(z: float, direction: float, beta: float, gamma: float) -> float:
    """dz/ds of the Bouc-Wen state while the stretch moves in ``direction`` (+1 or -1).

    :func:`bouc_wen_rate` divided by the stretch rate: ``1 - beta sgn(s') z - gamma |z|``.
    """
    return 1.0 - beta * direction * z - gamma * abs(z)


@njit(cache=True, inline="always")
def play(position: float, output: float, half_width: float) -> float:
    """Backlash (play) operator: the output follows the input only beyond ``half_width``."""
    if position - output > half_width:
        return position - half_width
    if position - output < -half_width:
        return position + half_width
    return output


@njit(cache=True, inline="always")
def fatigue_rate(speed: float, reference_speed: float, payload_gain: float, payload_kg: float,
                 time_scale: float) -> float:
    """Growth of the fatigue dose (equivalent operating hours per second of simulated time)."""
    return time_scale / 3600.0 * abs(speed) / reference_speed * (1.0 + payload_gain * payload_kg)


# ---- numpy forms for whole time series -------------------------------------------------------

MOTOR_STICTION_SPEED = np.array([1e-3, 1e-3, 1e-4])
"""Drive speed (rad/s, rad/s, m/s in joint units) below which the motor friction of a log's model
(:func:`motor_friction`) fades linearly to zero (``tanh(v / speed)``): a round tenth of a degree per
second and a tenth of a millimetre per second, where the motor's stick-slip cannot be followed in
a 30 Hz log."""


def motor_friction(drive_velocity, coulomb, gearbox_loss, transmitted, stiction_speed=MOTOR_STICTION_SPEED):
    """Torque the motors spend on their own and their gearboxes' friction, in joint units (N m, N m, N).

    ``(coulomb + gearbox_loss |transmitted|) tanh(u' / v_m)``: ``coulomb`` is the motor-shaft
    friction times the transmission ratio, ``gearbox_loss`` the loss per unit of transmitted
    torque, ``transmitted`` the cables' load ``A^T T`` on the motors and ``u'`` the drive velocity.
    The smooth form of :class:`~simulation.model.effects.MotorFriction`'s set-valued law, for
    replaying and identifying logs, whose 30 Hz rate cannot follow the motor's stick-slip.
    """
    return (coulomb + gearbox_loss * np.abs(transmitted)) * np.tanh(drive_velocity / stiction_speed)


def cable_stretch_curve(tension, stiffness, hardening) -> np.ndarray:
    """Vectorized :func:`stretch_from_tension` for numpy arrays (same units)."""
    return hardening * np.arcsinh(np.asarray(tension, dtype=float) / (stiffness * hardening))


def cable_tension_curve(stretch, stiffness, hardening) -> np.ndarray:
    """Vectorized :func:`stiffness_tension` for numpy arrays (same units)."""
    return stiffness * hardening * np.sinh(np.asarray(stretch, dtype=float) / hardening)


def cable_stiffness_curve(stretch, stiffness, hardening) -> np.ndarray:
    """Vectorized :func:`cable_stiffness` for numpy arrays (same units)."""
    return stiffness * np.cosh(np.asarray(stretch, dtype=float) / hardening)
