"""The UKF baseline: accuracy on its own model class, robustness, bag logs, and its building blocks."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from sklearn.exceptions import NotFittedError

from kinematics import RavenII
from kinematics.gravity_closed_form import gravity_torques_fast
from simulation.model.laws import stiffness_tension
from simulation.recordings.dataset import synchronize
from simulation.identification import FITTABLE_EFFECTS, MotorLog
from simulation.recordings.bags import read_bag, write_bag
from simulation.model.parameters import RavenParameters
from simulation.engine.scenarios import powered_on, record_random_test

from estimators import UKFJointEstimator
from estimators.ukf._filter import BatchUnscentedKalmanFilter, sigma_points
from simulation.model.layout import HARDENING, LOAD_SCALE, STIFFNESS

from estimators.ukf.model import CableModel
from estimators.ukf.noise import ProcessNoise, encoder_noise
from estimators.ukf.process import ProcessModel
from estimators.ukf.run import SampleLimits, initial_state, motor_readings, run_filter

pytestmark = pytest.mark.xdist_group("ukf")
"""One worker runs this module, so its module fixtures (simulated sessions, fitted filters) are built once."""

OWN_MODEL = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction",
             "quantization", "noise")


def rmse(error: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(error ** 2, axis=0))


@pytest.fixture(scope="module")
def session():
    """A homed arm of the UKF's model class: 2 min to fit on, 50 s unloaded and 50 s loaded to test."""
    robot = powered_on(RavenParameters().only(*OWN_MODEL), seed=2)
    calibration = record_random_test(robot, 120.0, seed=11)
    test = record_random_test(robot, 50.0, seed=12)
    robot.set_payload(0.5)
    loaded = record_random_test(robot, 50.0, seed=13)
    return calibration, test, loaded


@pytest.fixture(scope="module")
def fitted(session):
    calibration, _, _ = session
    return UKFJointEstimator(tuning="none").fit(calibration)


def test_cuts_the_raw_error_of_its_own_model_class_by_at_least_80_percent(session, fitted):
    _, test, _ = session
    log = MotorLog.from_recording(test)
    estimates = fitted.predict(test)
    settled = slice(30, None)  # one second for the initial stretch uncertainty to settle
    raw = rmse((test.channel("jpos")[:, :3] - log.joints)[settled])
    ukf = rmse((estimates.joints - log.joints)[settled])
    assert np.all(ukf <= 0.2 * raw), (ukf, raw)
    assert np.all(np.isfinite(estimates.covariance))


def test_covariance_stays_symmetric_positive_definite_with_an_unmodelled_payload(session, fitted):
    _, _, loaded = session
    estimates = fitted.predict(loaded, eigenvalues=True)
    assert np.all(estimates.min_eigenvalue > 0.0)
    np.testing.assert_array_equal(estimates.covariance, np.swapaxes(estimates.covariance, 1, 2))
    assert estimates.n_repairs == 0


def test_lost_samples_skip_updates_and_are_counted_never_nan(session, fitted):
    _, test, _ = session
    log = MotorLog.from_recording(test)
    keep = np.ones(len(log), dtype=bool)
    keep[600:612] = False           # a 0.4 s gap: predicted across
    keep[1200:1260] = False         # a 2 s gap: the filter restarts
    positions = log.motor_positions.copy()
    torques = log.motor_torques.copy()
    positions[[100, 101, 900]] = np.nan
    torques[[300, 301]] = np.nan
    damaged = MotorLog(time=log.time, motor_positions=positions, motor_torques=torques, joints=log.joints).select(keep)
    counted = "skipped 3 updates.*held an earlier torque 2 times.*1 gaps.*restarted 1 times"
    with pytest.warns(RuntimeWarning, match=counted):
        estimates = fitted.predict(damaged)
    assert (estimates.n_skipped, estimates.n_missing_torque, estimates.n_gaps, estimates.n_restarts) == (3, 2, 1, 1)
    assert np.all(np.isfinite(estimates.joints)) and np.all(np.isfinite(estimates.covariance))
    clean = fitted.predict(test)
    # before the first gap only single readings and torques were lost: the estimates stay as good
    before = (damaged.time > log.time[60]) & (damaged.time < log.time[600])
    matching = np.isin(log.time, damaged.time[before])
    assert np.all(rmse((estimates.joints - damaged.joints)[before])
                  <= 1.2 * rmse((clean.joints - log.joints)[matching]) + np.array([1e-4, 1e-4, 1e-5]))
    # after the gaps the filter relearns the stretch that friction holds, still far better than raw
    raw = rmse(test.channel("jpos")[:, :3] - log.joints)
    assert np.all(rmse((estimates.joints - damaged.joints)[60:]) < 0.5 * raw)


