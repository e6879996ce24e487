"""The compiled 1 kHz servo loop of the virtual RAVEN-II.

One call of :func:`servo_loop` advances one arm by a number of servo ticks: the controller of
``rt_raven.cpp`` (encoder read-out, forward cable coupling, PD control on motor positions,
gravity compensation, DAC clipping), the motors, and the cable transmission to the links, built
from the effects of :mod:`simulation.model.effects` whose parameters arrive packed in the table built by
:func:`build_tables`. The plant is integrated with semi-implicit Euler sub-steps inside each tick.
The loop records the robot state at the log ticks and the ground truth at the truth ticks it is
given, so hours of 1 kHz simulation never keep 1 kHz internals.

Positioning joints: a two-mass model per joint. Motor coordinates ``u = motor angle /
transmission ratio`` (joint units) drive the cable-side positions ``p = A u`` (``A``: the true cable
coupling); the cable stretch ``s = play(p) - creep - q`` carries the tension ``T(s)`` to the links,
whose dynamics ``M(q) q'' = T - g(q) - friction(q')`` use the kinematics layer's closed-form
inertia and gravity; the motors feel ``A^T T``. With ``cable_stretch`` off the cable is rigid and
the links ride on the motors. Tool joints: motors with rigid coupling (including the z_ins motor
term of ``fwd_cable_coupling.cpp``) and a quasi-static cable compliance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from kinematics.gravity_closed_form import gravity_torques_fast, mass_matrix_fast

from simulation.model.laws import bouc_wen_rate, fatigue_rate, friction_force, play, stiffness_tension
from simulation.model.constants import coupling_matrix
from simulation.model.effects import EFFECT_NAMES
from simulation.model.parameters import RavenParameters

# Rows of the per-DOF parameter table (columns: the seven DOFs; positioning-only rows use 0..2).
R_TR, R_GEAR, R_TPA, R_DPA, R_DACMAX, R_KP, R_KD, R_KI, R_JM, R_BM = range(10)
R_HOMEDAC, R_HOMESPEED, R_STOP_LO, R_STOP_HI, R_HOMEPOSE, R_REGPOS = range(10, 16)
R_K1, R_K3, R_DAMP, R_KTOOL, R_GSCALE, R_FC, R_VC, R_FV = range(16, 24)
R_BL, R_HK, R_HB, R_HG = range(24, 28)
R_DK, R_DC, R_DLG, R_DVREF = range(28, 32)
R_HREP, R_TRUTHRES, R_TRUTHNOISE, R_INOISE, R_RUNOUT = range(32, 37)
N_ROWS = 37

# Effect switches.
(E_STRETCH, E_GRAVITY, E_COUPLING, E_COULOMB, E_VISCOUS, E_BACKLASH, E_HYSTERESIS, E_DRIFT,
 E_HOMING, E_QUANT, E_NOISE, E_RUNOUT) = range(12)
assert EFFECT_NAMES == ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction",
                        "backlash", "hysteresis", "drift", "homing_offset", "quantization", "noise",
                        "capstan_runout")

# Scalars.
S_DT, S_NSUB, S_TOOLGB, S_TOOLSIGN, S_CPR, S_TIMESCALE, S_SETTLE, S_PAYLOAD = range(8)
N_SCALARS = 8

# Plant state vector.
X_U = 0          # 7 motor coordinates (joint units)
X_UD = 7         # 7 motor velocities
X_Q = 14         # 3 link positions
X_QD = 17        # 3 link velocities
X_PB = 20        # 3 backlash outputs
X_Z = 23         # 3 Bouc-Wen states
X_DOSE = 26      # 3 fatigue doses (equivalent hours)
X_QT = 29        # 4 tool joint positions
X_SF = 33        # 3 cable stretches smoothed over the hysteresis response time
X_QF = 36        # 3 link positions smoothed the same way (the travel that ages the cables)
N_PLANT = 39

# Controller state vector.
C_PREV = 0       # 7 previous motor positions (rad, motor shaft)
C_INT = 7        # 7 integral errors
C_OFF = 14       # 7 registered encoder offsets (counts)
C_POWERON = 21   # 7 power-on encoder counts
C_HOLD = 28      # 7 held desired joint positions (homing)
C_HOMESTATE = 35  # 3 homing state per positioning joint (0 searching, 1 at hard stop)
C_HOMESTART = 38  # 3 desired joint positions where the search started
C_SETTLE = 41    # ticks spent with every joint at its stop
C_SEQ = 42       # command sequence number
C_READY = 43     # 1 once the motor filters are initialised
N_CTRL = 44

# Logged channels (columns of the float log).
LOG_MPOS, LOG_MVEL, LOG_JPOS, LOG_JVEL, LOG_MPOSD, LOG_JPOSD, LOG_TAU = 0, 7, 14, 21, 28, 35, 42
LOG_ENCOFF = 49
LOG_Q = 56         # 3 true link positions
LOG_QT = 59        # 4 true tool joint positions
LOG_TENSION = 63   # 3 cable tensions (joint units)
LOG_STRETCH = 66   # 3 cable stretches
LOG_Z = 69         # 3 hysteresis states
LOG_DOSE = 72      # 3 fatigue doses
LOG_TAUAPPLIED = 75  # 7 applied torques (gearbox output)
LOG_GRAVITY = 82   # 3 gravity holding torques of the plant
N_LOG = 85
# Integer log columns.
ILOG_ENC, ILOG_DAC = 0, 7
ILOG_SEQ = 14
N_ILOG = 15

MODE_TRAJECTORY = 0
MODE_HOMING = 1

HYSTERESIS_RESPONSE_TIME = 0.05
"""Time constant (s) over which the cable's hysteresis follows its stretch (see ``Hysteresis``) and
its fatigue follows the joint's travel (see ``Drift``)."""

