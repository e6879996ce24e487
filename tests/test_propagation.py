"""Joint errors to tool-tip errors: exact, first-order, Monte-Carlo and RMSE helpers."""

import numpy as np
import pinocchio as pin
import pytest

from kinematics import (
    RavenII,
    distance_rmse,
    linearized_tool_tip_error,
    per_axis_rmse,
    tool_tip_covariance,
    tool_tip_error,
    tool_tip_rmse,
    with_exact_tool_joints,
)

DEG = np.pi / 180.0
# The paper's calibration workspace (joint 1 20..60 deg, joint 2 55..110 deg, joint 3 0.33..0.42 m).
WORKSPACE_LOW = np.array([20 * DEG, 55 * DEG, 0.33, -np.pi, -70 * DEG, -80 * DEG])
WORKSPACE_HIGH = np.array([60 * DEG, 110 * DEG, 0.42, np.pi, 70 * DEG, 80 * DEG])


@pytest.fixture(params=["left", "right"])
def robot(request):
    return RavenII(request.param)


def workspace_q(rng, n):
    return rng.uniform(WORKSPACE_LOW, WORKSPACE_HIGH, size=(n, 6))


def paper_sized_errors(rng, n):
    """Joint errors of 0.1-1 deg (J0, J1) and 0.1-1 mm (J2), random signs; tool exact."""
    magnitude = np.column_stack(
        [rng.uniform(0.1, 1.0, (n, 2)) * DEG, rng.uniform(0.1e-3, 1.0e-3, n)]
    )
    return magnitude * rng.choice([-1.0, 1.0], size=(n, 3))


def test_first_order_covariance_matches_monte_carlo(robot):
    rng = np.random.default_rng(30)
    std = np.array([0.5 * DEG, 0.5 * DEG, 0.5e-3, 1.0 * DEG, 1.0 * DEG, 1.0 * DEG])
    correlation = np.eye(6)
    correlation[0, 1] = correlation[1, 0] = 0.4
    joint_cov = correlation * np.outer(std, std)
    # drawn through the Cholesky factor: numpy's multivariate_normal factors the covariance with
    # LAPACK's SVD, whose signs differ between builds, so its draws would differ between machines.
    # 40 000 draws put the 5 % tolerance at about 7 standard errors of a sampled variance.
    factor = np.linalg.cholesky(joint_cov)
    for q in workspace_q(rng, 3):
        dq = rng.standard_normal((40_000, 6)) @ factor.T
        errors = tool_tip_error(robot, np.tile(q, (len(dq), 1)), q + dq, check_limits=False)
        sampled = np.cov(errors, rowvar=False)
        predicted = tool_tip_covariance(robot, q, joint_cov)
        relative = np.linalg.norm(sampled - predicted) / np.linalg.norm(predicted)
        assert relative < 0.05
        np.testing.assert_allclose(np.diag(sampled), np.diag(predicted), rtol=0.05)


def test_linearized_error_matches_exact_within_two_percent(robot):
    rng = np.random.default_rng(31)
    q_true = workspace_q(rng, 2000)
    dq3 = paper_sized_errors(rng, len(q_true))
    q_est = with_exact_tool_joints(q_true[:, :3] + dq3, q_true)
    exact = tool_tip_error(robot, q_true, q_est, check_limits=False)
    linear = linearized_tool_tip_error(robot, q_true, q_est - q_true)
    relative = np.linalg.norm(linear - exact, axis=1) / np.linalg.norm(exact, axis=1)
    assert relative.max() < 0.02


def test_linearization_residual_is_second_order(robot):
    """Halving the joint error quarters the gap between exact and linear errors."""
    rng = np.random.default_rng(32)
    q = workspace_q(rng, 200)
    dq = np.zeros_like(q)
    dq[:, :3] = paper_sized_errors(rng, len(q))

    def residual(scale):
        exact = tool_tip_error(robot, q, q + scale * dq, check_limits=False)
        return np.linalg.norm(exact - linearized_tool_tip_error(robot, q, scale * dq), axis=1)

    ratio = residual(1.0) / residual(0.5)
    np.testing.assert_allclose(ratio, 4.0, rtol=0.05)