def test_a_prediction_that_blows_up_restarts_the_filter_from_the_next_reading(session, fitted):
    _, test, _ = session
    log = MotorLog.from_recording(test).between(test.time[0], test.time[0] + 10.0)
    torques = log.motor_torques.copy()
    torques[100] = 1e300              # beyond the DAC clip: the filter holds the last good torque
    corrupt = MotorLog(time=log.time, motor_positions=log.motor_positions, motor_torques=torques)
    with pytest.warns(RuntimeWarning, match="held an earlier torque 1 times.*restarted 0 times"):
        estimates = fitted.predict(corrupt)
    assert (estimates.n_missing_torque, estimates.n_restarts) == (1, 0)
    # without the torque bound the corrupt sample drives the motors to infinity: the filter
    # keeps its last good estimate and restarts from the next reading
    unbounded = SampleLimits(arm="left", motor_rate=fitted.limits_.motor_rate,
                             encoder_slack=fitted.limits_.encoder_slack, torque=np.full(3, np.inf))
    with pytest.warns(RuntimeWarning, match="re-initialised 1 times .non-finite prediction"):
        estimates = run_filter(corrupt, fitted.model_, fitted.process_noise_, fitted.measurement_noise_,
                               limits=unbounded)
    assert estimates.n_restarts == 1 and estimates.reinitialisations[0][0] == 101
    assert np.all(np.isfinite(estimates.joints)) and np.all(np.isfinite(estimates.covariance))


def test_a_log_read_from_a_bag_gives_the_recordings_estimates(tmp_path, session, fitted):
    _, test, _ = session
    short = test.select(test.time < test.time[0] + 20.0)
    state, truth = short.to_logs(RavenII(arm="left", check_limits=False))
    write_bag(tmp_path / "run.bag", state, truth)
    dataset = synchronize(*read_bag(tmp_path / "run.bag", "left"))
    from_bag = fitted.predict(dataset)
    log = MotorLog.from_recording(short)
    rows = np.searchsorted(log.time, from_bag.time)
    np.testing.assert_allclose(log.time[rows], from_bag.time, atol=1e-6)
    direct = fitted.predict(log.select(rows))
    # the bag stores float32 degrees, which rounds the insertion motor by 3e-8 m (a sixth of an
    # encoder count): the typical estimate is unchanged, but near a stick-slip transition dry
    # friction carries the rounding to tens of micrometres on a few samples (how far depends on the
    # last bits of the fitted model), so the worst sample is bounded by the filter's own worst error
    difference = np.abs(from_bag.joints - direct.joints)
    assert np.all(np.median(difference, axis=0) < np.array([1e-7, 1e-7, 1e-8])), np.median(difference, axis=0)
    own_error = np.abs(direct.joints - log.select(rows).joints).max(axis=0)
    assert np.all(difference.max(axis=0) < 0.5 * own_error), (difference.max(axis=0), own_error)


