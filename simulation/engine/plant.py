"""The plant of the virtual RAVEN-II: motors, cables and links, integrated over one servo tick.

Positioning joints (shoulder, elbow, insertion): a two-mass model per joint. The motor
coordinates ``u`` (motor angle / transmission ratio, joint units) drive the cable-side positions
``p = A u`` (``A``: the arm's true cable coupling, with capstan runout and backlash); the cable
stretch ``s = play(p) - creep - q`` carries the tension ``T(s)`` (with damping, drift and
hysteresis) to the links, whose dynamics ``M(q) q'' = T - g(q) - friction(q')`` use the
kinematics layer's closed-form inertia and gravity; the motors feel ``A^T T``
(:func:`elastic_cable_step`). With ``cable_stretch`` off the cable is rigid and the links ride on
the motors (:func:`rigid_cable_step`). Tool joints: motors with rigid coupling, including the
insertion motor's term of ``fwd_cable_coupling.cpp``, and a quasi-static cable compliance
(:func:`tool_step`, :func:`tool_positions`).

The cable laws (tension, friction, play, hysteresis and fatigue rates) are those of
:mod:`simulation.model.laws`. The functions here are compiled and called by
:func:`simulation.engine.loop.servo_loop`: :func:`gravity_load` and :func:`refresh_inertia` once per
tick, then per semi-implicit Euler sub-step of ``h`` seconds :func:`cable_inputs`, one of the two
cable steps, :func:`cable_fatigue` and :func:`tool_step`, and :func:`tool_positions` at the end of
the tick. They update the plant state vector in place; the other arrays are outputs or scratch.

The motor-side friction of the ``motor_friction`` effect is applied in the motor updates of the
cable and tool steps (:func:`stick_slip_velocity`, :func:`motor_friction_bound`), summed over the
tick's sub-steps between :func:`begin_motor_loss` and :func:`end_motor_loss`, and taken off the
logged applied torque by :func:`delivered_torque`. With an effect switched off, these functions
leave every operation of the engine as it was without the effect.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from kinematics.gravity_closed_form import gravity_torques_fast, mass_matrix_fast

from simulation.engine.controller import tool_joints_from_motors
from simulation.engine.tables import (
    E_BACKLASH, E_CAPSTAN, E_COULOMB, E_DRIFT, E_GRAVITY, E_HYSTERESIS, E_MOTORFRICTION, E_RUNOUT, E_VISCOUS,
    R_BL, R_BM, R_CAPSTAN, R_DAMP, R_DC, R_DK, R_DLG, R_DVREF, R_FC, R_FV, R_GEAR, R_GSCALE, R_HB, R_HG, R_HK, R_HT,
    R_JM, R_K1, R_K3, R_KTOOL, R_MFC, R_MLOSS, R_RUNOUT, R_STOP_HI, R_STOP_LO, R_TOOL_FC, R_TOOL_FV, R_VC, X_DOSE,
    X_MF, X_PB, X_Q,
    X_QD, X_QF, X_QT, X_SF, X_U, X_UD, X_Z,
)
from simulation.model.laws import bouc_wen_rate, fatigue_rate, friction_force, play, stiffness_tension

FATIGUE_RESPONSE_TIME = 0.05
"""Time constant (s) over which the cable's fatigue follows the joint's travel (see ``Drift``); the
hysteresis follows the stretch over its own ``Hysteresis.response_time``."""

MASS_UPDATE_TICKS = 4
"""Servo ticks between refreshes of the links' inertia matrix (it moves < 0.01 % in 4 ms)."""


@njit(cache=True, inline="always")
def stick_slip_velocity(free_velocity: float, impulse: float) -> float:
    """Velocity after a dry-friction impulse of at most ``impulse`` (velocity units) over one step.

    The implicit (set-valued) Coulomb law on one body: it stops if the friction can stop it within
    the step, otherwise friction takes ``impulse`` off its speed. ``free_velocity`` is the velocity
    the step would reach without the friction.
    """
    if abs(free_velocity) <= impulse:
        return 0.0
    if free_velocity > 0.0:
        return free_velocity - impulse
    return free_velocity + impulse


