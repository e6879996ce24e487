"""RAVEN-II model against an independent implementation of the controller's equations.

The reference below is written from the controller's source (``r2_kinematics.cpp``:
DH table, ``getFKTransform``, ``joint2theta``; ``grav_comp.cpp``: masses, centres of
mass, ``getGravityTorque``), not through the ``kinematics`` package.
"""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numba import njit

from kinematics import RavenII, gravity_torques_fast, mass_matrix_fast

DEG = np.pi / 180.0
ARMS = ("left", "right")

# --- independent reference: the controller's tables and formulas ---------------------
REF_ALPHA = {
    "left": [0.0, 75 * DEG, np.pi - 52 * DEG, 0.0, np.pi / 2, np.pi / 2],
    "right": [np.pi, 75 * DEG, 52 * DEG, 0.0, np.pi / 2, np.pi / 2],
}
REF_A = [0.0, 0.0, 0.0, 0.0, 0.0, 0.013]
REF_D4 = -0.47
REF_THETA3 = {"left": np.pi / 2, "right": -np.pi / 2}
REF_J_TO_THETA = {  # joint2theta offsets (deg); index 2 is d3 = J2
    "left": [205.0, 180.0, 0.0, 0.0, -90.0, 0.0],
    "right": [25.0, 0.0, 0.0, 0.0, -90.0, 0.0],
}
REF_MASS = [0.494, 0.750, 0.231]
REF_COM = {
    "left": [[0.0065, 0.09775, -0.13771], [-0.002, -0.18274, -0.23053], [0.0, 0.0, 0.0]],
    "right": [[-0.0065, -0.09775, 0.13771], [-0.002, -0.18274, 0.23053], [0.0, 0.0, 0.0]],
}