def test_process_model_holds_a_resting_arm_whose_motors_carry_its_weight():
    params = RavenParameters()
    model = CableModel.from_parameters(params, np.array([0.01, -0.02, 0.003]))
    motor = np.linalg.solve(model.coupling, np.array([0.6, 1.4, 0.38]))
    state, _ = initial_state(model, motor)
    weight = model.table[LOAD_SCALE] * gravity_torques_fast(state[6:9].copy(), model.gravity_coefficients)
    stretch = model.cable_ends(state[:3]) - state[6:9]
    tension = np.array([stiffness_tension(stretch[i], model.table[STIFFNESS, i], model.table[HARDENING, i])
                        for i in range(3)])
    np.testing.assert_allclose(tension, weight, rtol=1e-6)   # the resting cables carry the links
    holding = model.coupling.T @ tension      # and the motors feel A^T T
    later = ProcessModel(model).single(state, 2.0, holding)
    np.testing.assert_allclose(later[6:9], state[6:9], atol=1e-8)
    np.testing.assert_allclose(later[:3], state[:3], atol=1e-8)
    # without the holding torque the motors are pulled towards the load
    dropped = ProcessModel(model).single(state, 0.05, np.zeros(3))
    assert np.all(np.sign(dropped[:3] - state[:3]) == -np.sign(holding))


def test_batch_process_model_equals_one_sigma_point_at_a_time():
    model = CableModel.from_parameters(RavenParameters(), np.zeros(3))
    process = ProcessModel(model)
    rng = np.random.default_rng(0)
    state, covariance = initial_state(model, np.array([0.5, 1.5, 0.4]))
    sigmas = state + rng.standard_normal((25, 12)) * np.sqrt(np.diag(covariance))
    torque = np.array([0.4, 0.1, 2.0])
    batch = process.batch(sigmas, 1 / 30, torque)
    single = np.array([process.single(s, 1 / 30, torque) for s in sigmas])
    np.testing.assert_array_equal(batch, single)


