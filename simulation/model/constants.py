"""Constants of the RAVEN-II hardware and controller that the virtual robot reproduces.

Every value here is read from the RAVEN-II controller (public repository ``uw-biorobotics/raven2``,
file named beside each value) or from a motor datasheet; none is tuned. The tunable physics of the
cable transmission lives in :mod:`simulation.model.effects`.

DOF slots follow the controller: ``[shoulder, elbow, z_ins, no_connection, tool_rot, wrist, grasp1,
grasp2]`` (``include/raven/defines.h``). Within the simulator the seven connected DOFs are indexed
``[shoulder, elbow, z_ins, tool_rot, wrist, grasp1, grasp2]`` (see :data:`SLOT_OF_DOF`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

DOF_NAMES = ("shoulder", "elbow", "z_ins", "tool_rot", "wrist", "grasp1", "grasp2")
"""The seven connected DOFs of one arm, in the simulator's order."""

POSITIONING_NAMES = ("shoulder", "elbow", "z_ins")
"""The paper's joints 1, 2, 3 (rad, rad, m)."""

REPORT_UNITS = ("deg", "deg", "mm")
"""Units of the positioning joints in tables, reports and plots (SI inside)."""

REPORT_SCALE = np.array([180.0 / np.pi, 180.0 / np.pi, 1000.0])
"""Multiplies positioning-joint values in SI (rad, rad, m) into :data:`REPORT_UNITS`."""
REPORT_SCALE.setflags(write=False)

SLOT_OF_DOF = np.array([0, 1, 2, 4, 5, 6, 7])
"""Controller slot (0..7) of each simulator DOF; slot 3 is the unused NO_CONNECTION channel."""

ARM_SERIAL = {"left": 49, "right": 22}
"""Arm serial numbers as published in ``ravenstate.type`` (GOLD_ARM_SERIAL = left, GREEN = right)."""

GEAR_BOX_GP42 = 49.0 / 4.0
GEAR_BOX_GP32 = 26.0 / 7.0
_CABLE_RADIUS_1050 = 1.19 / 2.0
_CABLE_RADIUS_1024 = 0.61 / 2.0
_PULLEY_LINK1 = 62.5 + _CABLE_RADIUS_1050
_PULLEY_LINK2 = 40.85 + _CABLE_RADIUS_1050
_CAPSTAN_LINK2_LARGE = 7.82 + _CABLE_RADIUS_1050
_CAPSTAN_LINK2_SMALL = 5.60 + _CABLE_RADIUS_1050
_CAPSTAN_GP42 = 11.35 / 2.0
_CAPSTAN_GP32 = 4.7 + _CABLE_RADIUS_1024
_CAPSTAN_TOOL = 10.6 + _CABLE_RADIUS_1024


def _transmission_ratios() -> np.ndarray:
    """Motor rad per joint rad (per metre for z_ins), ``include/raven/defines.h`` *_TR_GREEN_ARM."""
    tool = _CAPSTAN_TOOL / _CAPSTAN_GP32 * GEAR_BOX_GP32
    return np.array(
        [
            _PULLEY_LINK1 / _CAPSTAN_GP42 * GEAR_BOX_GP42,
            _PULLEY_LINK2 / _CAPSTAN_LINK2_SMALL * _CAPSTAN_LINK2_LARGE / _CAPSTAN_GP42 * GEAR_BOX_GP42,
            1.0 / (2 * np.pi * _CAPSTAN_GP42 / 1000.0) * GEAR_BOX_GP42 * 2 * np.pi,
            tool * 120.0 / 180.0,
            tool * 200.0 / 180.0,
            tool * 100.0 / 90.0,
            tool * 100.0 / 90.0,
        ]
    )


