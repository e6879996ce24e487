"""Zig-zag calibration paths of the positioning joints (paper section II-B, eq. 1-5).

Construction, following the authors' generator (``traj_generator/`` of
``uw-biorobotics/raven2_CRTK_Python_controller``):

1. In a unit cube of *lane coordinates* ``(u, v, w)``, a snake runs straight lanes along ``u``
   from 0 to 1 and back. Lanes sit at ``v, w`` in ``0, s, 2 s, ..., 1`` (sparsity ``s``, so
   ``1/s + 1`` positions per stepped axis and ``(1/s + 1)**2`` lanes); ``v`` is stepped inside
   ``w`` and reverses after each ``w`` step, so consecutive lanes are joined by connecting
   segments of length ``s``. Points are ``step`` (default 1e-3) apart along the path.
2. The cube is centred, turned so that ``u`` follows the named direction in the normalized
   workspace (eq. 1-3), scaled by ``1/sqrt(3)`` and centred at 0.5. Every direction is thus the
   same cube of side ``1/sqrt(3)`` and volume ``3**-1.5``, only turned. Eq. 4-5's ranges
   ``1/sqrt(3)``, ``sqrt(2)/sqrt(3)`` and 1 for single, double and triple directions are that
   cube's edge, face diagonal and space diagonal: the per-joint extent of the cube when its
   lanes run along a joint axis (every joint spans ``1/sqrt(3)``), along a face diagonal (the two
   lane joints span ``sqrt(2)/sqrt(3)``) or along the space diagonal (up to 1).
3. The normalized path is mapped to the workspace (joint 1 rad, joint 2 rad, joint 3 m).

Direction ``"J1"`` is the published ``dir_x`` path. ``"J2"``, ``"J3"``, ``"J1-J2"``, ``"J2-J3"`` and
``"J1-J3"`` use the published rotations (``dir_y``: 90 deg about joint 3; ``dir_z``: 90 deg about
joint 2; ``dir_xy``: 45 deg about joint 3; ``dir_yz``: 90 deg about joint 3 then 45 deg about
joint 1; ``dir_xz``: 45 deg about joint 2). Differences from the published files, on purpose:
lanes sit exactly at ``k s`` (the generator's accumulated 1e-3 steps overshoot to 0.334, 0.668,
1.002), the path ends with its last lane (the generator's stopping rule adds a 0.05 stub along
``w``), and ``"J1-J2-J3"`` runs its lanes along the space diagonal ``(1, 1, 1)/sqrt(3)``: the
published ``dir_xyz`` rotation sequence leaves the lanes along ``(0.85, 0.50, -0.15)`` and its
output leaves the workspace in joint 2 by 1.4 % of the range.
"""

from __future__ import annotations

import numpy as np

from simulation.trajectories.workspace import Workspace, resolve_workspace

DEFAULT_STEP = 1e-3
"""Distance between consecutive path points in lane coordinates (the generator's ``scar_l``);
``DEFAULT_STEP * CUBE_SIDE`` in the normalized workspace."""

CUBE_SIDE = float(1.0 / np.sqrt(3.0))
"""Side of the zig-zag cube in the normalized workspace, for every direction (eq. 4-5)."""

_SPARSITY_TOLERANCE = 0.01
"""How far ``1/s`` may be from an integer: accepts the published 0.3333 and 0.1666."""

_TRIPLE_TWIST = np.deg2rad(15.0)
"""Turn of the J1-J2-J3 cube about its lane axis. No turn gives every joint the full range (a
cube's edges cannot make equal angles with all three axes); 15 deg maximizes the smallest
per-joint extent: 0.911, 1.000, 0.911 of the workspace."""


def _triple_axes() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    lane = np.ones(3) / np.sqrt(3.0)
    inner0 = np.array([-1.0, 1.0, 0.0]) / np.sqrt(2.0)
    outer0 = np.cross(lane, inner0)
    inner = np.cos(_TRIPLE_TWIST) * inner0 + np.sin(_TRIPLE_TWIST) * outer0
    return lane, inner, np.cross(lane, inner)


_H = float(1.0 / np.sqrt(2.0))
_LANE_AXES = {
    "J1": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)),
    "J2": ((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)),
    "J3": ((0.0, 0.0, -1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)),
    "J1-J2": ((_H, _H, 0.0), (-_H, _H, 0.0), (0.0, 0.0, 1.0)),
    "J2-J3": ((0.0, _H, _H), (-1.0, 0.0, 0.0), (0.0, -_H, _H)),
    "J1-J3": ((_H, 0.0, -_H), (0.0, 1.0, 0.0), (_H, 0.0, _H)),
    "J1-J2-J3": _triple_axes(),
}

DIRECTIONS = tuple(_LANE_AXES)
"""Zig-zag directions of the paper: single, double and triple joint directions."""


def lane_axes(direction: str) -> np.ndarray:
    """Rotation that turns lane coordinates into the named direction.

    Parameters
    ----------
    direction : str
        One of :data:`DIRECTIONS`.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        Columns are the lane axis ``u``, the inner stepped axis ``v`` and the outer stepped axis
        ``w``, as unit vectors in the normalized (joint 1, joint 2, joint 3) space.

    Raises
    ------
    ValueError
        If ``direction`` is not one of :data:`DIRECTIONS`.
    """
    if direction not in _LANE_AXES:
        raise ValueError(
            f"unknown zig-zag direction {direction!r}; expected one of {', '.join(DIRECTIONS)}"
        )
    return np.array(_LANE_AXES[direction], dtype=float).T


