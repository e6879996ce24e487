"""casadi (nlpsol + IPOPT) identification of the cable transmission of the positioning joints.

:func:`identify` fits the parameters of the chosen effects (cable stiffness law, damping, friction,
gravity load scale, coupling) and the session's joint offsets to a log with ground-truth joints,
by weighted least squares on the equation errors of :mod:`.residuals`:

1. derivatives, gravity and inertia at every sample (:func:`~.samples.prepare_samples`); samples
   near a stop of a joint leave out the residuals that involve its friction (dry friction is
   set-valued at a stop, the model's ``tanh`` law is not; see :func:`_usage_weights`);
2. a structural check at the initial guess: parameters the data cannot tell apart (a rank-deficient
   residual Jacobian, e.g. no motion, constant torque) raise :class:`NotIdentifiableError`;
3. feasible generalized least squares: solve with every residual channel scaled by its RMS, rescale
   by the new RMS, solve again (``reweight_passes`` times), so joint errors (rad) and torque errors
   (N m) are weighted by their own noise levels;
4. standard errors from the residual Jacobian: ``(J^T J)^-1`` sandwiched with a Newey-West estimate
   of the score covariance (``covariance="hac"``, the default: model error makes neighbouring
   residuals of a 30 Hz log correlated), or the classical ``s^2 (J^T J)^-1``; confidence intervals
   through the parameter transforms; estimates whose standard error exceeds ``max_relative_error``
   of their magnitude, or that end on the bound of their search range, raise a
   :class:`PoorlyIdentifiedWarning`.

The standard errors account for the noise of the measured joints and torques; the velocities and
accelerations enter as exact regressors, so noise in them (derivatives of quantized encoders) is
not in the intervals. With RAVEN-II encoder resolutions the estimates sit within a few percent of
the truth on the virtual RAVEN-II, which can be a few standard errors on long logs.
"""

from __future__ import annotations

import threading
import time
import warnings
from collections import OrderedDict
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.stats import norm

from simulation.model.laws import cable_stretch_curve
from simulation.model.constants import coupling_matrix
from simulation.model.parameters import RavenParameters
from simulation.identification.nominal import nominal_parameters
from simulation.identification.layout import (
    COULOMB,
    COUPLING_DELTA,
    DAMPING,
    DEFAULT_FIXED,
    FITTABLE_EFFECTS,
    GEARBOX_LOSS,
    HARDENING,
    LOAD_SCALE,
    MOTOR_COULOMB,
    OFFSET,
    OFFSETS,
    QUANTITIES,
    RATIO_ERROR,
    SLOT_NAMES,
    STIFFNESS,
    VISCOUS,
    ParameterLayout,
    build_layout,
)
from simulation.identification.compiled import SampleFunctions, compiled_maps, mapped, sample_functions
from simulation.identification.residuals import D_GRAVITY, D_INERTIAL, D_Q, D_QD, D_TAU, D_U, D_UD, D_UDD, D_WQ, D_WT, N_DATA, residual_function
from simulation.identification.result import FitReport, IdentificationResult, NotIdentifiableError, ParameterEstimate, PoorlyIdentifiedWarning
from simulation.identification.samples import DERIVATIVE_WINDOW, IdentificationSamples, prepare_samples

MIN_SPEED_FACTOR = 5.0
"""Residuals involving a joint's dry friction are used where it moves faster than this many
velocity scales of the ``tanh`` law (there ``tanh`` is within 1e-4 of the sign)."""
RANK_TOLERANCE = 1e-7
"""Singular values of the column-normalised Jacobian below this fraction of the largest mark
parameter combinations the data cannot determine."""
SIGMA_FLOOR = np.array([1e-9, 1e-9, 1e-10, 1e-9, 1e-9, 1e-8])
ACCEPTED_STATUS = ("Solve_Succeeded", "Solved_To_Acceptable_Level")


def _data_matrix(samples: IdentificationSamples, joint_weight: np.ndarray, torque_weight: np.ndarray) -> np.ndarray:
    d = np.empty((N_DATA, len(samples)))
    d[D_Q] = samples.joints.T
    d[D_QD] = samples.joint_velocity.T
    d[D_INERTIAL] = samples.inertial.T
    d[D_GRAVITY] = samples.gravity.T
    d[D_U] = samples.motor.T
    d[D_UD] = samples.motor_velocity.T
    d[D_UDD] = samples.motor_acceleration.T
    d[D_TAU] = samples.motor_torque.T
    d[D_WQ] = joint_weight.T
    d[D_WT] = torque_weight.T
    return d