@pytest.mark.parametrize("error_mm", [0.1, 1.0, -5.0])
def test_insertion_error_moves_tip_along_tool_axis(robot, error_mm):
    rng = np.random.default_rng(33)
    data = robot.create_data()
    tool_roll = robot.model.getJointId("tool_rot")
    for q in workspace_q(rng, 10):
        pin.forwardKinematics(robot.model, data, q)
        tool_axis = data.oMi[tool_roll].rotation[:, 2]
        dq = np.array([0.0, 0.0, error_mm * 1e-3, 0.0, 0.0, 0.0])
        exact = tool_tip_error(robot, q, q + dq)
        np.testing.assert_allclose(exact, error_mm * 1e-3 * tool_axis, atol=1e-15)
        assert np.linalg.norm(exact) == pytest.approx(abs(error_mm) * 1e-3, rel=1e-12)
        np.testing.assert_allclose(
            linearized_tool_tip_error(robot, q, dq), exact, atol=1e-15
        )


def test_covariance_of_positioning_joints_equals_padded_full_covariance(robot):
    rng = np.random.default_rng(34)
    q = workspace_q(rng, 5)
    cov3 = np.diag([(0.3 * DEG) ** 2, (0.2 * DEG) ** 2, (0.4e-3) ** 2])
    cov6 = np.zeros((6, 6))
    cov6[:3, :3] = cov3
    batch = tool_tip_covariance(robot, q, cov3)
    assert batch.shape == (5, 3, 3)
    np.testing.assert_allclose(batch, tool_tip_covariance(robot, q, cov6), atol=1e-20)
    np.testing.assert_allclose(batch[2], tool_tip_covariance(robot, q[2], cov3), atol=1e-20)


def test_covariance_input_is_validated(robot):
    q = workspace_q(np.random.default_rng(35), 2)
    with pytest.raises(ValueError, match="symmetric"):
        tool_tip_covariance(robot, q, np.triu(np.ones((3, 3))))
    with pytest.raises(ValueError, match="positive semi-definite"):
        tool_tip_covariance(robot, q, -np.eye(3))
    with pytest.raises(ValueError, match="shape"):
        tool_tip_covariance(robot, q, np.eye(4))
    with pytest.raises(ValueError, match="3 configurations"):
        tool_tip_covariance(robot, np.vstack([q, q[:1]]), np.stack([np.eye(3)] * 2))


def test_estimates_outside_limits_need_the_explicit_switch(robot):
    q_true = np.array([5 * DEG, 50 * DEG, 0.25, 0.0, 0.0, 0.0])
    q_est = q_true - np.array([10 * DEG, 0.0, 0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"shoulder \(J0\)"):
        tool_tip_error(robot, q_true, q_est)
    assert tool_tip_error(robot, q_true, q_est, check_limits=False).shape == (3,)
    with pytest.raises(ValueError, match="same shape"):
        tool_tip_error(robot, q_true, np.tile(q_est, (2, 1)), check_limits=False)


def test_rmse_helpers_on_hand_values():
    errors = np.array([[3e-3, 0.0, 0.0], [0.0, 4e-3, 0.0], [0.0, 0.0, 0.0], [1e-3, 0.0, 2e-3]])
    np.testing.assert_allclose(
        per_axis_rmse(errors), np.sqrt([10e-6 / 4, 16e-6 / 4, 4e-6 / 4]), rtol=1e-12
    )
    assert distance_rmse(errors) == pytest.approx(np.sqrt(30e-6 / 4), rel=1e-12)
    summary = tool_tip_rmse(errors)
    mm = summary.in_millimetres()
    assert list(mm) == ["X", "Y", "Z", "Dist"]
    assert mm["Dist"] == pytest.approx(1e3 * np.sqrt(30e-6 / 4), rel=1e-12)
    assert mm["X"] == pytest.approx(1e3 * summary.x)
    with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
        per_axis_rmse(np.zeros((0, 3)))
    with pytest.raises(ValueError, match="NaN"):
        distance_rmse([[np.nan, 0.0, 0.0]])


def test_distance_rmse_is_root_sum_of_axis_mse():
    errors = np.random.default_rng(36).normal(scale=1e-3, size=(100, 3))
    assert distance_rmse(errors) == pytest.approx(np.linalg.norm(per_axis_rmse(errors)))


def test_with_exact_tool_joints_takes_estimate_and_true_tool_joints():
    rng = np.random.default_rng(37)
    q_true = workspace_q(rng, 4)
    q3 = rng.normal(size=(4, 3))
    full = with_exact_tool_joints(q3, q_true)
    np.testing.assert_array_equal(full[:, :3], q3)
    np.testing.assert_array_equal(full[:, 3:], q_true[:, 3:])
    assert with_exact_tool_joints(q3[0], q_true[0]).shape == (6,)
    with pytest.raises(ValueError, match="same number of configurations"):
        with_exact_tool_joints(q3[:3], q_true)
