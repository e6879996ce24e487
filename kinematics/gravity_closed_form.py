"""Closed-form, compiled gravity torques and inertia of the positioning joints.

The 1 kHz simulator needs the gravity load (and the inertia) of joints J0..J2 every
millisecond, inside numba-compiled loops, without calling Pinocchio. Everything the
computation needs is packed once into a small float64 array of *coefficients*
(:func:`pack_coefficients`, or ``RavenII.gravity_coefficients``); the compiled
functions :func:`gravity_torques_fast` and :func:`mass_matrix_fast` take the three
positioning joints and that array, and can be called from other ``@njit`` code.

The computation follows the controller (``getGravityTorque`` in
``src/raven/grav_comp.cpp``): the gravity vector is rotated into each link frame and
the first moments of the links beyond each joint are accumulated. A payload at the
tool tip is a point mass rigidly attached to link 3 for fixed tool joints (J3..J5),
so its position in frame 3 is a constant of the coefficient array.

Sign convention: the torques (N m for J0, J1) and force (N for J2) the joints must
supply to hold the arm at rest, i.e. the ``g(q)`` of ``M(q) qdd + C qd + g(q) = tau``.

The compiled functions do not validate their inputs (they run in hot loops); the
checked path is ``RavenII.gravity_torques``. Numba's on-disk cache of a caller
compiled with ``@njit(cache=True)`` does not notice changes to this module: clear
the caller's cache after editing it.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from kinematics.arm_parameters import RavenArmParameters
from kinematics.dh_batch import LinkConstants, joint_frames
from kinematics.joint_limits import as_real_array, check_payload

# Layout of the coefficient array (offsets of each block).
GRAVITY = 0  # 3 values: gravity in the base frame (m/s^2)
ALPHA = 3  # 3 values: alpha_0..alpha_2 (rad)
LENGTH_A = 6  # 3 values: a_0..a_2 (m)
THETA_OFFSET = 9  # 3 values: theta offsets of links 1-3 (rad)
D_OFFSET = 12  # 3 values: d offsets of links 1-3 (m)
MASS = 15  # 3 values: masses of links 1-3 (kg)
COM = 18  # 9 values: centres of mass of links 1-3, each in its own frame (m)
RADIUS_OF_GYRATION = 27  # 3 values: isotropic radius of gyration of links 1-3 (m)
PAYLOAD_MASS = 30  # 1 value: payload at the tool tip (kg)
PAYLOAD_POINT = 31  # 3 values: tool tip in frame 3 for the packed tool joints (m)
N_COEFFICIENTS = 34


def pack_coefficients(
    params: RavenArmParameters, payload_kg: float = 0.0, tool_joints=(0.0, 0.0, 0.0)
) -> np.ndarray:
    """Coefficient array of one arm for the compiled gravity and inertia functions.

    Parameters
    ----------
    params : RavenArmParameters
        The arm; its first three joints must be revolute, revolute, prismatic.
    payload_kg : float
        Point mass hanging at the tool tip (kg), >= 0.
    tool_joints : array_like, shape (3,)
        Tool roll, wrist and grasp (J3, J4, J5; rad) held fixed; they place the tool
        tip relative to link 3 (the default zeros put the jaw on the tool axis).

    Returns
    -------
    numpy.ndarray, shape (N_COEFFICIENTS,)
        Read-only float64 array; the layout is given by the module's offsets.

    Raises
    ------
    ValueError
        If the payload is negative or not finite, the tool joints are not three
        finite numbers, or the arm's first joints are not revolute, revolute,
        prismatic.
    """
    if params.dh.prismatic[:3] != (False, False, True):
        raise ValueError("the closed form needs joints J0, J1 revolute and J2 prismatic")
    payload_kg = check_payload(payload_kg)
    tool = as_real_array(tool_joints, "tool_joints", "rad")
    if tool.shape != (3,) or not np.all(np.isfinite(tool)):
        raise ValueError(f"tool_joints must be 3 finite numbers (rad), got {tool_joints!r}")

    q = np.concatenate([np.zeros(3), tool])[None, :]
    rotations, origins = joint_frames(LinkConstants.from_dh(params.dh), q)
    tip_in_frame3 = rotations[0, 2].T @ (origins[0, 5] - origins[0, 2])

    dh = params.dh
    coeffs = np.concatenate(
        [
            params.gravity,
            dh.alpha[:3],
            dh.a[:3],
            dh.theta_offset[:3],
            dh.d_offset[:3],
            [link.mass for link in params.links],
            np.concatenate([link.com for link in params.links]),
            [link.radius_of_gyration for link in params.links],
            [payload_kg],
            tip_in_frame3,
        ]
    ).astype(np.float64)
    assert coeffs.shape == (N_COEFFICIENTS,)
    coeffs.setflags(write=False)
    return coeffs


# Small-vector algebra on tuples: no heap allocation inside the 1 kHz loop.
# A rotation is a 9-tuple (row-major), a vector a 3-tuple.
@njit(cache=True, inline="always")
def _link_rotation(alpha, theta):
    """``Rx(alpha) Rz(theta)``."""
    ca, sa = np.cos(alpha), np.sin(alpha)
    ct, st = np.cos(theta), np.sin(theta)
    return (ct, -st, 0.0, st * ca, ct * ca, -sa, st * sa, ct * sa, ca)


@njit(cache=True, inline="always")
def _link_translation(alpha, a, d):
    """``Rx(alpha) (a, 0, d)``."""
    return (a, -np.sin(alpha) * d, np.cos(alpha) * d)


@njit(cache=True, inline="always")
def _rotate(r, v):
    return (
        r[0] * v[0] + r[1] * v[1] + r[2] * v[2],
        r[3] * v[0] + r[4] * v[1] + r[5] * v[2],
        r[6] * v[0] + r[7] * v[1] + r[8] * v[2],
    )


@njit(cache=True, inline="always")
def _rotate_back(r, v):
    """``r.T @ v``."""
    return (
        r[0] * v[0] + r[3] * v[1] + r[6] * v[2],
        r[1] * v[0] + r[4] * v[1] + r[7] * v[2],
        r[2] * v[0] + r[5] * v[1] + r[8] * v[2],
    )


@njit(cache=True, inline="always")
def _compose(a, b):
    """``a @ b`` for rotations."""
    return (
        a[0] * b[0] + a[1] * b[3] + a[2] * b[6],
        a[0] * b[1] + a[1] * b[4] + a[2] * b[7],
        a[0] * b[2] + a[1] * b[5] + a[2] * b[8],
        a[3] * b[0] + a[4] * b[3] + a[5] * b[6],
        a[3] * b[1] + a[4] * b[4] + a[5] * b[7],
        a[3] * b[2] + a[4] * b[5] + a[5] * b[8],
        a[6] * b[0] + a[7] * b[3] + a[8] * b[6],
        a[6] * b[1] + a[7] * b[4] + a[8] * b[7],
        a[6] * b[2] + a[7] * b[5] + a[8] * b[8],
    )


@njit(cache=True, inline="always")
def _add(u, v):
    return (u[0] + v[0], u[1] + v[1], u[2] + v[2])


@njit(cache=True, inline="always")
def _sub(u, v):
    return (u[0] - v[0], u[1] - v[1], u[2] - v[2])


@njit(cache=True, inline="always")
def _scale(s, v):
    return (s * v[0], s * v[1], s * v[2])


@njit(cache=True, inline="always")
def _dot(u, v):
    return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]


@njit(cache=True, inline="always")
def _cross(u, v):
    return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])


@njit(cache=True, inline="always")
def _block(c, start):
    return (c[start], c[start + 1], c[start + 2])


@njit(cache=True)
def _positioning_links(q3, c):
    """Rotations and translations of links 1-3 (frame i in frame i-1)."""
    r1 = _link_rotation(c[ALPHA], c[THETA_OFFSET] + q3[0])
    p1 = _link_translation(c[ALPHA], c[LENGTH_A], c[D_OFFSET])
    r2 = _link_rotation(c[ALPHA + 1], c[THETA_OFFSET + 1] + q3[1])
    p2 = _link_translation(c[ALPHA + 1], c[LENGTH_A + 1], c[D_OFFSET + 1])
    r3 = _link_rotation(c[ALPHA + 2], c[THETA_OFFSET + 2])
    p3 = _link_translation(c[ALPHA + 2], c[LENGTH_A + 2], c[D_OFFSET + 2] + q3[2])
    return r1, p1, r2, p2, r3, p3


@njit(cache=True)
def gravity_torques_fast(q3, coeffs):
    """Holding torques of the positioning joints (compiled, unchecked).

    Parameters
    ----------
    q3 : numpy.ndarray, shape (3,)
        Shoulder (rad), elbow (rad), insertion (m): J0..J2.
    coeffs : numpy.ndarray, shape (N_COEFFICIENTS,)
        From :func:`pack_coefficients` (gravity, geometry, masses, payload).

    Returns
    -------
    numpy.ndarray, shape (3,)
        Torque (N m), torque (N m) and force (N) the joints supply to hold the arm.
    """
    r1, p1, r2, p2, r3, p3 = _positioning_links(q3, coeffs)
    g1 = _rotate_back(r1, _block(coeffs, GRAVITY))
    g2 = _rotate_back(r2, g1)
    g3 = _rotate_back(r3, g2)

    # First moments (mass times centre of mass) of the links beyond each joint.
    payload = coeffs[PAYLOAD_MASS]
    mass3 = coeffs[MASS + 2] + payload
    moment3 = _add(
        _scale(coeffs[MASS + 2], _block(coeffs, COM + 6)),
        _scale(payload, _block(coeffs, PAYLOAD_POINT)),
    )
    moment2 = _add(
        _scale(coeffs[MASS + 1], _block(coeffs, COM + 3)),
        _add(_rotate(r3, moment3), _scale(mass3, p3)),
    )
    mass2 = coeffs[MASS + 1] + mass3
    moment1 = _add(
        _scale(coeffs[MASS], _block(coeffs, COM)),
        _add(_rotate(r2, moment2), _scale(mass2, p2)),
    )

    out = np.empty(3)
    out[0] = g1[0] * moment1[1] - g1[1] * moment1[0]
    out[1] = g2[0] * moment2[1] - g2[1] * moment2[0]
    out[2] = -mass3 * g3[2]
    return out


@njit(cache=True)
def gravity_torques_fast_batch(q3, coeffs):
    """:func:`gravity_torques_fast` over rows of ``q3`` (N, 3) -> (N, 3)."""
    out = np.empty((q3.shape[0], 3))
    for n in range(q3.shape[0]):
        # element by element: numba compiles a row assignment from an array with a formatted
        # shape-mismatch error, seconds of compilation per process
        g = gravity_torques_fast(q3[n], coeffs)
        for j in range(3):
            out[n, j] = g[j]
    return out


@njit(cache=True, inline="always")
def _velocity_columns(point, o1, z1, o2, z2, z3, count):
    """Columns of d(point)/d(J0..J2) for a point moved by the first ``count`` joints.

    J0 and J1 are revolute (axes z1, z2 through o1, o2); J2 slides along z3.
    """
    zero = (0.0, 0.0, 0.0)
    c1 = _cross(z1, _sub(point, o1))
    c2 = _cross(z2, _sub(point, o2)) if count >= 2 else zero
    c3 = z3 if count >= 3 else zero
    return c1, c2, c3


@njit(cache=True, inline="always")
def _add_gram(out, mass, c1, c2, c3):
    """``out += mass * C^T C`` for the columns c1, c2, c3 of C."""
    cols = (c1, c2, c3)
    for a in range(3):
        for b in range(3):
            out[a, b] += mass * _dot(cols[a], cols[b])


@njit(cache=True)
def mass_matrix_fast(q3, coeffs):
    """Joint-space inertia of the positioning joints (compiled, unchecked).

    The tool joints are locked (the inertia ``J0..J2`` see with J3..J5 at rest);
    links carry point masses at their centres of mass plus an isotropic rotational
    inertia ``m k^2 I``; the payload is a point mass at the tool tip.

    Parameters
    ----------
    q3 : numpy.ndarray, shape (3,)
        Shoulder (rad), elbow (rad), insertion (m).
    coeffs : numpy.ndarray, shape (N_COEFFICIENTS,)
        From :func:`pack_coefficients`.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        Symmetric inertia matrix (kg m^2, kg m, kg by block).
    """
    r1, p1, r2, p2, r3, p3 = _positioning_links(q3, coeffs)
    rot2 = _compose(r1, r2)
    rot3 = _compose(rot2, r3)
    o1 = p1
    o2 = _add(o1, _rotate(r1, p2))
    o3 = _add(o2, _rotate(rot2, p3))
    z1 = (r1[2], r1[5], r1[8])
    z2 = (rot2[2], rot2[5], rot2[8])
    z3 = (rot3[2], rot3[5], rot3[8])

    out = np.zeros((3, 3))
    com1 = _add(o1, _rotate(r1, _block(coeffs, COM)))
    com2 = _add(o2, _rotate(rot2, _block(coeffs, COM + 3)))
    com3 = _add(o3, _rotate(rot3, _block(coeffs, COM + 6)))
    tip = _add(o3, _rotate(rot3, _block(coeffs, PAYLOAD_POINT)))
    c1, c2, c3 = _velocity_columns(com1, o1, z1, o2, z2, z3, 1)
    _add_gram(out, coeffs[MASS], c1, c2, c3)
    c1, c2, c3 = _velocity_columns(com2, o1, z1, o2, z2, z3, 2)
    _add_gram(out, coeffs[MASS + 1], c1, c2, c3)
    c1, c2, c3 = _velocity_columns(com3, o1, z1, o2, z2, z3, 3)
    _add_gram(out, coeffs[MASS + 2], c1, c2, c3)
    c1, c2, c3 = _velocity_columns(tip, o1, z1, o2, z2, z3, 3)
    _add_gram(out, coeffs[PAYLOAD_MASS], c1, c2, c3)

    # Rotational part: link 1 spins about z1, links 2 and 3 about z1 and z2.
    spin1 = coeffs[MASS] * coeffs[RADIUS_OF_GYRATION] ** 2
    spin23 = (
        coeffs[MASS + 1] * coeffs[RADIUS_OF_GYRATION + 1] ** 2
        + coeffs[MASS + 2] * coeffs[RADIUS_OF_GYRATION + 2] ** 2
    )
    cross12 = spin23 * _dot(z1, z2)
    out[0, 0] += spin1 + spin23
    out[0, 1] += cross12
    out[1, 0] += cross12
    out[1, 1] += spin23
    return out
