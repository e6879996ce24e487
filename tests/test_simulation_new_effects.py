"""The effects outside the estimators' model class: off by default, each with its physical signature."""

from __future__ import annotations

import json

import numpy as np
import pytest

from simulation.engine.scenarios import powered_on, rehome
from simulation.model.effects import (
    EFFECT_NAMES, CapstanFriction, CoulombFriction, GravityModelError, MotorFriction, RegistrationOffset,
    TransmissionError,
)
from simulation.model.mismatch import FILTER_CLASS, out_of_class_effects
from simulation.model.parameters import RavenParameters
from simulated_motion import POSE, sweep

NEW_EFFECTS = ("motor_friction", "capstan_friction", "gravity_model_error", "transmission_error",
               "registration_offset")


def joint_error(rec, joint: int) -> np.ndarray:
    """Controller's joint estimate minus the true joint, at the same servo ticks (noise-free runs)."""
    return rec.channel("jpos")[:, joint] - rec.channel("true_joints")[:, joint]


def ready(params: RavenParameters, payload_kg: float = 0.0, seed: int = 1):
    robot = powered_on(params, seed=seed, payload_kg=payload_kg)
    robot.move_to(POSE, 2.0)
    robot.hold(0.5)
    return robot


def held_error(robot, pose, joint: int) -> tuple[float, float]:
    """Move to ``pose``, settle, and return the mean error of ``joint`` and its true position."""
    robot.move_to(pose, 1.5)
    robot.hold(1.0)
    rec = robot.hold(0.5)
    return float(joint_error(rec, joint).mean()), float(rec.channel("true_joints")[:, joint].mean())


def test_new_effects_are_on_by_default_outside_the_filter_class_and_appended_after_the_old_ones():
    params = RavenParameters()
    assert EFFECT_NAMES[-5:] == NEW_EFFECTS
    for name in NEW_EFFECTS:
        assert params.is_enabled(name)
        assert type(params.effect(name))().enabled
    assert set(NEW_EFFECTS) <= set(out_of_class_effects(params))
    assert not set(NEW_EFFECTS) & set(FILTER_CLASS)


def test_new_effects_round_trip_through_a_dictionary_and_json():
    params = RavenParameters().switched(NEW_EFFECTS, True).with_effect(
        MotorFriction.from_efficiency(np.full(7, 0.75), enabled=True, coulomb=np.full(7, 3e-3)))
    data = params.to_dict()
    assert data["effects"]["transmission_error"]["enabled"] is True
    assert data["effects"]["motor_friction"]["gearbox_loss"] == pytest.approx([1 / 3] * 7)
    assert RavenParameters.from_dict(data) == params
    assert RavenParameters.from_dict(json.loads(json.dumps(data))) == params
    assert RavenParameters.from_dict({}) == RavenParameters()


@pytest.mark.parametrize("effect, message", [
    (lambda: MotorFriction.from_efficiency(np.full(7, 1.2)), "efficiency"),
    (lambda: MotorFriction(gearbox_loss=np.full(7, -0.1)), "gearbox_loss"),
    (lambda: CapstanFriction(mu=[-0.1, 0.0, 0.0]), "mu"),
    (lambda: GravityModelError(scale_error=[-1.0, 0.0, 0.0]), "scale_error"),
    (lambda: TransmissionError(ratio_error=[0.0, 0.0]), "ratio_error"),
    (lambda: RegistrationOffset(repeatability=[0.0, -1e-3, 0.0]), "repeatability"),
])
def test_new_effects_reject_bad_parameters_by_name(effect, message):
    with pytest.raises(ValueError, match=message):
        effect()


