"""The controller of the virtual RAVEN-II: what ``rt_raven.cpp`` computes every servo tick.

Compiled functions called in this order by :func:`simulation.engine.loop.servo_loop`:
:func:`forward_coupling` (motor positions to joint positions through the controller's nominal
cable coupling, ``fwd_cable_coupling.cpp``), :func:`desired_motion` (the trajectory sample, or
the homing search of ``homing.cpp``), :func:`servo_control` (inverse coupling, PID on motor
positions, gravity compensation, DAC clipping and the commanded motor torques,
``pid_control.cpp``), :func:`detect_hard_stops` and, once every joint has settled at its stop,
:func:`register_encoders` (``set_joints_known_pos``). Units: motor rad, joint rad or m, torques
in N m at the motor (``tau_d``) and at the gearbox output (``tau_applied``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from kinematics.gravity_closed_form import gravity_torques_fast

from simulation.engine.tables import (
    C_HOLD, C_HOMESTART, C_HOMESTATE, C_INT, C_OFF, C_POWERON, C_READY, C_SETTLE, E_GRAVERROR, E_HOMING,
    E_NOISE, E_QUANT, E_REGISTRATION, MODE_TRAJECTORY, R_DACMAX, R_DPA, R_GEAR, R_GERR, R_HOMEDAC,
    R_HOMESPEED, R_HREP, R_INOISE, R_KD, R_KI, R_KP, R_REGPOS, R_ROFF, R_RREP, R_TPA, R_TR, S_SETTLE,
)


@njit(cache=True)
def interpolate_trajectory(traj_q, traj_qd, rate, t, out_q, out_qd):
    """Cubic Hermite interpolation of a uniformly sampled trajectory at time ``t`` (s)."""
    n = traj_q.shape[0]
    x = t * rate
    i = int(np.floor(x))
    if i >= n - 1 or i < 0:
        # element by element: numba compiles a slice assignment from an array with a formatted
        # shape-mismatch error, seconds of compilation per process
        end = n - 1 if i >= 0 else 0
        for k in range(traj_q.shape[1]):
            out_q[k] = traj_q[end, k]
            out_qd[k] = traj_qd[end, k]
        return
    s = x - i
    h = 1.0 / rate
    s2 = s * s
    s3 = s2 * s
    h00 = 2 * s3 - 3 * s2 + 1
    h10 = s3 - 2 * s2 + s
    h01 = -2 * s3 + 3 * s2
    h11 = s3 - s2
    d00 = (6 * s2 - 6 * s) / h
    d10 = 3 * s2 - 4 * s + 1
    d01 = (-6 * s2 + 6 * s) / h
    d11 = 3 * s2 - 2 * s
    for k in range(traj_q.shape[1]):
        q0 = traj_q[i, k]
        q1 = traj_q[i + 1, k]
        v0 = traj_qd[i, k]
        v1 = traj_qd[i + 1, k]
        out_q[k] = h00 * q0 + h10 * h * v0 + h01 * q1 + h11 * h * v1
        out_qd[k] = d00 * q0 + d10 * v0 + d01 * q1 + d11 * v1



@njit(cache=True)
def tool_joints_from_motors(mpos, tr, gb, sign, out):
    """Tool joint positions from motor angles (``fwd_cable_coupling.cpp``, RAVEN tool).

    ``mpos`` (7,) motor angles (rad); ``tr`` transmission ratios; ``gb`` the tool's gearbox ratio
    and ``sign`` its direction for the insertion motor's term; ``out`` (4,) tool joints (rad).
    """
    m_ins = mpos[2]
    out[0] = (mpos[3] - sign * m_ins / gb) / tr[3]
    out[1] = (mpos[4] - sign * m_ins / gb) / tr[4]
    out[2] = (mpos[5] + sign * m_ins / gb) / tr[5]
    out[3] = (mpos[6] - sign * m_ins / gb) / tr[6]


@njit(cache=True, inline="always")
def forward_coupling(mpos, mvel, tr, a_nom, gb, tsign, tmp3, tool_nom, jpos, jvel):
    """Joint positions and velocities as the controller computes them from its motor readings.

    The positioning joints through the nominal coupling ``a_nom`` (3, 3), the tool joints through
    :func:`tool_joints_from_motors`; ``tmp3`` (3,) and ``tool_nom`` (4,) are scratch. Outputs:
    ``jpos``, ``jvel`` (7,) in rad, m and rad/s, m/s.
    """
    for i in range(3):
        tmp3[i] = mpos[i] / tr[i]
    for i in range(3):
        jpos[i] = a_nom[i, 0] * tmp3[0] + a_nom[i, 1] * tmp3[1] + a_nom[i, 2] * tmp3[2]
    tool_joints_from_motors(mpos, tr, gb, tsign, tool_nom)
    for j in range(4):
        jpos[3 + j] = tool_nom[j]
    for j in range(7):
        jvel[j] = mvel[j] / tr[j]


@njit(cache=True, inline="always")
def desired_motion(mode, ctrl, table, traj_q, traj_qd, traj_rate, t, traj_t0, jpos, qd_des, vd_des):
    """Desired joint positions ``qd_des`` and velocities ``vd_des`` (7,) at time ``t`` (s).

    In MODE_TRAJECTORY, the trajectory sampled at ``traj_rate`` Hz from ``traj_t0``; in
    MODE_HOMING, the held pose with the linear-sinusoid search toward the hard stops of each
    positioning joint still searching (the search starts from the measured ``jpos`` the first
    time, when the homing state of ``ctrl`` is negative).
    """
    if mode == MODE_TRAJECTORY:
        interpolate_trajectory(traj_q, traj_qd, traj_rate, t - traj_t0, qd_des, vd_des)
    else:
        if ctrl[C_HOMESTATE] < 0.0:
            # homing starts where the arm is (homing.cpp: mpos_d = mpos, jpos_d = jpos)
            for j in range(7):
                ctrl[C_HOLD + j] = jpos[j]
            for i in range(3):
                ctrl[C_HOMESTART + i] = jpos[i]
                ctrl[C_HOMESTATE + i] = 0.0
            ctrl[C_SETTLE] = 0.0
        for j in range(7):
            qd_des[j] = ctrl[C_HOLD + j]
            vd_des[j] = 0.0
        elapsed = t - traj_t0
        for i in range(3):
            if ctrl[C_HOMESTATE + i] == 0.0:
                # linear-sinusoid search (homing.cpp): smooth ramp up to the search speed
                v = table[R_HOMESPEED, i]
                qd_des[i] = ctrl[C_HOMESTART + i] + v * (elapsed - np.sin(2 * np.pi * elapsed) / (2 * np.pi))
                vd_des[i] = v * (1.0 - np.cos(2 * np.pi * elapsed))


@njit(cache=True, inline="always")
def servo_control(mode, ctrl, table, flags, tr, a_nom_inv, gb, tsign, dt, grav_ctrl, qd_des, vd_des,
                  mpos, mvel, jpos, tmp3, q3, gctrl, mpos_d, mvel_d, tau_d, dac, tau_applied, tau_u):
    """PID on motor positions with gravity compensation, clipped to the DAC (``pid_control.cpp``).

    The desired joint motion goes through the inverse nominal coupling ``a_nom_inv`` to desired
    motor positions ``mpos_d`` and velocities ``mvel_d``; the motor torques ``tau_d`` (N m) add the
    gravity compensation of the controller's model ``grav_ctrl`` in MODE_TRAJECTORY; the command
    is clipped to the DAC range (whole DAC units with ``quantization``). Outputs also the DAC
    values ``dac``, the torques the amplifiers apply at the gearbox output ``tau_applied`` (with
    the ``noise`` effect's current noise: one standard normal per DOF from numba's random
    state) and the same in joint units ``tau_u``. ``tmp3``, ``q3``, ``gctrl`` (3,) are scratch.
    With ``gravity_model_error`` on, the gravity compensation of joint j is ``1 + scale_error[j]``
    times the model's.
    """
    for i in range(3):
        tmp3[i] = a_nom_inv[i, 0] * qd_des[0] + a_nom_inv[i, 1] * qd_des[1] + a_nom_inv[i, 2] * qd_des[2]
    for i in range(3):
        mpos_d[i] = tr[i] * tmp3[i]
    for i in range(3):
        tmp3[i] = a_nom_inv[i, 0] * vd_des[0] + a_nom_inv[i, 1] * vd_des[1] + a_nom_inv[i, 2] * vd_des[2]
    for i in range(3):
        mvel_d[i] = tr[i] * tmp3[i]
    m_ins = mpos[2]
    mpos_d[3] = tr[3] * qd_des[3] + tsign * m_ins / gb
    mpos_d[4] = tr[4] * qd_des[4] + tsign * m_ins / gb
    mpos_d[5] = tr[5] * qd_des[5] - tsign * m_ins / gb
    mpos_d[6] = tr[6] * qd_des[6] + tsign * m_ins / gb
    for j in range(3, 7):
        mvel_d[j] = tr[j] * vd_des[j]

    if mode == MODE_TRAJECTORY:
        for i in range(3):
            q3[i] = jpos[i]
        g = gravity_torques_fast(q3, grav_ctrl)
        for i in range(3):
            gctrl[i] = g[i]
    for j in range(7):
        err = mpos_d[j] - mpos[j]
        ctrl[C_INT + j] += err * dt
        tau_d[j] = table[R_KP, j] * err + table[R_KD, j] * (mvel_d[j] - mvel[j]) + table[R_KI, j] * ctrl[C_INT + j]
        if mode == MODE_TRAJECTORY and j < 3:
            if flags[E_GRAVERROR] == 1:
                # the controller's masses are not the arm's (gravity_model_error)
                tau_d[j] += (1.0 + table[R_GERR, j]) * gctrl[j] / tr[j] * table[R_GEAR, j]
            else:
                tau_d[j] += gctrl[j] / tr[j] * table[R_GEAR, j]
        cmd = tau_d[j] / table[R_TPA, j] * table[R_DPA, j]
        if flags[E_QUANT] == 1:
            cmd = float(int(cmd))
        lim = table[R_DACMAX, j]
        if cmd > lim:
            cmd = lim
        elif cmd < -lim:
            cmd = -lim
        dac[j] = cmd
        current = cmd / table[R_DPA, j]
        if flags[E_NOISE] == 1:
            current += table[R_INOISE, j] * np.random.standard_normal()
        tau_applied[j] = current * table[R_TPA, j]
        tau_u[j] = tau_applied[j] * tr[j] / table[R_GEAR, j]


@njit(cache=True, inline="always")
def detect_hard_stops(ctrl, table, scalars, dac, jpos):
    """Homing: mark each searching joint whose DAC reached the homing threshold as at its stop.

    A joint that reaches its stop holds its measured position (``stop_trajectory``,
    ``trajectory.cpp``). Returns True once every positioning joint has been at its stop for the
    settle time, when the encoders are to be registered.
    """
    registered = False
    all_at_stop = True
    for i in range(3):
        if ctrl[C_HOMESTATE + i] == 0.0 and abs(dac[i]) >= table[R_HOMEDAC, i]:
            # stop_trajectory (trajectory.cpp): the desired position jumps to the measured one
            ctrl[C_HOMESTATE + i] = 1.0
            ctrl[C_HOLD + i] = jpos[i]
        if ctrl[C_HOMESTATE + i] == 0.0:
            all_at_stop = False
    if all_at_stop:
        ctrl[C_SETTLE] += 1.0
        if ctrl[C_SETTLE] > scalars[S_SETTLE]:
            registered = True
    return registered


@njit(cache=True)
def register_encoders(table, flags, a_nom_inv, plant, ctrl, enc, counts_per_rad):
    """Set the encoder offsets at the hard stops (``set_joints_known_pos`` in homing.cpp).

    With ``homing_offset`` on, the current motor positions are declared to be those of the
    registered stop positions, whatever the cable stretch; each registration also lands off by
    the effect's repeatability. Switched off, the offsets are ideal (the power-on counts).
    """
    tr = table[R_TR]
    if flags[E_HOMING] == 1:
        noise = np.zeros(7)
        for j in range(7):
            noise[j] = table[R_HREP, j] * np.random.standard_normal()
        reg = np.zeros(3)
        for i in range(3):
            reg[i] = table[R_REGPOS, i] + noise[i]
        for i in range(3):
            u_reg = a_nom_inv[i, 0] * reg[0] + a_nom_inv[i, 1] * reg[1] + a_nom_inv[i, 2] * reg[2]
            ctrl[C_OFF + i] = enc[i] - u_reg * tr[i] * counts_per_rad
        for j in range(3, 7):
            ctrl[C_OFF + j] = ctrl[C_POWERON + j] + noise[j] * tr[j] * counts_per_rad
    else:
        for j in range(7):
            ctrl[C_OFF + j] = ctrl[C_POWERON + j]
    if flags[E_REGISTRATION] == 1:
        # the stops are not where defines.h puts them: the controller's joints read off by d
        shift = np.zeros(3)
        for i in range(3):
            shift[i] = table[R_ROFF, i] + table[R_RREP, i] * np.random.standard_normal()
        for i in range(3):
            u_shift = a_nom_inv[i, 0] * shift[0] + a_nom_inv[i, 1] * shift[1] + a_nom_inv[i, 2] * shift[2]
            ctrl[C_OFF + i] -= u_shift * tr[i] * counts_per_rad
    ctrl[C_READY] = 0.0
    for j in range(7):
        ctrl[C_INT + j] = 0.0