COUPLED_FRICTION_SHARE = 0.05
"""A coupled joint's stop matters to a motor's torque residual when its friction, carried through
the coupling, exceeds this share of the motor's own joint friction."""


def _dilate(flags: np.ndarray, width: int) -> np.ndarray:
    """Columns of 0/1 flags spread to ``width`` samples around each set sample."""
    kernel = np.ones(width)
    return np.column_stack([np.convolve(flags[:, i], kernel, mode="same") for i in range(flags.shape[1])]) > 0.0


def _usage_weights(samples: IdentificationSamples, min_speed: np.ndarray, window: float,
                   params: RavenParameters) -> tuple[np.ndarray, np.ndarray]:
    """0/1 weights of the joint and torque residuals: 0 where dry friction makes the model unsure.

    At a stop a joint's dry friction is set-valued, and its cable stretch flips by twice the
    friction over a few tens of milliseconds. So a joint residual is dropped within half a
    derivative window of a sample where its joint is slower than ``min_speed`` or has reversed
    since the previous sample (the smoothed derivatives spread a stop over the window). The torque
    of motor ``i`` carries, through ``A^T``,
    the tensions of joints ``j > i`` (dropped near their stops when their friction reaches the motor
    with a noticeable share), and through the motor inertia the stretch changes of joints ``j < i``
    that its motor coordinate follows (dropped near their starts and stops).
    """
    velocity = samples.joint_velocity
    slow = np.abs(velocity) <= min_speed
    # a reversal between two samples is a stop too, however fast the joint is at both
    slow[1:] |= np.sign(velocity[1:]) != np.sign(velocity[:-1])
    if not np.any(min_speed > 0) or len(samples) < 2:
        ones = np.ones((len(samples), 3))
        return ones, ones.copy()
    step = float(np.median(np.diff(samples.time)))
    width = 2 * int(round(0.5 * window / step)) + 1
    near_stop = _dilate(slow.astype(float), width)
    changes = np.vstack([np.zeros((1, 3), dtype=bool), slow[1:] != slow[:-1]])
    near_change = _dilate(changes.astype(float), width)
    joint_weight = (~near_stop).astype(float)
    coupling = np.abs(params.constants.nominal_coupling())
    force = params.effect("coulomb_friction").force
    torque_weight = np.empty_like(joint_weight)
    for i in range(3):
        carried = [j for j in range(i + 1, 3) if coupling[j, i] * force[j] > COUPLED_FRICTION_SHARE * force[i]]
        keep = ~near_stop[:, i] & ~np.any(near_stop[:, carried], axis=1) & ~np.any(near_change[:, :i], axis=1)
        torque_weight[:, i] = keep
    return joint_weight, torque_weight


def _initial_offsets(samples: IdentificationSamples, params: RavenParameters, effects) -> np.ndarray:
    """Offsets that make the base model's mean joint error zero (the solver refines them)."""
    c = params.constants
    delta = params.effect("coupling").delta if "coupling" in effects else np.zeros(3)
    a = coupling_matrix(*(np.asarray(c.cable_coupling) + delta))
    if "transmission_error" in effects and params.is_enabled("transmission_error"):
        a = a / (1.0 + params.effect("transmission_error").ratio_error)[None, :]
    predicted = samples.motor @ a.T
    if "cable_stretch" in effects:
        law = params.effect("cable_stretch")
        scale = params.effect("gravity_stretch").load_scale if "gravity_stretch" in effects else np.zeros(3)
        tension = samples.inertial + scale * samples.gravity
        stretch = np.column_stack([cable_stretch_curve(tension[:, i], law.stiffness[i], law.hardening[i])
                                   for i in range(3)])
        predicted = predicted - stretch
    return np.mean(samples.joints - predicted, axis=0)


_WARM_START = {"warm_start_init_point": "yes", "mu_init": 1e-2, "mu_strategy": "adaptive",
               "warm_start_bound_push": 1e-9, "warm_start_mult_bound_push": 1e-9}
