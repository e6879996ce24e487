"""The laws of :mod:`simulation.model.laws` as casadi expressions, for the identification's fits.

Each function here is the same formula as its namesake in :mod:`simulation.model.laws`, written
with casadi's operators so that it accepts symbols (``SX``, ``MX``) as well as numbers (``DM``,
floats, numpy arrays) and casadi can differentiate it. ``tests/test_model_laws.py`` checks that the
two forms agree on random states. Vector arguments act elementwise (one entry per joint).
"""

from __future__ import annotations

import casadi as ca

__all__ = [
    "bouc_wen_rate",
    "cable_ends",
    "cable_stiffness",
    "coulomb_friction",
    "coupling_matrix",
    "friction_force",
    "gravity_load",
    "link_tension",
    "motor_friction",
    "motor_load",
    "stiffness_tension",
    "stretch_from_tension",
]


def stiffness_tension(stretch, stiffness, hardening):
    """Elastic cable tension ``k x0 sinh(s / x0)`` (:func:`simulation.model.laws.stiffness_tension`)."""
    return stiffness * hardening * ca.sinh(stretch / hardening)


def stretch_from_tension(tension, stiffness, hardening):
    """Stretch ``x0 asinh(T / (k x0))`` (:func:`simulation.model.laws.stretch_from_tension`)."""
    return hardening * ca.asinh(tension / (stiffness * hardening))


def cable_stiffness(stretch, stiffness, hardening):
    """Tangent stiffness ``k cosh(s / x0)`` (:func:`simulation.model.laws.cable_stiffness`)."""
    return stiffness * ca.cosh(stretch / hardening)


def coulomb_friction(velocity, coulomb, velocity_scale):
    """Smoothed dry friction ``coulomb tanh(v / v_s)`` (:func:`simulation.model.laws.coulomb_friction`)."""
    return coulomb * ca.tanh(velocity / velocity_scale)


def friction_force(velocity, coulomb, velocity_scale, viscous):
    """Joint friction ``coulomb tanh(v / v_s) + viscous v`` (:func:`simulation.model.laws.friction_force`)."""
    return coulomb_friction(velocity, coulomb, velocity_scale) + viscous * velocity


def gravity_load(gravity_torque, load_scale):
    """Weight on the cable ``load_scale g(q)`` (:func:`simulation.model.laws.gravity_load`)."""
    return load_scale * gravity_torque


def link_tension(inertial, gravity_torque, velocity, load_scale, coulomb, velocity_scale, viscous):
    """Tension that moves the link, ``M q'' + load_scale g + F(q')`` (:func:`simulation.model.laws.link_tension`)."""
    return (inertial + gravity_load(gravity_torque, load_scale) + coulomb_friction(velocity, coulomb, velocity_scale)
            + viscous * velocity)


def bouc_wen_rate(z, stretch_rate, beta, gamma):
    """Bouc-Wen rate ``s' - beta |s'| z - gamma s' |z|`` (:func:`simulation.model.laws.bouc_wen_rate`)."""
    return stretch_rate - beta * ca.fabs(stretch_rate) * z - gamma * stretch_rate * ca.fabs(z)


def coupling_matrix(c01, c02, c12):
    """The cable coupling ``A`` (:func:`simulation.model.constants.coupling_matrix`) as a casadi matrix."""
    return ca.vertcat(
        ca.horzcat(1.0, 0.0, 0.0),
        ca.horzcat(-c01, 1.0, 0.0),
        ca.horzcat(-c02 + c12 * c01, -c12, 1.0),
    )


def cable_ends(coupling, motor, offset):
    """Cable-end positions ``A u + offset`` of the three joints (:func:`simulation.model.laws.cable_end`)."""
    return coupling @ motor + offset


def motor_load(coupling, tension):
    """Load ``A^T T`` of the cable tensions on the motor coordinates
    (:func:`simulation.model.laws.coupled_transpose`)."""
    return coupling.T @ tension


def motor_friction(drive_velocity, coulomb, gearbox_loss, transmitted, stiction_speed):
    """Torque the motors spend on their own and their gearboxes' friction, in joint units:
    ``(coulomb + gearbox_loss |transmitted|) tanh(u' / v_m)`` (:func:`simulation.model.laws.motor_friction`,
    which the discrepancy replay evaluates), with ``coulomb`` the motor-shaft
    friction already multiplied by the transmission ratio and ``transmitted`` the cables' load
    ``A^T T`` on the motors."""
    return (coulomb + gearbox_loss * ca.fabs(transmitted)) * ca.tanh(drive_velocity / stiction_speed)
