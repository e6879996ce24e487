"""The model-based baseline: an unscented Kalman filter on the identified motor-cable-link model.

After Haghighipanah et al. (IROS 2015) and its ancestor, Naerum, King and Hannaford (RSS 2009):
the joints of a cable-driven arm are estimated from what its controller logs, motor encoders and
commanded motor torques, through a two-mass model of each positioning joint (motor, cable, link).

Design choices
--------------
* State, 12 (joint units): motor coordinates ``u = mpos / ratio`` and rates, joint positions and
  rates, for shoulder, elbow and insertion together, because the cable coupling ``A`` ties them
  (the joint cables run over the earlier joints' axes). Input: commanded torque ``tau``, held
  between log samples. Measurement: the three motor encoders, linear in the state.
* Process model: the identified cable model (:mod:`simulation.identification`) integrated at 1 kHz
  inside ``fx`` for all sigma points at once (:mod:`~estimators.ukf.process`); the filter updates at
  the rate of the log (30 Hz ravenstate, or faster). ``benchmarks/bench_ukf.py`` measures the
  real-time factor and the accuracy against the update rate.
* Sigma points: filterpy's ``MerweScaledSigmaPoints`` with alpha = 1, beta = 2, kappa = 0: every
  weight is non-negative, so the predicted covariance is positive semi-definite by construction.
* Noise: measurement noise is the motor encoder's one-count quantization (known, not tuned).
  Process noise is white acceleration noise on the motors and on the links (six densities),
  started from the identification's residuals and tuned on the calibration run by Nelder-Mead in
  log space, maximising the innovation likelihood (``tuning="likelihood"``, needs no ground truth)
  or minimising the joint error against the ground truth (``tuning="joint_error"``).

The estimator follows the project's calibrators where it can (hyper-parameters in ``__init__``,
``fit`` returns ``self``, learned state ends in ``_``) but consumes time-ordered logs: a
:class:`~simulation.recordings.dataset.CalibrationDataset` (simulated or read from a ROS bag), a simulated
:class:`~simulation.recordings.recording.Recording`, or a :class:`~simulation.identification.MotorLog`.
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import numpy as np
from scipy.optimize import minimize
from sklearn.base import BaseEstimator, clone
from sklearn.utils.validation import check_is_fitted

from simulation.identification import (
    DEFAULT_FIXED,
    FITTABLE_EFFECTS,
    IdentificationResult,
    MotorLog,
    NotIdentifiableError,
    as_motor_log,
    identify,
)
from simulation.identification.motor_log import MOTOR_POSITION_COLUMNS, MOTOR_TORQUE_COLUMNS
from simulation.identification.nominal import nominal_parameters
from simulation.model.parameters import RavenParameters
from simulation.recordings.dataset import CalibrationDataset

from estimators.ukf.model import CableModel
from estimators.ukf.noise import ProcessNoise, encoder_noise, physical_process_noise
from estimators.ukf.process import MAX_STEP, REFRESH
from estimators.ukf.run import (DIVERGENCE_REASONS, JointEstimates, SampleLimits, UKFSettings, check_log_rate,
                                run_filter)

TUNING_CRITERIA = ("likelihood", "joint_error", "none")
VELOCITY_SCALE_FACTORS = (0.3, 1.0, 3.0)
"""Factors of the nominal friction smoothing scale the fit chooses from (round values)."""
HOLDOUT_FRACTION = 0.25
"""Share of the calibration log, at its end, held out to choose the smoothing scale."""
HOLDOUT_SETTLE = 30
"""Samples at the start of the held-out part left out of its score (the filter settling)."""
COAST_SCALES = (1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0)
"""Factors on the process covariance while coasting that ``coast_noise_scale="auto"`` tries."""
COAST_COVERAGE = 0.99
"""Share of the coasted joint errors that must lie within 3 reported standard deviations."""
COAST_SPACING = 2.5
"""Seconds between the starts of the blanked stretches the coasting calibration uses."""


class UKFJointEstimator(BaseEstimator):
    """Unscented Kalman filter for joints 1-3 of a RAVEN-II arm from motor encoders and torques.

    Parameters
    ----------
    effects : effects of the identified model (see :func:`simulation.identification.identify`).
    fixed : parameters held at ``base_parameters``' values during identification.
    base_parameters : RavenParameters giving constants, initial guesses and fixed values (default:
        :func:`~simulation.identification.nominal.nominal_parameters` of the log's arm: the
        controller's constants and round effect values, never the simulator's), with its friction
        smoothing scale chosen on held-out calibration data (see ``velocity_scale_factors``).
    identification_options : dict of further keyword arguments for ``identify``.
    process_noise : a :class:`~estimators.ukf.noise.ProcessNoise` to use as is (no tuning), or None.
    measurement_noise : (3,) standard deviation of the motor encoder readings (motor rad), or None
        for one-count quantization.
    tuning : ``"likelihood"``, ``"joint_error"`` or ``"none"`` (keep the starting noise). A noise
        under which the filter diverges on the tuning window (:data:`~estimators.ukf.run.DIVERGENCE_REASONS`)
        is never kept, however well it scores.
    tuning_seconds : length of the calibration log the tuning filters (from its start), s.
    tuning_evaluations : filter runs the Nelder-Mead search may spend.
    payload_kg : payload the process model assumes at the tool tip (kg); the controller does not
        know the payload, and neither does the filter by default.
    alpha, beta, kappa : sigma-point parameters.
    max_step : longest integration sub-step of the process model (s).
    refresh : sub-steps between fresh evaluations of inertia, gravity and the cable law.
    max_gap : a log gap, or a run of unusable readings, longer than this re-initialises the filter (s).
    gate_probability : chi-square probability (3 degrees of freedom) of the innovation gate: a
        reading whose squared Mahalanobis distance exceeds ``chi2.ppf(gate_probability, 3)`` is
        rejected (21.1 at 0.9999; 1.0 turns the gate off).
    max_inflation : largest factor on the predicted covariance that may bring a reading beyond the
        gate inside it (the model's prediction was overconfident); a reading needing more is
        rejected. 1 makes the gate a plain rejection test.
    max_rejections : readings rejected in a row before the filter re-initialises from the readings.
    covariance_calibration : scale the reported joint variances so that, on the fit log's tuning
        window (which has ground truth), the mean squared joint error over the variance is 1 per
        joint (``covariance_scale_``). The filter's own joint covariance is far too small: the
        joints are seen only through the cable model, whose friction and stretch it takes as exact
        (on its own model class the shoulder and elbow errors are 12-17x its standard deviation). The
        estimates are unchanged; without ground truth the scale is 1.
    coast_noise_scale : factor on the process covariance over steps without a usable reading, or
        ``"auto"`` (default): chosen at fit time on the tuning window, which has ground truth, as
        the smallest of :data:`COAST_SCALES` for which 99 % of the joint errors over blanked
        stretches of 0.9 ``max_gap`` seconds (one every 2.5 s) lie within 3 reported standard deviations
        (``coast_noise_scale_``). The tuned noise is right while readings correct the model every
        step; while coasting the model runs open loop on the logged torques and its error grows
        faster than that noise says. Without ground truth, "auto" keeps 1.
    disturbance_density : 0 (default) runs the 12-state filter; a positive value adds a disturbance
        torque per positioning joint at the link (states 12-14, N m, N m, N), a random walk of this
        density (N m s^-0.5; N s^-0.5 on the insertion axis). It absorbs an unknown payload's gravity
        and unmodelled friction. A round-number hyper-parameter, not tuned.
    velocity_scale_factors : factors of the nominal friction smoothing scale tried when
        ``base_parameters`` is None: each is identified and filtered on the first 75 % of the
        calibration log and scored by joint error on the last 25 % (``velocity_scale_scores_``);
        the best is used for the final fit on the whole log. None or one factor: the nominal scale.
    verbose : 0 prints nothing; 1 prints a line when the identification, the noise tuning and each
        filter run end (with their times), to stdout as scikit-learn does; 2 also prints each
        identification pass and every tuning run.

    Bad samples are handled as :mod:`estimators.ukf.run` describes: implausible and gated readings
    are rejected, missing or flagged ones coasted through, divergence re-initialises; the
    :class:`~estimators.ukf.run.JointEstimates` carry per-sample codes and the counts, and one
    :class:`~estimators.ukf.run.UKFFaultWarning` per log gives them.

    Attributes
    ----------
    identification_ : IdentificationResult of the fit log.
    model_ : CableModel the filter runs.
    process_noise_ : ProcessNoise in use.
    measurement_noise_ : (3, 3) measurement covariance (motor coordinates).
    covariance_scale_ : (3,) factor on the reported joint variances (see ``covariance_calibration``).
    coast_noise_scale_ : factor on the process covariance while coasting (see ``coast_noise_scale``).
    limits_ : SampleLimits bounding readings and torques (the arm's RE40 motors and DAC clip).
    arm_ : the arm of the calibration log; logs of the other arm are refused.
    tuning_history_ : list of (log10 densities, objective) of every tuning run.
    """

    def __init__(self, *, effects=FITTABLE_EFFECTS, fixed=DEFAULT_FIXED, base_parameters: RavenParameters | None = None,
                 identification_options: dict | None = None, process_noise: ProcessNoise | None = None,
                 measurement_noise=None, tuning: str = "likelihood", tuning_seconds: float = 120.0,
                 tuning_evaluations: int = 40, payload_kg: float = 0.0, alpha: float = 1.0, beta: float = 2.0,
                 kappa: float = 0.0, max_step: float = MAX_STEP, refresh: int = REFRESH, max_gap: float = 1.0,
                 gate_probability: float = 0.9999, max_inflation: float = 10.0, max_rejections: int = 10,
                 coast_noise_scale: float | str = "auto", covariance_calibration: bool = True,
                 disturbance_density: float = 0.0, velocity_scale_factors=VELOCITY_SCALE_FACTORS,
                 verbose: int = 0):
        self.effects = effects
        self.fixed = fixed
        self.base_parameters = base_parameters
        self.velocity_scale_factors = velocity_scale_factors
        self.identification_options = identification_options
        self.process_noise = process_noise
        self.measurement_noise = measurement_noise
        self.tuning = tuning
        self.tuning_seconds = tuning_seconds
        self.tuning_evaluations = tuning_evaluations
        self.payload_kg = payload_kg
        self.alpha = alpha
        self.beta = beta
        self.kappa = kappa
        self.max_step = max_step
        self.refresh = refresh
        self.max_gap = max_gap
        self.gate_probability = gate_probability
        self.max_inflation = max_inflation
        self.max_rejections = max_rejections
        self.coast_noise_scale = coast_noise_scale
        self.covariance_calibration = covariance_calibration
        self.disturbance_density = disturbance_density
        self.verbose = verbose

    # ---- settings ------------------------------------------------------------------------

    def _settings(self) -> UKFSettings:
        for name in ("alpha", "max_step", "max_gap"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive, got {value!r}")
        if int(self.refresh) < 1:
            raise ValueError(f"refresh must be >= 1, got {self.refresh!r}")
        if not 0.0 < self.gate_probability <= 1.0:
            raise ValueError(f"gate_probability must be in (0, 1], got {self.gate_probability!r}")
        if not (np.isfinite(self.max_inflation) and self.max_inflation >= 1.0):
            raise ValueError(f"max_inflation must be a finite number >= 1, got {self.max_inflation!r}")
        if int(self.max_rejections) < 1:
            raise ValueError(f"max_rejections must be >= 1, got {self.max_rejections!r}")
        coast = self.coast_noise_scale
        if isinstance(coast, str):
            if coast != "auto":
                raise ValueError(f"coast_noise_scale must be a finite number >= 1 or 'auto', got {coast!r}")
            coast = getattr(self, "coast_noise_scale_", 1.0)
        elif not (isinstance(coast, (int, float, np.integer, np.floating)) and np.isfinite(coast) and coast >= 1.0):
            raise ValueError(f"coast_noise_scale must be a finite number >= 1 or 'auto', got {coast!r}")
        if not (np.isfinite(self.disturbance_density) and self.disturbance_density >= 0.0):
            raise ValueError(f"disturbance_density must be a finite number >= 0, got {self.disturbance_density!r}")
        return UKFSettings(alpha=float(self.alpha), beta=float(self.beta), kappa=float(self.kappa),
                           max_step=float(self.max_step), refresh=int(self.refresh), max_gap=float(self.max_gap),
                           gate_probability=float(self.gate_probability),
                           max_inflation=float(self.max_inflation), max_rejections=int(self.max_rejections),
                           coast_noise_scale=float(coast),
                           disturbance_density=float(self.disturbance_density))

    def _measurement_covariance(self, model: CableModel) -> np.ndarray:
        if self.measurement_noise is None:
            return encoder_noise(model)
        sigma = np.broadcast_to(np.asarray(self.measurement_noise, dtype=float), (3,))
        if not np.all(np.isfinite(sigma) & (sigma > 0)):
            raise ValueError(f"measurement_noise must be 3 positive values (motor rad), got {self.measurement_noise!r}")
        return np.diag((sigma / model.transmission_ratio) ** 2)

    # ---- fitting -------------------------------------------------------------------------

    def fit(self, log, y=None) -> "UKFJointEstimator":
        """Identify the cable model on a log with ground truth (the calibration run), then set the noise.

        Parameters
        ----------
        log : CalibrationDataset, Recording or MotorLog with motor positions, motor torques and
            ground-truth joints.
        y : ignored (the ground truth comes with the log).

        Returns
        -------
        self
        """
        if self.tuning not in TUNING_CRITERIA:
            raise ValueError(f"tuning must be one of {TUNING_CRITERIA}, got {self.tuning!r}")
        _check_model_class(self.effects)
        if isinstance(log, CalibrationDataset) and log.n_invalid:
            log = log.select(log.valid_mask())      # flagged rows hold values no robot produces
        log = as_motor_log(log)
        check_log_rate(log.time)
        settings = self._settings()
        options = dict(self.identification_options or {})
        options.setdefault("verbose", max(int(self.verbose) - 1, 0))
        base = self.base_parameters
        if base is None:
            base = self._nominal_with_chosen_smoothing(log)
        started = time.perf_counter()
        result = identify(log, effects=self.effects, base=base, fixed=self.fixed, **options)
        self._say(1, f"UKF: cable model identified on {len(log)} samples in {time.perf_counter() - started:.1f} s")
        return self._finish_fit(result, log, settings)

    def _nominal_with_chosen_smoothing(self, log: MotorLog) -> RavenParameters:
        """The nominal set with the friction smoothing scale that predicts held-out joints best.

        Each factor of ``velocity_scale_factors`` scales the nominal ``velocity_scale``; for each,
        the model is identified and the filter run (no noise tuning) on the first
        ``1 - HOLDOUT_FRACTION`` of the calibration log, and scored on the rest by the joint RMSE
        relative to the nominal scale's, averaged over the three joints.
        """
        nominal = nominal_parameters(log.arm)
        factors = tuple(float(f) for f in (self.velocity_scale_factors or ()))
        if any(not np.isfinite(f) or f <= 0 for f in factors):
            raise ValueError(f"velocity_scale_factors must be positive, got {self.velocity_scale_factors}")
        if len(factors) < 2 or "coulomb_friction" not in self.effects:
            return nominal
        cut = int(round((1.0 - HOLDOUT_FRACTION) * len(log)))
        part = lambda rows: MotorLog(time=log.time[rows], motor_positions=log.motor_positions[rows],
                                     motor_torques=log.motor_torques[rows], joints=log.joints[rows],
                                     payload_kg=None if log.payload_kg is None else log.payload_kg[rows],
                                     arm=log.arm)
        fit_part, held = part(slice(0, cut)), part(slice(cut, None))
        settled = slice(min(HOLDOUT_SETTLE, len(held) // 2), None)
        friction = nominal.effect("coulomb_friction")
        candidates, errors = [], []
        for factor in factors:
            candidate = nominal.with_effect(friction.replace(velocity_scale=friction.velocity_scale * factor))
            # the coasting noise only acts on missing readings and the covariance scale only on the
            # reported variances, not on the joints that score a trial: both are set once, for the final model
            trial = clone(self).set_params(base_parameters=candidate, tuning="none", verbose=0,
                                           coast_noise_scale=1.0, covariance_calibration=False)
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    estimates = trial.fit(fit_part).predict(held)
                error = np.sqrt(np.mean((estimates.joints - held.joints)[settled] ** 2, axis=0))
            except (NotIdentifiableError, ValueError, np.linalg.LinAlgError):
                error = np.full(3, np.inf)
            candidates.append(candidate)
            errors.append(error)
        errors = np.array(errors)
        reference = errors[factors.index(1.0)] if 1.0 in factors else np.nanmin(errors, axis=0)
        score = np.mean(errors / np.maximum(reference, 1e-12), axis=1)
        score[~np.isfinite(score)] = np.inf
        best = int(np.argmin(score))
        self.velocity_scale_scores_ = dict(zip(factors, score.tolist()))
        self._say(1, f"UKF: friction smoothing scale x{factors[best]:g} of nominal chosen on the last "
                     f"{HOLDOUT_FRACTION:.0%} of the calibration log (scores {self.velocity_scale_scores_})")
        return candidates[best]

    def _say(self, level: int, message: str) -> None:
        if int(self.verbose) >= level:
            print(message, flush=True)

    def fit_identified(self, result: IdentificationResult, log=None) -> "UKFJointEstimator":
        """Use an existing identification; tune the noise on ``log`` unless ``process_noise`` is given."""
        if not isinstance(result, IdentificationResult):
            raise TypeError(f"expected an IdentificationResult, got {type(result).__name__}")
        _check_model_class(result.effects)
        if self.tuning not in TUNING_CRITERIA:
            raise ValueError(f"tuning must be one of {TUNING_CRITERIA}, got {self.tuning!r}")
        needs_log = self.process_noise is None and self.tuning != "none"
        if needs_log and log is None:
            raise ValueError("noise tuning needs a log; pass one, or process_noise, or tuning='none'")
        if isinstance(log, CalibrationDataset) and log.n_invalid:
            log = log.select(log.valid_mask())
        return self._finish_fit(result, None if log is None else as_motor_log(log), self._settings())

    def _finish_fit(self, result: IdentificationResult, log: MotorLog | None, settings: UKFSettings):
        model = CableModel.from_parameters(result.parameters, result.offsets, self.payload_kg)
        limits = SampleLimits.from_constants(result.parameters.constants, result.parameters.arm)
        measurement = self._measurement_covariance(model)
        self.tuning_history_ = []
        if self.process_noise is not None:
            if not isinstance(self.process_noise, ProcessNoise):
                raise TypeError("process_noise must be a ProcessNoise or None")
            noise = self.process_noise
        else:
            period = float(np.median(np.diff(log.time))) if log is not None and len(log) > 1 else 1.0 / 30.0
            noise = physical_process_noise(model, result.report.torque_rmse, result.report.joint_rmse, period)
            if self.tuning != "none":
                started = time.perf_counter()
                noise = self._tune(noise, model, measurement, log, settings, limits)
                self._say(1, f"UKF: noise tuned ({self.tuning}) in {len(self.tuning_history_)} filter runs, "
                             f"{time.perf_counter() - started:.1f} s")
        self.identification_ = result
        self.arm_ = result.parameters.arm
        self.limits_ = limits
        self.model_ = model
        self.process_noise_ = noise
        self.measurement_noise_ = measurement
        self.covariance_scale_ = np.ones(3)
        if self.covariance_calibration and log is not None and log.has_truth:
            self.covariance_scale_ = self._covariance_scale(log, settings)
        self.coast_noise_scale_ = settings.coast_noise_scale
        if self.coast_noise_scale == "auto":
            self.coast_noise_scale_ = 1.0
            if log is not None and log.has_truth:
                self.coast_noise_scale_ = self._coast_scale(log, settings)
        return self

    def _tune(self, start: ProcessNoise, model: CableModel, measurement: np.ndarray, log: MotorLog,
              settings: UKFSettings, limits: SampleLimits) -> ProcessNoise:
        if not (np.isfinite(self.tuning_seconds) and self.tuning_seconds > 0):
            raise ValueError(f"tuning_seconds must be positive, got {self.tuning_seconds!r}")
        window = log.between(log.time[0], log.time[0] + float(self.tuning_seconds))
        if len(window) < 10:
            raise ValueError("the tuning window holds fewer than 10 samples")
        if self.tuning == "joint_error":
            if not window.has_truth:
                raise ValueError("tuning='joint_error' needs ground truth in the log")
            raw = (window.motor_positions / model.transmission_ratio) @ model.nominal_coupling.T
            raw_mse = np.mean((raw - window.joints) ** 2, axis=0)

        def objective(vector):
            noise = ProcessNoise.from_vector(vector)
            estimates = run_filter(window, model, noise, measurement, settings, warn=False, limits=limits,
                                   likelihood=self.tuning == "likelihood")
            if self.tuning == "likelihood":
                value = -estimates.log_likelihood / len(window)
            else:
                value = float(np.sum(np.mean((estimates.joints - window.joints) ** 2, axis=0) / raw_mse))
            # a noise under which the filter diverges is no candidate, however likely its readings
            if not np.isfinite(value) or any(reason in DIVERGENCE_REASONS for _, reason in estimates.reinitialisations):
                value = 1e30
            self.tuning_history_.append((np.asarray(vector, dtype=float).copy(), float(value)))
            self._say(2, f"UKF: tuning run {len(self.tuning_history_)}: objective {value:.6g}")
            return value

        x0 = start.as_vector()
        simplex = np.vstack([x0] + [x0 + 0.5 * np.eye(x0.size)[k] for k in range(x0.size)])
        solution = minimize(objective, x0, method="Nelder-Mead",
                            options={"maxfev": int(self.tuning_evaluations), "initial_simplex": simplex,
                                     "xatol": 0.02, "fatol": 1e-6})
        best = min(self.tuning_history_, key=lambda item: item[1])[0] if self.tuning_history_ else solution.x
        return ProcessNoise.from_vector(best)

    def _covariance_scale(self, log: MotorLog, settings: UKFSettings) -> np.ndarray:
        """Mean over the tuning window (after its first second) of squared joint error over variance."""
        window = log.between(log.time[0], log.time[0] + float(self.tuning_seconds))
        if len(window) < 10:
            return np.ones(3)
        estimates = run_filter(window, self.model_, self.process_noise_, self.measurement_noise_, settings,
                               limits=self.limits_, warn=False)
        settled = window.time >= window.time[0] + 1.0
        variance = np.einsum("nii->ni", estimates.covariance)[settled]
        ratio = (estimates.joints - window.joints)[settled] ** 2 / variance
        scale = np.mean(ratio, axis=0) if ratio.shape[0] else np.ones(3)
        return np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)

    def _coast_scale(self, log: MotorLog, settings: UKFSettings) -> float:
        """Smallest of :data:`COAST_SCALES` whose coasting spread covers the coasted joint errors."""
        window = log.between(log.time[0], log.time[0] + float(self.tuning_seconds))
        t = window.time - window.time[0]
        starts = np.arange(2.0, t[-1] - settings.max_gap - 1.0, COAST_SPACING)
        if len(window) < 10 or starts.size == 0:
            return 1.0
        blank = np.zeros(len(window), dtype=bool)
        for start in starts:
            # strictly shorter than max_gap, so the filter coasts and never re-initialises
            blank |= (t >= start) & (t < start + 0.9 * settings.max_gap)
        for scale in COAST_SCALES:
            trial = dataclasses.replace(settings, coast_noise_scale=scale)
            estimates = run_filter(window, self.model_, self.process_noise_, self.measurement_noise_, trial,
                                   valid=~blank, limits=self.limits_, covariance_scale=self.covariance_scale_,
                                   warn=False)
            spread = np.sqrt(np.einsum("nii->ni", estimates.covariance))[blank]
            error = np.abs(estimates.joints - window.joints)[blank]
            if np.all(np.mean(error <= 3.0 * spread, axis=0) >= COAST_COVERAGE):
                return scale
        return COAST_SCALES[-1]

    # ---- filtering -----------------------------------------------------------------------

    def predict(self, log, *, eigenvalues: bool = False) -> JointEstimates:
        """Run the filter over a time-ordered log.

        Parameters
        ----------
        log : CalibrationDataset, Recording or MotorLog of the calibration log's arm (ground truth
            not needed). Time in seconds at a RAVEN-II log rate. Rows a dataset flags (``valid``
            False) and non-finite readings are coasted through, NaN or implausible torques
            replaced by the last good one, implausible and gated readings rejected, gaps
            predicted across (re-initialisation after ``max_gap``); all counted in the result and
            in one :class:`~estimators.ukf.run.UKFFaultWarning`.
        eigenvalues : also record the smallest eigenvalue of the full state covariance at every
            sample (positive definiteness check).

        Returns
        -------
        JointEstimates
            ``joints`` (N, 3) rad, rad, m and ``covariance`` (N, 3, 3) at every log sample, the
            sample codes ``flags`` and the counts (``events``).

        Raises
        ------
        ValueError
            The log is of the other arm, its time is not in seconds, or it has no usable reading.
        """
        check_is_fitted(self, "model_")
        log, valid = _filter_input(log)
        arm = getattr(self, "arm_", log.arm)
        if log.arm != arm:
            raise ValueError(f"the log is of the {log.arm} arm, but the filter's model was identified on the {arm} arm")
        started = time.perf_counter()
        estimates = run_filter(log, self.model_, self.process_noise_, self.measurement_noise_, self._settings(),
                               valid=valid, limits=getattr(self, "limits_", None),
                               covariance_scale=getattr(self, "covariance_scale_", None), eigenvalues=eigenvalues)
        self._say(1, f"UKF: filtered {len(log)} samples ({log.time[-1] - log.time[0]:.0f} s of log) in "
                     f"{time.perf_counter() - started:.1f} s; events {estimates.events}")
        return estimates


def _filter_input(source) -> tuple[MotorLog, np.ndarray]:
    """The motor signals of a log and its usable-row mask; infinite values (in flagged rows) become NaN."""
    if not isinstance(source, CalibrationDataset):
        log = as_motor_log(source)
        return log, np.ones(len(log), dtype=bool)
    table = source.table
    with np.errstate(invalid="ignore"):
        positions = np.array(table.loc[:, list(MOTOR_POSITION_COLUMNS)].to_numpy(dtype=float))
        torques = np.array(table.loc[:, list(MOTOR_TORQUE_COLUMNS)].to_numpy(dtype=float))
    positions[np.isinf(positions)] = np.nan
    torques[np.isinf(torques)] = np.nan
    log = MotorLog(time=source.time, motor_positions=positions, motor_torques=torques, arm=source.arm)
    return log, source.valid_mask()


def _check_model_class(effects) -> None:
    """Refuse effects the filter's process model does not simulate (it would ignore them)."""
    outside = [name for name in effects if name not in FITTABLE_EFFECTS]
    if outside:
        raise ValueError(f"the UKF's process model has no {', '.join(outside)}; its model class is "
                         f"{', '.join(FITTABLE_EFFECTS)}")