"""IPOPT options of a reweighting pass, which starts at the previous pass's solution: a smaller
barrier parameter than IPOPT's 0.1, no push away from the bounds (so it does not first walk back
into the interior) and the adaptive barrier update. With the monotone update the pass crawled where
the model fits to the encoders' resolution: on two-minute logs of the discrepancy tests, 128
iterations with nothing hidden and 176 with an eccentric capstan, against 6 and 17 adaptive, with
estimates within 0.12 standard errors and replayed joints within 3e-9 rad
(``python benchmarks/bench_identification.py`` times a whole fit). The first pass, from the
uninformed start, keeps the monotone update: adaptive from there, the capstan log stalls at the
200-iteration limit."""


@dataclass(frozen=True)
class _SampleMaps:
    """The per-sample functions mapped over ``n`` samples; the unknowns, the channel scales and the
    references are shared by every sample, the data matrix has one column per sample. ``compiled``:
    the maps themselves are machine code (:func:`~.compiled.compiled_maps`), not only the
    per-sample functions they call."""

    cost: ca.Function
    gauss_newton: ca.Function
    residual: ca.Function
    jacobian: ca.Function
    compiled: bool = False


_CACHE_SIZE = 16
"""Mapped functions and solvers kept per thread, the most recently used first. The discrepancy
workflow re-identifies one structure on one record many times (19 fits in one analysis of a
two-minute record); building the solvers took 9.1 s and the maps 1.2 s of those fits' 21.9 s
under the profiler."""

COMPILE_MAPS_AT = 4
"""The identification of a structure on a record of a given length that has its maps compiled
(:func:`~.compiled.compiled_maps`): the fourth, and every later one while they are remembered.
Compiling them takes about a second, and each identification of a two-minute record then takes
about a third less, to the same estimates (``python benchmarks/bench_identification.py``): a
structure and length seen once or twice (most logs of the UKF and of the tests) are not worth it,
the two dozen re-identifications of a discrepancy analysis are."""


class _Caches(threading.local):
    """Each thread keeps its own: a solver's statistics are those of its last call."""

    def __init__(self):
        self.maps: OrderedDict = OrderedDict()
        self.solvers: OrderedDict = OrderedDict()
        self.uses: dict = {}


_CACHES = _Caches()


def _remembered(cache: OrderedDict, functions: SampleFunctions, key: tuple, build):
    """``build()`` for ``functions`` and ``key``, or the value remembered for them."""
    key = (id(functions),) + key
    if key in cache:
        cache.move_to_end(key)
        return cache[key][1]
    value = build()
    # the functions stay alive beside the value, so their id is not reused while the entry lives
    cache[key] = (functions, value)
    while len(cache) > _CACHE_SIZE:
        cache.popitem(last=False)
    return value


def _sample_maps(functions: SampleFunctions, n: int) -> _SampleMaps:
    """The maps of ``functions`` over ``n`` samples for one more identification: compiled whole
    from the :data:`COMPILE_MAPS_AT`-th identification of this structure and length on, the
    virtual machine's before (or when nothing compiles)."""
    # the per-sample functions live as long as the process (compiled._CACHE), so their id is theirs
    key = (id(functions), n)
    _CACHES.uses[key] = _CACHES.uses.get(key, 0) + 1
    if _CACHES.uses[key] >= COMPILE_MAPS_AT and functions.compiled:
        maps = _remembered(_CACHES.maps, functions, (n, True), lambda: compiled_maps(functions, n))
        if maps is not None:
            return _SampleMaps(**maps, compiled=True)
    return _remembered(_CACHES.maps, functions, (n, False), lambda: _SampleMaps(**mapped(functions, n)))


