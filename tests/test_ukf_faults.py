"""The UKF's fault handling: bad samples rejected or coasted through and counted, bad logs refused,
and an honest reported uncertainty on its own model class."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.stats import chi2

from kinematics import RavenII
from simulation.engine.scenarios import powered_on, record_random_test
from simulation.identification import MotorLog
from simulation.model.parameters import RavenParameters
from simulation.recordings.dataset import CalibrationDataset
from simulation.recordings.recording import recording_to_dataset

from estimators import UKFJointEstimator
from estimators.ukf.run import ACCEPTED, COASTING, REINITIALISED, REJECTED, UKFFaultWarning

pytestmark = pytest.mark.xdist_group("ukf_faults")
"""One worker runs this module, so its module fixtures (simulated sessions, fitted filters) are built once."""

OWN_MODEL = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction",
             "quantization", "noise")
SETTLE = 30                     # the first second: the initial stretch uncertainty settles
COUNTS_PER_RAD = 4000.0 / (2.0 * np.pi)


def rmse(error: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(error ** 2, axis=0))


@pytest.fixture(scope="module")
def session():
    """An arm of the UKF's model class: 90 s to fit on, three independent 20 s test motions."""
    robot = powered_on(RavenParameters().only(*OWN_MODEL), seed=5)
    calibration = record_random_test(robot, 90.0, seed=21)
    tests = [record_random_test(robot, 20.0, seed=22 + k) for k in range(3)]
    fitted = UKFJointEstimator(tuning="none", tuning_seconds=60.0).fit(calibration)
    dataset = recording_to_dataset(tests[0], RavenII(arm="left", check_limits=False))
    return fitted, tests, dataset


def _quiet_predict(fitted, log):
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # a clean log raises no warning at all
        return fitted.predict(log)


def _edited(dataset: CalibrationDataset, edit) -> CalibrationDataset:
    table = dataset.table.copy()
    edit(table)
    return CalibrationDataset(table, arm=dataset.arm)


def _with_motor_glitch(joint: str, size: float, row: int):
    def edit(table):
        table.loc[row, f"mpos.{joint}"] += size
        table.loc[row, f"encVals.{joint}"] += round(size * COUNTS_PER_RAD)
    return edit


def _with_torque(joint: str, value: float, row: int):
    def edit(table):
        table.loc[row, f"tau.{joint}"] = value
        if not np.isfinite(value):
            table.loc[row, "valid"] = False         # a dataset holds non-finite values only in flagged rows
    return edit


def _with_lost_readings(start: int, stop: int):
    def edit(table):
        for joint in ("shoulder", "elbow", "z_ins"):
            table.loc[start:stop - 1, f"mpos.{joint}"] = np.nan
        table.loc[start:stop - 1, "valid"] = False
    return edit


def test_a_clean_log_is_filtered_without_a_rejection_or_a_warning(session):
    fitted, _, dataset = session
    estimates = _quiet_predict(fitted, dataset)
    assert estimates.events == {"rejected": 0, "coasted": 0, "reinitialised": 0}
    assert estimates.flags[0] == REINITIALISED and np.all(estimates.flags[1:] == ACCEPTED)


@pytest.mark.parametrize("edit, rejected", [
    (_with_motor_glitch("shoulder", 30.0, 300), 1),
    (_with_motor_glitch("elbow", 100.0, 400), 1),
    (_with_motor_glitch("z_ins", -4.0, 250), 1),
    (_with_motor_glitch("shoulder", 0.5, 350), 1),      # within what the motor can turn: the gate's case
], ids=["shoulder+30rad", "elbow+100rad", "insertion-4rad", "shoulder+0.5rad"])
def test_a_motor_glitch_is_rejected_counted_and_leaves_the_accuracy(session, edit, rejected):
    fitted, _, dataset = session
    clean = _quiet_predict(fitted, dataset)
    damaged = _edited(dataset, edit)
    with pytest.warns(UKFFaultWarning, match=f"rejected {rejected} readings") as caught:
        estimates = fitted.predict(damaged)
    assert len([w for w in caught if issubclass(w.category, UKFFaultWarning)]) == 1
    assert estimates.events == {"rejected": rejected, "coasted": 0, "reinitialised": 0}
    assert np.count_nonzero(estimates.flags == REJECTED) == rejected
    truth = MotorLog.from_dataset(dataset).joints
    assert np.all(np.isfinite(estimates.joints)) and np.all(np.isfinite(estimates.covariance))
    assert np.all(rmse((estimates.joints - truth)[SETTLE:]) <= 1.2 * rmse((clean.joints - truth)[SETTLE:]))


def test_a_flagged_glitch_is_coasted_through(session):
    fitted, _, dataset = session
    damaged = _edited(dataset, _with_motor_glitch("shoulder", 30.0, 300))
    flagged = CalibrationDataset(damaged.table.assign(valid=np.arange(len(damaged)) != 300), arm=damaged.arm)
    with pytest.warns(UKFFaultWarning, match="coasted through 1 samples"):
        estimates = fitted.predict(flagged)
    assert estimates.flags[300] == COASTING and estimates.events["rejected"] == 0
    clean = _quiet_predict(fitted, dataset)
    truth = MotorLog.from_dataset(dataset).joints
    assert np.all(rmse((estimates.joints - truth)[SETTLE:]) <= 1.2 * rmse((clean.joints - truth)[SETTLE:]))


