"""The plant of the positioning joints driven by logged motor positions: a replay that follows the
links' swing on their cables.

The discrepancy workflow's replay (:mod:`simulation.discrepancy.replay`) is quasi-static: at each
logged sample the link hangs where its cable's tension balances the load, and the links' inertia
enters through an acceleration estimated from the measured joints. The links swing on their cables
at a few hertz (about 3 Hz for the shoulder and the elbow, 15 Hz for the insertion axis on the
virtual RAVEN-II's cables), which a quasi-static replay cannot follow. This replay integrates
``M(q) q'' = T(s) - g(q) - friction(q')`` with the plant functions of the servo loop
(:mod:`~simulation.engine.plant`: the cable tension with its damping, backlash and hysteresis,
gravity, the coupled inertia, implicit viscous and dry friction, the hard stops), the motor
coordinates set at every sub-step to the logged ones, linearly interpolated between samples,
instead of being integrated under the controller's torques. Between two logged samples the motors
therefore move at the rate those two samples give (the next sample is a motor reading, not the
joint the replay predicts). The links start at rest at the given positions, at the first sample
and at every restart (a re-homing).

It scores the blind analysis's final models (:mod:`studies.common.plant_scoring`, the analysis's
last step) and measures the quasi-static replay's floor (``studies/discrepancy_floor.py
--dynamic``); it is not the replay the workflow fits and chooses with: one replay of a
twenty-minute record integrates 2.4 million sub-steps, about a second of CPU, where the
quasi-static replay takes 7 ms to 10 ms (``python benchmarks/bench_plant_replay.py``) and a
candidate's fit replays thousands of times. The motors' own dynamics and friction, and the sensors, are not replayed: the
motor positions are taken as logged, and the replay returns the links' true positions.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simulation.engine.plant import (
    MASS_UPDATE_TICKS, cable_fatigue, cable_inputs, elastic_cable_step, gravity_load, refresh_inertia,
)
from simulation.engine.tables import (
    N_PLANT, R_TR, S_DT, S_NSUB, S_PAYLOAD, S_TIMESCALE, X_PB, X_Q, X_QD, X_SF, X_U, X_UD, X_Z,
)

FOLLOWED_EFFECTS = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction",
                    "transmission_error", "capstan_friction", "backlash", "hysteresis", "drift", "capstan_runout")
"""Effects of a parameter set the plant replay integrates. The others act through the motors
(motor friction, the controller's gravity model), whose positions it takes as logged, or belong to
the sensors and the session (quantization, noise, homing and registration offsets)."""


@njit(cache=True, error_model="numpy")
def plant_link_series(time, drive, start, restart, table, flags, scalars, a_true, grav_plant):
    """(N, 3) link positions of the positioning joints at the logged ``time`` (N,) (s), the plant
    driven by the motor coordinates ``drive`` (N, 3) (joint units), linearly interpolated between
    samples, in sub-steps of ``scalars[S_DT] / scalars[S_NSUB]`` (or a little shorter, to end on each
    sample). ``start`` (N, 3) are the link positions the plant starts from, at rest, where
    ``restart`` (N,) holds; the first sample must be one."""
    n = time.shape[0]
    out = np.empty((n, 3))
    plant = np.zeros(N_PLANT)
    h_nominal = scalars[S_DT] / scalars[S_NSUB]
    substeps = int(scalars[S_NSUB])
    payload = scalars[S_PAYLOAD]
    time_scale = scalars[S_TIMESCALE]
    tr = table[R_TR]
    tau_u = np.zeros(7)
    p = np.zeros(3)
    pdot = np.zeros(3)
    pbdot = np.zeros(3)
    creep = np.zeros(3)
    stiff = np.ones(3)
    fric = np.zeros(3)
    fc = np.zeros(3)
    fv = np.zeros(3)
    tension = np.zeros(3)
    stretch = np.zeros(3)
    rhs = np.zeros(3)
    acc = np.zeros(3)
    v_free = np.zeros(3)
    visc = np.zeros((3, 3))
    tmp3 = np.zeros(3)
    dry = np.zeros(3)
    grav = np.zeros(3)
    q3 = np.zeros(3)
    mass = np.eye(3)
    inv_mass = np.eye(3)
    unit = np.zeros(3)
    column = np.zeros(3)
    count = 0
    for k in range(n):
        if restart[k]:
            for i in range(3):
                plant[X_U + i] = drive[k, i]
                plant[X_UD + i] = 0.0
                plant[X_Q + i] = start[k, i]
                plant[X_QD + i] = 0.0
                plant[X_PB + i] = (a_true[i, 0] * drive[k, 0] + a_true[i, 1] * drive[k, 1]
                                   + a_true[i, 2] * drive[k, 2])
                plant[X_Z + i] = 0.0
                plant[X_SF + i] = plant[X_PB + i] - start[k, i]
                tension[i] = 0.0
            count = 0
        for i in range(3):
            out[k, i] = plant[X_Q + i]
        if k == n - 1 or restart[k + 1]:
            continue
        span = time[k + 1] - time[k]
        steps = max(1, int(np.ceil(span / h_nominal - 1e-9)))
        h = span / steps
        for s in range(steps):
            for i in range(3):
                rate = (drive[k + 1, i] - drive[k, i]) / span
                plant[X_U + i] = drive[k, i] + rate * (s * h)
                plant[X_UD + i] = rate
            if count % substeps == 0:
                # gravity once per servo period and the inertia every few, as the servo loop updates them
                gravity_load(plant, table, flags, grav_plant, q3, grav)
                if count % (substeps * MASS_UPDATE_TICKS) == 0:
                    refresh_inertia(q3, grav_plant, mass, inv_mass, unit, column)
            cable_inputs(plant, table, flags, a_true, tr, p, pdot, pbdot, creep, stiff, fric, fc, fv, tension)
            elastic_cable_step(plant, table, flags, a_true, tr, h, tau_u, grav, mass, inv_mass, pbdot, creep,
                               stiff, fc, fv, fric, tension, stretch, rhs, acc, v_free, visc, tmp3, dry)
            cable_fatigue(plant, table, flags, h, payload, time_scale)
            count += 1
    return out


def replay_links(params, robot, time, drive, start, restart=None, payload_kg: float = 0.0,
                 substeps: int = 2, registration=None) -> np.ndarray:
    """(N, 3) link positions (rad, rad, m) the plant of ``params`` (a
    :class:`~simulation.model.parameters.RavenParameters`; only its :data:`FOLLOWED_EFFECTS`) gives
    along a log.

    Parameters
    ----------
    params : the arm's constants and effects; its cables must be elastic (``cable_stretch`` on).
    robot : the :class:`kinematics.RavenII` of the same arm (the links' gravity and inertia).
    time : (N,) sample times (s), strictly increasing.
    drive : (N, 3) logged motor coordinates of the positioning joints (motor angle over the
        transmission ratio: rad, rad, m).
    start : (N, 3) link positions the plant starts from, at rest, at the samples of ``restart``.
    restart : (N,) bool, the samples where the plant starts again (the first, and the first after
        each re-homing); the first sample alone by default.
    payload_kg : mass at the tool tip (kg).
    substeps : integration steps per 1 ms servo period (the simulator's two by default).
    registration : (N, 3) offsets (rad, rad, m) of the joints the logged motor coordinates place,
        from where the motors' registration at homing put their zero; None for none. They enter on
        the motor side, where RAVEN-II registers (the motor encoders are zeroed at the hard stops):
        the plant is driven by ``drive`` plus the coupling's inverse times ``registration``, so its
        links, and the gravity and inertia evaluated at them, sit where the measured joints are,
        not where the unregistered motor coordinates would put them. Adding such offsets to the
        replayed joints instead evaluates the links' gravity at a pose off by the offsets, and the
        cables' stretch under it with an error that changes with the pose.

    Raises
    ------
    ValueError
        Naming what is wrong: shapes that do not match, values that are not finite, times that do
        not increase, rigid cables (no swing to follow), a negative payload or too few substeps.
    """
    from simulation.engine.tables import build_tables

    time = np.ascontiguousarray(time, dtype=float)
    n = time.shape[0]
    if time.ndim != 1 or n < 2:
        raise ValueError(f"time must be one row of at least two sample times, got shape {time.shape}")
    arrays = {"drive": drive, "start": start}
    if registration is not None:
        arrays["registration"] = registration
    for name, value in arrays.items():
        value = np.ascontiguousarray(value, dtype=float)
        if value.shape != (n, 3):
            raise ValueError(f"{name} must have shape {(n, 3)}, got {value.shape}")
        arrays[name] = value
    for name, value in (("time", time), *arrays.items()):
        if not np.all(np.isfinite(value)):
            raise ValueError(f"{name} is not finite at sample {int(np.argmax(~np.isfinite(value).reshape(n, -1).all(axis=1)))}")
    if np.any(np.diff(time) <= 0):
        raise ValueError(f"time must increase strictly; it does not at sample {int(np.argmax(np.diff(time) <= 0)) + 1}")
    if restart is None:
        restart = np.zeros(n, dtype=np.bool_)
        restart[0] = True
    restart = np.ascontiguousarray(restart, dtype=np.bool_)
    if restart.shape != (n,) or not restart[0]:
        raise ValueError(f"restart must be {n} flags, the first set (the plant starts at the first sample)")
    if not params.is_enabled("cable_stretch"):
        raise ValueError("the plant replay follows the links' swing on elastic cables; this parameter set has rigid "
                         "cables (cable_stretch off)")
    if not (np.isfinite(payload_kg) and payload_kg >= 0):
        raise ValueError(f"payload_kg must be a non-negative mass, got {payload_kg!r}")
    if isinstance(substeps, bool) or int(substeps) != substeps or substeps < 1:
        raise ValueError(f"substeps must be a positive whole number, got {substeps!r}")
    followed = params.only(*[name for name in FOLLOWED_EFFECTS if params.is_enabled(name)])
    tables = build_tables(followed, robot, float(payload_kg), int(substeps))
    coupling = np.ascontiguousarray(tables.coupling_true)
    motors = arrays["drive"]
    if registration is not None:
        motors = np.ascontiguousarray(motors + np.linalg.solve(coupling, arrays["registration"].T).T)
    return plant_link_series(time, motors, arrays["start"], restart, tables.table, tables.flags,
                             tables.scalars, coupling, tables.gravity_plant)