def ref_link(alpha, a, theta, d):
    """getFKTransform's single-link matrix (modified DH)."""
    ca, sa, ct, st = np.cos(alpha), np.sin(alpha), np.cos(theta), np.sin(theta)
    return np.array(
        [
            [ct, -st, 0.0, a],
            [st * ca, ct * ca, -sa, -sa * d],
            [st * sa, ct * sa, ca, ca * d],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def ref_links(J, arm):
    """The six link transforms ^{i-1}T_i for controller joints J."""
    th = [J[i] + REF_J_TO_THETA[arm][i] * DEG for i in range(6)]
    th = [(t + np.pi) % (2 * np.pi) - np.pi for t in th]  # joint2theta wraps to [-pi, pi]
    thetas = [th[0], th[1], REF_THETA3[arm], th[3], th[4], th[5]]
    ds = [0.0, 0.0, J[2], REF_D4, 0.0, 0.0]
    return [ref_link(REF_ALPHA[arm][i], REF_A[i], thetas[i], ds[i]) for i in range(6)]


def ref_frames(J, arm):
    """^0T_i for i = 1..6."""
    out, T = [], np.eye(4)
    for link in ref_links(J, arm):
        T = T @ link
        out.append(T)
    return out


def ref_fk(J, arm):
    return ref_frames(J, arm)[-1]


def ref_gravity(J, arm, g0):
    """getGravityTorque before the motor mapping: GZ_i = -z . GT_i."""
    T01, T12, T23 = ref_links(J, arm)[:3]
    R01, R12, R23 = T01[:3, :3], T12[:3, :3], T23[:3, :3]
    com1, com2, com3 = (np.append(c, 1.0) for c in REF_COM[arm])
    com3_2 = T23 @ com3
    com3_1 = (T12 @ com3_2)[:3]
    com2_1 = (T12 @ com2)[:3]
    com3_2 = com3_2[:3]
    G1 = R01.T @ g0
    G2 = R12.T @ G1
    G3 = R23.T @ G2
    M1, M2, M3 = REF_MASS
    GT1 = np.cross(com1[:3], M1 * G1) + np.cross(com2_1, M2 * G1) + np.cross(com3_1, M3 * G1)
    GT2 = np.cross(com2[:3], M2 * G2) + np.cross(com3_2, M3 * G2)
    GT3 = M3 * G3
    return -np.array([GT1[2], GT2[2], GT3[2]])


def ref_point_jacobian(J, arm, point, n_joints):
    """Linear Jacobian (3, 3) wrt J0..J2 of a base-frame point moved by the first joints."""
    frames = ref_frames(J, arm)
    jac = np.zeros((3, 3))
    for i in range(n_joints):
        z, o = frames[i][:3, 2], frames[i][:3, 3]
        jac[:, i] = z if i == 2 else np.cross(z, point - o)
    return jac


def random_q(rng, n, robot):
    lower, upper = robot.joint_limits
    return rng.uniform(lower, upper, size=(n, 6))


@pytest.fixture(params=ARMS)
def robot(request):
    return RavenII(request.param)


# --- forward kinematics --------------------------------------------------------------
@pytest.mark.parametrize("backend", ["pinocchio", "numpy"])
def test_fk_equals_independent_dh_product(robot, backend):
    q = random_q(np.random.default_rng(1), 200, robot)
    got = robot.forward_kinematics(q, backend=backend)
    expected = np.array([ref_fk(qn, robot.arm) for qn in q])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-10)


def test_fk_single_configuration_shape_and_value(robot):
    q = random_q(np.random.default_rng(2), 1, robot)[0]
    pose = robot.forward_kinematics(q)
    assert pose.shape == (4, 4)
    np.testing.assert_allclose(pose, ref_fk(q, robot.arm), rtol=0, atol=1e-10)


def _hand_computed_pose(arm, insertion):
    """Pose at J = (65 deg, 90 deg, insertion, 0, 0, 0), derived by hand.

    theta1 = theta2 = +-90 deg, so R_01 R_12 R_23 reduces to sines and cosines of
    the twists 75 and 52 deg. The insertion axis z3 and x3 follow; with tool roll 0
    and wrist 0 (theta5 = -90 deg) the jaw frame is x6 = -z3, y6 = -y3, z6 = -x3,
    and the tip lies on the tool axis at d3 + d4 - Lw.
    """
    s52, c52, s75, c75 = np.sin(52 * DEG), np.cos(52 * DEG), np.sin(75 * DEG), np.cos(75 * DEG)
    if arm == "left":
        z3 = np.array([c52 * s75, s52, -c52 * c75])
        x3 = np.array([-s52 * s75, c52, s52 * c75])
    else:
        z3 = np.array([c52 * s75, -s52, -c52 * c75])
        x3 = np.array([-s52 * s75, -c52, s52 * c75])
    y3 = np.cross(z3, x3)
    pose = np.eye(4)
    pose[:3, :3] = np.column_stack([-z3, -y3, -x3])
    pose[:3, 3] = (insertion - 0.47 - 0.013) * z3
    return pose


@pytest.mark.parametrize("insertion", [0.25, 0.40, 0.55])
def test_fk_matches_hand_computed_configuration(robot, insertion):
    q = np.array([65 * DEG, 90 * DEG, insertion, 0.0, 0.0, 0.0])
    np.testing.assert_allclose(
        robot.forward_kinematics(q), _hand_computed_pose(robot.arm, insertion), atol=1e-12
    )


def test_arms_are_mirror_images_in_y(robot):
    """The two arms mirror each other in the base x-z plane (see the hand result above);
    a mirrored tool roll turns the other way."""
    other = RavenII("right" if robot.arm == "left" else "left")
    q = random_q(np.random.default_rng(3), 50, robot)
    q_mirrored = q * [1, 1, 1, -1, 1, 1]
    np.testing.assert_allclose(
        robot.tool_position(q) * [1, -1, 1], other.tool_position(q_mirrored), atol=1e-12
    )


_limits = RavenII("left").joint_limits
joint_vectors = st.tuples(
    *(st.floats(float(lo), float(hi), allow_nan=False) for lo, hi in zip(*_limits))
)


@settings(max_examples=60, deadline=None)
@given(q=joint_vectors, arm=st.sampled_from(ARMS))
def test_fk_is_a_rigid_transform(q, arm):
    pose = RavenII(arm).forward_kinematics(np.array(q))
    rotation = pose[:3, :3]
    np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-12)
    assert np.linalg.det(rotation) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(pose[3], [0.0, 0.0, 0.0, 1.0])


