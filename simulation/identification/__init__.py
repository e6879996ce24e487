"""Identification of the RAVEN-II cable transmission from logged data (casadi nlpsol + IPOPT).

:func:`identify` fits the cable model of the positioning joints (hardening stiffness law, damping,
Coulomb and viscous friction, gravity load scale, coupling) and the session's joint offsets to a log
of motor positions, motor torques and ground-truth joints, such as the calibration run. It returns
an :class:`IdentificationResult`: a fitted :class:`~simulation.model.parameters.RavenParameters` (so
``VirtualRaven(result.parameters)`` is the fitted model, and the UKF takes its cable model from
it), the offsets, estimates with standard errors and confidence intervals, and a fit report. Asked
to (``effects=FITTABLE_EFFECTS + ("motor_friction",)``, :data:`IDENTIFIABLE_EFFECTS`), it also fits
the motors' and gearboxes' friction, which only the motor torques see, and the transmission ratios'
errors (``"transmission_error"``); the UKF's model class (:data:`FITTABLE_EFFECTS`, the default)
has neither.

The stiffness law is the simulator's ``T = k x0 sinh(s / x0)`` (see
:class:`~simulation.model.effects.CableStretch`): a hardening spring whose inverse is closed-form, so the
joint prediction is explicit in the tension.
"""

from simulation.identification.fit import identify
from simulation.identification.layout import DEFAULT_FIXED, FITTABLE_EFFECTS, IDENTIFIABLE_EFFECTS, SLOT_NAMES
from simulation.identification.motor_log import MotorLog, as_motor_log
from simulation.identification.nominal import nominal_parameters
from simulation.identification.result import FitReport, IdentificationResult, NotIdentifiableError, ParameterEstimate, PoorlyIdentifiedWarning
from simulation.identification.samples import IdentificationSamples, prepare_samples

__all__ = [
    "DEFAULT_FIXED",
    "nominal_parameters",
    "FITTABLE_EFFECTS",
    "IDENTIFIABLE_EFFECTS",
    "FitReport",
    "IdentificationResult",
    "IdentificationSamples",
    "MotorLog",
    "NotIdentifiableError",
    "ParameterEstimate",
    "PoorlyIdentifiedWarning",
    "SLOT_NAMES",
    "as_motor_log",
    "identify",
    "prepare_samples",
]
