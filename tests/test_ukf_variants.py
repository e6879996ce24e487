"""The UKF variants: disturbance-torque states (an unmodelled payload's gravity) and the learned-residual hybrid."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from estimators import UKFJointEstimator
from kinematics import RavenII
from simulation.engine.scenarios import powered_on, record_random_test
from simulation.identification import MotorLog
from simulation.model.parameters import RavenParameters
from simulation.recordings.recording import recording_to_dataset
from studies.common.methods import UKFHybridOnSamples
from studies.common.samples import Samples

pytestmark = pytest.mark.xdist_group("ukf_variants")
"""One worker runs this module, so its module fixtures (simulated sessions, fitted filters) are built once."""

OWN_MODEL = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction",
             "quantization", "noise")
PAYLOAD_KG = 0.5


@pytest.fixture(scope="module")
def loaded_run():
    """Filters identified on 60 s unloaded, run on 30 s with an unmodelled 0.5 kg at the tool tip,
    at the nominal friction smoothing scale (its held-out choice is tested in ``test_nominal.py``)."""
    robot = powered_on(RavenParameters().only(*OWN_MODEL), seed=2)
    calibration = record_random_test(robot, 60.0, seed=11)
    robot.set_payload(PAYLOAD_KG)
    loaded = record_random_test(robot, 30.0, seed=13)
    plain = UKFJointEstimator(tuning="none", velocity_scale_factors=(1.0,)).fit(calibration)
    disturbed = UKFJointEstimator(tuning="none", disturbance_density=1.0).fit_identified(plain.identification_)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return loaded, plain.predict(loaded), disturbed.predict(loaded)


def test_disturbance_state_converges_to_the_payloads_gravity_from_the_kinematics(loaded_run):
    loaded, _, estimates = loaded_run
    assert estimates.states.shape == (len(loaded.time), 15)
    settled = slice(60, None)   # two seconds for the disturbance to build up
    q6 = np.hstack([loaded.channel("true_joints"), loaded.channel("true_tool_joints")[:, :3]])[settled]
    robot = RavenII()
    payload = (robot.gravity_torques(q6, payload_kg=PAYLOAD_KG, check_limits=False)
               - robot.gravity_torques(q6, check_limits=False)).mean(axis=0)
    # the model's links feel T - g(q) + d: the disturbance carries the payload's holding load, negated
    disturbance = estimates.states[settled, 12:].mean(axis=0)
    print(f"insertion axis: disturbance {-disturbance[2]:.2f} N, the payload's gravity {payload[2]:.2f} N")
    np.testing.assert_allclose(-disturbance, payload, rtol=0.35)
    np.testing.assert_allclose(-disturbance[2], payload[2], rtol=0.1)    # the insertion axis takes 4.5 N


def test_disturbance_state_cuts_the_loaded_joint_error_of_the_plain_filter(loaded_run):
    loaded, plain, disturbed = loaded_run
    truth = MotorLog.from_recording(loaded).joints
    settled = slice(60, None)
    error = lambda e: np.sqrt(np.mean((e.joints - truth)[settled] ** 2, axis=0))
    assert np.all(error(disturbed) < 0.5 * error(plain)), (error(disturbed), error(plain))
    assert disturbed.events == {"rejected": 0, "coasted": 0, "reinitialised": 0}


def test_a_negative_disturbance_density_is_refused():
    with pytest.raises(ValueError, match="disturbance_density"):
        UKFJointEstimator(disturbance_density=-1.0)._settings()


@pytest.fixture(scope="module")
def hybrid_samples():
    """20 s to fit on and 10 s to test of the UKF's own model class, as study samples."""
    params = RavenParameters().only(*OWN_MODEL)
    robot = powered_on(params, seed=3)
    kinematics = RavenII(params.arm, check_limits=False)
    calibration = record_random_test(robot, 20.0, seed=21)
    test = record_random_test(robot, 10.0, seed=22)
    return (Samples.from_dataset(recording_to_dataset(calibration, kinematics)),
            Samples.from_dataset(recording_to_dataset(test, kinematics)))


def test_hybrid_adds_a_least_squares_fit_of_the_filters_causal_residual(hybrid_samples):
    calibration, test = hybrid_samples
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        hybrid = UKFHybridOnSamples(tuning="none").fit(calibration)
        ukf_train = hybrid.filter_.predict(calibration)     # the filter run causally over its fit log
        ukf_test = hybrid.filter_.predict(test)
        predicted = hybrid.predict(test)
    design = lambda samples, ukf: np.hstack([samples.X, ukf, np.ones((len(samples), 1))])
    coefficients, *_ = np.linalg.lstsq(design(calibration, ukf_train), calibration.targets - ukf_train, rcond=None)
    expected = ukf_test + design(test, ukf_test) @ coefficients
    np.testing.assert_allclose(predicted, expected, atol=1e-6 * np.abs(expected).max())
    assert hybrid.events_ == {"rejected": 0, "coasted": 0, "reinitialised": 0}


def test_hybrid_needs_the_robot_state(hybrid_samples):
    calibration, _ = hybrid_samples
    with pytest.raises(ValueError, match="robot state"):
        UKFHybridOnSamples().fit(calibration.without_dataset())
