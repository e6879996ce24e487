"""One pass of the UKF over a time-ordered motor log, with its fault handling.

The filter predicts from each log sample to the next with the torque of the earlier sample held
and updates with the motor encoder reading. What it cannot believe it does not use, and it says
what it did (per-sample codes and counts in :class:`JointEstimates`, one :class:`UKFFaultWarning`
per run):

* **Coasting** (predict only, the covariance growing with the process noise): a reading that is
  NaN or infinite, or in a sample the recording flagged (``valid`` False, see
  :mod:`simulation.recordings.limits`). A gap (a step over ``GAP_FACTOR`` median log periods) is
  predicted across. After ``max_gap`` seconds without a usable reading the open-loop model is no
  longer followed: the estimate is held, its joint spread widened to at least ``LOST_SPREAD``, and
  the filter re-initialises from the next usable reading; a time step over ``max_gap`` does the same.
* **Implausible readings** (rejected before the gate): a motor that moved further since the last
  accepted reading than the RE40 can turn at its no-load speed, 7580 rpm for the Maxon RE40
  148877 at 48 V (:data:`simulation.recordings.limits.RE40_NO_LOAD_SPEED`), plus
  ``SPEED_MARGIN`` and two encoder counts, divided by the transmission ratio in motor
  coordinates (794 rad/s at the motor shaft: 29 motor rad in one 30 Hz tick, 0.21 rad of the
  shoulder's motor coordinate). A torque sample that is not finite, flagged, or beyond what the controller's DAC
  clip lets the motor produce (``dac_max / dac_per_amp * torque_per_amp``, N m at the gearbox
  output, plus ``SPEED_MARGIN``) is not used: the last good torque is held.
* **The innovation gate**: a reading whose squared Mahalanobis distance ``y^T S^-1 y`` exceeds
  ``chi2.ppf(gate_probability, 3)`` (21.1 at the default 0.9999) is rejected (predict only),
  unless widening the predicted covariance by at most ``max_inflation`` (10: innovations up to
  about 14.5 predicted standard deviations) brings it inside: then the model's prediction, not the
  reading, was at fault (an unmodelled payload does this), and the reading is used with the wider
  prediction (counted as ``n_inflated``, not as a fault).
* **Divergence** (re-initialisation from the reading: state at rest under gravity at the motor
  positions, covariance the initial one): a non-finite state or covariance, a joint or motor
  position standard deviation beyond ``COVARIANCE_LIMIT``, or ``max_rejections`` readings
  rejected in a row.

With ``UKFSettings.disturbance_density`` > 0 the state carries a disturbance torque per joint
(15 states); the same gating, coasting and divergence tests apply, and a re-initialisation
restarts the disturbance at zero with its initial spread.

The log's time stamps must be seconds at a RAVEN-II log rate (``LOG_RATE_RANGE``): a log in
milliseconds or kiloseconds is refused.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy.stats import chi2

from kinematics.gravity_closed_form import gravity_torques_fast
from simulation.identification.motor_log import MotorLog
from simulation.model.constants import RavenConstants
from simulation.recordings.limits import RE40_NO_LOAD_SPEED

from estimators.ukf._filter import BatchUnscentedKalmanFilter, sigma_points
from estimators.ukf.model import DISTURBANCE_SPREAD, N_DISTURBANCE_STATE, N_STATE, CableModel
from estimators.ukf.noise import ProcessNoise
from estimators.ukf.process import MAX_STEP, REFRESH, ProcessModel
from simulation.identification.samples import GAP_FACTOR

INITIAL_SPREAD = np.array([0.05, 0.05, 0.005, 2e-3, 2e-3, 1e-4, 0.05, 0.05, 0.005])
"""Initial standard deviations of u', q, q' (joint units): at rest within a few cm/s or deg/s, the
joints within the stretch that friction leaves undetermined (a tenth of a degree, 0.1 mm)."""
LOG_RATE_RANGE = (2.0, 2000.0)
"""Median log rates (Hz) the filter accepts: RAVEN-II logs at 30 Hz to 1 kHz; two samples are at
least half a 1 ms servo tick apart. A log outside is in other time units (ms, ks) or not RAVEN-II's."""
SPEED_MARGIN = 0.10
"""Fraction above the RE40's no-load speed and the DAC-clipped torque a reading may reach."""
COVARIANCE_LIMIT = np.array([1.0, 1.0, 0.1])
"""Largest standard deviation of a motor coordinate or joint position (rad, rad, m) before the
filter counts as diverged: beyond it the estimate says nothing about the arm's pose."""
DIVERGENCE_REASONS = ("non-finite prediction", "covariance beyond COVARIANCE_LIMIT",
                      "negative variance of a position")