MASS_UPDATE_TICKS = 4
"""Servo ticks between refreshes of the links' inertia matrix (it moves < 0.01 % in 4 ms)."""


@dataclass(frozen=True)
class EngineTables:
    """Everything the compiled loop needs about one arm, packed as arrays.

    Built by :func:`build_tables` from a :class:`~simulation.model.parameters.RavenParameters` and a payload.
    """

    table: np.ndarray          # (N_ROWS, 7)
    flags: np.ndarray          # (12,) int64 effect switches
    scalars: np.ndarray        # (N_SCALARS,)
    coupling_nominal: np.ndarray  # (3, 3) controller's A
    coupling_true: np.ndarray     # (3, 3) the arm's A
    gravity_plant: np.ndarray     # gravity/inertia coefficients with payload
    gravity_controller: np.ndarray  # coefficients the controller's gravity compensation uses


def build_tables(params: RavenParameters, robot, payload_kg: float = 0.0, substeps: int = 4) -> EngineTables:
    """Pack a parameter set and a payload into the arrays of the compiled loop.

    Parameters
    ----------
    params : the arm's constants and effects.
    robot : the :class:`kinematics.RavenII` of the same arm (gravity and inertia coefficients).
    payload_kg : mass hanging at the tool tip (kg).
    substeps : plant integration steps per 1 ms servo tick.
    """
    c = params.constants
    t = np.zeros((N_ROWS, 7))
    t[R_TR] = c.transmission_ratio
    t[R_GEAR] = c.gearbox
    t[R_TPA] = c.torque_per_amp
    t[R_DPA] = c.dac_per_amp
    t[R_DACMAX] = c.dac_max
    t[R_KP] = c.kp
    t[R_KD] = c.kd
    t[R_KI] = c.ki
    t[R_JM] = c.motor_inertia
    t[R_BM] = c.motor_damping
    t[R_HOMEDAC] = c.homing_dac
    t[R_HOMESPEED, :3] = c.homing_speed
    lo = np.array([c.hard_stop[0], np.deg2rad(40.0), 0.22])
    hi = np.array([np.deg2rad(95.0), c.hard_stop[1], c.hard_stop[2]])
    t[R_STOP_LO, :3] = lo
    t[R_STOP_HI, :3] = hi
    t[R_HOMEPOSE] = c.home_pose
    t[R_REGPOS, :3] = c.hard_stop

    stretch = params.effect("cable_stretch")
    t[R_K1, :3] = stretch.stiffness
    t[R_K3, :3] = stretch.hardening
    t[R_DAMP, :3] = stretch.damping
    t[R_KTOOL, 3:] = c.tool_cable_stiffness
    t[R_GSCALE, :3] = params.effect("gravity_stretch").load_scale
    coulomb = params.effect("coulomb_friction")
    t[R_FC, :3] = coulomb.force
    t[R_FC, 3:] = c.tool_friction
    t[R_VC, :3] = coulomb.velocity_scale
    t[R_VC, 3:] = 0.05
    viscous = params.effect("viscous_friction")
    t[R_FV, :3] = viscous.coefficient
    t[R_FV, 3:] = c.tool_viscous
    t[R_BL, :3] = params.effect("backlash").half_width
    hyst = params.effect("hysteresis")
    t[R_HK, :3] = hyst.stiffness
    t[R_HB, :3] = hyst.beta
    t[R_HG, :3] = hyst.gamma
    drift = params.effect("drift")
    t[R_DK, :3] = drift.stiffness_loss
    t[R_DC, :3] = drift.creep_rate
    t[R_DLG, :3] = drift.payload_gain
    t[R_DVREF, :3] = drift.reference_speed
    homing = params.effect("homing_offset")
    t[R_HREP, :3] = homing.repeatability
    t[R_HREP, 3:] = homing.tool_repeatability
    quant = params.effect("quantization")
    t[R_TRUTHRES, :3] = quant.truth_resolution
    noise = params.effect("noise")
    t[R_TRUTHNOISE, :3] = noise.truth_noise
    t[R_INOISE] = noise.current_noise
    t[R_RUNOUT, :3] = params.effect("capstan_runout").amplitude

    flags = np.array([1 if params.is_enabled(n) else 0 for n in EFFECT_NAMES], dtype=np.int64)
    scalars = np.zeros(N_SCALARS)
    scalars[S_DT] = c.servo_period
    scalars[S_NSUB] = substeps
    scalars[S_TOOLGB] = c.tool_gb_ratio
    scalars[S_TOOLSIGN] = c.tool_sign
    scalars[S_CPR] = quant.motor_counts_per_rev if quant.enabled else c.encoder_counts_per_rev
    scalars[S_TIMESCALE] = drift.time_scale
    scalars[S_SETTLE] = round(c.settle_time / c.servo_period)
    scalars[S_PAYLOAD] = payload_kg

    nominal = c.nominal_coupling()
    coupling = params.effect("coupling")
    delta = coupling.delta if coupling.enabled else np.zeros(3)
    true = coupling_matrix(*(np.asarray(c.cable_coupling) + delta))
    return EngineTables(
        table=t,
        flags=flags,
        scalars=scalars,
        coupling_nominal=nominal,
        coupling_true=true,
        gravity_plant=robot.gravity_coefficients(payload_kg),
        gravity_controller=robot.gravity_coefficients(0.0),
    )