def lanes_per_axis(sparsity: float) -> int:
    """Number of lane positions ``1/s + 1`` along each stepped axis for sparsity ``s``.

    Parameters
    ----------
    sparsity : float
        Lane spacing as a fraction of the zig-zag cube, in (0, 1], with ``1/s`` an integer;
        a value within 0.01 of ``1/n`` in ``1/s`` (such as the published 0.3333 or 0.1666) is
        read as ``1/n``.

    Raises
    ------
    ValueError
        If ``sparsity`` is not a finite number in (0, 1] or ``1/sparsity`` is not an integer.
    """
    s = float(sparsity)
    if not (np.isfinite(s) and 0.0 < s <= 1.0):
        raise ValueError(f"sparsity must be a number in (0, 1], got {sparsity}")
    inverse = 1.0 / s
    n_intervals = round(inverse)
    if abs(inverse - n_intervals) > _SPARSITY_TOLERANCE:
        raise ValueError(f"sparsity must be 1/n for an integer n, got {sparsity} (1/s = {inverse:.4g})")
    return n_intervals + 1


def zigzag_length(sparsity: float) -> float:
    """Length of a zig-zag path of any direction in the normalized workspace.

    ``n**2`` lanes of length 1, ``n`` inner sweeps and one outer sweep of total length 1 each
    (``n = 1/s + 1``), in lane coordinates, times :data:`CUBE_SIDE`.
    """
    n = lanes_per_axis(sparsity)
    return (n * n + n + 1) * CUBE_SIDE


def _evenly(start: np.ndarray, stop: np.ndarray, step: float, include_start: bool) -> np.ndarray:
    n_steps = max(1, int(np.ceil(np.linalg.norm(stop - start) / step - 1e-9)))
    fractions = np.arange(0 if include_start else 1, n_steps + 1) / n_steps
    return start + fractions[:, None] * (stop - start)


def snake_in_unit_cube(sparsity: float, step: float = DEFAULT_STEP) -> np.ndarray:
    """The published snake in lane coordinates ``(u, v, w)`` of the unit cube.

    Parameters
    ----------
    sparsity : float
        Lane spacing, see :func:`lanes_per_axis`.
    step : float
        Largest distance between consecutive points (lane units), in (0, sparsity].

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        Points from ``(0, 0, 0)`` through every lane; lane ``k`` runs along ``+u`` when ``k`` is
        even, ``v`` is stepped inside ``w``.
    """
    n = lanes_per_axis(sparsity)
    spacing = 1.0 / (n - 1)
    step = float(step)
    if not (np.isfinite(step) and 0.0 < step <= spacing):
        raise ValueError(f"step must be in (0, {spacing:.4g}] (the lane spacing), got {step}")
    corners = []
    for lane in range(n * n):
        outer = lane // n
        inner = lane % n if outer % 2 == 0 else n - 1 - lane % n
        u_start, u_stop = (0.0, 1.0) if lane % 2 == 0 else (1.0, 0.0)
        corners.append((u_start, inner * spacing, outer * spacing))
        corners.append((u_stop, inner * spacing, outer * spacing))
    corners = np.array(corners)
    pieces = [corners[:1]]
    for start, stop in zip(corners[:-1], corners[1:]):
        pieces.append(_evenly(start, stop, step, include_start=False))
    return np.concatenate(pieces)


def zigzag_normalized(direction: str, sparsity: float, step: float = DEFAULT_STEP) -> np.ndarray:
    """Zig-zag path in the normalized workspace (each joint 0..1 over its range).

    Parameters
    ----------
    direction : str
        One of :data:`DIRECTIONS`.
    sparsity : float
        Lane spacing, see :func:`lanes_per_axis`.
    step : float
        Point spacing in lane coordinates; ``step * CUBE_SIDE`` in the normalized workspace.

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        Points of a cube of side :data:`CUBE_SIDE` centred at 0.5, turned to ``direction``.
    """
    axes = lane_axes(direction)
    cube = snake_in_unit_cube(sparsity, step)
    # The J1-J2-J3 cube touches 0 and 1 in joint 2; clipping removes only rounding.
    return np.clip(0.5 + CUBE_SIDE * (cube - 0.5) @ axes.T, 0.0, 1.0)


def zigzag(
    direction: str, sparsity: float, workspace: Workspace | None = None, step: float = DEFAULT_STEP
) -> np.ndarray:
    """Zig-zag calibration path of the positioning joints.

    Parameters
    ----------
    direction : str
        ``"J1"``, ``"J2"``, ``"J3"``, ``"J1-J2"``, ``"J2-J3"``, ``"J1-J3"`` or ``"J1-J2-J3"``: the
        joints the lanes move (the paper's numbering: shoulder, elbow, insertion).
    sparsity : float
        Lane spacing ``s`` as a fraction of the zig-zag cube, ``1/s`` an integer (e.g. 1/2, 1/3,
        1/4, 1/6); smaller means more lanes, ``(1/s + 1)**2``, and a longer path.
    workspace : Workspace, optional
        Box the normalized path is mapped to; default the paper's calibration workspace.
    step : float
        Point spacing in lane coordinates (default 1e-3, the published step).

    Returns
    -------
    numpy.ndarray, shape (N, 3)
        Joint positions ``[joint 1 rad, joint 2 rad, joint 3 m]``, all inside ``workspace``.

    Raises
    ------
    ValueError
        On an unknown direction, a sparsity outside (0, 1] or not ``1/n``, or a bad step.
    """
    return resolve_workspace(workspace).denormalize(zigzag_normalized(direction, sparsity, step))