"""Re-initialisation reasons that mean the filter diverged (rather than lost its readings)."""
_POSITION_STATES = np.array([0, 1, 2, 6, 7, 8])
"""Indices of the motor coordinates and joint positions in the state vector."""
_POSITION_VARIANCE_LIMIT = np.tile(COVARIANCE_LIMIT ** 2, 2)
LOST_SPREAD = np.array([0.5, 0.5, 0.05])
"""Smallest joint standard deviation (rad, rad, m) reported while the filter has lost the arm (no
usable reading for ``max_gap`` seconds): the spread of the joints over a working motion."""

ACCEPTED = 0
"""Sample code: the reading updated the filter."""
REJECTED = 1
"""Sample code: the reading was rejected (implausible jump or innovation gate); predict only."""
COASTING = 2
"""Sample code: no usable reading (NaN, infinite, flagged, or the arm lost after a long gap)."""
REINITIALISED = 3
"""Sample code: the filter was re-initialised from this reading (first sample, long gap, divergence)."""
SAMPLE_CODES = {"accepted": ACCEPTED, "rejected": REJECTED, "coasting": COASTING, "reinitialised": REINITIALISED}


class UKFFaultWarning(RuntimeWarning):
    """The UKF rejected, coasted through or re-initialised at some samples of a log (counts in the message)."""


@dataclass(frozen=True)
class SampleLimits:
    """What a RAVEN-II positioning motor can report between two samples, in the filter's units.

    Attributes
    ----------
    arm : the arm the limits (and the model) belong to.
    motor_rate : (3,) largest motor-coordinate speed (joint units per s): the RE40's no-load speed
        (7580 rpm) times ``1 + SPEED_MARGIN`` divided by the transmission ratio.
    encoder_slack : (3,) two encoder counts in motor coordinates, added to every jump bound.
    torque : (3,) largest commanded torque at the gearbox output (N m): the DAC clip in amperes
        times the torque constant (with gearbox), times ``1 + SPEED_MARGIN``.
    """

    arm: str
    motor_rate: np.ndarray
    encoder_slack: np.ndarray
    torque: np.ndarray

    @classmethod
    def from_constants(cls, constants: RavenConstants, arm: str) -> "SampleLimits":
        ratio = np.asarray(constants.transmission_ratio[:3], dtype=float)
        dac_torque = (np.asarray(constants.dac_max[:3]) / np.asarray(constants.dac_per_amp[:3])
                      * np.asarray(constants.torque_per_amp[:3]))
        return cls(arm=arm, motor_rate=RE40_NO_LOAD_SPEED * (1.0 + SPEED_MARGIN) / ratio,
                   encoder_slack=2.0 * 2.0 * np.pi / constants.encoder_counts_per_rev / ratio,
                   torque=dac_torque * (1.0 + SPEED_MARGIN))


@dataclass(frozen=True)
class UKFSettings:
    """Numerical settings of one filter run (see :class:`~estimators.ukf.estimator.UKFJointEstimator`).

    ``gate_probability``: probability mass of the chi-square gate (3 degrees of freedom) a reading's
    innovation must fall in; ``max_rejections``: readings rejected in a row before the filter
    re-initialises; ``max_inflation``: largest factor on the predicted covariance that may bring a
    reading beyond the gate back inside it (a prediction the model made overconfident; see
    :meth:`~estimators.ukf._filter.BatchUnscentedKalmanFilter.gated_update`); ``coast_noise_scale``:
    factor on the process covariance while no reading is used (the noise was tuned with the
    readings correcting the model every step).
    """

    alpha: float = 1.0
    beta: float = 2.0
    kappa: float = 0.0
    max_step: float = MAX_STEP
    refresh: int = REFRESH
    max_gap: float = 1.0
    gate_probability: float = 0.9999
    max_inflation: float = 10.0
    max_rejections: int = 10
    coast_noise_scale: float = 1.0
    disturbance_density: float = 0.0

    @property
    def n_state(self) -> int:
        """12 for the plain filter, 15 with the disturbance torques (``disturbance_density`` > 0)."""
        return N_DISTURBANCE_STATE if self.disturbance_density > 0 else N_STATE

    @property
    def gate_threshold(self) -> float:
        """Squared Mahalanobis distance beyond which a reading is rejected."""
        return float(chi2.ppf(self.gate_probability, 3))