@njit(cache=True)
def _hermite(traj_q, traj_qd, rate, t, out_q, out_qd):
    """Cubic Hermite interpolation of a uniformly sampled trajectory at time ``t`` (s)."""
    n = traj_q.shape[0]
    x = t * rate
    i = int(np.floor(x))
    if i >= n - 1:
        out_q[:] = traj_q[n - 1]
        out_qd[:] = traj_qd[n - 1]
        return
    if i < 0:
        out_q[:] = traj_q[0]
        out_qd[:] = traj_qd[0]
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
def _solve3(a, b, out):
    """Solve the 3x3 system ``a x = b`` by Cramer's rule (a is well conditioned here)."""
    det = (a[0, 0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1])
           - a[0, 1] * (a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0])
           + a[0, 2] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]))
    inv = 1.0 / det
    out[0] = inv * (b[0] * (a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1])
                    - a[0, 1] * (b[1] * a[2, 2] - a[1, 2] * b[2])
                    + a[0, 2] * (b[1] * a[2, 1] - a[1, 1] * b[2]))
    out[1] = inv * (a[0, 0] * (b[1] * a[2, 2] - a[1, 2] * b[2])
                    - b[0] * (a[1, 0] * a[2, 2] - a[1, 2] * a[2, 0])
                    + a[0, 2] * (a[1, 0] * b[2] - b[1] * a[2, 0]))
    out[2] = inv * (a[0, 0] * (a[1, 1] * b[2] - b[1] * a[2, 1])
                    - a[0, 1] * (a[1, 0] * b[2] - b[1] * a[2, 0])
                    + b[0] * (a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]))


