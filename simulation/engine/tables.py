"""The arrays the compiled servo loop works on: parameter table, switches, scalars, state vectors.

:func:`build_tables` packs a :class:`~simulation.model.parameters.RavenParameters` and a payload
into an :class:`EngineTables`; the integer constants below name the rows of its per-DOF table
(``R_*``), its effect switches (``E_*``, in the order of
:data:`simulation.model.effects.EFFECT_NAMES`) and scalars (``S_*``), the slots of the plant's
state vector (``X_*``) and of the controller's (``C_*``), and the loop's modes (``MODE_*``).
The compiled functions of :mod:`~simulation.engine.sensors`, :mod:`~simulation.engine.controller`
and :mod:`~simulation.engine.plant` index their arrays with them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.model import layout
from simulation.model.constants import coupling_matrix
from simulation.model.effects import EFFECT_NAMES
from simulation.model.parameters import RavenParameters

# Rows of the per-DOF parameter table (columns: the seven DOFs; positioning-only rows use 0..2).
# Controller, sensor and tool rows, the engine's own:
R_TR, R_GEAR, R_TPA, R_DPA, R_DACMAX, R_KP, R_KD, R_KI, R_JM, R_BM = range(10)
R_HOMEDAC, R_HOMESPEED, R_STOP_LO, R_STOP_HI, R_HOMEPOSE, R_REGPOS = range(10, 16)
R_KTOOL, R_TOOL_FC, R_TOOL_FV = range(16, 19)
R_HREP, R_TRUTHRES, R_TRUTHNOISE, R_INOISE, R_MFC, R_MLOSS = range(19, 25)
# The motor-cable-link model's rows: the block of simulation.model.layout, in its row order
# (positioning columns 0..2; the rows of an effect that is off are zero, and every read of them
# is behind the effect's switch).
R_MODEL = 25
R_K1 = R_MODEL + layout.STIFFNESS
R_K3 = R_MODEL + layout.HARDENING
R_DAMP = R_MODEL + layout.DAMPING
R_GSCALE = R_MODEL + layout.LOAD_SCALE
R_FC = R_MODEL + layout.COULOMB
R_VC = R_MODEL + layout.VELOCITY_SCALE
R_FV = R_MODEL + layout.VISCOUS
R_BL = R_MODEL + layout.BACKLASH
R_HK = R_MODEL + layout.HYSTERESIS_STIFFNESS
R_HB = R_MODEL + layout.HYSTERESIS_BETA
R_HG = R_MODEL + layout.HYSTERESIS_GAMMA
R_HT = R_MODEL + layout.HYSTERESIS_RESPONSE_TIME
R_DK = R_MODEL + layout.STIFFNESS_LOSS
R_DC = R_MODEL + layout.CREEP_RATE
R_DLG = R_MODEL + layout.PAYLOAD_GAIN
R_DVREF = R_MODEL + layout.REFERENCE_SPEED
R_RUNOUT = R_MODEL + layout.RUNOUT
R_CAPSTAN = R_MODEL + layout.CAPSTAN_COEFFICIENT
R_GERR = R_MODEL + layout.GRAVITY_MODEL_ERROR
R_ROFF = R_MODEL + layout.REGISTRATION_OFFSET
R_RREP = R_MODEL + layout.REGISTRATION_REPEATABILITY
N_ROWS = R_MODEL + layout.N_ROWS

# Effect switches.
(E_STRETCH, E_GRAVITY, E_COUPLING, E_COULOMB, E_VISCOUS, E_BACKLASH, E_HYSTERESIS, E_DRIFT,
 E_HOMING, E_QUANT, E_NOISE, E_RUNOUT, E_MOTORFRICTION, E_CAPSTAN, E_GRAVERROR, E_TRANSMISSION,
 E_REGISTRATION) = range(17)
N_EFFECTS = 17
assert EFFECT_NAMES == ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction",
                        "backlash", "hysteresis", "drift", "homing_offset", "quantization", "noise",
                        "capstan_runout", "motor_friction", "capstan_friction", "gravity_model_error",
                        "transmission_error", "registration_offset")

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
X_MF = 39        # 7 motor-side friction of the last servo tick (joint units, mean over its sub-steps)
N_PLANT = 46

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

# Modes of the loop.
MODE_TRAJECTORY = 0   # follow a desired trajectory
MODE_HOMING = 1       # search the hard stops and register the encoders


@dataclass(frozen=True)
class EngineTables:
    """Everything the compiled loop needs about one arm, packed as arrays.

    Built by :func:`build_tables` from a :class:`~simulation.model.parameters.RavenParameters` and a payload.
    """

    table: np.ndarray          # (N_ROWS, 7)
    flags: np.ndarray          # (N_EFFECTS,) int64 effect switches
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

    Raises
    ------
    ValueError
        For a parameter the loop divides by that is zero (the compiled loop uses numpy's error
        model, where such a division would give inf or nan instead of an error).
    """
    c = params.constants
    _check_divisors(params, substeps)
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

    t[R_MODEL:, :3] = layout.joint_table(params)
    t[R_KTOOL, 3:] = c.tool_cable_stiffness
    t[R_TOOL_FC, 3:] = c.tool_friction
    t[R_TOOL_FV, 3:] = c.tool_viscous
    homing = params.effect("homing_offset")
    t[R_HREP, :3] = homing.repeatability
    t[R_HREP, 3:] = homing.tool_repeatability
    quant = params.effect("quantization")
    t[R_TRUTHRES, :3] = quant.truth_resolution
    noise = params.effect("noise")
    t[R_TRUTHNOISE, :3] = noise.truth_noise
    t[R_INOISE] = noise.current_noise
    motor = params.effect("motor_friction")
    t[R_MFC] = motor.coulomb
    t[R_MLOSS] = motor.gearbox_loss

    flags = np.array([1 if params.is_enabled(n) else 0 for n in EFFECT_NAMES], dtype=np.int64)
    scalars = np.zeros(N_SCALARS)
    scalars[S_DT] = c.servo_period
    scalars[S_NSUB] = substeps
    scalars[S_TOOLGB] = c.tool_gb_ratio
    scalars[S_TOOLSIGN] = c.tool_sign
    scalars[S_CPR] = quant.motor_counts_per_rev if quant.enabled else c.encoder_counts_per_rev
    scalars[S_TIMESCALE] = params.effect("drift").time_scale
    scalars[S_SETTLE] = round(c.settle_time / c.servo_period)
    scalars[S_PAYLOAD] = payload_kg

    nominal = c.nominal_coupling()
    coupling = params.effect("coupling")
    delta = coupling.delta if coupling.enabled else np.zeros(3)
    true = coupling_matrix(*(np.asarray(c.cable_coupling) + delta))
    transmission = params.effect("transmission_error")
    if transmission.enabled:
        # true ratio = nominal (1 + error): a motor coordinate moves its cable 1 / (1 + error) as far
        true = true / (1.0 + transmission.ratio_error)[None, :]
    return EngineTables(
        table=t,
        flags=flags,
        scalars=scalars,
        coupling_nominal=nominal,
        coupling_true=true,
        gravity_plant=robot.gravity_coefficients(payload_kg),
        gravity_controller=robot.gravity_coefficients(0.0),
    )


