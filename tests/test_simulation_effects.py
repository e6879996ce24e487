"""Each effect of the virtual RAVEN-II, alone, shows the signature of its physics."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import RavenII
from simulation.model.laws import cable_stretch_curve
from simulation.model.effects import Backlash, Coupling, Drift, Quantization
from simulation.model.parameters import RavenParameters
from simulation.engine.robot import VirtualRaven
from simulation.engine.scenarios import powered_on, rehome
from simulated_motion import POSE, sweep



def errors(rec) -> np.ndarray:
    truth = np.column_stack([np.interp(rec.time, rec.truth_time, rec.truth[:, i]) for i in range(3)])
    return rec.channel("jpos")[:, :3] - truth


def homed(params: RavenParameters, seed: int = 0, payload_kg: float = 0.0) -> VirtualRaven:
    robot = powered_on(params, seed=seed, payload_kg=payload_kg)
    robot.move_to(POSE, 2.0)
    robot.hold(0.5)
    return robot


def test_all_effects_off_joints_equal_nominal_coupling_within_encoder_resolution():
    robot = homed(RavenParameters().only("quantization"))
    rec = robot.run(sweep(1, np.deg2rad(15), 4.0, 1.5))
    rec = Recording_concat(rec, robot.run(sweep(2, 0.03, 4.0, 1.5)))
    c = robot.params.constants
    resolution = 2 * np.pi / c.encoder_counts_per_rev / c.transmission_ratio[:3]
    nominal = (c.nominal_coupling() @ (rec.channel("mpos")[:, :3] / c.transmission_ratio[:3]).T).T
    np.testing.assert_allclose(rec.channel("jpos")[:, :3], nominal, atol=1e-12)
    err = nominal - rec.channel("true_joints")
    # one count of each motor through the coupling: at most two counts' worth per joint
    assert np.all(np.abs(err) <= 2.5 * resolution.max()), np.abs(err).max(axis=0) / resolution


def Recording_concat(a, b):
    from simulation.recordings.recording import Recording

    return Recording.concatenate([a, b])


def test_backlash_error_flips_with_velocity_by_the_dead_band():
    half_width = np.array([1e-3, 2e-3, 5e-5])
    params = RavenParameters().only("backlash").with_effect(Backlash(half_width=half_width))
    robot = homed(params)
    rec = robot.run(sweep(1, np.deg2rad(20), 6.0, 2.0))
    e = errors(rec)[:, 1]
    velocity = rec.channel("jvel")[:, 1]
    moving_up = velocity > 0.05
    moving_down = velocity < -0.05
    # the joint lags the motor by the dead band: +b when moving up, -b when moving down
    assert np.median(e[moving_up]) == pytest.approx(half_width[1], rel=0.05)
    assert np.median(e[moving_down]) == pytest.approx(-half_width[1], rel=0.05)


def test_coulomb_friction_flips_the_error_and_the_motor_torque_backlash_only_the_error():
    def flip(params):
        robot = homed(params)
        rec = robot.run(sweep(1, np.deg2rad(20), 6.0, 2.0))
        v = rec.channel("jvel")[:, 1]
        up, down = v > 0.05, v < -0.05
        e = errors(rec)[:, 1]
        tau = rec.channel("applied_torque")[:, 1]
        return np.median(e[up]) - np.median(e[down]), np.median(tau[up]) - np.median(tau[down])

    base = RavenParameters().only("cable_stretch", "coulomb_friction")
    friction = base.effect("coulomb_friction").force[1]
    stiffness = base.effect("cable_stretch").stiffness[1]
    e_flip, tau_flip = flip(base)
    # the dry friction loads the cable: stretch flips by about 2 F / k, motor torque by 2 F / ratio
    assert e_flip == pytest.approx(2 * friction / stiffness, rel=0.35)
    c = base.constants
    assert tau_flip == pytest.approx(2 * friction / (c.transmission_ratio[1] / c.gearbox[1]), rel=0.35)
    backlash = RavenParameters().only("cable_stretch", "backlash")
    e_flip_bl, tau_flip_bl = flip(backlash)
    assert e_flip_bl == pytest.approx(2 * backlash.effect("backlash").half_width[1], rel=0.3)
    assert abs(tau_flip_bl) < 0.2 * abs(tau_flip)


def test_gravity_stretch_scales_with_payload_as_the_cable_law_predicts():
    params = RavenParameters().only("cable_stretch", "gravity_stretch")
    law = params.effect("cable_stretch")
    kin = RavenII("left", check_limits=False)
    measured, predicted = [], []
    for payload in (0.0, 0.5, 1.0):
        robot = homed(params, payload_kg=payload)
        rec = robot.hold(1.0)
        measured.append(rec.channel("cable_stretch")[-1])
        q6 = np.r_[rec.channel("true_joints")[-1], 0.0, 0.0, 0.0]
        load = kin.gravity_torques(q6, payload_kg=payload)
        predicted.append([cable_stretch_curve(load[i], law.stiffness[i], law.hardening[i]) for i in range(3)])
    measured = np.array(measured)
    predicted = np.array(predicted)
    np.testing.assert_allclose(measured, predicted, rtol=0.02, atol=1e-6)
    # the insertion cable carries the payload's weight along the tool axis
    assert measured[2, 2] - measured[0, 2] > 1e-3


def test_coupling_error_follows_joint_one_with_the_coefficient_difference():
    delta = np.array([0.02, 0.002, -0.002])
    params = RavenParameters().only("coupling").with_effect(Coupling(delta=delta))
    robot = homed(params)
    rec = robot.run(sweep(0, np.deg2rad(25), 6.0, 1.0))
    q1 = rec.channel("true_joints")[:, 0]
    slope = np.polyfit(q1, errors(rec)[:, 1], 1)[0]
    assert slope == pytest.approx(delta[0], rel=0.02)


def test_viscous_friction_error_grows_with_speed():
    params = RavenParameters().only("cable_stretch", "viscous_friction")
    robot = homed(params)
    rec = robot.run(sweep(1, np.deg2rad(30), 4.0, 2.0))
    v = rec.channel("true_joints")
    qd = np.gradient(v[:, 1], rec.time)
    e = errors(rec)[:, 1] - errors(rec)[:, 1].mean()
    slope = np.polyfit(qd, e, 1)[0]
    law = params.effect("cable_stretch")
    expected = params.effect("viscous_friction").coefficient[1] / law.stiffness[1]
    assert slope == pytest.approx(expected, rel=0.3)


def test_hysteresis_makes_the_error_a_loop_in_tension():
    params = RavenParameters().only("cable_stretch", "gravity_stretch", "hysteresis")
    robot = homed(params)
    rec = robot.run(sweep(1, np.deg2rad(30), 8.0, 2.0))
    tension = rec.channel("cable_tension")[:, 1]
    e = errors(rec)[:, 1]
    v = rec.channel("jvel")[:, 1]
    mid = np.abs(tension - np.median(tension)) < 0.25 * np.ptp(tension)
    up, down = mid & (v > 0.05), mid & (v < -0.05)
    gap = np.median(e[up]) - np.median(e[down])
    hysteresis = params.effect("hysteresis")
    z_max = 1.0 / (hysteresis.beta[1] + hysteresis.gamma[1])
    assert abs(gap) > 0.2 * hysteresis.stiffness[1] * z_max / params.effect("cable_stretch").stiffness[1]
    without = homed(params.without("hysteresis")).run(sweep(1, np.deg2rad(30), 8.0, 2.0))
    e0 = errors(without)[:, 1]
    v0 = without.channel("jvel")[:, 1]
    t0 = without.channel("cable_tension")[:, 1]
    mid0 = np.abs(t0 - np.median(t0)) < 0.25 * np.ptp(t0)
    gap0 = np.median(e0[mid0 & (v0 > 0.05)]) - np.median(e0[mid0 & (v0 < -0.05)])
    assert abs(gap0) < 0.3 * abs(gap)


def _bouc_wen_of_lagged_stretch(stretch, time, lag, beta, gamma, z0):
    """The Bouc-Wen state (n = 1) of a stretch series passed through a first-order lag of ``lag``
    seconds (0: none), integrated in ten explicit sub-steps per sample from ``z0``."""
    z = np.empty_like(stretch)
    z[0], smoothed = z0, stretch[0]
    for k in range(1, time.size):
        gain = 1.0 if lag == 0 else 1 - np.exp(-(time[k] - time[k - 1]) / lag)
        new = smoothed + gain * (stretch[k] - smoothed)
        step, smoothed, state = (new - smoothed) / 10, new, z[k - 1]
        for _ in range(10):
            state += step * (1 - beta * np.sign(step) * state - gamma * abs(state))
        z[k] = state
    return z


@pytest.mark.parametrize("lag", [0.0, 0.05, 0.2])
def test_the_hysteresis_state_follows_the_stretch_lagged_by_its_response_time(lag):
    params = RavenParameters().only("cable_stretch", "gravity_stretch", "hysteresis")
    hysteresis = params.effect("hysteresis").replace(response_time=np.full(3, lag))
    robot = powered_on(params.with_effect(hysteresis), seed=0, log_rate=1000.0, truth_rate=1000.0)
    robot.move_to(POSE, 2.0)
    robot.hold(0.5)
    rec = robot.run(sweep(1, np.deg2rad(30), 2.0, 2.0))
    # the first logged row precedes the first step; the lag forgets where it started within 1.5 s
    stretch, z, time = rec.channel("cable_stretch")[1:, 1], rec.channel("hysteresis_state")[1:, 1], rec.time[1:]
    late = time > time[0] + 1.5
    assert np.ptp(z[late]) > 1.9 / (hysteresis.beta[1] + hysteresis.gamma[1])  # the loop saturates both ways

    def misfit(guess):
        predicted = _bouc_wen_of_lagged_stretch(stretch, time, guess, hysteresis.beta[1], hysteresis.gamma[1], z[0])
        return np.sqrt(np.mean((z[late] - predicted[late]) ** 2)) / np.ptp(z[late])

    assert misfit(lag) < 0.01
    for wrong in {0.0, 0.05, 0.2} - {lag}:
        assert misfit(wrong) > 0.05


def test_homing_registers_the_stretch_under_homing_tension_and_rehoming_shifts_it():
    exact = RavenParameters().only("cable_stretch", "gravity_stretch", "homing_offset")
    exact = exact.with_effect(exact.effect("homing_offset").replace(repeatability=np.zeros(3)))
    off = exact.without("homing_offset")
    robot_off = homed(off)
    e_off = errors(robot_off.hold(1.0)).mean(axis=0)
    robot_on = powered_on(exact, seed=0)
    homing = rehome(robot_on)
    homing_stretch = homing.select(homing.mode == 1).channel("cable_stretch")[-1]
    robot_on.move_to(POSE, 2.0)
    robot_on.hold(0.5)
    e_on = errors(robot_on.hold(1.0)).mean(axis=0)
    # ideal registration leaves the operating stretch; registration under tension subtracts the
    # stretch the cables had at the hard stops (degrees, millimetres)
    np.testing.assert_allclose(e_on - e_off, -homing_stretch, rtol=0.07, atol=2e-5)
    assert np.all(np.abs(homing_stretch) > np.array([0.01, 0.05, 5e-3]))

    # re-homing from the same pose (the home pose, as an operator would) lands within the
    # registration repeatability
    noisy = RavenParameters().only("cable_stretch", "gravity_stretch", "homing_offset")
    robot = homed(noisy)
    first = robot.hold(1.0)
    rehome(robot)
    robot.move_to(POSE, 2.0)
    robot.hold(0.5)
    second = robot.hold(1.0)
    assert not np.allclose(second.channel("encoffsets")[-1], first.channel("encoffsets")[-1])
    shift = errors(second).mean(axis=0) - errors(first).mean(axis=0)
    repeat = noisy.effect("homing_offset").repeatability
    assert np.all(np.abs(shift) < 6 * repeat + 2e-5)
    assert np.abs(shift[1]) > 0.05 * repeat[1]
    again = homed(off)
    np.testing.assert_allclose(errors(again.hold(1.0)).mean(axis=0), e_off, atol=1e-6)


def test_quantization_matches_the_stated_resolutions():
    quant = Quantization()
    robot = homed(RavenParameters().only("cable_stretch", "gravity_stretch", "quantization"))
    rec = robot.run(sweep(2, 0.03, 3.0, 1.0))
    counts = rec.truth / quant.truth_resolution
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-6)
    c = robot.params.constants
    motor_counts = rec.channel("mpos") * c.encoder_counts_per_rev / (2 * np.pi)
    np.testing.assert_allclose(motor_counts, np.round(motor_counts), atol=1e-6)
    dac = rec.dac_values
    np.testing.assert_array_equal(dac, np.round(dac))
    continuous = homed(RavenParameters().only("cable_stretch", "gravity_stretch")).run(sweep(2, 0.03, 3.0, 1.0))
    fractional = continuous.truth / quant.truth_resolution
    assert np.abs(fractional - np.round(fractional)).max() > 0.1


def drift_run(kind: str, blocks: int = 4):
    params = RavenParameters().only("cable_stretch", "gravity_stretch", "drift").with_effect(
        Drift(creep_rate=[2.5e-3, 1e-3, 1e-5], time_scale=3600.0 * 0.25))
    robot = homed(params, payload_kg=0.5 if kind == "loaded" else 0.0)
    calibration = robot.run(sweep(1, np.deg2rad(25), 4.0, 2.0))
    offset = errors(calibration).mean(axis=0)
    growth = []
    for _ in range(blocks):
        block = robot.run(sweep(1, np.deg2rad(25), 4.0, 2.0))
        growth.append(np.sqrt(np.mean((errors(block) - offset) ** 2, axis=0)))
    return np.array(growth), robot.fatigue_dose()


def test_drift_grows_the_fixed_offset_error_with_hours_faster_when_loaded():
    unloaded, dose_u = drift_run("unloaded")
    loaded, dose_l = drift_run("loaded")
    # fatigue accumulates with motion: the fixed-offset error of joint 1 grows block after block
    assert np.all(np.diff(unloaded[:, 0]) > 0)
    assert unloaded[-1, 0] > 1.3 * unloaded[0, 0]
    # a load ages the cable faster
    assert dose_l[0] > dose_u[0]
    assert loaded[-1, 0] > unloaded[-1, 0]


def test_idle_does_not_age_the_cable():
    params = RavenParameters().only("cable_stretch", "gravity_stretch", "drift").with_effect(Drift(time_scale=3600.0))
    robot = homed(params)
    robot.hold(2.0)
    before = robot.fatigue_dose()
    robot.hold(4.0)
    idle = robot.fatigue_dose() - before
    robot.run(sweep(1, np.deg2rad(20), 4.0, 1.0))
    moving = robot.fatigue_dose() - before - idle
    assert np.all(idle < 1e-3 * moving)


def test_noise_perturbs_the_applied_torque_around_the_command():
    robot = homed(RavenParameters().only("noise"))
    rec = robot.hold(2.0)
    c = robot.params.constants
    difference = rec.channel("applied_torque") - rec.channel("tau")
    expected = robot.params.effect("noise").current_noise * c.torque_per_amp
    np.testing.assert_allclose(difference.std(axis=0), expected, rtol=0.2)
    quiet = homed(RavenParameters().only()).hold(2.0)
    np.testing.assert_allclose(quiet.channel("applied_torque"), quiet.channel("tau"), atol=1e-12)
