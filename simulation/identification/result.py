"""What an identification returns: the fitted parameter set, the session offsets, the estimates
with their uncertainty, and a fit report."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.model.constants import REPORT_SCALE, REPORT_UNITS
from simulation.model.parameters import RavenParameters
from simulation.identification.layout import JOINT_NAMES


def _read_only(obj, names) -> None:
    for name in names:
        array = np.array(getattr(obj, name), dtype=float)
        array.setflags(write=False)
        object.__setattr__(obj, name, array)


class NotIdentifiableError(ValueError):
    """The data cannot determine the requested parameters (no excitation, or confounded ones)."""


class PoorlyIdentifiedWarning(UserWarning):
    """Some estimates are so uncertain that their values carry little information."""


@dataclass(frozen=True)
class ParameterEstimate:
    """One estimated parameter, SI units.

    Attributes
    ----------
    name : e.g. ``"cable_stretch.stiffness[shoulder]"``.
    value : the estimate.
    standard_error : its standard error (delta method from the solver's unknowns).
    lower, upper : the confidence interval at the result's confidence level (for positive scale
        parameters, fitted in log space, the interval is asymmetric and positive).
    initial : the starting value (the base parameter set's, or the data's guess for offsets).
    """

    name: str
    value: float
    standard_error: float
    lower: float
    upper: float
    initial: float

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies inside the confidence interval."""
        return bool(self.lower <= value <= self.upper)


@dataclass(frozen=True)
class FitReport:
    """How well the identified model explains the log.

    Attributes
    ----------
    joint_rmse : (3,) RMS of the joint residual (rad, rad, m) over the samples used.
    torque_rmse : (3,) RMS of the motor-torque residual (N m, N m, N) over the samples used.
    n_samples : samples in the fit; ``n_joint_used``, ``n_torque_used`` (3,) those each residual used
        (samples near a stop of the joint, where dry friction is set-valued, are left out).
    iterations : IPOPT iterations of the last pass; ``solver_status`` its return status.
    converged : whether every pass ended with an optimal (or acceptable) solution.
    condition_number : of the column-normalised residual Jacobian at the solution.
    covariance_method : ``"hac"`` (Newey-West, residuals may be correlated in time) or ``"classical"``.
    poorly_identified : names of estimates whose standard error exceeds the stated fraction of
        their magnitude.
    """

    joint_rmse: np.ndarray
    torque_rmse: np.ndarray
    n_samples: int
    n_joint_used: np.ndarray
    n_torque_used: np.ndarray
    iterations: int
    solver_status: str
    converged: bool
    condition_number: float
    covariance_method: str
    poorly_identified: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        _read_only(self, ("joint_rmse", "torque_rmse", "n_joint_used", "n_torque_used"))

    def describe(self) -> str:
        """A few lines: residual RMSE per joint in degrees and millimetres, solver outcome."""
        lines = ["joint     residual RMSE    torque residual RMSE   samples used (joint/torque)"]
        torque_units = ("N m", "N m", "N")
        for j, name in enumerate(JOINT_NAMES):
            lines.append(f"{name:9s} {self.joint_rmse[j] * REPORT_SCALE[j]:9.4f} {REPORT_UNITS[j]:3s}"
                         f"   {self.torque_rmse[j]:12.4f} {torque_units[j]:3s}"
                         f"       {int(self.n_joint_used[j])}/{int(self.n_torque_used[j])}")
        lines.append(f"solver: {self.solver_status} after {self.iterations} iterations; "
                     f"Jacobian condition number {self.condition_number:.3g}; covariance {self.covariance_method}")
        if self.poorly_identified:
            lines.append("poorly identified: " + ", ".join(self.poorly_identified))
        return "\n".join(lines)


@dataclass(frozen=True)
class IdentificationResult:
    """The identified cable model of one session.

    Attributes
    ----------
    parameters : the fitted :class:`~simulation.model.parameters.RavenParameters`: the model's effects
        on with their fitted values, every other effect off; ``VirtualRaven(parameters)`` is the
        fitted model, and the UKF takes its cable model from it.
    offsets : (3,) joint offsets of the session (rad, rad, m): the cable ends sit at
        ``A u + offsets`` for motor coordinates ``u = mpos / transmission_ratio``. They are the
        encoder registration of this homing, not an effect.
    estimates : the free parameters with standard errors and confidence intervals.
    covariance : covariance of the free parameters' values, in the order of ``estimates``.
    report : the fit report.
    effects : the effects of the model.
    fixed : parameters held at the base values.
    confidence : level of the confidence intervals.
    """

    parameters: RavenParameters
    offsets: np.ndarray
    estimates: tuple[ParameterEstimate, ...]
    covariance: np.ndarray
    report: FitReport
    effects: tuple[str, ...]
    fixed: tuple[str, ...]
    confidence: float

    def __post_init__(self) -> None:
        _read_only(self, ("offsets", "covariance"))

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(e.name for e in self.estimates)

    def estimate(self, name: str) -> ParameterEstimate:
        """The estimate called ``name`` (e.g. ``"coupling.delta[c01]"``)."""
        for estimate in self.estimates:
            if estimate.name == name:
                return estimate
        raise KeyError(f"no free parameter {name!r}; estimated: {', '.join(self.names)}")

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix of the estimates."""
        scale = np.sqrt(np.diag(self.covariance))
        with np.errstate(invalid="ignore", divide="ignore"):
            return self.covariance / np.outer(scale, scale)

    def describe(self) -> str:
        """The estimates with their confidence intervals, then the fit report."""
        level = f"{100 * self.confidence:.0f}%"
        lines = [f"{'parameter':42s} {'estimate':>12s} {'std err':>10s}   {level} interval"]
        for e in self.estimates:
            lines.append(f"{e.name:42s} {e.value:12.6g} {e.standard_error:10.3g}   [{e.lower:.6g}, {e.upper:.6g}]")
        offsets = ", ".join(f"{v * s:.4f} {u}" for v, s, u in zip(self.offsets, REPORT_SCALE, REPORT_UNITS))
        lines.append(f"session offsets: {offsets}")
        lines.append(self.report.describe())
        return "\n".join(lines)