@dataclass(frozen=True)
class RavenConstants:
    """Hardware and controller constants of one RAVEN-II arm (SI, simulator DOF order).

    Attributes
    ----------
    transmission_ratio : (7,) motor rad per joint rad (per m for z_ins); ``defines.h``.
    gearbox : (7,) gearbox ratio inside each transmission ratio; ``defines.h`` GEAR_BOX_*.
    cable_coupling : (c01, c02, c12) of ``fwd_cable_coupling.h``: th2 = m2/tr2 - c01 th1,
        d3 = m4/tr4 - c02 th1 - c12 th2.
    tool_gb_ratio : GB_RATIO of ``fwd_cable_coupling.h``: how far the z_ins motor turns the tool
        capstans.
    torque_per_amp : (7,) motor torque constant times gearbox (N m/A at the gearbox output), as
        ``init.cpp`` sets ``tau_per_amp``; motor.h: RE40 0.0603 N m/A, RE30 0.0538 N m/A.
    dac_per_amp : (7,) amplifier DAC counts per ampere (``init.cpp``: high-current 2730 for the big
        motors, low-current 5461 for the tool motors).
    dac_max : (7,) current clip in DAC counts (``defines.h`` *_MAX_DAC, moderate safety mode).
    kp, kd, ki : (7,) joint PID gains on motor position (N m per motor rad at the gearbox output;
        ``params/r2params.yaml``).
    motor_inertia : (7,) rotor inertia at the motor shaft (kg m^2): Maxon RE40 (48 V, torque
        constant 60.3 mN m/A) 142 g cm^2, RE30 (48 V, 53.8 mN m/A) 33.5 g cm^2 (datasheets); the
        gearbox's own inertia is neglected.
    motor_damping : (7,) viscous loss at the motor shaft (N m s/rad), the datasheets' no-load
        current times torque constant divided by no-load speed (RE40 ~5e-6, RE30 ~3e-6); small
        beside the cable load, kept for completeness.
    encoder_counts_per_rev : motor encoder resolution (``motor.h`` ENC_CNTS_PER_REV_R_II).
    homing_dac : (7,) current threshold that ends the hard-stop search (``homing.cpp``
        homing_max_dac, default build).
    homing_speed : (3,) speed of the hard-stop search for the positioning joints (``homing.cpp``
        f_magnitude per period of 1 s: 10 deg/s, 10 deg/s, 0.02 m/s), signed toward the stop.
    hard_stop : (3,) joint position of the hard stop the homing search reaches, which the controller
        registers as its ``max_position`` (``defines.h`` SHOULDER/ELBOW/Z_INS_MAX_ANGLE).
    home_pose : (7,) pose the robot moves to after homing (``defines.h`` *_HOME_ANGLE).
    settle_time : time the controller waits at the hard stops before registering (``homing.cpp``:
        200 servo ticks).
    servo_period : 1 ms servo loop (``defines.h`` STEP_PERIOD).
    tool_friction : (4,) dry friction of the tool joints (N m): the capstans, pulleys and wrist
        cables of the instrument. The controller leaves the tool joints undamped (kd = 0 on
        wrist and grasps), so this friction is what settles them; it is part of the instrument,
        not one of the named transmission effects of the positioning joints, and is always on.
        Chosen so the tool PID holds still within a few tenths of a degree (tuning).
    tool_viscous : (4,) viscous friction of the tool joints (N m s/rad), same role (tuning).
    tool_cable_stiffness : (4,) stiffness of the tool cables (N m/rad): the tool joint lags its
        motors by friction / stiffness while moving (tuning, order of the wrist cables' ~1 N m/rad).
    tool_sign : +1 for the gold (left) arm, -1 for the green (right) arm; sign of the z_ins motor
        in the tool coupling (``fwd_cable_coupling.cpp``, RAVEN tool style). grasp1 uses the
        opposite sign (OPPOSE_GRIP).
    encoder_sign, dac_sign : (7,) hardware signs between joint-positive motion and the raw encoder
        count / DAC value, per arm (``state_estimate.cpp`` and ``init.cpp``, default tool style);
        only the published ``encVals`` and ``dac_val`` carry them.
    """

    arm: str = "left"
    transmission_ratio: np.ndarray = field(default_factory=_transmission_ratios)
    gearbox: np.ndarray = field(default_factory=lambda: np.array([GEAR_BOX_GP42] * 3 + [GEAR_BOX_GP32] * 4))
    cable_coupling: tuple[float, float, float] = (0.14545, 0.0077973826, 0.008077387)
    tool_gb_ratio: float = GEAR_BOX_GP42 / GEAR_BOX_GP32 * (_CAPSTAN_GP32 / _CAPSTAN_GP42)
    torque_per_amp: np.ndarray = field(
        default_factory=lambda: np.array([0.0603 * GEAR_BOX_GP42] * 3 + [0.0538 * GEAR_BOX_GP32] * 4)
    )
    dac_per_amp: np.ndarray = field(default_factory=lambda: np.array([2730.0] * 3 + [5461.0] * 4))
    dac_max: np.ndarray = field(default_factory=lambda: np.array([2500.0, 2500.0, 2000.0, 3000.0, 3000.0, 3800.0, 3800.0]))
    kp: np.ndarray = field(default_factory=lambda: np.array([0.300, 0.300, 0.150, 0.09, 0.05, 0.05, 0.05]))
    kd: np.ndarray = field(default_factory=lambda: np.array([0.008, 0.008, 0.012, 0.001, 0.0, 0.0, 0.0]))
    ki: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 0.05, 0.05, 0.05, 0.05]))
    motor_inertia: np.ndarray = field(default_factory=lambda: np.array([142.0e-7] * 3 + [33.5e-7] * 4))
    motor_damping: np.ndarray = field(default_factory=lambda: np.array([5.0e-6] * 3 + [3.0e-6] * 4))
    encoder_counts_per_rev: float = 4000.0
    homing_dac: np.ndarray = field(default_factory=lambda: np.array([2100.0, 2100.0, 1600.0, 1900.0, 2100.0, 2250.0, 2250.0]))
    homing_speed: np.ndarray = field(default_factory=lambda: np.array([-np.deg2rad(10.0), np.deg2rad(10.0), 0.02]))
    hard_stop: np.ndarray = field(default_factory=lambda: np.array([0.0, 3 * np.pi / 4 + np.deg2rad(2.5), 0.562]))
    home_pose: np.ndarray = field(
        default_factory=lambda: np.array([np.pi / 6, np.pi / 2, 0.4, 0.0, 0.0, np.pi / 4, np.pi / 4])
    )
    settle_time: float = 0.2
    servo_period: float = 1e-3
    tool_friction: np.ndarray = field(default_factory=lambda: np.array([0.01, 0.01, 0.005, 0.005]))
    tool_viscous: np.ndarray = field(default_factory=lambda: np.array([0.002, 0.002, 0.001, 0.001]))
    tool_cable_stiffness: np.ndarray = field(default_factory=lambda: np.array([2.0, 2.0, 1.0, 1.0]))

    def __post_init__(self) -> None:
        if self.arm not in ARM_SERIAL:
            raise ValueError(f"arm must be 'left' or 'right', got {self.arm!r}")
        for name in ("transmission_ratio", "gearbox", "torque_per_amp", "dac_per_amp", "dac_max", "kp", "kd",
                     "ki", "motor_inertia", "motor_damping", "homing_dac", "home_pose"):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (7,) or not np.all(np.isfinite(value)):
                raise ValueError(f"RavenConstants.{name} must be 7 finite values, got {value!r}")
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        for name, size in (("homing_speed", 3), ("hard_stop", 3), ("tool_friction", 4), ("tool_viscous", 4),
                           ("tool_cable_stiffness", 4)):
            value = np.asarray(getattr(self, name), dtype=float)
            if value.shape != (size,) or not np.all(np.isfinite(value)):
                raise ValueError(f"RavenConstants.{name} must be {size} finite values, got {value!r}")
            value.setflags(write=False)
            object.__setattr__(self, name, value)
        if np.any(self.tool_cable_stiffness <= 0) or np.any(self.tool_friction < 0) or np.any(self.tool_viscous < 0):
            raise ValueError("tool friction must be non-negative and tool cable stiffness positive")

    @property
    def tool_sign(self) -> float:
        return 1.0 if self.arm == "left" else -1.0

    @property
    def encoder_sign(self) -> np.ndarray:
        if self.arm == "left":
            sign = -np.ones(7)
        else:
            sign = np.array([1.0, 1.0, 1.0, -1.0, -1.0, -1.0, -1.0])
        sign[5] *= -1.0
        return sign

    @property
    def dac_sign(self) -> np.ndarray:
        big = -1.0 if self.arm == "left" else 1.0
        sign = np.array([big, big, big, -1.0, -1.0, -1.0, -1.0])
        sign[5] *= -1.0
        return sign

    def nominal_coupling(self) -> np.ndarray:
        """(3, 3) matrix A with joint = A @ (motor / transmission_ratio), the controller's coupling."""
        return coupling_matrix(*self.cable_coupling)


def coupling_matrix(c01: float, c02: float, c12: float) -> np.ndarray:
    """Forward cable coupling of the positioning joints as a matrix.

    With ``u = motor_angle / transmission_ratio`` (joint units), the controller computes
    ``th1 = u1``, ``th2 = u2 - c01 th1`` and ``d3 = u3 - c02 th1 - c12 th2``
    (``fwd_cable_coupling.cpp``), i.e. ``joint = A @ u`` with the lower-triangular ``A`` returned here.
    """
    return np.array(
        [
            [1.0, 0.0, 0.0],
            [-c01, 1.0, 0.0],
            [-c02 + c12 * c01, -c12, 1.0],
        ]
    )
