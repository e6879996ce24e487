"""The nominal parameter set: round numbers only, and a UKF that needs nothing of the simulator's."""

from __future__ import annotations

import numpy as np
import pytest

from estimators import UKFJointEstimator
from simulation.engine.scenarios import powered_on, record_random_test
from simulation.identification import FITTABLE_EFFECTS, MotorLog, nominal_parameters
from simulation.model.parameters import RavenParameters

OWN_MODEL = FITTABLE_EFFECTS + ("quantization", "noise")


def one_significant_digit(value: float) -> bool:
    if value == 0.0:
        return True
    exponent = np.floor(np.log10(abs(value)))
    mantissa = abs(value) / 10.0 ** exponent
    return bool(np.isclose(mantissa, np.round(mantissa), rtol=0.0, atol=1e-9))


@pytest.mark.parametrize("arm", ["left", "right"])
def test_nominal_effect_values_are_round_and_not_the_simulators(arm):
    nominal, simulator = nominal_parameters(arm), RavenParameters(arm=arm)
    assert nominal.constants.arm == arm
    for name in FITTABLE_EFFECTS:
        effect = nominal.effect(name)
        assert effect.enabled
        for field, value in effect.parameters().items():
            values = np.atleast_1d(np.asarray(value, dtype=float))
            assert all(one_significant_digit(v) for v in values), (name, field, values)
    for name, field in [("cable_stretch", "stiffness"), ("cable_stretch", "hardening"), ("cable_stretch", "damping"),
                        ("coulomb_friction", "force"), ("coulomb_friction", "velocity_scale"),
                        ("viscous_friction", "coefficient"), ("coupling", "delta")]:
        ours = np.asarray(getattr(nominal.effect(name), field))
        theirs = np.asarray(getattr(simulator.effect(name), field))
        assert not np.any(np.isclose(ours, theirs, rtol=1e-3, atol=0.0)), (name, field, ours, theirs)
    others = [effect.name for effect in nominal.effects if effect.name not in FITTABLE_EFFECTS]
    assert not others


def test_bad_arm_is_named():
    with pytest.raises(ValueError, match="arm must be"):
        nominal_parameters("middle")


def _unusual_robot() -> RavenParameters:
    """The UKF's model class with effect values far from both the simulator's and the nominal set."""
    data = RavenParameters().only(*OWN_MODEL).to_dict()
    effects = data["effects"]
    effects["cable_stretch"]["stiffness"] = list(np.array(effects["cable_stretch"]["stiffness"]) * 0.5)
    effects["cable_stretch"]["damping"] = list(np.array(effects["cable_stretch"]["damping"]) * 2.0)
    effects["coulomb_friction"]["force"] = list(np.array(effects["coulomb_friction"]["force"]) * 0.6)
    effects["coulomb_friction"]["velocity_scale"] = list(np.array(effects["coulomb_friction"]["velocity_scale"]) * 3.0)
    effects["viscous_friction"]["coefficient"] = list(np.array(effects["viscous_friction"]["coefficient"]) * 1.5)
    effects["coupling"]["delta"] = list(-np.array(effects["coupling"]["delta"]))
    return RavenParameters.from_dict(data)


def test_ukf_from_the_nominal_start_cuts_the_raw_error_of_an_unusual_robot():
    robot = powered_on(_unusual_robot(), seed=3)
    calibration = record_random_test(robot, 90.0, seed=21)
    test = record_random_test(robot, 30.0, seed=22)
    # the coasting noise and the covariance scale act on missing readings and reported variances
    # only, neither of which this accuracy check has: both are left at 1, not calibrated
    estimator = UKFJointEstimator(tuning="none", coast_noise_scale=1.0, covariance_calibration=False).fit(calibration)
    assert estimator.base_parameters is None          # the default base set: the nominal one
    assert set(estimator.velocity_scale_scores_) == {0.3, 1.0, 3.0}
    log = MotorLog.from_recording(test)
    settled = slice(30, None)
    raw = np.sqrt(np.mean((test.channel("jpos")[:, :3] - log.joints)[settled] ** 2, axis=0))
    ukf = np.sqrt(np.mean((estimator.predict(test).joints - log.joints)[settled] ** 2, axis=0))
    assert np.all(ukf <= 0.1 * raw), (ukf, raw)    # measured about 0.005 on two robot seeds
