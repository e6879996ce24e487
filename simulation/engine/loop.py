"""The compiled 1 kHz servo loop of the virtual RAVEN-II.

One call of :func:`servo_loop` advances one arm by a number of servo ticks. Each tick runs, in
the order of ``rt_raven.cpp``, the sensors (:mod:`~simulation.engine.sensors`: encoder read-out),
the controller (:mod:`~simulation.engine.controller`: forward cable coupling, PD control on motor
positions, gravity compensation, DAC clipping, homing), then the motors and the cable
transmission to the links (:mod:`~simulation.engine.plant`), built from the effects of
:mod:`simulation.model.effects` whose parameters arrive packed in the tables of
:mod:`~simulation.engine.tables`. The plant is integrated with semi-implicit Euler sub-steps
inside each tick. The loop records the robot state at the log ticks and the ground truth at the
truth ticks it is given, so hours of 1 kHz simulation never keep 1 kHz internals; the columns of
its float and integer logs are the ``LOG_*`` and ``ILOG_*`` constants below.

Positioning joints: a two-mass model per joint. Motor coordinates ``u = motor angle /
transmission ratio`` (joint units) drive the cable-side positions ``p = A u`` (``A``: the true cable
coupling); the cable stretch ``s = play(p) - creep - q`` carries the tension ``T(s)`` to the links,
whose dynamics ``M(q) q'' = T - g(q) - friction(q')`` use the kinematics layer's closed-form
inertia and gravity; the motors feel ``A^T T``. With ``cable_stretch`` off the cable is rigid and
the links ride on the motors. Tool joints: motors with rigid coupling (including the z_ins motor
term of ``fwd_cable_coupling.cpp``) and a quasi-static cable compliance.

The parameter tables and the layout of the plant and controller state vectors
(:func:`build_tables`, :class:`EngineTables`, ``N_PLANT``, ``X_*``, ``N_CTRL``, ``C_*``,
``MODE_*``) are defined in :mod:`~simulation.engine.tables` and importable from here too, with
the loop they are made for.

The per-tick functions of the sensors, controller and plant are inlined into :func:`servo_loop`
(numba ``inline="always"``), which is compiled with numpy's error model (no exception paths
for divisions): the loop then compiles to one function that hands them its arrays without
reference counting on each tick. Numba caches each compiled function on its own, and a cached caller
is not recompiled when only a function it calls or inlines (here or in
:mod:`simulation.model.laws`) changes: :mod:`simulation.numba_cache` clears the cached kernels
whenever any kernel source changes, when :mod:`simulation` is imported.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simulation.engine.controller import (
    desired_motion, detect_hard_stops, forward_coupling, register_encoders, servo_control,
)
from simulation.engine.plant import (
    MASS_UPDATE_TICKS, begin_motor_loss, cable_fatigue, cable_inputs, delivered_torque, elastic_cable_step,
    end_motor_loss, gravity_load, refresh_inertia, rigid_cable_step, tool_positions, tool_step,
)
from simulation.engine.sensors import read_joint_encoders, read_motor_encoders
from simulation.engine.tables import (
    C_OFF, C_SEQ, E_STRETCH, MODE_HOMING, MODE_TRAJECTORY, R_TR, S_CPR, S_DT, S_NSUB, S_PAYLOAD, S_TIMESCALE,
    S_TOOLGB, S_TOOLSIGN, X_DOSE, X_Q, X_QT, X_Z,
)

__all__ = [
    "servo_loop",
    "LOG_MPOS", "LOG_MVEL", "LOG_JPOS", "LOG_JVEL", "LOG_MPOSD", "LOG_JPOSD", "LOG_TAU", "LOG_ENCOFF",
    "LOG_Q", "LOG_QT", "LOG_TENSION", "LOG_STRETCH", "LOG_Z", "LOG_DOSE", "LOG_TAUAPPLIED",
    "LOG_GRAVITY", "N_LOG", "ILOG_ENC", "ILOG_DAC", "ILOG_SEQ", "N_ILOG",
]

# Logged channels (columns of the float log).
LOG_MPOS, LOG_MVEL, LOG_JPOS, LOG_JVEL, LOG_MPOSD, LOG_JPOSD, LOG_TAU = 0, 7, 14, 21, 28, 35, 42
LOG_ENCOFF = 49
LOG_Q = 56         # 3 true link positions
LOG_QT = 59        # 4 true tool joint positions
LOG_TENSION = 63   # 3 cable tensions (joint units)
LOG_STRETCH = 66   # 3 cable stretches
LOG_Z = 69         # 3 hysteresis states
LOG_DOSE = 72      # 3 fatigue doses
LOG_TAUAPPLIED = 75  # 7 applied torques (gearbox output; past the motor friction with it on)
LOG_GRAVITY = 82   # 3 gravity holding torques of the plant
N_LOG = 85
# Integer log columns.
ILOG_ENC, ILOG_DAC = 0, 7
ILOG_SEQ = 14
N_ILOG = 15


@njit(cache=True, inline="always")
def _log_state(log_f, log_i, log_runlevel, row, mode, plant, ctrl, mpos, mvel, jpos, jvel, mpos_d, qd_des,
               tau_d, tau_applied, enc, dac, tension, stretch, grav):
    """Write the robot state as the controller sees it, and the plant's internals, to log ``row``."""
    for j in range(7):
        log_f[row, LOG_MPOS + j] = mpos[j]
        log_f[row, LOG_MVEL + j] = mvel[j]
        log_f[row, LOG_JPOS + j] = jpos[j]
        log_f[row, LOG_JVEL + j] = jvel[j]
        log_f[row, LOG_MPOSD + j] = mpos_d[j]
        log_f[row, LOG_JPOSD + j] = qd_des[j]
        log_f[row, LOG_TAU + j] = tau_d[j]
        log_f[row, LOG_ENCOFF + j] = ctrl[C_OFF + j]
        log_f[row, LOG_TAUAPPLIED + j] = tau_applied[j]
        log_i[row, ILOG_ENC + j] = np.int64(np.floor(enc[j]))
        log_i[row, ILOG_DAC + j] = np.int64(dac[j])
    log_i[row, ILOG_SEQ] = np.int64(ctrl[C_SEQ])
    for i in range(3):
        log_f[row, LOG_Q + i] = plant[X_Q + i]
        log_f[row, LOG_TENSION + i] = tension[i]
        log_f[row, LOG_STRETCH + i] = stretch[i]
        log_f[row, LOG_Z + i] = plant[X_Z + i]
        log_f[row, LOG_DOSE + i] = plant[X_DOSE + i]
        log_f[row, LOG_GRAVITY + i] = grav[i]
    for j in range(4):
        log_f[row, LOG_QT + j] = plant[X_QT + j]
    log_runlevel[row] = mode


