"""Immutable description of one RAVEN-II arm: DH table, masses, limits, gravity.

All numbers come from the RAVEN-II controller (repository ``uw-biorobotics/raven2``):

* modified-DH table and tool constants: ``src/raven/r2_kinematics.cpp`` and
  ``include/raven/r2_kinematics.h`` (``La12``, ``La23``, ``La3``, ``d4``, ``Lw``);
* joint-to-DH offsets: ``joint2theta`` in ``src/raven/r2_kinematics.cpp``;
* link masses and centres of mass: ``src/raven/grav_comp.cpp``;
* joint limits: ``include/raven/defines.h`` and ``include/raven/tool.h``;
* default gravity: ``getCurrentG`` and ``init.cpp`` (see :mod:`kinematics.mounting`).

Only masses and centres of mass are published. The rotational inertia of each link
about its centre of mass is an assumption of this model: isotropic, ``m k^2 I`` with a
radius of gyration ``k`` per link (default 0.05 m, the value of a 0.17 m slender rod,
``L / sqrt(12)``, the order of size of a RAVEN-II link). The centres of mass sit
0.17 m (link 1), 0.29 m (link 2) and 0.23-0.56 m (link 3) from the joint axes, so the
point-mass part dominates the joint-space inertia; ``k = 0`` gives pure point masses.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from kinematics.joint_limits import CONTROLLER_JOINT_LIMITS, N_JOINTS, JointLimits
from kinematics.mounting import ARMS, DEFAULT_GRAVITY

LA12 = float(np.deg2rad(75.0))
"""Twist between the shoulder and elbow axes (rad)."""
LA23 = float(np.deg2rad(52.0))
"""Twist between the elbow and insertion axes (rad)."""
TOOL_LENGTH = 0.47
"""RAVEN-II tool length (m): the controller's ``d4 = -0.47``."""
WRIST_LENGTH = 0.013
"""Wrist axis to jaw length of a RAVEN-II tool (m): the controller's ``Lw``."""
DEFAULT_RADIUS_OF_GYRATION = 0.05
"""Assumed isotropic radius of gyration of each link about its COM (m)."""

PRISMATIC = (False, False, True, False, False, False)
"""Joint type of J0..J5: only the insertion joint is prismatic."""


@dataclass(frozen=True)
class ModifiedDHTable:
    """Craig's modified-DH table with the controller's joint-to-DH offsets.

    Link ``i`` (1-based, i = 1..6) is ``Rx(alpha[i-1]) Tx(a[i-1]) Rz(theta_i) Tz(d_i)``.
    For a revolute joint ``theta_i = J[i-1] + theta_offset[i-1]`` and ``d_i = d_offset[i-1]``;
    for the prismatic joint ``d_i = J[i-1] + d_offset[i-1]`` and ``theta_i = theta_offset[i-1]``.

    Attributes
    ----------
    alpha : tuple of float, length 6
        Link twists alpha_0..alpha_5 (rad).
    a : tuple of float, length 6
        Link lengths a_0..a_5 (m).
    theta_offset : tuple of float, length 6
        Fixed part of theta_1..theta_6 (rad): the ``joint2theta`` offsets, or the
        constant theta of the prismatic joint.
    d_offset : tuple of float, length 6
        Fixed part of d_1..d_6 (m): link offsets, or the insertion offset.
    prismatic : tuple of bool, length 6
        Which joints are prismatic.
    """

    alpha: tuple[float, ...]
    a: tuple[float, ...]
    theta_offset: tuple[float, ...]
    d_offset: tuple[float, ...]
    prismatic: tuple[bool, ...] = PRISMATIC

    def __post_init__(self) -> None:
        for name in ("alpha", "a", "theta_offset", "d_offset"):
            values = np.asarray(getattr(self, name), dtype=float)
            if values.shape != (N_JOINTS,) or not np.all(np.isfinite(values)):
                raise ValueError(f"DH column {name} must hold {N_JOINTS} finite numbers")
            object.__setattr__(self, name, tuple(float(v) for v in values))
        if len(self.prismatic) != N_JOINTS:
            raise ValueError(f"DH column prismatic must hold {N_JOINTS} flags")
        object.__setattr__(self, "prismatic", tuple(bool(v) for v in self.prismatic))


@dataclass(frozen=True)
class LinkMass:
    """Mass properties of one link, expressed in its own DH frame.

    Attributes
    ----------
    mass : float
        Link mass (kg).
    com : tuple of float, length 3
        Centre of mass in the link's DH frame (m).
    radius_of_gyration : float
        Radius of gyration ``k`` of the assumed isotropic rotational inertia
        ``mass * k**2 * I`` about the centre of mass (m).
    """

    mass: float
    com: tuple[float, float, float]
    radius_of_gyration: float = DEFAULT_RADIUS_OF_GYRATION

    def __post_init__(self) -> None:
        com = np.asarray(self.com, dtype=float)
        if com.shape != (3,) or not np.all(np.isfinite(com)):
            raise ValueError(f"link centre of mass must be 3 finite numbers (m), got {self.com!r}")
        if not (np.isfinite(self.mass) and self.mass >= 0.0):
            raise ValueError(f"link mass must be finite and >= 0 kg, got {self.mass!r}")
        if not (np.isfinite(self.radius_of_gyration) and self.radius_of_gyration >= 0.0):
            raise ValueError(
                f"radius of gyration must be finite and >= 0 m, got {self.radius_of_gyration!r}"
            )
        object.__setattr__(self, "mass", float(self.mass))
        object.__setattr__(self, "com", tuple(float(v) for v in com))
        object.__setattr__(self, "radius_of_gyration", float(self.radius_of_gyration))

    def rotational_inertia(self) -> np.ndarray:
        """Rotational inertia about the centre of mass (kg m^2), shape (3, 3)."""
        return self.mass * self.radius_of_gyration**2 * np.eye(3)