@njit(cache=True, inline="always")
def motor_friction_bound(table, tr, j, transmitted):
    """Dry-friction bound of motor ``j`` in joint units (``motor_friction`` effect).

    The motor shaft's Coulomb torque through the transmission ratio plus the gearbox loss, a
    friction proportional to the ``transmitted`` torque (joint units).
    """
    return table[R_MFC, j] * tr[j] + table[R_MLOSS, j] * abs(transmitted)


@njit(cache=True, inline="always")
def begin_motor_loss(plant, flags):
    """Clear the motor-side friction accumulated over the last tick (``motor_friction`` on)."""
    if flags[E_MOTORFRICTION] == 1:
        for j in range(7):
            plant[X_MF + j] = 0.0


@njit(cache=True, inline="always")
def end_motor_loss(plant, flags, nsub):
    """Turn the motor-side friction summed over ``nsub`` sub-steps into its mean over the tick."""
    if flags[E_MOTORFRICTION] == 1:
        for j in range(7):
            plant[X_MF + j] /= nsub


@njit(cache=True, inline="always")
def delivered_torque(plant, table, flags, tr, tau_applied):
    """With ``motor_friction`` on, make ``tau_applied`` (7,) the torque delivered past the motor.

    Subtracts the motor-side friction of the last servo tick, converted from joint units to the
    gearbox output (N m): the torque that reaches the capstan, which is what the amplifier's
    command becomes after the motor's and the gearbox's friction. Unchanged with the effect off.
    """
    if flags[E_MOTORFRICTION] == 1:
        for j in range(7):
            tau_applied[j] -= plant[X_MF + j] * table[R_GEAR, j] / tr[j]


@njit(cache=True)
def solve3(a, b, out):
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


@njit(cache=True, inline="always")
def gravity_load(plant, table, flags, grav_plant, q3, grav):
    """Gravity holding torques of the links ``grav`` (3,) at the current link positions.

    ``grav_plant`` are the arm's gravity coefficients with the payload; scaled per joint by the
    ``gravity_stretch`` effect, zero with it off. ``q3`` (3,) receives the link positions.
    """
    for i in range(3):
        q3[i] = plant[X_Q + i]
    if flags[E_GRAVITY] == 1:
        g = gravity_torques_fast(q3, grav_plant)
        for i in range(3):
            grav[i] = table[R_GSCALE, i] * g[i]
    else:
        for i in range(3):
            grav[i] = 0.0


@njit(cache=True, inline="always")
def refresh_inertia(q3, grav_plant, mass, inv_mass, unit, column):
    """The links' inertia matrix ``mass`` (3, 3) at ``q3`` and its inverse ``inv_mass``.

    ``unit``, ``column`` (3,) are scratch.
    """
    m = mass_matrix_fast(q3, grav_plant)
    for i in range(3):
        for j in range(3):
            mass[i, j] = m[i, j]
    for i in range(3):
        unit[:] = 0.0
        unit[i] = 1.0
        solve3(mass, unit, column)
        for a in range(3):
            inv_mass[a, i] = column[a]


@njit(cache=True, inline="always")
def cable_inputs(plant, table, flags, a_true, tr, p, pdot, pbdot, creep, stiff, fric, fc, fv, tension):
    """What drives the cables in this sub-step: cable-side positions, play, creep, friction.

    Outputs (3,): cable-side positions ``p`` and rates ``pdot`` (``A u`` with capstan runout), the
    rate past the backlash ``pbdot`` (the backlash output is stored in the plant state), the
    ``drift`` effect's creep and stiffness factor ``stiff`` (unchanged with it off), the
    link friction ``fric`` at the current link velocities and the Coulomb and viscous
    coefficients ``fc``, ``fv`` in force for the implicit friction solve. With
    ``capstan_friction`` on, the dry-friction bound grows by the capstan coefficient times the
    cable ``tension`` (3,) of the previous sub-step (the loop's scratch, zero on the first
    sub-step of each loop call: one 0.5 ms sub-step per call without it).
    """
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
    if flags[E_CAPSTAN] == 1:
        for i in range(3):
            capstan = table[R_CAPSTAN, i] * abs(tension[i])
            fric[i] += friction_force(plant[X_QD + i], capstan, table[R_VC, i], 0.0)
            fc[i] += capstan


