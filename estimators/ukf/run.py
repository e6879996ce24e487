"""One pass of the UKF over a time-ordered motor log.

The filter predicts from each log sample to the next with the torque of the earlier sample held
(the last valid one if a torque is missing) and updates with the motor encoder reading. Lost
samples never stop it: a NaN reading skips that update, a gap (a step over ``GAP_FACTOR`` median
log periods) is predicted across, and a gap over ``max_gap`` seconds (where a held torque means
nothing) or a non-finite prediction restarts the filter from the next reading. Each is counted in
the returned :class:`JointEstimates` and in one warning.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from kinematics.gravity_closed_form import gravity_torques_fast
from simulation.identification.motor_log import MotorLog

from estimators.ukf._filter import BatchUnscentedKalmanFilter, sigma_points
from estimators.ukf.model import N_STATE, CableModel
from estimators.ukf.noise import ProcessNoise
from estimators.ukf.process import MAX_STEP, REFRESH, ProcessModel

GAP_FACTOR = 2.5
"""A step longer than this many median log periods counts as a gap."""
INITIAL_SPREAD = np.array([0.05, 0.05, 0.005, 2e-3, 2e-3, 1e-4, 0.05, 0.05, 0.005])
"""Initial standard deviations of u', q, q' (joint units): at rest within a few cm/s or deg/s, the
joints within the stretch that friction leaves undetermined (a tenth of a degree, 0.1 mm)."""


@dataclass(frozen=True)
class UKFSettings:
    """Numerical settings of one filter run (see :class:`~estimators.ukf.estimator.UKFJointEstimator`)."""

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    max_step: float = MAX_STEP
    refresh: int = REFRESH
    max_gap: float = 1.0


@dataclass(frozen=True)
class JointEstimates:
    """UKF estimates at every log sample.

    Attributes
    ----------
    time : (N,) s.
    joints : (N, 3) estimated joint positions (rad, rad, m) after each update.
    covariance : (N, 3, 3) their covariance.
    states : (N, 12) full state ``[u, u', q, q']``.
    min_eigenvalue : (N,) smallest eigenvalue of the full state covariance after each step, or
        None when not requested.
    log_likelihood : sum of the innovation log-likelihoods (NaN unless requested).
    n_skipped : updates skipped for a missing (NaN) motor reading.
    n_missing_torque : steps that reused an earlier torque because the sample's was missing.
    n_gaps : gaps predicted across; ``n_restarts``: restarts after long gaps or a failed prediction.
    n_repairs : covariance square roots that needed an eigenvalue repair.
    """

    time: np.ndarray
    joints: np.ndarray
    covariance: np.ndarray
    states: np.ndarray
    min_eigenvalue: np.ndarray | None
    log_likelihood: float
    n_skipped: int
    n_missing_torque: int
    n_gaps: int
    n_restarts: int
    n_repairs: int

    def __len__(self) -> int:
        return self.time.size

    @property
    def standard_deviation(self) -> np.ndarray:
        """(N, 3) standard deviations of the joint estimates."""
        return np.sqrt(np.einsum("nii->ni", self.covariance))


def initial_state(model: CableModel, motor: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """State at rest at motor coordinates ``motor`` (joints sagging under gravity) and its covariance."""
    q = model.cable_ends(motor)
    for _ in range(10):  # fixed point: gravity changes slowly with q beside the cable stiffness
        q = model.static_joints(motor, gravity_torques_fast(np.ascontiguousarray(q), model.gravity_coefficients))
    x = np.concatenate([motor, np.zeros(3), q, np.zeros(3)])
    spread = np.concatenate([model.encoder_resolution, INITIAL_SPREAD])
    return x, np.diag(spread ** 2)


def motor_readings(states: np.ndarray) -> np.ndarray:
    """The measurement model: the motor encoders read the motor coordinates (first three states)."""
    return states[:, :3]


def _build_filter(model: CableModel, settings: UKFSettings, measurement: np.ndarray) -> BatchUnscentedKalmanFilter:
    process = ProcessModel(model, settings.max_step, settings.refresh)
    points = sigma_points(N_STATE, settings.alpha, settings.beta, settings.kappa)
    ukf = BatchUnscentedKalmanFilter(N_STATE, 3, points, process.batch, hx_batch=motor_readings)
    ukf.R = measurement
    return ukf


def _restart(ukf: BatchUnscentedKalmanFilter, model: CableModel, motor: np.ndarray) -> None:
    ukf.x, ukf.P = initial_state(model, motor)


def run_filter(log: MotorLog, model: CableModel, process_noise: ProcessNoise, measurement: np.ndarray,
               settings: UKFSettings = UKFSettings(), *, eigenvalues: bool = False, likelihood: bool = False,
               warn: bool = True) -> JointEstimates:
    """Filter a log; see the module docstring for how lost samples are handled.

    ``eigenvalues`` records the smallest eigenvalue of the state covariance at every sample,
    ``likelihood`` sums the innovation log-likelihoods (NaN otherwise).

    Raises
    ------
    ValueError
        The log has no sample with a finite motor reading.
    """
    z = log.motor_positions / model.transmission_ratio
    torque = log.motor_torques * model.torque_scale
    valid_z = np.all(np.isfinite(z), axis=1)
    valid_tau = np.all(np.isfinite(torque), axis=1)
    if not np.any(valid_z):
        raise ValueError("the log has no sample with finite motor positions")
    n = len(log)
    time = log.time
    period = float(np.median(np.diff(time))) if n > 1 else 1.0
    first = int(np.argmax(valid_z))
    ukf = _build_filter(model, settings, measurement)
    _restart(ukf, model, z[first])
    held = torque[first] if valid_tau[first] else np.zeros(3)
    states = np.empty((n, N_STATE))
    joint_cov = np.empty((n, 3, 3))
    min_eig = np.empty(n) if eigenvalues else None
    counts = dict(skipped=first, missing=0, gaps=0, restarts=0)
    log_likelihood = 0.0 if likelihood else np.nan
    pending_restart = False

    def record(k: int) -> None:
        states[k] = ukf.x
        joint_cov[k] = ukf.P[6:9, 6:9]
        if min_eig is not None:
            min_eig[k] = np.linalg.eigvalsh(ukf.P)[0]

    for k in range(first + 1):
        record(k)
    for k in range(first + 1, n):
        dt = time[k] - time[k - 1]
        if valid_tau[k - 1]:
            held = torque[k - 1]
        elif k - 1 > first:
            counts["missing"] += 1
        if dt > settings.max_gap or pending_restart:
            if valid_z[k]:
                _restart(ukf, model, z[k])
                counts["restarts"] += 1
                pending_restart = False
            else:
                counts["skipped"] += 1
                pending_restart = True
            record(k)
            continue
        if dt > GAP_FACTOR * period:
            counts["gaps"] += 1
        before = (ukf.x.copy(), ukf.P.copy())
        ukf.Q = process_noise.covariance(dt)
        ukf.predict(dt=dt, motor_torque=held)
        if not (np.all(np.isfinite(ukf.x)) and np.all(np.isfinite(ukf.P))):
            ukf.x, ukf.P = before       # keep the last good estimate until a reading restarts the filter
            if valid_z[k]:
                _restart(ukf, model, z[k])
                counts["restarts"] += 1
            else:
                counts["skipped"] += 1
                pending_restart = True
            record(k)
            continue
        if valid_z[k]:
            ukf.update(z[k])
            if likelihood:
                log_likelihood += ukf.innovation_log_likelihood()
        else:
            counts["skipped"] += 1
        record(k)
    result = JointEstimates(
        time=time.copy(), joints=states[:, 6:9].copy(), covariance=joint_cov, states=states,
        min_eigenvalue=min_eig, log_likelihood=float(log_likelihood), n_skipped=counts["skipped"],
        n_missing_torque=counts["missing"], n_gaps=counts["gaps"], n_restarts=counts["restarts"],
        n_repairs=ukf.repairs,
    )
    if warn and (result.n_skipped or result.n_missing_torque or result.n_gaps or result.n_restarts):
        warnings.warn(
            f"UKF over {n} samples: skipped {result.n_skipped} updates (missing motor reading), held an earlier "
            f"torque {result.n_missing_torque} times, predicted across {result.n_gaps} gaps, restarted "
            f"{result.n_restarts} times", RuntimeWarning, stacklevel=3)
    return result