@njit(cache=True, error_model="numpy")
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

    Notes
    -----
    With numpy's error model a division by zero gives inf or nan rather than an exception:
    :func:`build_tables` rejects the parameters that would cause one. The random draws (current
    noise, ground-truth noise, homing repeatability) come from numba's random state, seeded here
    with ``seed`` and drawn in the order of the calls below.
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

    # signals and scratch of this call (the tension, stretch and gravity logged at its first tick,
    # before the plant has run, are zero)
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

        # ---- sensors and controller: encoders, coupling, desired motion, PD, homing ----------
        read_motor_encoders(plant, ctrl, flags, tr, counts_per_rad, dt, enc, mpos, mvel)
        forward_coupling(mpos, mvel, tr, a_nom, gb, tsign, tmp3, tool_nom, jpos, jvel)
        desired_motion(mode, ctrl, table, traj_q, traj_qd, traj_rate, t, traj_t0, jpos, qd_des, vd_des)
        servo_control(mode, ctrl, table, flags, tr, a_nom_inv, gb, tsign, dt, grav_ctrl, qd_des, vd_des,
                      mpos, mvel, jpos, tmp3, q3, gctrl, mpos_d, mvel_d, tau_d, dac, tau_applied, tau_u)
        delivered_torque(plant, table, flags, tr, tau_applied)
        registered = False
        if mode == MODE_HOMING:
            registered = detect_hard_stops(ctrl, table, scalars, dac, jpos)

        # ---- log the robot state as the controller sees it ---------------------------------
        if log_row < log_ticks.shape[0] and log_ticks[log_row] == tick:
            _log_state(log_f, log_i, log_runlevel, log_row, mode, plant, ctrl, mpos, mvel, jpos, jvel, mpos_d,
                       qd_des, tau_d, tau_applied, enc, dac, tension, stretch, grav)
            log_row += 1
        if mode == MODE_TRAJECTORY and tick % 2 == 0:
            ctrl[C_SEQ] += 1.0

        # ---- ground truth: external joint encoders, read at the same instant ----------------
        if truth_row < truth_ticks.shape[0] and truth_ticks[truth_row] == tick:
            read_joint_encoders(plant, table, flags, truth_out, truth_row)
            truth_row += 1

        if registered:
            register_encoders(table, flags, a_nom_inv, plant, ctrl, enc, counts_per_rad)
            done = k + 1
            return done, log_row, truth_row

        # ---- plant: gravity and inertia at this tick, then the sub-steps --------------------
        gravity_load(plant, table, flags, grav_plant, q3, grav)
        if k % MASS_UPDATE_TICKS == 0:
            # the inertia changes with the slow elbow and insertion angles only: refresh every few ticks
            refresh_inertia(q3, grav_plant, mass, inv_mass, unit, column)
        begin_motor_loss(plant, flags)
        for _ in range(nsub):
            cable_inputs(plant, table, flags, a_true, tr, p, pdot, pbdot, creep, stiff, fric, fc, fv, tension)
            if stretch_on:
                elastic_cable_step(plant, table, flags, a_true, tr, h, tau_u, grav, mass, inv_mass, pbdot, creep,
                                   stiff, fc, fv, fric, tension, stretch, rhs, acc, v_free, visc, tmp3, dry)
            else:
                rigid_cable_step(plant, table, flags, a_true, tr, h, tau_u, grav, mass, fric, creep, tension,
                                 stretch, meff, rhs, tmp3, acc)
            cable_fatigue(plant, table, flags, h, payload, time_scale)
            tool_step(plant, table, flags, tr, h, gb, tsign, tau_u, tool_load)
        end_motor_loss(plant, flags, nsub)
        tool_positions(plant, table, tr, gb, tsign, stretch_on, tool_load, mtrue, tool_nom)

        done = k + 1
    return done, log_row, truth_row