@pytest.mark.parametrize("value", [1e6, -1e6, np.inf, np.nan])
def test_an_impossible_torque_is_replaced_by_the_last_good_one(session, value):
    fitted, _, dataset = session
    clean = _quiet_predict(fitted, dataset)
    with pytest.warns(UKFFaultWarning, match="held an earlier torque 1 times"):
        estimates = fitted.predict(_edited(dataset, _with_torque("shoulder", value, 300)))
    assert estimates.n_reinitialised == 0
    truth = MotorLog.from_dataset(dataset).joints
    assert np.all(rmse((estimates.joints - truth)[SETTLE:]) <= 1.2 * rmse((clean.joints - truth)[SETTLE:]))


def test_lost_readings_are_coasted_through_with_a_growing_spread(session):
    fitted, _, dataset = session
    clean = _quiet_predict(fitted, dataset)
    start, stop = 300, 330                          # one second without readings
    with pytest.warns(UKFFaultWarning, match="coasted through 30 samples"):
        estimates = fitted.predict(_edited(dataset, _with_lost_readings(start, stop)))
    assert np.all(estimates.flags[start:stop] == COASTING)
    spread = estimates.standard_deviation
    assert np.all(spread[stop - 1] > spread[start - 1])
    truth = MotorLog.from_dataset(dataset).joints
    outside = np.r_[SETTLE:start, stop + SETTLE:len(truth)]
    assert np.all(rmse((estimates.joints - truth)[outside]) <= 1.2 * rmse((clean.joints - truth)[outside]))
    error = np.abs(estimates.joints - truth)[start:stop]
    assert np.mean(error <= 3.0 * spread[start:stop]) > 0.9       # the spread covers the coasting error


def test_a_long_run_of_lost_readings_reinitialises_from_the_next_reading(session):
    fitted, _, dataset = session
    start, stop = 200, 260                          # two seconds, beyond max_gap
    with pytest.warns(UKFFaultWarning, match="re-initialised 1 times"):
        estimates = fitted.predict(_edited(dataset, _with_lost_readings(start, stop)))
    assert estimates.flags[stop] == REINITIALISED
    assert np.all(np.isfinite(estimates.joints)) and np.all(np.isfinite(estimates.covariance))


def test_a_log_in_other_time_units_or_of_the_other_arm_is_refused(session):
    fitted, _, dataset = session
    for factor in (1e-3, 1e3):                       # kiloseconds, milliseconds
        table = dataset.table.assign(time=dataset.table["time"] * factor)
        with pytest.raises(ValueError, match="outside RAVEN-II's log rates .* in seconds"):
            fitted.predict(CalibrationDataset(table, arm=dataset.arm))
    with pytest.raises(ValueError, match="log is of the right arm.* left arm"):
        fitted.predict(CalibrationDataset(dataset.table, arm="right"))


def test_reported_uncertainty_is_honest_on_its_own_model_class(session):
    fitted, tests, _ = session
    nees, covered = [], []
    for test in tests:
        log = MotorLog.from_recording(test)
        estimates = _quiet_predict(fitted, test)
        error = (estimates.joints - log.joints)[SETTLE:]
        covariance = estimates.covariance[SETTLE:]
        nees.append(np.mean(np.einsum("ni,nij,nj->n", error, np.linalg.inv(covariance), error)))
        covered.append(np.mean(np.abs(error) <= 2.0 * estimates.standard_deviation[SETTLE:], axis=0))
    runs = len(tests)
    # the averaged NEES of independent runs within the 99.9 % band of chi-square(3 runs) / runs
    low, high = chi2.ppf([0.0005, 0.9995], 3 * runs) / runs
    assert low < np.mean(nees) < high, nees
    assert np.all((np.mean(covered, axis=0) > 0.85) & (np.mean(covered, axis=0) < 0.995)), covered


@pytest.mark.parametrize("coulomb", [0.5e-3, 2e-3])
def test_motor_shaft_friction_outside_its_model_never_gives_nonsense(coulomb):
    """Coulomb friction at the motor shaft (0.5-2 mN m, 12-50 % of an RE40's no-load friction) is
    outside the filter's model; the identification absorbs it in the cable and, unguarded, the
    filter ran away (joint errors of 1e20). Now every estimate is finite, and the filter either
    stays within twice the raw encoders' error or says, with a warning and its counts, that it had
    to re-initialise."""
    from simulation.model.effects import MotorFriction

    friction = MotorFriction(enabled=True, coulomb=[coulomb] * 7, gearbox_loss=[0.0] * 7)
    params = RavenParameters().only(*OWN_MODEL).with_effect(friction)
    robot = powered_on(params, seed=7)
    calibration = record_random_test(robot, 60.0, seed=31)
    test = recording_to_dataset(record_random_test(robot, 20.0, seed=32), RavenII(arm="left", check_limits=False))
    # the nominal friction smoothing scale: its held-out choice is tested in test_nominal.py
    fitted = UKFJointEstimator(tuning="none", tuning_seconds=40.0, velocity_scale_factors=(1.0,)).fit(calibration)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        estimates = fitted.predict(test)
    assert np.all(np.isfinite(estimates.joints))
    truth = test.targets
    error = rmse(estimates.joints[SETTLE:] - truth[SETTLE:])
    raw = rmse(test.raw_errors[SETTLE:])
    warned = any(issubclass(w.category, UKFFaultWarning) for w in caught)
    # outside its model class the filter may be no better than the encoders on a joint (at 2 mN m
    # its elbow error is about the raw one); running away from them must be detected and said
    if not np.all(error < 2.0 * raw):
        assert warned and estimates.n_reinitialised > 0, (error, raw)
    assert np.all(error < 0.1), error   # below 6 deg and 10 cm: a filter that ran away is far beyond