@dataclass(frozen=True)
class JointEstimates:
    """UKF estimates at every log sample.

    Attributes
    ----------
    time : (N,) s.
    joints : (N, 3) estimated joint positions (rad, rad, m) after each update; always finite.
    covariance : (N, 3, 3) their covariance.
    states : (N, 12) full state ``[u, u', q, q']``; (N, 15) with the disturbance torques ``d`` after it.
    min_eigenvalue : (N,) smallest eigenvalue of the full state covariance after each step, or
        None when not requested.
    log_likelihood : sum of the innovation log-likelihoods (NaN unless requested).
    n_skipped : updates skipped for a missing (NaN, infinite or flagged) motor reading.
    n_missing_torque : steps that reused an earlier torque because the sample's was missing or
        implausible.
    n_gaps : gaps predicted across; ``n_restarts``: re-initialisations after the first sample
        (long gaps, divergence, runs of rejections), the same as ``n_reinitialised``.
    n_repairs : covariance square roots that needed an eigenvalue repair.
    flags : (N,) int8 sample codes: :data:`ACCEPTED`, :data:`REJECTED`, :data:`COASTING`,
        :data:`REINITIALISED`.
    n_rejected : readings rejected (``n_implausible`` of them before the gate, the rest by it).
    n_coasted : samples predicted through without a usable reading.
    n_reinitialised : re-initialisations after the first sample.
    reinitialisations : ((sample index, reason), ...) of every re-initialisation.
    distance2 : (N,) squared Mahalanobis distance of each reading's innovation (NaN where none was
        gated).
    inflation : (N,) factor the predicted covariance was scaled by to accept the reading (1 mostly).
    n_inflated : readings accepted with a scaled prediction.
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
    flags: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))
    n_rejected: int = 0
    n_implausible: int = 0
    n_coasted: int = 0
    n_reinitialised: int = 0
    reinitialisations: tuple = ()
    distance2: np.ndarray = field(default_factory=lambda: np.zeros(0))
    inflation: np.ndarray = field(default_factory=lambda: np.zeros(0))
    n_inflated: int = 0

    def __len__(self) -> int:
        return self.time.size

    @property
    def standard_deviation(self) -> np.ndarray:
        """(N, 3) standard deviations of the joint estimates."""
        return np.sqrt(np.einsum("nii->ni", self.covariance))

    @property
    def events(self) -> dict[str, int]:
        """``{"rejected": n, "coasted": n, "reinitialised": n}``."""
        return {"rejected": int(self.n_rejected), "coasted": int(self.n_coasted),
                "reinitialised": int(self.n_reinitialised)}


def initial_state(model: CableModel, motor: np.ndarray, n_state: int = N_STATE) -> tuple[np.ndarray, np.ndarray]:
    """State at rest at motor coordinates ``motor`` (joints sagging under gravity) and its covariance.

    With ``n_state`` 15 the disturbance torques start at zero with spread ``DISTURBANCE_SPREAD``.
    """
    q = model.cable_ends(motor)
    for _ in range(10):  # fixed point: gravity changes slowly with q beside the cable stiffness
        q = model.static_joints(motor, gravity_torques_fast(np.ascontiguousarray(q), model.gravity_coefficients))
    x = np.concatenate([motor, np.zeros(3), q, np.zeros(3)])
    spread = np.concatenate([model.encoder_resolution, INITIAL_SPREAD])
    if n_state == N_DISTURBANCE_STATE:
        x = np.concatenate([x, np.zeros(3)])
        spread = np.concatenate([spread, DISTURBANCE_SPREAD])
    elif n_state != N_STATE:
        raise ValueError(f"the filter has {N_STATE} or {N_DISTURBANCE_STATE} states, not {n_state}")
    return x, np.diag(spread ** 2)


def motor_readings(states: np.ndarray) -> np.ndarray:
    """The measurement model: the motor encoders read the motor coordinates (first three states)."""
    return states[:, :3]


def _build_filter(model: CableModel, settings: UKFSettings, measurement: np.ndarray) -> BatchUnscentedKalmanFilter:
    process = ProcessModel(model, settings.max_step, settings.refresh)
    points = sigma_points(settings.n_state, settings.alpha, settings.beta, settings.kappa)
    ukf = BatchUnscentedKalmanFilter(settings.n_state, 3, points, process.batch, hx_batch=motor_readings)
    ukf.R = measurement
    return ukf


def _restart(ukf: BatchUnscentedKalmanFilter, model: CableModel, motor: np.ndarray) -> None:
    ukf.x, ukf.P = initial_state(model, motor, ukf.x.size)


def process_covariance(process_noise: ProcessNoise, settings: UKFSettings, dt: float) -> np.ndarray:
    """Discrete process covariance over ``dt`` s: the white-acceleration block, and with the disturbance
    states a random walk of density ``settings.disturbance_density`` (N m s^-0.5, N s^-0.5 for joint 3)."""
    covariance = process_noise.covariance(dt)
    if settings.n_state == N_STATE:
        return covariance
    full = np.zeros((N_DISTURBANCE_STATE, N_DISTURBANCE_STATE))
    full[:N_STATE, :N_STATE] = covariance
    full[N_STATE:, N_STATE:] = np.eye(3) * settings.disturbance_density ** 2 * dt
    return full


def check_log_rate(time: np.ndarray) -> float:
    """The median log period (s); raises ValueError when the rate is outside :data:`LOG_RATE_RANGE`."""
    if time.size < 2:
        return 1.0
    period = float(np.median(np.diff(time)))
    low, high = LOG_RATE_RANGE
    if not low <= 1.0 / period <= high:
        raise ValueError(f"the log's median sample period is {period:.4g} s ({1.0 / period:.4g} Hz), outside "
                         f"RAVEN-II's log rates ({low:g}-{high:g} Hz): are its time stamps in seconds?")
    return period


def _diverged(P: np.ndarray) -> str | None:
    """Why the state covariance ``P`` no longer describes the arm, or None while it does.

    A motor or joint position's variance beyond ``COVARIANCE_LIMIT`` says nothing about the pose;
    a negative one (the unscented update of a covariance that grew far beyond the sigma points'
    reach) is not a covariance at all.
    """
    positions = np.diagonal(P)[_POSITION_STATES]
    if not np.isfinite(P).all() or (positions > _POSITION_VARIANCE_LIMIT).any():
        return "covariance beyond COVARIANCE_LIMIT"
    if (positions < 0.0).any():
        return "negative variance of a position"
    return None


def _lost(joint_covariance: np.ndarray) -> np.ndarray:
    """The joint covariance with each standard deviation raised to at least ``LOST_SPREAD``
    (``LOST_SPREAD`` alone when the covariance has stopped being one)."""
    variance = np.diagonal(joint_covariance)
    if not (np.all(np.isfinite(joint_covariance)) and np.all(variance > 0.0)):
        return np.diag(LOST_SPREAD ** 2)
    spread = np.sqrt(variance)
    scale = np.maximum(LOST_SPREAD / spread, 1.0)
    return joint_covariance * scale[:, None] * scale[None, :]


def run_filter(log: MotorLog, model: CableModel, process_noise: ProcessNoise, measurement: np.ndarray,
               settings: UKFSettings = UKFSettings(), *, valid: np.ndarray | None = None,
               limits: SampleLimits | None = None, covariance_scale=None, eigenvalues: bool = False,
               likelihood: bool = False, warn: bool = True) -> JointEstimates:
    """Filter a log; see the module docstring for how bad and lost samples are handled.

    ``valid`` (N,) bool marks the samples a recording's check left usable (default: all);
    ``limits`` bounds the readings and torques (default: the RAVEN-II constants of ``log.arm``).
    ``covariance_scale`` (3,) multiplies the variances of the reported joint covariance (the
    correlations kept; see :meth:`~estimators.ukf.estimator.UKFJointEstimator.fit`); default 1.
    ``eigenvalues`` records the smallest eigenvalue of the state covariance at every sample,
    ``likelihood`` sums the innovation log-likelihoods of the accepted readings (NaN otherwise).

    Raises
    ------
    ValueError
        The log has no usable motor reading, its time is not in seconds (:func:`check_log_rate`),
        or ``valid`` has the wrong shape.
    """
    n = len(log)
    valid = np.ones(n, dtype=bool) if valid is None else np.asarray(valid, dtype=bool)
    if valid.shape != (n,):
        raise ValueError(f"valid must have shape ({n},), got {valid.shape}")
    if limits is None:
        limits = SampleLimits.from_constants(RavenConstants(arm=log.arm), log.arm)
    root = np.ones(3) if covariance_scale is None else np.sqrt(np.asarray(covariance_scale, dtype=float))
    if root.shape != (3,) or not np.all(np.isfinite(root) & (root > 0)):
        raise ValueError(f"covariance_scale must be 3 positive numbers, got {covariance_scale!r}")
    scaling = root[:, None] * root[None, :]
    time = log.time
    period = check_log_rate(time)
    with np.errstate(invalid="ignore", over="ignore"):
        z = log.motor_positions / model.transmission_ratio
        valid_z = valid & np.all(np.isfinite(z), axis=1)
        valid_tau = valid & np.all(np.isfinite(log.motor_torques), axis=1) & np.all(
            np.abs(log.motor_torques) <= limits.torque, axis=1)
        torque = log.motor_torques * model.torque_scale
    if not np.any(valid_z):
        raise ValueError("the log has no sample with finite, unflagged motor positions")
    first = int(np.argmax(valid_z))
    threshold = settings.gate_threshold
    ukf = _build_filter(model, settings, measurement)
    _restart(ukf, model, z[first])
    held = torque[first] if valid_tau[first] else np.zeros(3)
    states = np.empty((n, settings.n_state))
    joint_cov = np.empty((n, 3, 3))
    flags = np.full(n, COASTING, dtype=np.int8)
    distance2 = np.full(n, np.nan)
    inflation = np.ones(n)
    flags[first] = REINITIALISED
    min_eig = np.empty(n) if eigenvalues else None
    counts = dict(skipped=first, missing=0, gaps=0, rejected=0, implausible=0, coasted=first, inflated=0)
    reinitialisations: list[tuple[int, str]] = []
    log_likelihood = 0.0 if likelihood else np.nan
    pending: str | None = None          # why the filter waits for a reading to re-initialise
    last_z, last_t = z[first], time[first]
    run = 0                             # readings rejected in a row
    blind = 0.0                         # seconds since the last used reading

    def record(k: int, lost: bool = False) -> None:
        states[k] = ukf.x
        joint_cov[k] = ukf.P[6:9, 6:9] * scaling
        if lost:
            joint_cov[k] = _lost(joint_cov[k])
        if min_eig is not None:
            min_eig[k] = np.linalg.eigvalsh(ukf.P)[0]

    def plausible(k: int) -> bool:
        bound = limits.motor_rate * (time[k] - last_t) + limits.encoder_slack
        return bool(np.all(np.abs(z[k] - last_z) <= bound))

    def reinitialise(k: int, reason: str) -> None:
        nonlocal last_z, last_t, run, blind, pending
        _restart(ukf, model, z[k])
        reinitialisations.append((k, reason))
        flags[k] = REINITIALISED
        last_z, last_t, run, blind, pending = z[k], time[k], 0, 0.0, None

    def restart_or_coast(k: int, reason: str) -> None:
        """Re-initialise from a usable reading, else hold the estimate as lost."""
        if valid_z[k]:
            reinitialise(k, reason)
            record(k)
        else:
            counts["coasted"] += 1
            record(k, lost=True)

    for k in range(first + 1):
        record(k)
    for k in range(first + 1, n):
        dt = time[k] - time[k - 1]
        if valid_tau[k - 1]:
            held = torque[k - 1]
        elif k - 1 > first:
            counts["missing"] += 1
        if not valid_z[k]:
            counts["skipped"] += 1
        if dt > settings.max_gap and pending is None:
            pending = "gap"
        if pending is not None:
            restart_or_coast(k, pending)
            continue
        if dt > GAP_FACTOR * period:
            counts["gaps"] += 1
        before = (ukf.x.copy(), ukf.P.copy())
        usable = bool(valid_z[k])
        scale = 1.0 if usable else settings.coast_noise_scale
        ukf.Q = scale * process_covariance(process_noise, settings, dt)
        ukf.predict(dt=dt, motor_torque=held)
        if not (np.all(np.isfinite(ukf.x)) and np.all(np.isfinite(ukf.P))):
            ukf.x, ukf.P = before       # keep the last good estimate until a reading re-initialises
            pending = "non-finite prediction"
            restart_or_coast(k, pending)
            continue
        if not usable:
            counts["coasted"] += 1
            blind += dt
            flags[k] = COASTING
            if blind > settings.max_gap:
                pending = "no reading for max_gap"
                record(k, lost=True)
                continue
        elif not plausible(k):
            counts["rejected"] += 1
            counts["implausible"] += 1
            flags[k] = REJECTED
            run += 1
            blind += dt
        else:
            accepted, distance2[k], inflation[k] = ukf.gated_update(z[k], threshold, settings.max_inflation)
            counts["inflated"] += bool(accepted and inflation[k] > 1.0)
            if accepted:
                flags[k] = ACCEPTED
                last_z, last_t, run, blind = z[k], time[k], 0, 0.0
                if likelihood:
                    log_likelihood += ukf.innovation_log_likelihood()
            else:
                counts["rejected"] += 1
                flags[k] = REJECTED
                run += 1
                blind += dt
                if likelihood:
                    log_likelihood += ukf.innovation_log_likelihood(threshold)
        if usable and run >= settings.max_rejections:
            reinitialise(k, f"{run} readings rejected in a row")
        elif (diverged := _diverged(ukf.P)) is not None:
            if usable:
                reinitialise(k, diverged)
            else:
                pending = diverged
                record(k, lost=True)
                continue
        elif blind > settings.max_gap:
            pending = "no accepted reading for max_gap"
        record(k)
    n_reinit = len(reinitialisations)
    result = JointEstimates(
        time=time.copy(), joints=states[:, 6:9].copy(), covariance=joint_cov, states=states,
        min_eigenvalue=min_eig, log_likelihood=float(log_likelihood), n_skipped=counts["skipped"],
        n_missing_torque=counts["missing"], n_gaps=counts["gaps"], n_restarts=n_reinit,
        n_repairs=ukf.repairs, flags=flags, n_rejected=counts["rejected"], n_implausible=counts["implausible"],
        n_coasted=counts["coasted"], n_reinitialised=n_reinit, reinitialisations=tuple(reinitialisations),
        distance2=distance2, inflation=inflation, n_inflated=counts["inflated"],
    )
    if warn and (result.n_skipped or result.n_missing_torque or result.n_gaps or result.n_reinitialised
                 or result.n_rejected or result.n_coasted or result.n_repairs):
        reasons = sorted({reason for _, reason in reinitialisations})
        warnings.warn(
            f"UKF over {n} samples: rejected {result.n_rejected} readings ({result.n_implausible} implausible, "
            f"{result.n_rejected - result.n_implausible} by the innovation gate; {result.n_inflated} more accepted "
            f"by widening the prediction), coasted through {result.n_coasted} samples, re-initialised {result.n_reinitialised} times" + (f" ({'; '.join(reasons)})" if reasons else "")
            + f"; skipped {result.n_skipped} updates (missing motor reading), held an earlier torque "
            f"{result.n_missing_torque} times, predicted across {result.n_gaps} gaps, restarted "
            f"{result.n_restarts} times, repaired {result.n_repairs} covariances", UKFFaultWarning, stacklevel=3)
    return result
