"""Fitting a candidate effect to a residual with casadi, and scoring it on other data.

The residual is measured minus replayed, for the joints and (when the data has them) the motor
torques, each channel divided by its typical size on the starting model so the two weigh alike.
Constant offsets are profiled out in closed form (a registration offset is not an effect). The
candidate's parameters are found by casadi's Opti with IPOPT, the replay entering as a casadi
callback whose gradient casadi takes by finite differences (the replay runs operators such as
backlash and stick-slip friction sample by sample, which have no symbolic form); a few starting
points guard against local minima. A candidate whose contribution is linear in its parameters
(``Candidate.basis``, e.g. a weighted sum of play operators) is fitted in closed form instead, by
bounded linear least squares with a ridge penalty chosen by cross-validation over blocks of the fit
part in time (:func:`ridge_penalty`).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
from numba import njit

from simulation.discrepancy.candidates import Candidate
from simulation.discrepancy.signals import MeasuredSignals


@dataclass(frozen=True)
class ChannelWeights:
    """Typical residual size per joint of each channel (joint units, N m)."""

    joints: np.ndarray
    torque: np.ndarray | None

    @classmethod
    def from_residual(cls, joints: np.ndarray, torque: np.ndarray | None, floor: np.ndarray) -> "ChannelWeights":
        def size(r, lower):
            return np.maximum(np.sqrt(np.mean(np.square(r - r.mean(axis=0)), axis=0)), lower)

        return cls(joints=size(joints, floor), torque=None if torque is None else size(torque, 1e-6))


@dataclass(frozen=True)
class Residual:
    """Measured minus replayed, with the best constant offsets removed."""

    joints: np.ndarray
    torque: np.ndarray | None
    joint_offsets: np.ndarray

    def chi_square(self, weights: ChannelWeights) -> float:
        total = float(np.sum(np.square(self.joints / weights.joints)))
        if self.torque is not None and weights.torque is not None:
            total += float(np.sum(np.square(self.torque / weights.torque)))
        return total


@njit(cache=True)
def _row_sums(values: np.ndarray) -> np.ndarray:
    """Column sums of a C-ordered table, adding the rows in order (as numpy's ``sum(axis=0)`` does there)."""
    sums = np.zeros(values.shape[1])
    for i in range(values.shape[0]):
        for j in range(values.shape[1]):
            sums[j] += values[i, j]
    return sums


def column_means(values: np.ndarray) -> np.ndarray:
    """``values.mean(axis=0)`` of an (N, J) table, to the last bit. On a C-ordered table it adds the
    rows in order as numpy does, in about a quarter of numpy's time (13 us against 45 us for 2160
    rows of three columns; every replay of a candidate's fit takes two); other layouts go to numpy,
    which sums their columns pairwise."""
    if values.ndim == 2 and values.shape[0] > 0 and values.flags.c_contiguous:
        return _row_sums(values) / values.shape[0]
    return values.mean(axis=0)


def residual(model, signals: MeasuredSignals, robot=None, offsets: np.ndarray | None = None,
             mask: np.ndarray | None = None) -> Residual:
    """Replay ``model`` along the whole record and return the residual on the samples of ``mask``.

    Replaying the whole record keeps the state of history-dependent effects (backlash, friction,
    hysteresis, fatigue) continuous across the fit, validation and held-out parts. Offsets are
    fitted on the masked samples unless given.
    """
    if mask is not None:
        # the replay is causal: samples after the last one asked for change nothing before it
        picked = np.flatnonzero(mask)
        n = int(picked[-1]) + 1 if picked.size else len(signals)
        signals = signals.head(n)
        # a run of consecutive samples (a part split in time) is taken as a slice, without copying twice
        mask = slice(int(picked[0]), n) if picked.size and picked.size == n - picked[0] else mask[:n]
    state = model.replay(signals, robot)
    mask = slice(None) if mask is None else mask
    joints = (signals.truth - state.joints)[mask]
    if offsets is None:
        offsets = column_means(joints)
    torque = None
    if state.torque is not None and signals.torque is not None:
        torque = (signals.torque - state.torque)[mask]
        torque = torque - column_means(torque)
    return Residual(joints=joints - offsets, torque=torque, joint_offsets=offsets)


FD_STEP = 1e-5
"""Forward-difference step of the objective's gradient, in the scaled parameters (of order one).

The replay switches between stick and slip and rounds to encoder counts, so its sum of squares is
smooth only above a scale far larger than casadi's default step (1.5e-8): at that step the gradient
is mostly switching noise, and which local point IPOPT stops at changed between casadi 3.7 and 3.8
(a hidden hysteresis fitted to -11 % instead of 64 % shrink). At 1e-6 to 1e-4 both versions fit it
alike."""


class _Objective(ca.Callback):
    """Weighted sum of squares of a candidate's residual, as a casadi function of its parameters."""

    def __init__(self, name, evaluate, n):
        ca.Callback.__init__(self)
        self._evaluate = evaluate
        self._n = n
        self.construct(name, {"enable_fd": True, "fd_method": "forward", "fd_options": {"h": FD_STEP}})

    def get_n_in(self):
        return 1

    def get_n_out(self):
        return 1

    def get_sparsity_in(self, i):
        return ca.Sparsity.dense(self._n, 1)

    def get_sparsity_out(self, i):
        return ca.Sparsity.dense(1, 1)

    def eval(self, arg):
        # the nonzeros of the dense column, as numpy's conversion gives them at five times the cost
        return [self._evaluate(np.array(arg[0].nonzeros(), dtype=float))]


@dataclass(frozen=True)
class CandidateFit:
    """A candidate fitted on one data set and scored on another."""

    candidate: Candidate
    theta: np.ndarray
    model: object
    fit_chi_square: float
    validation_chi_square: float
    validation_residual: Residual

    @property
    def values(self) -> dict[str, np.ndarray]:
        return self.candidate.unpack(self.theta)


def fit_candidate(candidate: Candidate, model, signals: MeasuredSignals, weights: ChannelWeights, robot=None,
                  mask: np.ndarray | None = None, starts: int = 2, max_iter: int = 30,
                  initial: np.ndarray | None = None) -> tuple[np.ndarray, object, float]:
    """Parameters of ``candidate`` that best explain the residual of ``model`` on the ``mask`` samples.

    ``initial`` (e.g. the best point of a coarse scan) is the first starting point when given.

    Returns the parameter vector, the model with the fitted effect, and the weighted sum of squares.
    """
    if candidate.basis is not None:
        return fit_linear_candidate(candidate, model, signals, weights, robot, mask)
    lower, upper, scale, typical = candidate.bounds()

    seen: dict[bytes, float] = {}

    def evaluate(x):
        # casadi's finite differences evaluate the base point again with every gradient
        key = np.asarray(x, dtype=float).tobytes()
        if key not in seen:
            theta = np.clip(x * scale, lower, upper)
            try:
                seen[key] = residual(candidate.apply(model, theta), signals, robot, mask=mask).chi_square(weights)
            except ValueError:
                seen[key] = 1e30
        return seen[key]

    objective = _Objective(f"chi2_{candidate.name}", evaluate, candidate.n_parameters)
    best_theta, best_value = None, np.inf
    points = [] if initial is None else [np.asarray(initial, dtype=float)]
    if initial is not None:
        # never return worse than where the search started
        best_theta = np.clip(np.asarray(initial, dtype=float), lower, upper)
        best_value = evaluate(best_theta / scale)
    for factor, shift in ((1.0, 0.0), (0.25, 0.5), (4.0, -0.5)):
        # the typical value scaled down and up, or either side of zero
        points.append(np.where(typical != 0, typical * factor, shift * scale))
    for point in points[:starts]:
        x0 = np.clip(point, lower, upper) / scale
        opti = ca.Opti()
        x = opti.variable(candidate.n_parameters)
        opti.minimize(objective(x))
        opti.subject_to(opti.bounded(lower / scale, x, upper / scale))
        opti.set_initial(x, x0)
        opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "max_iter": max_iter,
                                                     "hessian_approximation": "limited-memory",
                                                     "tol": 1e-6, "acceptable_tol": 1e-4})
        try:
            solution = opti.solve()
            x_opt = np.asarray(solution.value(x)).ravel()
        except RuntimeError:
            x_opt = np.asarray(opti.debug.value(x)).ravel()
        value = evaluate(x_opt)
        if value < best_value:
            best_theta, best_value = np.clip(x_opt * scale, lower, upper), value
    return best_theta, candidate.apply(model, best_theta), float(best_value)


