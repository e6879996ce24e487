"""Samples for the identification: motor and joint signals with their time derivatives.

The fit needs the motor and joint velocities and accelerations. The logged ``mvel`` is the
controller's unfiltered one-tick difference of quantized encoders (about 0.01 rad/s of joint
speed per count on the shoulder), so every derivative here comes from Savitzky-Golay fits of the
positions over a short window, segment by segment: a gap in the log (a lost stretch of samples)
starts a new segment, and a few samples at each segment end, where the window is one-sided, are
dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.signal import savgol_filter

from kinematics import RavenII
from kinematics.gravity_closed_form import gravity_torques_fast, mass_matrix_fast

from simulation.model.constants import RavenConstants
from simulation.model.parameters import RavenParameters
from simulation.identification.motor_log import as_motor_log

DERIVATIVE_WINDOW = 0.6
"""Savitzky-Golay window (s): long beside the log period (19 samples at 30 Hz), short beside the
seconds-long sweeps of the paper's motions. The velocities enter the model as exact regressors;
their noise from quantized encoders (5 um steps on the insertion) biases the fitted load scale
(errors in variables), by about 12% with a 0.3 s window on the virtual RAVEN-II and 4% with 0.6 s."""
GAP_FACTOR = 2.5
"""A step longer than this many median log periods is a gap that splits the log into segments."""


def motor_coordinates(motor_positions: np.ndarray, constants: RavenConstants) -> np.ndarray:
    """Motor angles (rad) divided by the transmission ratios: motor positions in joint units."""
    return np.asarray(motor_positions, dtype=float) / constants.transmission_ratio[:3]


def motor_torques_in_joint_units(motor_torques: np.ndarray, constants: RavenConstants) -> np.ndarray:
    """Gearbox-output torques (N m, ``tau``) as torques on the motor coordinates (N m, N m, N)."""
    return np.asarray(motor_torques, dtype=float) * constants.transmission_ratio[:3] / constants.gearbox[:3]


def log_segments(time: np.ndarray, gap_factor: float = GAP_FACTOR) -> list[slice]:
    """Runs of the log without gaps, as slices (a gap is a step over ``gap_factor`` median steps)."""
    if time.size < 2:
        return [slice(0, time.size)]
    steps = np.diff(time)
    breaks = np.flatnonzero(steps > gap_factor * np.median(steps)) + 1
    edges = np.concatenate([[0], breaks, [time.size]])
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


@njit(cache=True)
def _gravity_and_inertia(q, qdd, coefficients):
    """Gravity holding torques g(q) and inertial torques M(q) q'' at each sample (N, 3) each."""
    n = q.shape[0]
    gravity = np.empty((n, 3))
    inertial = np.empty((n, 3))
    for i in range(n):
        # element by element: numba compiles a row assignment from an array with a formatted
        # shape-mismatch error, seconds of compilation per process
        g = gravity_torques_fast(q[i], coefficients)
        a = mass_matrix_fast(q[i], coefficients) @ qdd[i]
        for j in range(3):
            gravity[i, j] = g[j]
            inertial[i, j] = a[j]
    return gravity, inertial


def arm_model(params: RavenParameters) -> RavenII:
    """The kinematics layer's model of the arm of a parameter set (with its gravity vector)."""
    if params.gravity is None:
        return RavenII(arm=params.arm, check_limits=False)
    return RavenII(arm=params.arm, gravity=params.gravity, check_limits=False)


@dataclass(frozen=True)
class IdentificationSamples:
    """Model signals at each usable log sample, joint units (rad, rad, m; N m, N m, N).

    Attributes
    ----------
    time : (N,) s.
    motor, motor_velocity, motor_acceleration : (N, 3) motor coordinates ``u`` (motor angle over
        transmission ratio) and their first two derivatives.
    motor_torque : (N, 3) commanded torque on the motor coordinates, ``tau * ratio / gearbox``.
    joints, joint_velocity, joint_acceleration : (N, 3) ground truth ``q`` and derivatives (the
        joints less a :func:`prepare_samples` correction, the derivatives of the joints as measured).
    gravity : (N, 3) gravity holding torques ``g(q)`` of the arm with the sample's payload.
    inertial : (N, 3) link inertial torques ``M(q) q''``.
    n_dropped : log samples not used (segment ends, segments shorter than the window).
    """

    time: np.ndarray
    motor: np.ndarray
    motor_velocity: np.ndarray
    motor_acceleration: np.ndarray
    motor_torque: np.ndarray
    joints: np.ndarray
    joint_velocity: np.ndarray
    joint_acceleration: np.ndarray
    gravity: np.ndarray
    inertial: np.ndarray
    n_dropped: int = 0

    def __len__(self) -> int:
        return self.time.size