@njit(cache=True, inline="always")
def elastic_cable_step(plant, table, flags, a_true, tr, h, tau_u, grav, mass, inv_mass, pbdot, creep,
                       stiff, fc, fv, fric, tension, stretch, rhs, acc, v_free, visc, tmp3, dry):
    """One sub-step of ``h`` seconds of the two-mass dynamics with elastic cables.

    Cable stretch and tension (with hysteresis), link accelerations under tension and gravity,
    implicit friction consistent with the coupled inertia, the motors under their torques
    ``tau_u`` and the reaction ``A^T T``, the links held at their hard stops. Outputs (3,):
    ``tension``, ``stretch`` and the friction actually applied ``fric``; ``rhs``, ``acc``,
    ``v_free``, ``tmp3``, ``dry`` (3,) and ``visc`` (3, 3) are scratch.
    """
    for i in range(3):
        stretch[i] = plant[X_PB + i] - creep[i] - plant[X_Q + i]
        srate = pbdot[i] - plant[X_QD + i]
        tension[i] = stiff[i] * stiffness_tension(stretch[i], table[R_K1, i], table[R_K3, i]) \
            + table[R_DAMP, i] * srate
        if flags[E_HYSTERESIS] == 1:
            tension[i] += table[R_HK, i] * plant[X_Z + i]
            # a first-order lag of the stretch; a response time under the sub-step follows it at once
            lag = table[R_HT, i]
            smoothed = stretch[i] if lag <= h else plant[X_SF + i] + h / lag * (stretch[i] - plant[X_SF + i])
            mean_rate = (smoothed - plant[X_SF + i]) / h
            plant[X_SF + i] = smoothed
            plant[X_Z + i] += h * bouc_wen_rate(plant[X_Z + i], mean_rate, table[R_HB, i], table[R_HG, i])
    for i in range(3):
        rhs[i] = tension[i] - grav[i]
    solve3(mass, rhs, acc)
    for i in range(3):
        v_free[i] = plant[X_QD + i] + h * acc[i]
    # friction, implicit and consistent with the coupled inertia (W = M^-1):
    # viscous solved for the new velocity, (I + h W Fv) v = v_free ...
    for a in range(3):
        for b in range(3):
            visc[a, b] = h * inv_mass[a, b] * fv[b]
        visc[a, a] += 1.0
    solve3(visc, v_free, tmp3)
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
    if flags[E_MOTORFRICTION] == 1:
        # motor-side dry friction (motor_friction): the motor sticks while the net torque is within
        # its bound; the friction it applied is summed for the tick's delivered torque
        for i in range(3):
            load = a_true[0, i] * tension[0] + a_true[1, i] * tension[1] + a_true[2, i] * tension[2]
            inertia = table[R_JM, i] * tr[i] * tr[i]
            free = plant[X_UD + i] + h * (tau_u[i] - load - table[R_BM, i] * tr[i] * tr[i] * plant[X_UD + i]) / inertia
            velocity = stick_slip_velocity(free, h * motor_friction_bound(table, tr, i, load) / inertia)
            plant[X_MF + i] += (free - velocity) * inertia / h
            plant[X_UD + i] = velocity
            plant[X_U + i] += h * velocity
    else:
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


@njit(cache=True, inline="always")
def rigid_cable_step(plant, table, flags, a_true, tr, h, tau_u, grav, mass, fric, creep, tension, stretch,
                     meff, rhs, tmp3, acc):
    """One sub-step of ``h`` seconds with rigid cables: the links ride on the motors.

    The motors see the links' inertia, gravity and friction through the coupling; the links follow
    the motors (through runout, play and creep) and the motors are projected so that a link
    stays on its hard stop. Outputs (3,): the cable ``tension`` that carries the links and a zero
    ``stretch``; ``meff`` (3, 3) and ``rhs``, ``tmp3``, ``acc`` (3,) are scratch.
    """
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
    solve3(meff, tmp3, acc)
    if flags[E_MOTORFRICTION] == 1:
        # motor-side dry friction, per motor on the diagonal of the coupled inertia; the load it
        # scales with is the tension of the previous sub-step
        for i in range(3):
            load = a_true[0, i] * tension[0] + a_true[1, i] * tension[1] + a_true[2, i] * tension[2]
            free = plant[X_UD + i] + h * acc[i]
            velocity = stick_slip_velocity(free, h * motor_friction_bound(table, tr, i, load) / meff[i, i])
            plant[X_MF + i] += (free - velocity) * meff[i, i] / h
            acc[i] = (velocity - plant[X_UD + i]) / h
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