def test_batched_numpy_path_equals_pinocchio(robot):
    q = random_q(np.random.default_rng(4), 500, robot)
    np.testing.assert_allclose(
        robot.forward_kinematics(q, backend="numpy"),
        robot.forward_kinematics(q, backend="pinocchio"),
        rtol=0,
        atol=1e-12,
    )
    np.testing.assert_allclose(
        robot.jacobian(q, backend="numpy"), robot.jacobian(q, backend="pinocchio"), atol=1e-12
    )


def test_tool_position_is_fk_translation(robot):
    q = random_q(np.random.default_rng(5), 20, robot)
    positions = robot.tool_position(q)
    assert positions.shape == (20, 3)
    np.testing.assert_allclose(positions, [ref_fk(qn, robot.arm)[:3, 3] for qn in q], atol=1e-10)
    assert robot.tool_position(q[0]).shape == (3,)


# --- Jacobian --------------------------------------------------------------------------
def _vee(skew):
    return np.array([skew[2, 1] - skew[1, 2], skew[0, 2] - skew[2, 0], skew[1, 0] - skew[0, 1]]) / 2


@pytest.mark.parametrize("backend", ["pinocchio", "numpy"])
def test_jacobian_equals_central_differences(robot, backend):
    h = 1e-6
    for q in random_q(np.random.default_rng(6), 10, robot):
        jac = robot.jacobian(q, backend=backend, check_limits=False)
        numeric = np.zeros((6, 6))
        for i in range(6):
            step = np.zeros(6)
            step[i] = h
            plus = robot.forward_kinematics(q + step, check_limits=False)
            minus = robot.forward_kinematics(q - step, check_limits=False)
            numeric[:3, i] = (plus[:3, 3] - minus[:3, 3]) / (2 * h)
            rotation_rate = (plus[:3, :3] - minus[:3, :3]) / (2 * h)
            numeric[3:, i] = _vee(rotation_rate @ robot.forward_kinematics(q)[:3, :3].T)
        np.testing.assert_allclose(jac, numeric, atol=1e-7)


def test_insertion_column_is_the_tool_axis_and_angular_part_zero(robot):
    q = random_q(np.random.default_rng(7), 5, robot)
    jac = robot.jacobian(q)
    for qn, jn in zip(q, jac):
        z3 = ref_frames(qn, robot.arm)[2][:3, 2]
        np.testing.assert_allclose(jn[:3, 2], z3, atol=1e-12)
        np.testing.assert_allclose(jn[3:, 2], 0.0, atol=1e-15)


# --- gravity ---------------------------------------------------------------------------
def test_default_gravity_is_the_controllers_startup_vector(robot):
    """getCurrentG of the start-up reading grav_dir = (0, 0, 980) cm/s^2, both arms."""
    x, y, z = 0.0, 0.0, 980.0
    if robot.arm == "left":
        expected = np.array([-z, x, -y]) / 100
    else:
        expected = np.array([-z, -x, y]) / 100
    np.testing.assert_allclose(robot.gravity, expected, atol=0)


@pytest.mark.parametrize("gravity", [(-9.8, 0.0, 0.0), (-6.0, 3.0, 7.0)])
@pytest.mark.parametrize("arm", ARMS)
def test_gravity_torques_equal_controller_formula(arm, gravity):
    robot = RavenII(arm, gravity=gravity)
    q = random_q(np.random.default_rng(8), 100, robot)
    expected = np.array([ref_gravity(qn, arm, np.array(gravity)) for qn in q])
    np.testing.assert_allclose(robot.gravity_torques(q), expected, rtol=0, atol=1e-9)


def test_gravity_insertion_force_is_weight_along_axis(robot):
    """Holding the insertion stage: only link 3 hangs on the prismatic joint."""
    q = random_q(np.random.default_rng(9), 10, robot)
    for qn in q:
        z3 = ref_frames(qn, robot.arm)[2][:3, 2]
        expected = -REF_MASS[2] * z3 @ robot.gravity
        assert robot.gravity_torques(qn)[2] == pytest.approx(expected, abs=1e-12)


def test_payload_adds_jacobian_transpose_of_its_weight(robot):
    payload = 0.35
    q = random_q(np.random.default_rng(10), 30, robot)
    added = robot.gravity_torques(q, payload) - robot.gravity_torques(q)
    for qn, dn in zip(q, added):
        tip = ref_fk(qn, robot.arm)[:3, 3]
        jac = ref_point_jacobian(qn, robot.arm, tip, 3)
        np.testing.assert_allclose(dn, -jac.T @ (payload * robot.gravity), atol=1e-9)


