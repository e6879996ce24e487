"""Vectorized forward kinematics and Jacobian of a modified-DH chain (numpy).

The batch path evaluates many configurations at once without Pinocchio, for the
places that need millions of poses (Monte-Carlo error propagation, tool-tip errors
of long logs). It computes the same chain as the Pinocchio model built in
:mod:`kinematics.pinocchio_model`; a test holds the two equal.

Inputs here are already validated ``(N, 6)`` float arrays (see
:mod:`kinematics.joint_limits`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinematics.arm_parameters import ModifiedDHTable


def rot_x(angle: float) -> np.ndarray:
    """Rotation matrix about x by ``angle`` (rad), shape (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def rot_z(angle: float) -> np.ndarray:
    """Rotation matrix about z by ``angle`` (rad), shape (3, 3)."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


@dataclass(frozen=True)
class LinkConstants:
    """Configuration-independent parts of each link transform.

    Link ``i`` maps frame ``i`` into frame ``i-1`` as rotation
    ``fixed_rotation[i] @ Rz(q_i)`` (revolute) or ``fixed_rotation[i]`` (prismatic),
    and translation ``fixed_translation[i] + slide_direction[i] * q_i``
    (``slide_direction`` is zero for revolute joints).

    Attributes
    ----------
    fixed_rotation : numpy.ndarray, shape (6, 3, 3)
        ``Rx(alpha_{i-1}) Rz(theta_offset_i)``.
    fixed_translation : numpy.ndarray, shape (6, 3)
        ``Rx(alpha_{i-1}) (a_{i-1}, 0, d_offset_i)`` (m).
    slide_direction : numpy.ndarray, shape (6, 3)
        ``Rx(alpha_{i-1}) e_z`` for the prismatic joint, zero otherwise.
    prismatic : tuple of bool
    """

    fixed_rotation: np.ndarray
    fixed_translation: np.ndarray
    slide_direction: np.ndarray
    prismatic: tuple[bool, ...]

    @classmethod
    def from_dh(cls, dh: ModifiedDHTable) -> "LinkConstants":
        """Precompute the constants of every link of ``dh``."""
        rotations, translations, slides = [], [], []
        for alpha, a, theta, d, prismatic in zip(
            dh.alpha, dh.a, dh.theta_offset, dh.d_offset, dh.prismatic
        ):
            rx = rot_x(alpha)
            rotations.append(rx @ rot_z(theta))
            translations.append(rx @ np.array([a, 0.0, d]))
            slides.append(rx[:, 2] if prismatic else np.zeros(3))
        arrays = [np.array(rows) for rows in (rotations, translations, slides)]
        for arr in arrays:
            arr.setflags(write=False)
        return cls(*arrays, prismatic=tuple(dh.prismatic))


def _joint_rotation(fixed: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """``fixed @ Rz(angle)`` for a batch of angles, shape (N, 3, 3)."""
    c = np.cos(angle)[:, None]
    s = np.sin(angle)[:, None]
    out = np.empty((angle.shape[0], 3, 3))
    out[:, :, 0] = fixed[:, 0] * c + fixed[:, 1] * s
    out[:, :, 1] = fixed[:, 1] * c - fixed[:, 0] * s
    out[:, :, 2] = fixed[:, 2]
    return out


def _link(consts: LinkConstants, i: int, qi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (N, 3, 3) and translation (N, 3) of link ``i`` for joint values ``qi``."""
    if consts.prismatic[i]:
        rotation = np.broadcast_to(consts.fixed_rotation[i], (qi.shape[0], 3, 3))
        translation = consts.fixed_translation[i] + qi[:, None] * consts.slide_direction[i]
    else:
        rotation = _joint_rotation(consts.fixed_rotation[i], qi)
        translation = np.broadcast_to(consts.fixed_translation[i], (qi.shape[0], 3))
    return rotation, translation


def _accumulate(consts: LinkConstants, q: np.ndarray):
    """Yield the rotation (N, 3, 3) and origin (N, 3) of frames 1..6 in the base frame."""
    rotation, origin = _link(consts, 0, q[:, 0])
    yield rotation, origin
    for i in range(1, 6):
        link_rotation, link_translation = _link(consts, i, q[:, i])
        origin = origin + (rotation @ link_translation[:, :, None])[:, :, 0]
        rotation = rotation @ link_rotation
        yield rotation, origin


def joint_frames(consts: LinkConstants, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses of the six joint frames in the base frame.

    Parameters
    ----------
    consts : LinkConstants
    q : numpy.ndarray, shape (N, 6)
        Controller joint vectors J (rad, m).

    Returns
    -------
    rotations : numpy.ndarray, shape (N, 6, 3, 3)
    origins : numpy.ndarray, shape (N, 6, 3)
        Frame ``i`` (0-based here, the DH frame ``i + 1``) in the base frame (m).
    """
    n = q.shape[0]
    rotations = np.empty((n, 6, 3, 3))
    origins = np.empty((n, 6, 3))
    for i, (rotation, origin) in enumerate(_accumulate(consts, q)):
        rotations[:, i] = rotation
        origins[:, i] = origin
    return rotations, origins


def tool_transforms(consts: LinkConstants, q: np.ndarray) -> np.ndarray:
    """Tool (frame 6) transforms in the base frame, shape (N, 4, 4)."""
    for rotation, origin in _accumulate(consts, q):
        pass  # only the last frame, the tool's, is kept
    out = np.zeros((q.shape[0], 4, 4))
    out[:, :3, :3] = rotation
    out[:, :3, 3] = origin
    out[:, 3, 3] = 1.0
    return out


def tool_jacobians(consts: LinkConstants, q: np.ndarray) -> np.ndarray:
    """Geometric Jacobians of the tool frame, base-frame axes, shape (N, 6, 6).

    Rows 0-2 are d(tool origin)/dq (m/rad or m/m), rows 3-5 the base-frame angular
    velocity per joint rate (rad/s per rad/s, zero for the prismatic joint).
    """
    rotations, origins = joint_frames(consts, q)
    axes = rotations[:, :, :, 2]
    tip = origins[:, 5]
    jac = np.zeros((q.shape[0], 6, 6))
    for i in range(6):
        if consts.prismatic[i]:
            jac[:, :3, i] = axes[:, i]
        else:
            jac[:, :3, i] = np.cross(axes[:, i], tip - origins[:, i])
            jac[:, 3:, i] = axes[:, i]
    return jac