def savgol_derivatives(values: np.ndarray, window: int, step: float) -> tuple[np.ndarray, np.ndarray]:
    """First and second time derivatives of each column of ``values`` (sampled every ``step`` s)
    from centred Savitzky-Golay fits of a cubic over ``window`` samples (odd): the derivatives the
    identification fits with."""
    first = savgol_filter(values, window, 3, deriv=1, delta=step, axis=0)
    second = savgol_filter(values, window, 3, deriv=2, delta=step, axis=0)
    return first, second


def prepare_samples(log, params: RavenParameters, window: float = DERIVATIVE_WINDOW,
                    joint_correction: np.ndarray | None = None) -> IdentificationSamples:
    """Derivatives, gravity and inertia of a log with ground truth, ready for :func:`identify`.

    Parameters
    ----------
    log : MotorLog, CalibrationDataset or Recording with ground-truth joints.
    params : the arm's parameter set (constants, gravity vector).
    window : Savitzky-Golay window (s).
    joint_correction : (N, 3), one row per log sample (rad, rad, m): what an effect outside the
        model adds between the motors and the measured joints (e.g. a registration offset per
        homing). It is subtracted from the joints the joint residual compares, and from nothing
        else: the links are where the encoders measure them, so their loads and velocities come
        from the measured joints. (Subtracted from the log itself, a registration offset of 0.3 deg
        would move the pose the gravity is computed at by as much.)

    Raises
    ------
    ValueError
        The log has no ground truth, holds NaN, or has no segment longer than two windows, or the
        correction does not have one finite row per log sample.
    """
    log = as_motor_log(log)
    if not log.has_truth:
        raise ValueError("identification needs ground-truth joints (external encoders) in the log")
    if joint_correction is None:
        joint_correction = np.zeros((len(log), 3))
    joint_correction = np.asarray(joint_correction, dtype=float)
    if joint_correction.shape != (len(log), 3):
        raise ValueError(f"joint_correction must have one row of 3 per log sample, shape ({len(log)}, 3); "
                         f"got {joint_correction.shape}")
    if not np.all(np.isfinite(joint_correction)):
        raise ValueError("joint_correction holds NaN or infinite values")
    for name in ("motor_positions", "motor_torques"):
        values = getattr(log, name)
        if np.any(np.isnan(values)):
            row = int(np.flatnonzero(np.isnan(values).any(axis=1))[0])
            raise ValueError(f"{name} is NaN at row {row}; drop lost samples before identification")
    if not (np.isfinite(window) and window > 0):
        raise ValueError(f"window must be a positive number of seconds, got {window}")
    constants = params.constants
    u_all = motor_coordinates(log.motor_positions, constants)
    tau_all = motor_torques_in_joint_units(log.motor_torques, constants)
    payload_all = np.zeros(len(log)) if log.payload_kg is None else log.payload_kg
    pieces = []
    for segment in log_segments(log.time):
        time = log.time[segment]
        if time.size < 3:
            continue
        step = float(np.median(np.diff(time)))
        width = max(int(round(window / step)) | 1, 5)
        if time.size < 2 * width:
            continue
        u = u_all[segment]
        q = log.joints[segment]
        ud, udd = savgol_derivatives(u, width, step)
        qd, qdd = savgol_derivatives(q, width, step)
        keep = slice(width // 2, time.size - width // 2)
        pieces.append(dict(time=time[keep], motor=u[keep], motor_velocity=ud[keep], motor_acceleration=udd[keep],
                           motor_torque=tau_all[segment][keep], joints=q[keep], joint_velocity=qd[keep],
                           joint_acceleration=qdd[keep], payload=payload_all[segment][keep],
                           correction=joint_correction[segment][keep]))
    if not pieces:
        raise ValueError(f"no stretch of the log without gaps is longer than two derivative windows ({2 * window} s)")
    joined = {key: np.concatenate([piece[key] for piece in pieces]) for key in pieces[0]}
    robot = arm_model(params)
    gravity = np.empty_like(joined["joints"])
    inertial = np.empty_like(joined["joints"])
    payload = joined.pop("payload")
    for mass in np.unique(payload):
        rows = payload == mass
        gravity[rows], inertial[rows] = _gravity_and_inertia(
            np.ascontiguousarray(joined["joints"][rows]), np.ascontiguousarray(joined["joint_acceleration"][rows]),
            robot.gravity_coefficients(float(mass)))
    joined["joints"] = joined["joints"] - joined.pop("correction")
    return IdentificationSamples(**joined, gravity=gravity, inertial=inertial,
                                 n_dropped=len(log) - joined["time"].size)