def test_motor_friction_separates_the_delivered_torque_from_the_command_by_the_sign_of_motor_velocity():
    coulomb = np.full(7, 4e-3)
    base = RavenParameters().only("cable_stretch", "gravity_stretch")
    gear = base.constants.gearbox[0]
    robot = ready(base.with_effect(MotorFriction(enabled=True, coulomb=coulomb, gearbox_loss=np.zeros(7))))
    rec = robot.run(sweep(0, np.deg2rad(20), 4.0, 2.0))
    gap = rec.channel("tau")[:, 0] - rec.channel("applied_torque")[:, 0]
    velocity = rec.channel("mvel")[:, 0]
    moving = np.abs(velocity) > 0.3 * np.abs(velocity).max()
    # the motor's friction (at the gearbox output) is taken from the command, against the motion
    np.testing.assert_allclose(np.median(gap[moving & (velocity > 0)]), coulomb[0] * gear, rtol=0.05)
    np.testing.assert_allclose(np.median(gap[moving & (velocity < 0)]), -coulomb[0] * gear, rtol=0.05)
    # a gearbox loss adds a friction that grows with the transmitted torque
    robot = ready(base.with_effect(MotorFriction.from_efficiency(np.full(7, 0.8), enabled=True, coulomb=coulomb)))
    lossy = robot.run(sweep(0, np.deg2rad(20), 4.0, 2.0))
    gap_lossy = lossy.channel("tau")[:, 0] - lossy.channel("applied_torque")[:, 0]
    assert np.median(np.abs(gap_lossy[moving])) > 1.1 * np.median(np.abs(gap[moving]))
    # switched off, nothing is taken from the command
    robot = ready(base)
    plain = robot.run(sweep(0, np.deg2rad(20), 4.0, 1.0))
    np.testing.assert_allclose(plain.channel("tau"), plain.channel("applied_torque"), atol=1e-12)


def _direction_error(params: RavenParameters, payload_kg: float, joint: int, amplitude: float) -> float:
    """Half the difference of the joint error moving up and moving down (the friction's share)."""
    robot = ready(params, payload_kg)
    rec = robot.run(sweep(joint, amplitude, 4.0, 2.5))
    error = joint_error(rec, joint)
    speed = np.gradient(rec.channel("jpos_d")[:, joint], rec.time)
    fast = np.abs(speed) > 0.5 * np.abs(speed).max()
    return (np.median(error[fast & (speed > 0)]) - np.median(error[fast & (speed < 0)])) / 2


def test_capstan_friction_error_grows_with_the_load_plain_coulomb_does_not():
    base = RavenParameters().only("cable_stretch", "gravity_stretch")
    capstan = base.with_effect(CapstanFriction(enabled=True, mu=np.full(3, 0.05)))
    coulomb = base.with_effect(CoulombFriction(enabled=True))
    joint, amplitude = 2, 0.03
    capstan_ratio = _direction_error(capstan, 0.5, joint, amplitude) / _direction_error(capstan, 0.0, joint, amplitude)
    coulomb_ratio = _direction_error(coulomb, 0.5, joint, amplitude) / _direction_error(coulomb, 0.0, joint, amplitude)
    assert capstan_ratio > 1.25, capstan_ratio
    assert coulomb_ratio < 1.05, coulomb_ratio


