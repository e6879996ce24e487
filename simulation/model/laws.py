"""Pure functions of the motor-cable-link model of one RAVEN-II positioning joint.

These are the physics the virtual robot integrates, written once and shared: the simulator's
engine calls them every servo tick, the identification fits their parameters, and the UKF uses
them as its process model. All are numba-compiled scalar functions in joint units (rad or m for
positions, N m or N for tensions) so they run inside compiled loops and from Python alike.
"""

from __future__ import annotations

import numpy as np
from numba import njit


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
def friction_force(velocity: float, coulomb: float, velocity_scale: float, viscous: float) -> float:
    """Joint-side friction opposing motion: ``coulomb tanh(v / v_s) + viscous v`` (N m or N)."""
    return coulomb * np.tanh(velocity / velocity_scale) + viscous * velocity


@njit(cache=True, inline="always")
def bouc_wen_rate(z: float, stretch_rate: float, beta: float, gamma: float) -> float:
    """Rate of the Bouc-Wen hysteresis state (n = 1, A = 1): ``s' - beta |s'| z - gamma s' |z|``."""
    return stretch_rate - beta * abs(stretch_rate) * z - gamma * stretch_rate * abs(z)


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


def cable_stretch_curve(tension, stiffness: float, hardening: float) -> np.ndarray:
    """Vectorized :func:`stretch_from_tension` for numpy arrays (same units)."""
    return hardening * np.arcsinh(np.asarray(tension, dtype=float) / (stiffness * hardening))


def cable_tension_curve(stretch, stiffness: float, hardening: float) -> np.ndarray:
    """Vectorized :func:`stiffness_tension` for numpy arrays (same units)."""
    return stiffness * hardening * np.sinh(np.asarray(stretch, dtype=float) / hardening)
