"""Build the Pinocchio model of one RAVEN-II arm from its parameters.

Each modified-DH link ``Rx(alpha) Tx(a) Rz(theta) Tz(d)`` becomes a joint placement
holding the constant part and a joint holding the variable part:

* revolute: placement ``Rx(alpha) Tx(a) Tz(d) Rz(theta_offset)`` then ``Rz(J)``
  (rotations and translations along z commute);
* prismatic: placement ``Rx(alpha) Tx(a) Rz(theta) Tz(d_offset)`` then ``Tz(J)``.

So the Pinocchio configuration is the controller's joint vector ``J`` itself, and
each joint frame is the controller's DH frame. The tool frame ``"tool"`` is DH
frame 6, the pose the controller's ``fwd_kin`` returns.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from kinematics.arm_parameters import RavenArmParameters
from kinematics.dh_batch import rot_x, rot_z
from kinematics.joint_limits import JOINT_NAMES

TOOL_FRAME = "tool"
"""Name of the tool frame (DH frame 6) in the model."""


def link_placement(alpha: float, a: float, theta: float, d: float) -> pin.SE3:
    """Constant placement of a joint in its parent joint frame.

    Parameters
    ----------
    alpha, a : float
        Twist (rad) and length (m) of the preceding link.
    theta, d : float
        Constant rotation (rad) and offset (m) along the joint axis.

    Notes
    -----
    Both joint types share this constant part: ``theta`` is a revolute joint's
    zero offset or the prismatic joint's fixed angle, ``d`` a revolute joint's
    fixed offset or the prismatic joint's zero offset.
    """
    rx = rot_x(alpha)
    rotation = rx @ rot_z(theta)
    translation = rx @ np.array([a, 0.0, d])
    return pin.SE3(rotation, translation)


def build_model(params: RavenArmParameters) -> pin.Model:
    """Pinocchio model (kinematics, masses, limits, gravity) of one arm.

    Parameters
    ----------
    params : RavenArmParameters

    Returns
    -------
    pinocchio.Model
        Six joints named after :data:`kinematics.joint_limits.JOINT_NAMES`,
        bodies for links 1-3 (tool links massless), position limits set to
        ``params.limits``, gravity set to ``params.gravity`` and an operational
        frame :data:`TOOL_FRAME` at DH frame 6.
    """
    model = pin.Model()
    model.name = f"raven2_{params.arm}"
    dh = params.dh
    parent = 0
    for i, name in enumerate(JOINT_NAMES):
        placement = link_placement(dh.alpha[i], dh.a[i], dh.theta_offset[i], dh.d_offset[i])
        joint_model = pin.JointModelPZ() if dh.prismatic[i] else pin.JointModelRZ()
        parent = model.addJoint(parent, joint_model, placement, name)
        model.addJointFrame(parent)
        if i < len(params.links):
            link = params.links[i]
            inertia = pin.Inertia(link.mass, np.array(link.com), link.rotational_inertia())
            model.appendBodyToJoint(parent, inertia, pin.SE3.Identity())
        model.addBodyFrame(f"link{i + 1}", parent, pin.SE3.Identity(), len(model.frames) - 1)
    model.addFrame(
        pin.Frame(TOOL_FRAME, parent, model.getFrameId(JOINT_NAMES[-1]), pin.SE3.Identity(),
                  pin.FrameType.OP_FRAME)
    )
    lower, upper = params.limits.arrays
    model.lowerPositionLimit = lower
    model.upperPositionLimit = upper
    model.gravity = pin.Motion(np.array(params.gravity), np.zeros(3))
    return model