RIDGE_PENALTIES = (0.0,) + tuple(10.0 ** (k / 2) for k in range(-12, 1))
"""Ridge penalties :func:`ridge_penalty` chooses from: 0 and 1e-6 to 1 in half decades, as fractions of
the largest squared singular value of the design with its columns scaled to unit norm (so that the
choice does not depend on the units of the weights or the length of the record)."""

RIDGE_FOLDS = 5
"""Consecutive blocks of the fit part in time that :func:`ridge_penalty` holds out one at a time."""


def _ridge_weights(design: np.ndarray, target: np.ndarray, penalties) -> np.ndarray:
    """(len(penalties), P) ridge solutions of ``design @ w ~ target`` for each relative penalty.

    The penalty on weight ``p`` is ``penalty * s_max^2 * |design[:, p]|^2 * w_p^2``: a penalty on the
    weights of the design with unit-norm columns, relative to its largest squared singular value.
    """
    norms = np.linalg.norm(design, axis=0)
    norms[norms == 0] = 1.0
    u, singular, vt = np.linalg.svd(design / norms, full_matrices=False)
    projected = u.T @ target
    top = singular[0] ** 2 if singular.size else 0.0
    solutions = []
    for penalty in penalties:
        denominator = singular ** 2 + penalty * top
        gain = np.divide(singular, denominator, out=np.zeros_like(singular), where=denominator > 0)
        solutions.append((vt.T @ (gain * projected)) / norms)
    return np.array(solutions)