@njit(cache=True)
def _tool_joints_from_motors(mpos, tr, gb, sign, out):
    """Tool joint positions from motor angles (``fwd_cable_coupling.cpp``, RAVEN tool)."""
    m_ins = mpos[2]
    out[0] = (mpos[3] - sign * m_ins / gb) / tr[3]
    out[1] = (mpos[4] - sign * m_ins / gb) / tr[4]
    out[2] = (mpos[5] + sign * m_ins / gb) / tr[5]
    out[3] = (mpos[6] - sign * m_ins / gb) / tr[6]


@njit(cache=True)
def servo_loop(mode, start_tick, n_ticks, traj_q, traj_qd, traj_rate, traj_t0,
               table, flags, scalars, a_nom, a_true, grav_plant, grav_ctrl,
               plant, ctrl, seed,
               log_ticks, log_f, log_i, log_runlevel, truth_ticks, truth_out):
    """Advance one arm by up to ``n_ticks`` servo ticks.

    Parameters
    ----------
    mode : MODE_TRAJECTORY (follow ``traj_q``) or MODE_HOMING (search the hard stops and register
        the encoders; returns early once registered).
    start_tick : global tick index of the first tick (time = tick * dt).
    traj_q, traj_qd : (N, 7) desired DOF positions and velocities sampled at ``traj_rate`` Hz from
        global time ``traj_t0``.
    plant, ctrl : state vectors, updated in place.
    log_ticks, truth_ticks : sorted global ticks at which to record (state after the controller of
        that tick); outputs are written to ``log_f``/``log_i``/``log_runlevel`` and ``truth_out``
        at the matching rows.

    Returns
    -------
    (ticks done, log rows written, truth rows written)
    """
    np.random.seed(seed)
    dt = scalars[S_DT]
    nsub = int(scalars[S_NSUB])
    h = dt / nsub
    gb = scalars[S_TOOLGB]
    tsign = scalars[S_TOOLSIGN]
    cpr = scalars[S_CPR]
    time_scale = scalars[S_TIMESCALE]
    payload = scalars[S_PAYLOAD]
    counts_per_rad = cpr / (2.0 * np.pi)
    tr = table[R_TR]
    stretch_on = flags[E_STRETCH] == 1

    qd_des = np.zeros(7)
    vd_des = np.zeros(7)
    mpos = np.zeros(7)
    mvel = np.zeros(7)
    jpos = np.zeros(7)
    jvel = np.zeros(7)
    mpos_d = np.zeros(7)
    mvel_d = np.zeros(7)
    tau_d = np.zeros(7)
    tau_u = np.zeros(7)
    tau_applied = np.zeros(7)
    dac = np.zeros(7)
    enc = np.zeros(7)
    tmp3 = np.zeros(3)
    rhs = np.zeros(3)
    acc = np.zeros(3)
    tension = np.zeros(3)
    stretch = np.zeros(3)
    p = np.zeros(3)
    pdot = np.zeros(3)
    pbdot = np.zeros(3)
    creep = np.zeros(3)
    stiff = np.ones(3)
    fric = np.zeros(3)
    grav = np.zeros(3)
    q3 = np.zeros(3)
    meff = np.zeros((3, 3))
    tool_nom = np.zeros(4)
    tool_load = np.zeros(4)
    mtrue = np.zeros(7)
    gctrl = np.zeros(3)
    fc = np.zeros(3)
    fv = np.zeros(3)
    unit = np.zeros(3)
    column = np.zeros(3)
    inv_mass = np.eye(3)
    mass = np.eye(3)
    v_free = np.zeros(3)
    visc = np.zeros((3, 3))
    dry = np.zeros(3)
    a_nom_inv = np.linalg.inv(a_nom)

    log_row = 0
    while log_row < log_ticks.shape[0] and log_ticks[log_row] < start_tick:
        log_row += 1
    truth_row = 0
    while truth_row < truth_ticks.shape[0] and truth_ticks[truth_row] < start_tick:
        truth_row += 1

    done = 0
    for k in range(n_ticks):
        tick = start_tick + k
        t = tick * dt

        # ---- sensors: motor encoders -------------------------------------------------------
        for j in range(7):
            m_true = plant[X_U + j] * tr[j]
            if flags[E_QUANT] == 1:
                enc[j] = np.floor(m_true * counts_per_rad) + ctrl[C_POWERON + j]
            else:
                enc[j] = m_true * counts_per_rad + ctrl[C_POWERON + j]
            mpos[j] = (enc[j] - ctrl[C_OFF + j]) / counts_per_rad
        if ctrl[C_READY] == 0.0:
            for j in range(7):
                ctrl[C_PREV + j] = mpos[j]
            ctrl[C_READY] = 1.0
        for j in range(7):
            mvel[j] = (mpos[j] - ctrl[C_PREV + j]) / dt
            ctrl[C_PREV + j] = mpos[j]

        # ---- forward cable coupling (controller's view) ------------------------------------
        for i in range(3):
            tmp3[i] = mpos[i] / tr[i]
        for i in range(3):
            jpos[i] = a_nom[i, 0] * tmp3[0] + a_nom[i, 1] * tmp3[1] + a_nom[i, 2] * tmp3[2]
        _tool_joints_from_motors(mpos, tr, gb, tsign, tool_nom)
        for j in range(4):
            jpos[3 + j] = tool_nom[j]
        for j in range(7):
            jvel[j] = mvel[j] / tr[j]

        # ---- desired motion ----------------------------------------------------------------
        if mode == MODE_TRAJECTORY:
            _hermite(traj_q, traj_qd, traj_rate, t - traj_t0, qd_des, vd_des)
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

        # ---- inverse cable coupling and PD control (pid_control.cpp) -----------------------
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
            gctrl[:] = gravity_torques_fast(q3, grav_ctrl)
        for j in range(7):
            err = mpos_d[j] - mpos[j]
            ctrl[C_INT + j] += err * dt
            tau_d[j] = table[R_KP, j] * err + table[R_KD, j] * (mvel_d[j] - mvel[j]) + table[R_KI, j] * ctrl[C_INT + j]
            if mode == MODE_TRAJECTORY and j < 3:
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

        # ---- homing: hard-stop detection and registration (homing.cpp) --------------------
        registered = False
        if mode == MODE_HOMING:
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

        # ---- log the robot state as the controller sees it ---------------------------------
        if log_row < log_ticks.shape[0] and log_ticks[log_row] == tick:
            for j in range(7):
                log_f[log_row, LOG_MPOS + j] = mpos[j]
                log_f[log_row, LOG_MVEL + j] = mvel[j]
                log_f[log_row, LOG_JPOS + j] = jpos[j]
                log_f[log_row, LOG_JVEL + j] = jvel[j]
                log_f[log_row, LOG_MPOSD + j] = mpos_d[j]
                log_f[log_row, LOG_JPOSD + j] = qd_des[j]
                log_f[log_row, LOG_TAU + j] = tau_d[j]
                log_f[log_row, LOG_ENCOFF + j] = ctrl[C_OFF + j]
                log_f[log_row, LOG_TAUAPPLIED + j] = tau_applied[j]
                log_i[log_row, ILOG_ENC + j] = np.int64(np.floor(enc[j]))
                log_i[log_row, ILOG_DAC + j] = np.int64(dac[j])
            log_i[log_row, ILOG_SEQ] = np.int64(ctrl[C_SEQ])
            for i in range(3):
                log_f[log_row, LOG_Q + i] = plant[X_Q + i]
                log_f[log_row, LOG_TENSION + i] = tension[i]
                log_f[log_row, LOG_STRETCH + i] = stretch[i]
                log_f[log_row, LOG_Z + i] = plant[X_Z + i]
                log_f[log_row, LOG_DOSE + i] = plant[X_DOSE + i]
                log_f[log_row, LOG_GRAVITY + i] = grav[i]
            for j in range(4):
                log_f[log_row, LOG_QT + j] = plant[X_QT + j]
            log_runlevel[log_row] = mode
            log_row += 1
        if mode == MODE_TRAJECTORY and tick % 2 == 0:
            ctrl[C_SEQ] += 1.0

        # ---- ground truth: external joint encoders, read at the same instant ----------------
        if truth_row < truth_ticks.shape[0] and truth_ticks[truth_row] == tick:
            for i in range(3):
                value = plant[X_Q + i]
                if flags[E_NOISE] == 1:
                    value += table[R_TRUTHNOISE, i] * np.random.standard_normal()
                if flags[E_QUANT] == 1:
                    res = table[R_TRUTHRES, i]
                    value = np.round(value / res) * res
                truth_out[truth_row, i] = value
            truth_row += 1

        if registered:
            _register(table, flags, a_nom_inv, plant, ctrl, enc, counts_per_rad)
            done = k + 1
            return done, log_row, truth_row

        # ---- plant: gravity and inertia at this tick ---------------------------------------
        for i in range(3):
            q3[i] = plant[X_Q + i]
        if flags[E_GRAVITY] == 1:
            g = gravity_torques_fast(q3, grav_plant)
            for i in range(3):
                grav[i] = table[R_GSCALE, i] * g[i]
        else:
            for i in range(3):
                grav[i] = 0.0
        if k % MASS_UPDATE_TICKS == 0:
            # the inertia changes with the slow elbow and insertion angles only: refresh every few ticks
            mass[:, :] = mass_matrix_fast(q3, grav_plant)
            for i in range(3):
                unit[:] = 0.0
                unit[i] = 1.0
                _solve3(mass, unit, column)
                for a in range(3):
                    inv_mass[a, i] = column[a]

        for sub in range(nsub):
            # cable-side positions of the positioning joints
            for i in range(3):
                p[i] = a_true[i, 0] * plant[X_U + 0] + a_true[i, 1] * plant[X_U + 1] + a_true[i, 2] * plant[X_U + 2]
                pdot[i] = a_true[i, 0] * plant[X_UD + 0] + a_true[i, 1] * plant[X_UD + 1] + a_true[i, 2] * plant[X_UD + 2]
                if flags[E_RUNOUT] == 1:
                    angle = plant[X_U + i] * tr[i] / table[R_GEAR, i]
                    p[i] += table[R_RUNOUT, i] * np.sin(angle)
                    pdot[i] += table[R_RUNOUT, i] * np.cos(angle) * plant[X_UD + i] * tr[i] / table[R_GEAR, i]
                if flags[E_BACKLASH] == 1:
                    before = plant[X_PB + i]
                    plant[X_PB + i] = play(p[i], before, table[R_BL, i])
                    pbdot[i] = pdot[i] if plant[X_PB + i] != before else 0.0
                else:
                    plant[X_PB + i] = p[i]
                    pbdot[i] = pdot[i]
                if flags[E_DRIFT] == 1:
                    creep[i] = table[R_DC, i] * plant[X_DOSE + i]
                    stiff[i] = 1.0 / (1.0 + table[R_DK, i] * plant[X_DOSE + i])
                fric[i] = 0.0
                if flags[E_COULOMB] == 1:
                    fric[i] += friction_force(plant[X_QD + i], table[R_FC, i], table[R_VC, i], 0.0)
                if flags[E_VISCOUS] == 1:
                    fric[i] += table[R_FV, i] * plant[X_QD + i]
                fc[i] = table[R_FC, i] if flags[E_COULOMB] == 1 else 0.0
                fv[i] = table[R_FV, i] if flags[E_VISCOUS] == 1 else 0.0

            if stretch_on:
                for i in range(3):
                    stretch[i] = plant[X_PB + i] - creep[i] - plant[X_Q + i]
                    srate = pbdot[i] - plant[X_QD + i]
                    tension[i] = stiff[i] * stiffness_tension(stretch[i], table[R_K1, i], table[R_K3, i]) \
                        + table[R_DAMP, i] * srate
                    if flags[E_HYSTERESIS] == 1:
                        tension[i] += table[R_HK, i] * plant[X_Z + i]
                        smoothed = plant[X_SF + i] + h / HYSTERESIS_RESPONSE_TIME * (stretch[i] - plant[X_SF + i])
                        mean_rate = (smoothed - plant[X_SF + i]) / h
                        plant[X_SF + i] = smoothed
                        plant[X_Z + i] += h * bouc_wen_rate(plant[X_Z + i], mean_rate, table[R_HB, i], table[R_HG, i])
                for i in range(3):
                    rhs[i] = tension[i] - grav[i]
                _solve3(mass, rhs, acc)
                for i in range(3):
                    v_free[i] = plant[X_QD + i] + h * acc[i]
                # friction, implicit and consistent with the coupled inertia (W = M^-1):
                # viscous solved for the new velocity, (I + h W Fv) v = v_free ...
                for a in range(3):
                    for b in range(3):
                        visc[a, b] = h * inv_mass[a, b] * fv[b]
                    visc[a, a] += 1.0
                _solve3(visc, v_free, tmp3)
                # ... then dry friction as a box-constrained impulse (projected Gauss-Seidel): a joint
                # sticks while the force that stops it is within its friction force
                for i in range(3):
                    v_free[i] = tmp3[i]
                    dry[i] = 0.0
                for _ in range(4):
                    for i in range(3):
                        v_i = v_free[i] - h * (inv_mass[i, 0] * dry[0] + inv_mass[i, 1] * dry[1] + inv_mass[i, 2] * dry[2])
                        f_i = dry[i] + v_i / (h * inv_mass[i, i])
                        dry[i] = min(max(f_i, -fc[i]), fc[i])
                for i in range(3):
                    velocity = v_free[i] - h * (inv_mass[i, 0] * dry[0] + inv_mass[i, 1] * dry[1] + inv_mass[i, 2] * dry[2])
                    if fc[i] > 0.0 and abs(dry[i]) < fc[i]:
                        velocity = 0.0
                    fric[i] = dry[i] + fv[i] * velocity
                    plant[X_QD + i] = velocity
                    plant[X_Q + i] += h * velocity
                for i in range(3):
                    load = a_true[0, i] * tension[0] + a_true[1, i] * tension[1] + a_true[2, i] * tension[2]
                    ud_acc = (tau_u[i] - load - table[R_BM, i] * tr[i] * tr[i] * plant[X_UD + i]) \
                        / (table[R_JM, i] * tr[i] * tr[i])
                    plant[X_UD + i] += h * ud_acc
                    plant[X_U + i] += h * plant[X_UD + i]
                for i in range(3):
                    if plant[X_Q + i] < table[R_STOP_LO, i]:
                        plant[X_Q + i] = table[R_STOP_LO, i]
                        if plant[X_QD + i] < 0.0:
                            plant[X_QD + i] = 0.0
                    elif plant[X_Q + i] > table[R_STOP_HI, i]:
                        plant[X_Q + i] = table[R_STOP_HI, i]
                        if plant[X_QD + i] > 0.0:
                            plant[X_QD + i] = 0.0
            else:
                # rigid cable: links ride on the motors, (J + A^T M A) u'' = tau - A^T (g + f)
                for i in range(3):
                    rhs[i] = grav[i] + fric[i]
                for a in range(3):
                    for b in range(3):
                        s_ab = 0.0
                        for c in range(3):
                            for d in range(3):
                                s_ab += a_true[c, a] * mass[c, d] * a_true[d, b]
                        meff[a, b] = s_ab
                    meff[a, a] += table[R_JM, a] * tr[a] * tr[a]
                for i in range(3):
                    tmp3[i] = tau_u[i] - (a_true[0, i] * rhs[0] + a_true[1, i] * rhs[1] + a_true[2, i] * rhs[2]) \
                        - table[R_BM, i] * tr[i] * tr[i] * plant[X_UD + i]
                _solve3(meff, tmp3, acc)
                for i in range(3):
                    plant[X_UD + i] += h * acc[i]
                    plant[X_U + i] += h * plant[X_UD + i]
                for i in range(3):
                    # positions follow the motors through the coupling (and the play, and creep)
                    pos = a_true[i, 0] * plant[X_U + 0] + a_true[i, 1] * plant[X_U + 1] + a_true[i, 2] * plant[X_U + 2]
                    if flags[E_RUNOUT] == 1:
                        pos += table[R_RUNOUT, i] * np.sin(plant[X_U + i] * tr[i] / table[R_GEAR, i])
                    if flags[E_BACKLASH] == 1:
                        pos = play(pos, plant[X_PB + i], table[R_BL, i])
                    plant[X_PB + i] = pos
                    target = pos - creep[i]
                    velocity = (target - plant[X_Q + i]) / h
                    if target < table[R_STOP_LO, i] or target > table[R_STOP_HI, i]:
                        stop = table[R_STOP_LO, i] if target < table[R_STOP_LO, i] else table[R_STOP_HI, i]
                        # project the motor so the rigid link sits on the stop
                        plant[X_U + i] += stop - target
                        plant[X_PB + i] += stop - target
                        coupled = 0.0
                        for jj in range(i):
                            coupled += a_true[i, jj] * plant[X_UD + jj]
                        plant[X_UD + i] = -coupled
                        target = stop
                        velocity = 0.0
                    plant[X_Q + i] = target
                    plant[X_QD + i] = velocity
                    stretch[i] = 0.0
                for i in range(3):
                    rhs[i] = a_true[i, 0] * acc[0] + a_true[i, 1] * acc[1] + a_true[i, 2] * acc[2]
                for i in range(3):
                    tension[i] = grav[i] + fric[i] + mass[i, 0] * rhs[0] + mass[i, 1] * rhs[1] + mass[i, 2] * rhs[2]

            if flags[E_DRIFT] == 1:
                for i in range(3):
                    # the cable ages with the joint's travel, not with the servo's millisecond chatter
                    smoothed = plant[X_QF + i] + h / HYSTERESIS_RESPONSE_TIME * (plant[X_Q + i] - plant[X_QF + i])
                    travel_rate = (smoothed - plant[X_QF + i]) / h
                    plant[X_QF + i] = smoothed
                    plant[X_DOSE + i] += h * fatigue_rate(travel_rate, table[R_DVREF, i], table[R_DLG, i],
                                                          payload, time_scale)

            # tool DOFs: motors with rigid coupling and a quasi-static cable compliance
            for j in range(3, 7):
                z_sign = -tsign if j == 5 else tsign
                tool_rate = plant[X_UD + j] - z_sign * plant[X_UD + 2] * tr[2] / (gb * tr[j])
                inertia = table[R_JM, j] * tr[j] * tr[j]
                free = plant[X_UD + j] + h * (tau_u[j] - table[R_BM, j] * tr[j] * tr[j] * plant[X_UD + j]) / inertia
                # the instrument's own friction on the tool joint (always on), implicit as for the
                # positioning joints
                coupled = plant[X_UD + j] - tool_rate
                rate = (free - coupled) / (1.0 + h * table[R_FV, j] / inertia)
                impulse = h * table[R_FC, j] / inertia
                if abs(rate) <= impulse:
                    rate = 0.0
                else:
                    rate -= impulse if rate > 0.0 else -impulse
                tool_load[j - 3] = (free - coupled - rate) * inertia / h
                plant[X_UD + j] = rate + coupled
                plant[X_U + j] += h * plant[X_UD + j]

        for jj in range(7):
            mtrue[jj] = plant[X_U + jj] * tr[jj]
        _tool_joints_from_motors(mtrue, tr, gb, tsign, tool_nom)
        for j in range(4):
            compliance = tool_load[j] / table[R_KTOOL, 3 + j] if stretch_on else 0.0
            plant[X_QT + j] = tool_nom[j] - compliance

        done = k + 1
    return done, log_row, truth_row


@njit(cache=True)
def _register(table, flags, a_nom_inv, plant, ctrl, enc, counts_per_rad):
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
    ctrl[C_READY] = 0.0
    for j in range(7):
        ctrl[C_INT + j] = 0.0