def test_batch_filter_reproduces_plain_filterpy(session, fitted):
    _, test, _ = session
    log = MotorLog.from_recording(test)
    model = fitted.model_
    process = ProcessModel(model)
    z = log.motor_positions / model.transmission_ratio
    torque = log.motor_torques * model.torque_scale
    x0, p0 = initial_state(model, z[0])
    noise = fitted.process_noise_
    batch = BatchUnscentedKalmanFilter(12, 3, sigma_points(12, 1.0, 2.0, 0.0), process.batch, motor_readings)
    plain = UnscentedKalmanFilter(12, 3, 1 / 30, hx=lambda x: x[:3], fx=process.single,
                                  points=MerweScaledSigmaPoints(12, 1.0, 2.0, 0.0))
    for ukf in (batch, plain):
        ukf.x, ukf.P, ukf.R = x0.copy(), p0.copy(), encoder_noise(model)
    for k in range(1, 40):
        dt = log.time[k] - log.time[k - 1]
        for ukf in (batch, plain):
            ukf.Q = noise.covariance(dt)
            ukf.predict(dt=dt, motor_torque=torque[k - 1])
            ukf.update(z[k])
    np.testing.assert_allclose(batch.x, plain.x, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(batch.P, plain.P, rtol=1e-6, atol=1e-15)


def test_process_noise_is_white_acceleration_noise_integrated_over_the_step():
    noise = ProcessNoise(motor=[0.02, 0.03, 0.004], joint=[0.1, 0.2, 0.01])
    dt = 1 / 30
    transition = np.eye(12)
    for i in (0, 1, 2, 6, 7, 8):
        transition[i, i + 3] = dt
    # two steps of dt accumulate the noise of one step of 2 dt (Chapman-Kolmogorov)
    two_steps = transition @ noise.covariance(dt) @ transition.T + noise.covariance(dt)
    np.testing.assert_allclose(two_steps, noise.covariance(2 * dt), rtol=1e-12, atol=1e-18)
    assert np.all(np.linalg.eigvalsh(noise.covariance(dt)) > 0)


def test_noise_tuning_keeps_the_best_noise_it_tried(session, fitted):
    calibration, _, _ = session
    estimator = UKFJointEstimator(tuning="likelihood", tuning_seconds=10.0, tuning_evaluations=8).fit_identified(
        fitted.identification_, calibration)
    objectives = [value for _, value in estimator.tuning_history_]
    assert len(objectives) >= 7
    best = min(estimator.tuning_history_, key=lambda item: item[1])[0]
    np.testing.assert_allclose(estimator.process_noise_.as_vector(), best)
    assert min(objectives) <= objectives[0]


def test_bad_use_raises_clear_errors(session):
    calibration, test, _ = session
    with pytest.raises(NotFittedError):
        UKFJointEstimator().predict(test)
    with pytest.raises(ValueError, match="tuning must be one of"):
        UKFJointEstimator(tuning="grid").fit(calibration)
    with pytest.raises(TypeError, match="MotorLog, CalibrationDataset or Recording"):
        UKFJointEstimator(tuning="none").fit(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="cable_stretch off"):
        CableModel.from_parameters(RavenParameters().without("cable_stretch"), np.zeros(3))
    # the identification fits motor friction and ratio errors, but the filter's process model has neither
    for effect in ("motor_friction", "transmission_error"):
        with pytest.raises(ValueError, match=f"process model has no {effect}"):
            UKFJointEstimator(effects=FITTABLE_EFFECTS + (effect,), tuning="none").fit(calibration)
    with pytest.raises(ValueError, match="positive"):
        ProcessNoise(motor=[1.0, 0.0, 1.0], joint=[1.0, 1.0, 1.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match="max_step"):
            UKFJointEstimator(tuning="none", max_step=0.0).fit(calibration)


def test_verbose_reports_the_filter_run_and_changes_nothing(session, fitted, capsys):
    """verbose=1 prints one line per filter run (samples, time, events); the estimates are the same."""
    calibration, test, _ = session
    capsys.readouterr()
    # the fitted filter's coasting noise, and no covariance calibration (reported variances only): the
    # estimates must not change with the verbosity, whatever else is chosen at fit time
    talkative = UKFJointEstimator(tuning="none", verbose=1, coast_noise_scale=fitted.coast_noise_scale_,
                                  covariance_calibration=False).fit_identified(fitted.identification_, calibration)
    quiet_estimates = fitted.predict(test)
    assert capsys.readouterr().out == ""
    estimates = talkative.predict(test)
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 1 and lines[0].startswith("UKF: filtered") and "events" in lines[0]
    np.testing.assert_array_equal(estimates.joints, quiet_estimates.joints)


def test_noise_tuning_never_keeps_a_noise_under_which_the_filter_diverges(session, fitted, monkeypatch):
    import dataclasses

    from estimators.ukf import estimator as module

    calibration, _, _ = session
    real, runs = module.run_filter, []

    def diverging_after_the_first_run(*args, **kwargs):
        estimates = real(*args, **kwargs)
        runs.append(None)
        if len(runs) == 1:
            return estimates
        return dataclasses.replace(estimates, n_reinitialised=1,
                                   reinitialisations=((1, "covariance beyond COVARIANCE_LIMIT"),))

    monkeypatch.setattr(module, "run_filter", diverging_after_the_first_run)
    estimator = UKFJointEstimator(tuning="likelihood", tuning_seconds=10.0, tuning_evaluations=8).fit_identified(
        fitted.identification_, calibration)
    (start, first), *others = estimator.tuning_history_
    assert first < 1e30 and others and all(value == 1e30 for _, value in others)
    np.testing.assert_allclose(estimator.process_noise_.as_vector(), start)


def test_a_negative_position_variance_is_divergence_and_a_lost_spread_stays_a_covariance():
    from estimators.ukf.run import DIVERGENCE_REASONS, LOST_SPREAD, _diverged, _lost

    healthy = np.diag(np.r_[np.full(3, 1e-6), np.full(3, 1e-2), np.full(3, 1e-6), np.full(3, 1e-2)])
    assert _diverged(healthy) is None
    broken = healthy.copy()
    broken[7, 7] = -1e-4                  # the elbow joint's variance
    assert _diverged(broken) == "negative variance of a position"
    assert _diverged(broken) in DIVERGENCE_REASONS
    huge = healthy.copy()
    huge[0, 0] = 4.0                      # a 2 rad standard deviation of the shoulder motor
    assert _diverged(huge) == "covariance beyond COVARIANCE_LIMIT"
    np.testing.assert_array_equal(_lost(broken[6:9, 6:9]), np.diag(LOST_SPREAD ** 2))
    small = _lost(healthy[6:9, 6:9])
    np.testing.assert_allclose(np.sqrt(np.diagonal(small)), LOST_SPREAD)