def test_gravity_model_error_leaves_a_static_error_proportional_to_the_gravity_torque():
    scale_error = np.array([0.2, 0.2, 0.2])
    base = RavenParameters().only("cable_stretch", "gravity_stretch")
    c = base.constants
    tr = c.transmission_ratio[:3]
    poses = [POSE, POSE + np.array([np.deg2rad(35.0), np.deg2rad(35.0), 0.0, 0, 0, 0, 0])]
    shifts, gravity = [], []
    for pose in poses:
        tracking = []
        for params in (base, base.with_effect(GravityModelError(enabled=True, scale_error=scale_error))):
            robot = ready(params)
            robot.move_to(pose, 1.5)
            robot.hold(1.0)
            rec = robot.hold(0.5)
            # static error of each motor coordinate (motor angle over its ratio, joint units)
            tracking.append(((rec.channel("mpos") - rec.channel("mpos_d"))[:, :3] / tr).mean(axis=0))
            # the gravity torque of the controller's model, at the joints it believes it holds
            joints = rec.channel("jpos")[:, :3].mean(axis=0)
            torque = robot.robot.gravity_torques(np.r_[joints, 0.0, 0.0, 0.0])
        shifts.append(tracking[1] - tracking[0])
        gravity.append(torque)
    shifts, gravity = np.array(shifts), np.array(gravity)
    assert abs(gravity[1, 0]) > 2 * abs(gravity[0, 0])
    # the PD loop on each motor holds the excess compensation e g over its stiffness kp tr^2 / gear
    stiffness = c.kp[:3] * tr ** 2 / c.gearbox[:3]
    for joint in (0, 1):
        np.testing.assert_allclose(shifts[:, joint], scale_error[joint] * gravity[:, joint] / stiffness[joint],
                                   rtol=0.03)
    # and the controller's joints carry it through the nominal coupling
    robot = ready(base.with_effect(GravityModelError(enabled=True, scale_error=scale_error)))
    rec = robot.hold(0.5)
    mpos = rec.channel("mpos")[:, :3] / tr
    np.testing.assert_allclose(rec.channel("jpos")[:, :3], mpos @ c.nominal_coupling().T, atol=1e-12)


def test_transmission_error_grows_linearly_with_the_distance_from_the_registration_pose():
    ratio_error = np.array([0.01, 0.01, 0.01])
    params = RavenParameters().only("homing_offset").with_effect(
        TransmissionError(enabled=True, ratio_error=ratio_error))
    params = params.with_effect(params.effect("homing_offset").replace(repeatability=np.zeros(3),
                                                                        tool_repeatability=np.zeros(4)))
    robot = ready(params)
    stop = params.constants.hard_stop
    for joint, offsets in ((0, np.deg2rad([10.0, 30.0, 50.0])), (2, np.array([0.30, 0.36, 0.42]))):
        errors, distances = [], []
        for value in offsets:
            pose = POSE.copy()
            pose[joint] = value
            error, true = held_error(robot, pose, joint)
            errors.append(error)
            distances.append(true - stop[joint])
        slope, intercept = np.polyfit(distances, errors, 1)
        np.testing.assert_allclose(slope, ratio_error[joint], rtol=0.02)
        assert abs(intercept) < 0.02 * ratio_error[joint] * np.abs(distances).max()


def test_registration_offset_is_constant_within_a_homing_and_redrawn_at_each():
    offset = np.array([2e-3, -3e-3, 1e-4])
    base = RavenParameters().only("registration_offset")
    # deterministic: the same offset after every homing, whatever the pose
    robot = ready(base.with_effect(RegistrationOffset(enabled=True, offset=offset, repeatability=np.zeros(3))))
    for _ in range(2):
        rec = robot.run(sweep(0, np.deg2rad(20), 4.0, 1.0))
        for joint in range(3):
            np.testing.assert_allclose(joint_error(rec, joint), offset[joint], atol=1e-9)
        rehome(robot)
    # random: constant within each homing, a new draw at each, scattered by the repeatability
    repeatability = np.array([1e-3, 1e-3, 5e-5])
    robot = ready(base.with_effect(RegistrationOffset(enabled=True, offset=offset, repeatability=repeatability)))
    draws = []
    for _ in range(6):
        rec = robot.run(sweep(1, np.deg2rad(20), 4.0, 1.0))
        error = np.column_stack([joint_error(rec, joint) for joint in range(3)])
        assert np.all(error.std(axis=0) < 1e-9)
        draws.append(error.mean(axis=0))
        rehome(robot)
    draws = np.array(draws)
    assert np.all(draws.std(axis=0) > 0.1 * repeatability)
    assert np.all(np.abs(draws - offset) < 6 * repeatability)