@njit(cache=True, inline="always")
def cable_fatigue(plant, table, flags, h, payload, time_scale):
    """Grow the cables' fatigue doses over ``h`` seconds with the ``drift`` effect on.

    ``payload`` (kg) speeds the ageing; ``time_scale`` compresses time (see ``Drift``).
    """
    if flags[E_DRIFT] == 1:
        for i in range(3):
            # the cable ages with the joint's travel, not with the servo's millisecond chatter
            smoothed = plant[X_QF + i] + h / FATIGUE_RESPONSE_TIME * (plant[X_Q + i] - plant[X_QF + i])
            travel_rate = (smoothed - plant[X_QF + i]) / h
            plant[X_QF + i] = smoothed
            plant[X_DOSE + i] += h * fatigue_rate(travel_rate, table[R_DVREF, i], table[R_DLG, i],
                                                  payload, time_scale)


@njit(cache=True, inline="always")
def tool_step(plant, table, flags, tr, h, gb, tsign, tau_u, tool_load):
    """One sub-step of ``h`` seconds of the four tool motors, with the instrument's friction.

    Outputs ``tool_load`` (4,): the torque the tool cables carry (joint units), for the
    quasi-static compliance of :func:`tool_positions`. With ``motor_friction`` on, the motors'
    own dry friction (bound by the motor's command as the transmitted torque) acts first, on the
    motor velocity; the cables do not carry it.
    """
    # tool DOFs: motors with rigid coupling and a quasi-static cable compliance
    for j in range(3, 7):
        z_sign = -tsign if j == 5 else tsign
        tool_rate = plant[X_UD + j] - z_sign * plant[X_UD + 2] * tr[2] / (gb * tr[j])
        inertia = table[R_JM, j] * tr[j] * tr[j]
        free = plant[X_UD + j] + h * (tau_u[j] - table[R_BM, j] * tr[j] * tr[j] * plant[X_UD + j]) / inertia
        if flags[E_MOTORFRICTION] == 1:
            slowed = stick_slip_velocity(free, h * motor_friction_bound(table, tr, j, tau_u[j]) / inertia)
            plant[X_MF + j] += (free - slowed) * inertia / h
            free = slowed
        # the instrument's own friction on the tool joint (always on), implicit as for the
        # positioning joints
        coupled = plant[X_UD + j] - tool_rate
        rate = (free - coupled) / (1.0 + h * table[R_TOOL_FV, j] / inertia)
        impulse = h * table[R_TOOL_FC, j] / inertia
        if abs(rate) <= impulse:
            rate = 0.0
        else:
            rate -= impulse if rate > 0.0 else -impulse
        tool_load[j - 3] = (free - coupled - rate) * inertia / h
        plant[X_UD + j] = rate + coupled
        plant[X_U + j] += h * plant[X_UD + j]


@njit(cache=True, inline="always")
def tool_positions(plant, table, tr, gb, tsign, stretch_on, tool_load, mtrue, tool_nom):
    """True tool joint positions: the motors' through the coupling, less the cables' compliance.

    The cables' compliance under ``tool_load`` applies with ``stretch_on`` (the cable_stretch
    effect). ``mtrue`` (7,) and ``tool_nom`` (4,) are scratch.
    """
    for jj in range(7):
        mtrue[jj] = plant[X_U + jj] * tr[jj]
    tool_joints_from_motors(mtrue, tr, gb, tsign, tool_nom)
    for j in range(4):
        compliance = tool_load[j] / table[R_KTOOL, 3 + j] if stretch_on else 0.0
        plant[X_QT + j] = tool_nom[j] - compliance