def ridge_penalty(design: np.ndarray, target: np.ndarray, penalties=RIDGE_PENALTIES,
                  folds: int = RIDGE_FOLDS) -> tuple[float, np.ndarray]:
    """The ridge penalty of a linear fit that predicts best on samples it was not fitted on.

    The samples (rows, in time order) are cut into ``folds`` consecutive blocks. Each block in turn
    is predicted by the ridge fit (:data:`RIDGE_PENALTIES` explains the scale of a penalty) of the
    others, with the constant offsets of every column fitted on the others too, as the workflow
    carries the fit part's offsets to the parts it scores. Blocks in time, not random samples: a
    sample's neighbours share its motion, and a model has to predict motion it has not seen. A
    design whose weights the motion excites in every direction keeps (nearly) zero penalty; one
    with combinations of its features that some blocks barely move gets a penalty that keeps their
    weights from extrapolating.

    Parameters
    ----------
    design : (N, J, P) what each of ``P`` weights adds to each of ``J`` channels at each of ``N``
        samples, the channels already divided by their typical sizes.
    target : (N, J) what the weights should explain, divided alike.
    penalties : the relative penalties to try (non-negative).
    folds : the number of blocks (at least 2; every block needs a sample).

    Returns
    -------
    The penalty of smallest summed squared prediction error (the smallest such penalty on a tie),
    and the (len(penalties),) summed squared errors, in the order of ``penalties``.
    """
    design, target = np.asarray(design, dtype=float), np.asarray(target, dtype=float)
    penalties = np.asarray(penalties, dtype=float)
    if design.ndim != 3 or target.shape != design.shape[:2]:
        raise ValueError(f"ridge_penalty needs an (N, J, P) design and an (N, J) target, got shapes {design.shape} "
                         f"and {target.shape}")
    if not (np.all(np.isfinite(design)) and np.all(np.isfinite(target))):
        raise ValueError("ridge_penalty needs a finite design and target; they hold NaN or inf")
    if penalties.ndim != 1 or penalties.size == 0 or not np.all(np.isfinite(penalties) & (penalties >= 0)):
        raise ValueError(f"ridge penalties must be a non-empty list of non-negative numbers, got {penalties.tolist()}")
    if int(folds) != folds or folds < 2 or design.shape[0] < folds:
        raise ValueError(f"ridge_penalty needs at least 2 folds and a sample per fold, got {folds} folds of "
                         f"{design.shape[0]} samples")
    n, _, p = design.shape
    errors = np.zeros(penalties.size)
    for block in np.array_split(np.arange(n), int(folds)):
        learn = np.ones(n, dtype=bool)
        learn[block] = False
        design_mean, target_mean = design[learn].mean(axis=0), target[learn].mean(axis=0)
        weights = _ridge_weights((design[learn] - design_mean).reshape(-1, p),
                                 (target[learn] - target_mean).reshape(-1), penalties)
        predicted = np.einsum("njp,kp->knj", design[block] - design_mean, weights)
        errors += np.sum(np.square(target[block] - target_mean - predicted), axis=(1, 2))
    order = np.argsort(penalties, kind="stable")
    best = order[int(np.argmin(errors[order]))]
    return float(penalties[best]), errors