def _solver(functions: SampleFunctions, maps: _SampleMaps, n: int, max_iterations: int, print_level: int,
            warm: bool) -> ca.Function:
    """IPOPT on the mean sample cost, with the data, the channel scales and the references as the
    problem's parameter vector ``[vec(data); sigma; references]`` (data column by column), so that
    one solver serves every fit of a structure to a record of ``n`` samples.

    The bounds are IPOPT's own variable bounds (an ``Opti`` with the same problem spends about
    0.2 s per solve building constraint functions). The Hessian of the Lagrangian is the
    Gauss-Newton ``J^T J / n``: one Jacobian pass instead of the exact Hessian's ``p``
    second-order passes, and the least-squares curvature IPOPT converges with in a few iterations
    here.
    """
    def build():
        p, rows, n_sigma, n_references = (functions.cost.size1_in(i) for i in range(4))
        xi = ca.MX.sym("xi", p)
        parameters = ca.MX.sym("p", rows * n + n_sigma + n_references)
        data = ca.reshape(parameters[:rows * n], rows, n)
        sigma = parameters[rows * n:rows * n + n_sigma]
        references = parameters[rows * n + n_sigma:]
        lam_f = ca.MX.sym("lam_f")
        hessian = ca.Function(
            "nlp_hess_l", [xi, parameters, lam_f, ca.MX.sym("lam_g", 0)],
            [ca.triu(lam_f * maps.gauss_newton(xi, data, sigma, references) / n)],
            ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])
        return ca.nlpsol("identification", "ipopt",
                         {"x": xi, "p": parameters, "f": maps.cost(xi, data, sigma, references) / n}, {
                             "print_time": False, "hess_lag": hessian,
                             "ipopt": {"print_level": int(print_level), "sb": "yes", "max_iter": int(max_iterations),
                                       "tol": 1e-8, "acceptable_tol": 1e-5, "acceptable_iter": 2,
                                       **(_WARM_START if warm else {})}})

    return _remembered(_CACHES.solvers, functions, (n, maps.compiled, int(max_iterations), int(print_level), bool(warm)),
                       build)


class _Problem:
    """The residuals of one fit as fast casadi maps over the samples."""

    def __init__(self, layout: ParameterLayout, params: RavenParameters, data: np.ndarray):
        velocity_scale = params.effect("coulomb_friction").velocity_scale
        self.layout = layout
        self.n = data.shape[1]
        self.p = len(layout)
        self.data = np.asarray(data, dtype=float)
        self.functions = sample_functions(residual_function(layout, params.constants, velocity_scale))
        self.maps = _sample_maps(self.functions, self.n)
        self.references = layout.references()

    def residuals(self, xi, sigma) -> np.ndarray:
        """(n, 6) weighted, scaled residuals."""
        return np.array(self.maps.residual(xi, self.data, sigma, self.references)).T

    def jacobian(self, xi, sigma) -> np.ndarray:
        """(n, 6, p) Jacobian of the residuals with respect to the unknowns."""
        blocks = np.array(self.maps.jacobian(xi, self.data, sigma, self.references))
        return blocks.reshape(6, self.n, self.p).transpose(1, 0, 2)

    def solve(self, xi0, sigma, max_iterations: int, print_level: int = 0,
              warm: bool = False) -> tuple[np.ndarray, int, str]:
        solver = _solver(self.functions, self.maps, self.n, max_iterations, print_level, warm)
        lower, upper = self.layout.bounds()
        parameters = np.concatenate([self.data.ravel(order="F"), np.asarray(sigma, dtype=float), self.references])
        solution = solver(x0=np.asarray(xi0, dtype=float), p=parameters, lbx=lower, ubx=upper)
        stats = solver.stats()
        value = np.asarray(solution["x"], dtype=float).ravel()
        return value, int(stats.get("iter_count", 0)), str(stats.get("return_status"))


def _channel_rms(residuals: np.ndarray, used: np.ndarray) -> np.ndarray:
    return np.sqrt(np.sum(residuals ** 2, axis=0) / np.maximum(used, 1))


def _structural_check(problem: _Problem, xi: np.ndarray, sigma: np.ndarray) -> None:
    """Raise if the Jacobian at ``xi`` is rank-deficient, naming the confounded parameters."""
    names = problem.layout.names
    jac = problem.jacobian(xi, sigma).reshape(-1, problem.p)
    norms = np.linalg.norm(jac, axis=0)
    silent = [names[k] for k in np.flatnonzero(norms <= 1e-12 * max(norms.max(), 1e-300))]
    if silent:
        raise NotIdentifiableError(
            f"the data carry no information on {', '.join(silent)} (no motion or no load change moves them); "
            "record motion that excites them or hold them fixed")
    # the singular values and directions of the tall (samples x unknowns) matrix are those of its
    # triangular factor, whose decomposition is the cheaper route
    _, singular, vt = np.linalg.svd(np.linalg.qr(jac / norms, mode="r"))
    weak = np.flatnonzero(singular < RANK_TOLERANCE * singular[0])
    if weak.size:
        groups = []
        for k in weak:
            members = [names[i] for i in np.flatnonzero(np.abs(vt[k]) > 0.1)]
            groups.append("{" + ", ".join(members) + "}")
        raise NotIdentifiableError(
            "the data cannot tell these parameters apart: " + "; ".join(groups)
            + " (e.g. no motion or constant torque); record richer motion or hold some of them fixed")


