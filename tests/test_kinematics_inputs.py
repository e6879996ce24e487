"""Bad input to the kinematics API: clear ValueErrors that name the joint and the limit."""

import numpy as np
import pytest

from kinematics import RavenII, check_joint_limits, gravity_from_accelerometer

DEG = np.pi / 180.0
INSIDE = np.array([30 * DEG, 80 * DEG, 0.40, 0.1, 0.2, 0.3])


@pytest.fixture(scope="module")
def robot():
    return RavenII("left")


METHODS = ["forward_kinematics", "tool_position", "jacobian", "gravity_torques", "mass_matrix"]


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("shape", [(5,), (7,), (2, 5), (2, 3, 6), ()])
def test_wrong_shape_is_rejected(robot, method, shape):
    with pytest.raises(ValueError, match=r"shape \(6,\) or \(N, 6\)"):
        getattr(robot, method)(np.zeros(shape))


def test_non_numeric_input_is_rejected(robot):
    with pytest.raises(ValueError, match="numeric"):
        robot.forward_kinematics(["a"] * 6)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("method", METHODS)
def test_non_finite_value_names_the_joint(robot, method, bad):
    q = INSIDE.copy()
    q[4] = bad
    with pytest.raises(ValueError, match=r"non-finite.*wrist \(J4\)"):
        getattr(robot, method)(q, check_limits=False)


def test_non_finite_value_in_batch_names_the_row(robot):
    q = np.tile(INSIDE, (4, 1))
    q[2, 1] = np.nan
    with pytest.raises(ValueError, match=r"elbow \(J1\) in row 2"):
        robot.forward_kinematics(q)


@pytest.mark.parametrize("method", METHODS)
def test_joint_below_limit_names_joint_and_limit(robot, method):
    q = INSIDE.copy()
    q[1] = 30 * DEG
    with pytest.raises(ValueError) as info:
        getattr(robot, method)(q)
    message = str(info.value)
    assert "elbow (J1)" in message
    assert "lower limit 0.785398 rad (45 deg)" in message
    assert "check_limits=False" in message


def test_insertion_above_limit_names_joint_limit_and_row(robot):
    q = np.tile(INSIDE, (3, 1))
    q[1, 2] = 0.60
    with pytest.raises(ValueError) as info:
        robot.forward_kinematics(q)
    message = str(info.value)
    assert "z_ins (J2) in row 1 = 0.6 m" in message
    assert "upper limit 0.56 m" in message


@pytest.mark.parametrize(
    "index, value, label",
    [
        (0, -1 * DEG, "shoulder (J0)"),
        (0, 91 * DEG, "shoulder (J0)"),
        (1, 136 * DEG, "elbow (J1)"),
        (2, 0.22, "z_ins (J2)"),
        (3, 183 * DEG, "tool_rot (J3)"),
        (4, -76 * DEG, "wrist (J4)"),
        (5, 90 * DEG, "grasp (J5)"),
    ],
)
def test_every_controller_limit_is_enforced(robot, index, value, label):
    q = INSIDE.copy()
    q[index] = value
    with pytest.raises(ValueError, match=label.replace("(", r"\(").replace(")", r"\)")):
        robot.forward_kinematics(q)


def test_limits_are_inclusive(robot):
    lower, upper = robot.joint_limits
    robot.forward_kinematics(np.stack([lower, upper]))


def test_limit_check_can_be_switched_off_per_call_and_per_model(robot):
    q = INSIDE.copy()
    q[0] = -10 * DEG
    expected = robot.forward_kinematics(q, check_limits=False)
    lenient = RavenII("left", check_limits=False)
    np.testing.assert_array_equal(lenient.forward_kinematics(q), expected)
    with pytest.raises(ValueError, match="shoulder"):
        lenient.forward_kinematics(q, check_limits=True)


def test_joint_limits_property_is_the_controllers(robot):
    lower, upper = robot.joint_limits
    np.testing.assert_allclose(np.rad2deg(lower[[0, 1, 3, 4, 5]]), [0, 45, -182, -75, -89])
    np.testing.assert_allclose(np.rad2deg(upper[[0, 1, 3, 4, 5]]), [90, 135, 182, 75, 89])
    assert (lower[2], upper[2]) == (0.23, 0.56)
    lower[0] = 5.0  # a copy: the model's limits stay
    assert robot.joint_limits[0][0] == 0.0


def test_check_joint_limits_accepts_the_positioning_joints_alone():
    check_joint_limits(INSIDE[:3])
    with pytest.raises(ValueError, match=r"z_ins \(J2\)"):
        check_joint_limits([[0.1, 1.0, 0.1]])
    with pytest.raises(ValueError, match="1 <= k <= 6"):
        check_joint_limits(np.zeros(7))


def test_bad_payload_and_backend_are_rejected(robot):
    with pytest.raises(ValueError, match="payload_kg"):
        robot.gravity_torques(INSIDE, payload_kg=-0.1)
    with pytest.raises(ValueError, match="payload_kg"):
        robot.gravity_coefficients(payload_kg=np.nan)
    with pytest.raises(ValueError, match="tool_joints"):
        robot.gravity_coefficients(0.1, tool_joints=(0.0, np.inf, 0.0))
    with pytest.raises(ValueError, match="backend"):
        robot.forward_kinematics(INSIDE, backend="casadi")


def test_bad_model_parameters_are_rejected():
    with pytest.raises(ValueError, match="arm"):
        RavenII("middle")
    with pytest.raises(ValueError, match="gravity"):
        RavenII("left", gravity=(0.0, np.nan, -9.8))
    with pytest.raises(ValueError, match="radius of gyration"):
        RavenII("left", radius_of_gyration=-0.01)
    with pytest.raises(ValueError, match="accelerometer"):
        gravity_from_accelerometer((0.0, 980.0), "left")