def fit_linear_candidate(candidate: Candidate, model, signals: MeasuredSignals, weights: ChannelWeights, robot=None,
                         mask: np.ndarray | None = None, penalties=RIDGE_PENALTIES,
                         folds: int = RIDGE_FOLDS) -> tuple[np.ndarray, object, float]:
    """Parameters of a candidate linear in them (``candidate.basis``) that best explain the residual
    of ``model`` on the ``mask`` samples: bounded linear least squares of the weighted joint residual,
    with the constant offsets profiled out as in :func:`residual`, and a ridge penalty chosen by
    :func:`ridge_penalty` over ``penalties`` on ``folds`` blocks of the ``mask`` samples (``(0.0,)``
    gives plain least squares; the choice ignores the bounds, which hold only a fit that runs away). Exact, free of the scaling and step choices of a search, and, with
    many weights, kept from extrapolating along combinations of features the fit part barely moves
    (the dVRK wrist's plays: fitted on the peg transfer, the random motion reaches combinations it
    never excited). Returns what :func:`fit_candidate` returns.
    """
    from scipy.optimize import lsq_linear

    current = residual(model, signals, robot, mask=mask)
    if current.torque is not None and weights.torque is not None:
        raise ValueError(f"{candidate.name} is fitted to joints alone, but the data have motor torques too")
    design = np.asarray(candidate.basis(signals), dtype=float)
    if design.shape != (len(signals), signals.n_joints, candidate.n_parameters):
        raise ValueError(f"the basis of {candidate.name} has shape {design.shape}, expected "
                         f"{(len(signals), signals.n_joints, candidate.n_parameters)}")
    if mask is not None:
        design = design[np.asarray(mask, dtype=bool)]
    scale = np.asarray(weights.joints, dtype=float)
    scaled_design = design / scale[None, :, None]
    scaled_target = current.joints / scale
    penalty, _ = ridge_penalty(scaled_design, scaled_target, penalties, folds)
    rows = (scaled_design - scaled_design.mean(axis=0)).reshape(-1, candidate.n_parameters)
    target = scaled_target.reshape(-1)
    if penalty > 0:
        norms = np.linalg.norm(rows, axis=0)
        norms[norms == 0] = 1.0
        top = np.linalg.norm(rows / norms, ord=2)
        rows = np.vstack([rows, np.sqrt(penalty) * top * np.diag(norms)])
        target = np.concatenate([target, np.zeros(candidate.n_parameters)])
    lower, upper, _, _ = candidate.bounds()
    fit = lsq_linear(rows, target, bounds=(lower, upper))
    theta = np.clip(fit.x, lower, upper)
    trial = candidate.apply(model, theta)
    return theta, trial, residual(trial, signals, robot, mask=mask).chi_square(weights)