def _hac_scores(jac: np.ndarray, residuals: np.ndarray, lags: int) -> np.ndarray:
    """Newey-West estimate of the covariance of the summed scores ``J_n^T r_n``.

    The Bartlett-weighted sum over lags ``sum_{|l| <= L} (1 - |l| / (L + 1)) sum_t s_{t+l} s_t^T``
    is computed as ``W^T W / (L + 1)``, ``W`` the sums of the scores over every window of ``L + 1``
    consecutive samples of the series padded with ``L`` zeros at each end: a pair of samples ``l``
    apart shares ``L + 1 - l`` such windows. One product of ``n + L`` rows instead of one per lag.
    """
    scores = np.einsum("nrp,nr->np", jac, residuals)
    lags = max(int(lags), 0)
    if lags == 0:
        return scores.T @ scores
    cumulative = np.zeros((scores.shape[0] + 2 * lags + 1, scores.shape[1]))
    np.cumsum(scores, axis=0, out=cumulative[lags + 1:lags + 1 + scores.shape[0]])
    cumulative[lags + 1 + scores.shape[0]:] = cumulative[lags + scores.shape[0]]
    windows = cumulative[lags + 1:] - cumulative[:-(lags + 1)]
    return windows.T @ windows / (lags + 1.0)


def _covariance(jac: np.ndarray, residuals: np.ndarray, used: np.ndarray, method: str,
                lags: int) -> tuple[np.ndarray, float]:
    """Covariance of the unknowns from the residual Jacobian, and the Jacobian's condition number.

    The inverse of ``J^T J`` floors its eigenvalues instead of dropping them, so a direction the
    data leave flat shows as a huge variance rather than none. The sandwich of ``method="hac"``
    would give such a direction ``v' Omega v / floor^2`` with ``v' Omega v`` itself close to zero
    (the scores have no component along a flat direction): a tiny variance decided by rounding.
    Flat directions therefore get the classical variance ``s^2 / floor`` in both methods, and the
    sandwich covers the others.
    """
    flat = jac.reshape(-1, jac.shape[2])
    hessian = flat.T @ flat
    values, vectors = np.linalg.eigh(hessian)
    floor = max(float(values[-1]), 1e-300) * 1e-18
    inverse = (vectors / np.maximum(values, floor)) @ vectors.T
    dof = max(float(used.sum()) - jac.shape[2], 1.0)
    noise = float(np.sum(residuals ** 2) / dof)
    if method == "hac":
        cov = inverse @ _hac_scores(jac, residuals, lags) @ inverse
        floored = values < floor
        if np.any(floored):
            kept = vectors[:, ~floored]
            projector = kept @ kept.T
            cov = projector @ cov @ projector + (vectors[:, floored] * (noise / floor)) @ vectors[:, floored].T
    else:
        cov = inverse * noise
    scale = np.sqrt(np.maximum(np.diag(hessian), 1e-300))
    normalised = np.linalg.eigvalsh(hessian / np.outer(scale, scale))
    condition = float(np.sqrt(normalised[-1] / max(normalised[0], 1e-300)))
    return cov, condition


def _estimates(layout: ParameterLayout, xi: np.ndarray, cov_xi: np.ndarray, confidence: float,
               max_relative_error: float) -> tuple[list[ParameterEstimate], np.ndarray, list[str]]:
    """Estimates with standard errors and intervals in physical units, their covariance, and the
    names of the poorly identified ones."""
    se_xi = np.sqrt(np.maximum(np.diag(cov_xi), 0.0))
    gradient = layout.derivatives(xi)
    z = float(norm.ppf(0.5 + confidence / 2.0))
    lower, upper = layout.bounds()
    with np.errstate(invalid="ignore"):
        at_bound = (xi - lower <= 1e-6) | (upper - xi <= 1e-6)
    estimates, poorly = [], []
    for k, spec in enumerate(layout.specs):
        value = spec.value(xi[k])
        with np.errstate(over="ignore"):  # a flat direction's interval reaches infinity
            ends = sorted((spec.value(xi[k] - z * se_xi[k]), spec.value(xi[k] + z * se_xi[k])))
        se = abs(gradient[k]) * se_xi[k]
        estimates.append(ParameterEstimate(spec.name, float(value), float(se), float(ends[0]), float(ends[1]),
                                           float(spec.reference)))
        relative = se_xi[k] if spec.transform == "log" else se / max(abs(value), spec.scale)
        if not relative <= max_relative_error or at_bound[k]:
            poorly.append(spec.name)
    return estimates, cov_xi * np.outer(gradient, gradient), poorly