@pytest.mark.parametrize("payload", [0.0, 0.5])
def test_fast_gravity_equals_pinocchio(robot, payload):
    q = random_q(np.random.default_rng(11), 100, robot)
    expected = robot.gravity_torques(q, payload)
    for qn, en in zip(q, expected):
        coeffs = robot.gravity_coefficients(payload, tool_joints=qn[3:])
        np.testing.assert_allclose(gravity_torques_fast(qn[:3], coeffs), en, rtol=0, atol=1e-9)


def test_fast_gravity_is_callable_from_other_compiled_code(robot):
    @njit
    def total_load(q3s, coeffs):
        out = np.zeros(3)
        for n in range(q3s.shape[0]):
            out += gravity_torques_fast(q3s[n], coeffs)
        return out

    q = random_q(np.random.default_rng(12), 20, robot)
    q[:, 3:] = 0.0
    coeffs = robot.gravity_coefficients(0.2)
    np.testing.assert_allclose(
        total_load(q[:, :3].copy(), coeffs), robot.gravity_torques(q, 0.2).sum(axis=0), atol=1e-9
    )


# --- inertia ---------------------------------------------------------------------------
def ref_mass_matrix(J, arm, radius_of_gyration, payload):
    """sum_j m_j Jv_j^T Jv_j + m_j k^2 Jw_j^T Jw_j, plus the payload as a point mass."""
    frames = ref_frames(J, arm)
    out = np.zeros((3, 3))
    for j in range(3):
        com = (frames[j] @ np.append(REF_COM[arm][j], 1.0))[:3]
        jv = ref_point_jacobian(J, arm, com, j + 1)
        jw = np.zeros((3, 3))
        for i in range(min(j + 1, 2)):
            jw[:, i] = frames[i][:3, 2]
        out += REF_MASS[j] * (jv.T @ jv + radius_of_gyration**2 * jw.T @ jw)
    tip = frames[-1][:3, 3]
    jt = ref_point_jacobian(J, arm, tip, 3)
    return out + payload * jt.T @ jt


@pytest.mark.parametrize("radius_of_gyration", [0.0, 0.05])
@pytest.mark.parametrize("arm", ARMS)
def test_mass_matrix_equals_point_mass_formula(arm, radius_of_gyration):
    robot = RavenII(arm, radius_of_gyration=radius_of_gyration)
    q = random_q(np.random.default_rng(13), 20, robot)
    got = robot.mass_matrix(q, payload_kg=0.3)
    for qn, mn in zip(q, got):
        expected = ref_mass_matrix(qn, arm, radius_of_gyration, 0.3)
        np.testing.assert_allclose(mn, expected, atol=1e-12)
        assert np.all(np.linalg.eigvalsh(mn) > 0)


@pytest.mark.parametrize("payload", [0.0, 0.5])
def test_fast_mass_matrix_equals_pinocchio(robot, payload):
    q = random_q(np.random.default_rng(14), 50, robot)
    expected = robot.mass_matrix(q, payload)
    for qn, en in zip(q, expected):
        coeffs = robot.gravity_coefficients(payload, tool_joints=qn[3:])
        np.testing.assert_allclose(mass_matrix_fast(qn[:3], coeffs), en, atol=1e-12)


def test_home_pose_is_the_controllers_home_and_inside_the_limits(robot):
    # defines.h: SHOULDER_HOME 30 deg, ELBOW_HOME 90 deg, Z_INS_HOME 0.4 m, tool roll and wrist 0,
    # both grasp jaws at 45 deg, so the controller's grasp coordinate (grasp2 - grasp1) / 2 is 0
    expected = [30 * DEG, 90 * DEG, 0.4, 0.0, 0.0, 0.0]
    home = RavenII.home_pose()
    np.testing.assert_allclose(home, expected, rtol=0, atol=1e-15)
    robot.check_joint_limits(home)
    home[0] = 0.0  # a fresh array each call: changing one leaves the next untouched
    np.testing.assert_allclose(RavenII.home_pose(), expected, rtol=0, atol=1e-15)
    assert robot.tool_position(RavenII.home_pose()).shape == (3,)
