"""The servo loop's parts on their own: the controller's PD law, homing registration, table checks."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from kinematics import RavenII
from simulation.engine import tables
from simulation.engine.controller import register_encoders, servo_control
from simulation.engine.sensors import read_motor_encoders
from simulation.engine.tables import C_INT, C_OFF, C_POWERON, MODE_TRAJECTORY, X_U, build_tables
from simulation.model.parameters import RavenParameters


@pytest.fixture(scope="module")
def arm():
    params = RavenParameters().only()
    robot = RavenII(arm=params.arm, check_limits=False)
    return params, robot, build_tables(params, robot)


def test_one_servo_tick_applies_the_pd_law_with_gravity_compensation(arm):
    params, robot, t = arm
    c = params.constants
    tr = np.asarray(c.transmission_ratio, dtype=float)
    rng = np.random.default_rng(0)
    qd_des = c.home_pose + rng.normal(0.0, [0.02, 0.02, 0.002, 0.05, 0.05, 0.05, 0.05])
    vd_des = rng.normal(0.0, 0.1, 7)
    mpos = rng.normal(0.0, 1.0, 7)
    mvel = rng.normal(0.0, 1.0, 7)
    jpos = c.home_pose + rng.normal(0.0, 0.01, 7)
    ctrl = np.zeros(tables.N_CTRL)
    out = {name: np.zeros(7) for name in ("mpos_d", "mvel_d", "tau_d", "dac", "tau_applied", "tau_u")}
    servo_control(MODE_TRAJECTORY, ctrl, t.table, t.flags, tr, np.linalg.inv(t.coupling_nominal),
                  c.tool_gb_ratio, c.tool_sign, c.servo_period, t.gravity_controller, qd_des, vd_des,
                  mpos, mvel, jpos, np.zeros(3), np.zeros(3), np.zeros(3), out["mpos_d"], out["mvel_d"],
                  out["tau_d"], out["dac"], out["tau_applied"], out["tau_u"])

    # the same law written out: inverse coupling, PID, gravity compensation, DAC clipping
    mpos_d = np.empty(7)
    mpos_d[:3] = tr[:3] * np.linalg.solve(c.nominal_coupling(), qd_des[:3])
    mpos_d[3:] = tr[3:] * qd_des[3:] + np.array([1.0, 1.0, -1.0, 1.0]) * c.tool_sign * mpos[2] / c.tool_gb_ratio
    mvel_d = np.r_[tr[:3] * np.linalg.solve(c.nominal_coupling(), vd_des[:3]), tr[3:] * vd_des[3:]]
    err = mpos_d - mpos
    tau = c.kp * err + c.kd * (mvel_d - mvel) + c.ki * err * c.servo_period
    tau[:3] += robot.gravity_torques(np.r_[jpos[:3], 0.0, 0.0, 0.0]) / tr[:3] * c.gearbox[:3]
    dac = np.clip(tau / c.torque_per_amp * c.dac_per_amp, -c.dac_max, c.dac_max)
    np.testing.assert_allclose(out["mpos_d"], mpos_d, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(out["tau_d"], tau, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(out["dac"], dac, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(out["tau_applied"], dac / c.dac_per_amp * c.torque_per_amp, rtol=1e-9)
    np.testing.assert_allclose(ctrl[C_INT:C_INT + 7], err * c.servo_period, rtol=1e-12, atol=1e-15)


def test_homing_registration_reads_the_hard_stops_at_the_motors_it_finds_there():
    params = RavenParameters().only("homing_offset")
    homing = params.effect("homing_offset")
    params = params.with_effect(dataclasses.replace(homing, repeatability=np.zeros(3),
                                                    tool_repeatability=np.zeros(4)))
    robot = RavenII(arm=params.arm, check_limits=False)
    t = build_tables(params, robot)
    c = params.constants
    tr = np.asarray(c.transmission_ratio, dtype=float)
    counts_per_rad = t.scalars[tables.S_CPR] / (2.0 * np.pi)
    plant = np.zeros(tables.N_PLANT)
    plant[X_U:X_U + 7] = np.random.default_rng(1).normal(0.0, 0.3, 7)
    ctrl = np.zeros(tables.N_CTRL)
    ctrl[C_POWERON:C_POWERON + 7] = [1200.0, -300.0, 45.0, 7.0, -8.0, 9.0, 10.0]
    ctrl[C_OFF:C_OFF + 7] = ctrl[C_POWERON:C_POWERON + 7]
    enc, mpos, mvel = np.zeros(7), np.zeros(7), np.zeros(7)
    read_motor_encoders(plant, ctrl, t.flags, tr, counts_per_rad, c.servo_period, enc, mpos, mvel)

    register_encoders(t.table, t.flags, np.linalg.inv(t.coupling_nominal), plant, ctrl, enc, counts_per_rad)
    read_motor_encoders(plant, ctrl, t.flags, tr, counts_per_rad, c.servo_period, enc, mpos, mvel)
    # wherever the motors stand, the controller now reads its registered hard-stop positions there
    np.testing.assert_allclose(c.nominal_coupling() @ (mpos[:3] / tr[:3]), c.hard_stop, atol=1e-9)
    np.testing.assert_array_equal(ctrl[C_OFF + 3:C_OFF + 7], ctrl[C_POWERON + 3:C_POWERON + 7])
    np.testing.assert_array_equal(mvel, 0.0)


@pytest.mark.parametrize("name", ["transmission_ratio", "gearbox", "torque_per_amp", "dac_per_amp"])
def test_tables_refuse_a_zero_the_loop_would_divide_by(arm, name):
    params, robot, _ = arm
    value = np.array(getattr(params.constants, name), dtype=float)
    value[4] = 0.0
    constants = dataclasses.replace(params.constants, **{name: value})
    with pytest.raises(ValueError, match=name):
        build_tables(dataclasses.replace(params, constants=constants), robot)


def test_tables_refuse_a_zero_truth_resolution_when_quantizing(arm):
    params, robot, _ = arm
    quant = RavenParameters().effect("quantization")
    zero = dataclasses.replace(quant, truth_resolution=np.array([0.0, 1e-4, 1e-6]))
    with pytest.raises(ValueError, match="truth_resolution"):
        build_tables(params.with_effect(zero), robot)
    build_tables(params.with_effect(zero.with_enabled(False)), robot)