def _fitted_parameters(base: RavenParameters, effects, slots: np.ndarray) -> RavenParameters:
    fitted = base.only(*effects) if effects else base.only()
    updates = {
        "cable_stretch": dict(stiffness=slots[STIFFNESS], hardening=slots[HARDENING], damping=slots[DAMPING]),
        "gravity_stretch": dict(load_scale=slots[LOAD_SCALE]),
        "coupling": dict(delta=slots[COUPLING_DELTA]),
        "coulomb_friction": dict(force=np.maximum(slots[COULOMB], 0.0)),
        "viscous_friction": dict(coefficient=np.maximum(slots[VISCOUS], 0.0)),
        # the tool DOFs' friction is not in a positioning joints' log: zero, not the class defaults
        "motor_friction": dict(coulomb=np.r_[np.maximum(slots[MOTOR_COULOMB], 0.0), np.zeros(4)],
                               gearbox_loss=np.r_[np.maximum(slots[GEARBOX_LOSS], 0.0), np.zeros(4)]),
        "transmission_error": dict(ratio_error=slots[RATIO_ERROR]),
    }
    for name in effects:
        fitted = fitted.with_effect(fitted.effect(name).replace(**updates[name]))
    return fitted


def identify(log, *, effects=FITTABLE_EFFECTS, base: RavenParameters | None = None, fixed=DEFAULT_FIXED,
             confidence: float = 0.95, derivative_window: float = DERIVATIVE_WINDOW, min_speed=None,
             reweight_passes: int = 1, covariance: str = "hac", hac_window: float = 1.0,
             max_iterations: int = 200, max_relative_error: float = 0.5, verbose: int = 0) -> IdentificationResult:
    """Fit the cable model of the positioning joints to a log with ground-truth joints.

    Parameters
    ----------
    log : MotorLog, CalibrationDataset or Recording with motor positions, motor torques and
        ground-truth joints (e.g. the calibration run), or prepared :class:`IdentificationSamples`.
    effects : the effects in the model (subset of :data:`~.layout.IDENTIFIABLE_EFFECTS`; by default
        :data:`FITTABLE_EFFECTS`, the UKF's model class); their parameters are estimated, every
        other effect is off in the returned parameter set.
    base : parameter set giving the constants, gravity vector, friction velocity scale, initial
        guesses and fixed values (default: :func:`~.nominal.nominal_parameters`, the controller's
        constants and round effect values; never the simulator's own).
    fixed : parameters held at ``base``'s values, by name or field (default: the cable damping,
        see :data:`~.layout.DEFAULT_FIXED`).
    confidence : level of the reported confidence intervals.
    derivative_window : Savitzky-Golay window for the derivatives (s).
    min_speed : (3,) joint speed below which residuals involving that joint's dry friction are left
        out (rad/s, rad/s, m/s); default ``5 * velocity_scale`` when Coulomb friction is modelled, else 0.
    reweight_passes : re-solves after rescaling each residual channel by its RMS.
    covariance : ``"hac"`` (Newey-West over ``hac_window`` seconds) or ``"classical"``.
    max_iterations : IPOPT iteration limit per pass.
    verbose : 0 prints nothing; 1 prints one line per solver pass (iterations, status, elapsed) to
        stdout; 2 or more also shows IPOPT's own iteration log.
    max_relative_error : standard error, as a fraction of the magnitude, beyond which an estimate is
        reported as poorly identified.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    NotIdentifiableError
        The data cannot determine the free parameters (no motion, constant torque, confounded).
    ValueError
        Unknown effects or parameter names, a log without ground truth, or bad options.
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}")
    if covariance not in ("hac", "classical"):
        raise ValueError(f"covariance must be 'hac' or 'classical', got {covariance!r}")
    if int(reweight_passes) < 0:
        raise ValueError(f"reweight_passes must be >= 0, got {reweight_passes}")
    if isinstance(fixed, str):
        fixed = (fixed,)
    effects = tuple(effects)
    if base is None:
        arm = getattr(log, "arm", "left")
        base = nominal_parameters(arm)
    samples = log if isinstance(log, IdentificationSamples) else prepare_samples(log, base, derivative_window)
    velocity_scale = base.effect("coulomb_friction").velocity_scale
    if min_speed is None:
        min_speed = MIN_SPEED_FACTOR * velocity_scale if "coulomb_friction" in effects else np.zeros(3)
    min_speed = np.broadcast_to(np.asarray(min_speed, dtype=float), (3,))
    if not np.all(np.isfinite(min_speed) & (min_speed >= 0)):
        raise ValueError(f"min_speed must be 3 non-negative speeds, got {min_speed}")

    layout = build_layout(effects, fixed, base, _initial_offsets(samples, base, effects))
    if len(layout) == 0:
        raise ValueError("every parameter is fixed: nothing to identify")
    joint_weight, torque_weight = _usage_weights(samples, min_speed, derivative_window, base)
    used = np.concatenate([joint_weight.sum(axis=0), torque_weight.sum(axis=0)])
    if np.any(used[:3] < 10):
        slow = [name for name, n in zip(("shoulder", "elbow", "z_ins"), used[:3]) if n < 10]
        raise NotIdentifiableError(
            f"joints {slow} never move faster than min_speed {min_speed} in this log: their cable law and "
            "friction are not identifiable (no motion)")
    problem = _Problem(layout, base, _data_matrix(samples, joint_weight, torque_weight))

    xi = np.zeros(len(layout))
    sigma = np.maximum(_channel_rms(problem.residuals(xi, np.ones(6)), used), SIGMA_FLOOR)
    _structural_check(problem, xi, sigma)
    converged = True
    started = time.perf_counter()
    for k in range(int(reweight_passes) + 1):
        xi, iterations, status = problem.solve(xi, sigma, max_iterations, print_level=5 if verbose >= 2 else 0,
                                               warm=k > 0)
        converged = converged and status in ACCEPTED_STATUS
        if verbose >= 1:
            print(f"identify: pass {k + 1} of {int(reweight_passes) + 1}, {len(samples)} samples, {len(layout)} "
                  f"unknowns: {iterations} IPOPT iterations, {status}, {time.perf_counter() - started:.1f} s",
                  flush=True)
        sigma = np.maximum(sigma * _channel_rms(problem.residuals(xi, sigma), used), SIGMA_FLOOR)
    if not converged:
        warnings.warn(f"IPOPT did not converge (status {status}); the estimates are the last iterate",
                      RuntimeWarning, stacklevel=2)

    residuals = problem.residuals(xi, sigma)
    jac = problem.jacobian(xi, sigma)
    step = float(np.median(np.diff(samples.time))) if len(samples) > 1 else 1.0
    cov_xi, condition = _covariance(jac, residuals, used, covariance, max(int(round(hac_window / step)), 0))
    estimates, cov, poorly = _estimates(layout, xi, cov_xi, confidence, max_relative_error)
    if poorly:
        warnings.warn(f"poorly identified (standard error above {max_relative_error:.0%} of the value, or at the "
                      "bound of the search range): " + ", ".join(poorly), PoorlyIdentifiedWarning, stacklevel=2)
    raw = residuals * sigma
    report = FitReport(
        joint_rmse=_channel_rms(raw[:, :3], used[:3]),
        torque_rmse=_channel_rms(raw[:, 3:], used[3:]),
        n_samples=len(samples),
        n_joint_used=used[:3].astype(int),
        n_torque_used=used[3:].astype(int),
        iterations=iterations,
        solver_status=status,
        converged=converged,
        condition_number=condition,
        covariance_method=covariance,
        poorly_identified=tuple(poorly),
    )
    slots = layout.slots(xi)
    held = tuple(name for name in _slot_names_in_model(layout) if name not in layout.names)
    return IdentificationResult(
        parameters=_fitted_parameters(base, effects, slots),
        offsets=slots[OFFSETS].copy(),
        estimates=tuple(estimates),
        covariance=cov,
        report=report,
        effects=effects,
        fixed=held,
        confidence=float(confidence),
    )


def _slot_names_in_model(layout: ParameterLayout) -> tuple[str, ...]:
    """Names of the slots the model uses (its effects' parameters and the offsets)."""
    names = []
    for index, quantity in enumerate(QUANTITIES):
        if quantity.effect == OFFSET or quantity.effect in layout.effects:
            if layout.rigid and quantity.effect == "cable_stretch":
                continue
            names.extend(SLOT_NAMES[3 * index:3 * index + 3])
    return tuple(names)