@dataclass(frozen=True)
class RavenArmParameters:
    """Everything that defines the model of one RAVEN-II arm.

    Attributes
    ----------
    arm : {"left", "right"}
        ``"left"`` is the gold arm, ``"right"`` the green arm.
    dh : ModifiedDHTable
        Geometry and joint conventions.
    links : tuple of LinkMass, length 3
        Links 1-3 (shoulder, elbow, insertion). The tool links 4-6 are massless,
        as in the controller's gravity compensation.
    gravity : tuple of float, length 3
        Gravity in the base frame (m/s^2).
    limits : JointLimits
        Joint ranges used by the limit checks.
    """

    arm: str
    dh: ModifiedDHTable
    links: tuple[LinkMass, LinkMass, LinkMass]
    gravity: tuple[float, float, float] = DEFAULT_GRAVITY
    limits: JointLimits = field(default=CONTROLLER_JOINT_LIMITS)

    def __post_init__(self) -> None:
        if self.arm not in ARMS:
            raise ValueError(f"arm must be one of {ARMS}, got {self.arm!r}")
        if len(self.links) != 3 or not all(isinstance(link, LinkMass) for link in self.links):
            raise ValueError("links must be three LinkMass objects (links 1-3)")
        gravity = np.asarray(self.gravity, dtype=float)
        if gravity.shape != (3,) or not np.all(np.isfinite(gravity)):
            raise ValueError(f"gravity must be 3 finite numbers (m/s^2), got {self.gravity!r}")
        object.__setattr__(self, "links", tuple(self.links))
        object.__setattr__(self, "gravity", tuple(float(v) for v in gravity))

    def with_gravity(self, gravity) -> "RavenArmParameters":
        """A copy with another base-frame gravity vector (m/s^2)."""
        return replace(self, gravity=gravity)


def controller_dh_table(
    arm: str, tool_length: float = TOOL_LENGTH, wrist_length: float = WRIST_LENGTH
) -> ModifiedDHTable:
    """The controller's modified-DH table of one arm with its ``joint2theta`` offsets.

    Parameters
    ----------
    arm : {"left", "right"}
    tool_length : float
        Distance from the insertion frame to the wrist axis (m); ``d4 = -tool_length``.
    wrist_length : float
        Wrist axis to jaw length ``Lw`` (m).
    """
    if arm not in ARMS:
        raise ValueError(f"arm must be one of {ARMS}, got {arm!r}")
    deg = np.deg2rad
    if arm == "left":
        alpha = (0.0, LA12, np.pi - LA23, 0.0, np.pi / 2, np.pi / 2)
        theta_offset = (deg(205.0), deg(180.0), np.pi / 2, 0.0, deg(-90.0), 0.0)
    else:
        alpha = (np.pi, LA12, LA23, 0.0, np.pi / 2, np.pi / 2)
        theta_offset = (deg(25.0), 0.0, -np.pi / 2, 0.0, deg(-90.0), 0.0)
    return ModifiedDHTable(
        alpha=alpha,
        a=(0.0, 0.0, 0.0, 0.0, 0.0, wrist_length),
        theta_offset=theta_offset,
        d_offset=(0.0, 0.0, 0.0, -tool_length, 0.0, 0.0),
    )


def controller_link_masses(
    arm: str, radius_of_gyration=DEFAULT_RADIUS_OF_GYRATION
) -> tuple[LinkMass, LinkMass, LinkMass]:
    """Masses and centres of mass of links 1-3 from the controller's ``grav_comp.cpp``.

    Parameters
    ----------
    arm : {"left", "right"}
    radius_of_gyration : float or sequence of 3 floats
        Assumed isotropic radius of gyration of links 1-3 (m).
    """
    if arm not in ARMS:
        raise ValueError(f"arm must be one of {ARMS}, got {arm!r}")
    k = np.broadcast_to(np.asarray(radius_of_gyration, dtype=float), (3,))
    if arm == "left":
        coms = ((0.0065, 0.09775, -0.13771), (-0.002, -0.18274, -0.23053), (0.0, 0.0, 0.0))
    else:
        coms = ((-0.0065, -0.09775, 0.13771), (-0.002, -0.18274, 0.23053), (0.0, 0.0, 0.0))
    masses = (0.494, 0.750, 0.231)
    return tuple(LinkMass(m, c, float(ki)) for m, c, ki in zip(masses, coms, k))


def raven_arm_parameters(
    arm: str = "left",
    gravity=DEFAULT_GRAVITY,
    *,
    tool_length: float = TOOL_LENGTH,
    wrist_length: float = WRIST_LENGTH,
    radius_of_gyration=DEFAULT_RADIUS_OF_GYRATION,
    limits: JointLimits = CONTROLLER_JOINT_LIMITS,
) -> RavenArmParameters:
    """Parameters of one RAVEN-II arm as the controller defines it.

    Parameters
    ----------
    arm : {"left", "right"}
        ``"left"`` is the gold arm, ``"right"`` the green arm.
    gravity : array_like, shape (3,)
        Gravity in the base frame (m/s^2); default ``(-9.8, 0, 0)``, see
        :mod:`kinematics.mounting`.
    tool_length, wrist_length : float
        Tool constants (m); defaults are the RAVEN-II tool's.
    radius_of_gyration : float or sequence of 3 floats
        Assumed isotropic radius of gyration of links 1-3 (m).
    limits : JointLimits
        Joint ranges (default: the controller's).
    """
    return RavenArmParameters(
        arm=arm,
        dh=controller_dh_table(arm, tool_length, wrist_length),
        links=controller_link_masses(arm, radius_of_gyration),
        gravity=gravity,
        limits=limits,
    )
