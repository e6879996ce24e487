"""URDF text of one RAVEN-II arm, for RViz, meshcat or another Pinocchio user.

The URDF holds the same kinematic chain as :mod:`kinematics.pinocchio_model`: one
link per DH frame (``link1`` .. ``link6``), joints named after the controller's joints
with the ``joint2theta`` offsets folded into the joint origins, so the URDF joint
positions are the controller's ``J``. A fixed joint adds the ``tool`` link at DH
frame 6. Links 1-3 carry their masses, centres of mass and the assumed isotropic
rotational inertia. URDF has no gravity: set it on the loaded model (the default
here is :data:`kinematics.mounting.DEFAULT_GRAVITY`). Effort and velocity limits
are not part of the model; the URDF states them as unbounded (``1e6``).
"""

from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np
import pinocchio as pin

from kinematics.arm_parameters import RavenArmParameters
from kinematics.joint_limits import JOINT_NAMES
from kinematics.pinocchio_model import TOOL_FRAME, link_placement

BASE_LINK = "base_link"
UNBOUNDED = "1e6"


def _number(value) -> str:
    return repr(float(value))


def _vector(values) -> str:
    return " ".join(_number(v) for v in values)


def _inertial(mass: float, com, inertia: np.ndarray) -> list[str]:
    return [
        "    <inertial>",
        f'      <origin xyz="{_vector(com)}" rpy="0 0 0"/>',
        f'      <mass value="{_number(mass)}"/>',
        f'      <inertia ixx="{_number(inertia[0, 0])}" ixy="{_number(inertia[0, 1])}" '
        f'ixz="{_number(inertia[0, 2])}" iyy="{_number(inertia[1, 1])}" '
        f'iyz="{_number(inertia[1, 2])}" izz="{_number(inertia[2, 2])}"/>',
        "    </inertial>",
    ]


def urdf_from_parameters(params: RavenArmParameters) -> str:
    """URDF string of the arm described by ``params``.

    Parameters
    ----------
    params : RavenArmParameters

    Returns
    -------
    str
        A complete URDF document; lengths in m, angles in rad, masses in kg.
    """
    dh = params.dh
    lower, upper = params.limits.arrays
    lines = [
        '<?xml version="1.0"?>',
        f"<robot name={quoteattr('raven2_' + params.arm)}>",
        f'  <link name="{BASE_LINK}"/>',
    ]
    parent = BASE_LINK
    for i, name in enumerate(JOINT_NAMES):
        child = f"link{i + 1}"
        placement = link_placement(dh.alpha[i], dh.a[i], dh.theta_offset[i], dh.d_offset[i])
        rpy = pin.rpy.matrixToRpy(placement.rotation)
        kind = "prismatic" if dh.prismatic[i] else "revolute"
        lines += [
            f'  <joint name="{name}" type="{kind}">',
            f'    <parent link="{parent}"/>',
            f'    <child link="{child}"/>',
            f'    <origin xyz="{_vector(placement.translation)}" rpy="{_vector(rpy)}"/>',
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_number(lower[i])}" upper="{_number(upper[i])}" '
            f'effort="{UNBOUNDED}" velocity="{UNBOUNDED}"/>',
            "  </joint>",
            f'  <link name="{child}">',
        ]
        if i < len(params.links) and params.links[i].mass > 0.0:
            link = params.links[i]
            lines += _inertial(link.mass, link.com, link.rotational_inertia())
        lines.append("  </link>")
        parent = child
    lines += [
        f'  <joint name="{TOOL_FRAME}_joint" type="fixed">',
        f'    <parent link="{parent}"/>',
        f'    <child link="{TOOL_FRAME}"/>',
        '    <origin xyz="0 0 0" rpy="0 0 0"/>',
        "  </joint>",
        f'  <link name="{TOOL_FRAME}"/>',
        "</robot>",
    ]
    return "\n".join(lines) + "\n"
