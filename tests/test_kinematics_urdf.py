"""The exported URDF loads into Pinocchio as the same arm."""

import numpy as np
import pinocchio as pin
import pytest

from kinematics import RavenII


@pytest.fixture(params=["left", "right"])
def robot(request):
    return RavenII(request.param)


def _load(urdf_text, gravity):
    model = pin.buildModelFromXML(urdf_text)
    model.gravity = pin.Motion(np.asarray(gravity), np.zeros(3))
    return model, model.createData()


def test_urdf_model_has_the_same_forward_kinematics(robot):
    model, data = _load(robot.to_urdf(), robot.gravity)
    tool = model.getFrameId("tool")
    rng = np.random.default_rng(20)
    for q in rng.uniform(*robot.joint_limits, size=(50, 6)):
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(
            data.oMf[tool].homogeneous, robot.forward_kinematics(q), atol=1e-12
        )


def test_urdf_model_has_the_same_joints_limits_and_gravity_torques(robot):
    model, data = _load(robot.to_urdf(), robot.gravity)
    assert [model.names[i] for i in range(1, model.njoints)] == list(robot.model.names)[1:]
    lower, upper = robot.joint_limits
    np.testing.assert_allclose(model.lowerPositionLimit, lower)
    np.testing.assert_allclose(model.upperPositionLimit, upper)
    rng = np.random.default_rng(21)
    for q in rng.uniform(lower, upper, size=(20, 6)):
        torques = pin.computeGeneralizedGravity(model, data, q)[:3]
        np.testing.assert_allclose(torques, robot.gravity_torques(q), atol=1e-12)
        inertia = pin.crba(model, data, q)[:3, :3]
        np.testing.assert_allclose(np.triu(inertia), np.triu(robot.mass_matrix(q)), atol=1e-12)