def _check_divisors(params: RavenParameters, substeps: int) -> None:
    """Reject the parameters the servo loop would divide by zero with, each by name."""
    c = params.constants
    for name in ("transmission_ratio", "gearbox", "torque_per_amp", "dac_per_amp"):
        if np.any(np.asarray(getattr(c, name)) == 0):
            raise ValueError(f"RavenConstants.{name} must be non-zero, got {np.asarray(getattr(c, name)).tolist()}")
    inertia = np.asarray(c.motor_inertia)
    if np.any(inertia[3:] == 0) or (params.is_enabled("cable_stretch") and np.any(inertia[:3] == 0)):
        raise ValueError(f"RavenConstants.motor_inertia must be non-zero, got {inertia.tolist()}")
    for name in ("servo_period", "tool_gb_ratio", "encoder_counts_per_rev"):
        if getattr(c, name) == 0:
            raise ValueError(f"RavenConstants.{name} must be non-zero, got {getattr(c, name)!r}")
    if int(substeps) < 1:
        raise ValueError(f"substeps must be >= 1, got {substeps}")
    quant = params.effect("quantization")
    if quant.enabled and np.any(quant.truth_resolution == 0):
        raise ValueError(f"quantization truth_resolution must be positive, got {quant.truth_resolution.tolist()}")
