"""Which cable-model parameters a fit estimates, and how the solver sees them.

The identified model has eleven per-joint quantities (33 slots): cable stiffness, hardening
stretch and damping, Coulomb and viscous friction, gravity load scale, the three coupling
deviations, the session's joint offsets, the motors' dry friction and gearbox loss, and the
transmission ratios' relative errors. A slot
is *free* (estimated), *fixed* (held at the base parameter set's value) or *off* (its effect is
not part of the model: zero, or a rigid cable).
Free parameters reach the solver as dimensionless unknowns ``xi`` of order one: positive scale
parameters as ``reference * exp(xi)`` (so they stay positive and relative errors are symmetric),
the others as ``reference + scale * xi``.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from simulation.model.constants import POSITIONING_NAMES
from simulation.model.parameters import RavenParameters

FITTABLE_EFFECTS = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction")
"""The effects the identification estimates by default (the UKF's model class)."""
IDENTIFIABLE_EFFECTS = FITTABLE_EFFECTS + ("motor_friction", "transmission_error")
"""Every effect whose parameters the identification can estimate: :data:`FITTABLE_EFFECTS`, the
motors' and gearboxes' friction, which only the motor torques see (the smooth law of
:func:`simulation.model.laws.motor_friction`, on the positioning joints), and the transmission
ratios' errors (each motor's column of the coupling scaled by ``1 / (1 + ratio_error)``, in the
cable ends and in the load the motors feel, as :class:`~simulation.model.effects.TransmissionError`
says)."""
JOINT_NAMES = POSITIONING_NAMES
COUPLING_NAMES = ("c01", "c02", "c12")
OFFSET = "offset"


@dataclass(frozen=True)
class Quantity:
    """One per-joint quantity of the model: its effect field, transform and typical scale."""

    effect: str
    field: str
    transform: str            # "log", "nonnegative" or "linear"
    scale: tuple[float, float, float]
    entries: tuple[str, str, str] = JOINT_NAMES
    start: tuple[float, float, float] | None = None
    """Where the search starts when the base parameter set does not hold the effect (a switched-off
    effect keeps its class defaults, which for the simulator's effects are the simulator's values);
    None: the base set's values whatever they are."""

    @property
    def prefix(self) -> str:
        return self.effect if self.effect == OFFSET else f"{self.effect}.{self.field}"


QUANTITIES = (
    Quantity("cable_stretch", "stiffness", "log", (1.0, 1.0, 1.0)),
    Quantity("cable_stretch", "hardening", "log", (1.0, 1.0, 1.0)),
    Quantity("cable_stretch", "damping", "log", (0.01, 0.01, 1.0)),
    Quantity("coulomb_friction", "force", "nonnegative", (0.01, 0.01, 0.01)),
    Quantity("viscous_friction", "coefficient", "nonnegative", (0.01, 0.01, 0.1)),
    Quantity("gravity_stretch", "load_scale", "linear", (0.1, 0.1, 0.1)),
    Quantity("coupling", "delta", "linear", (1e-3, 1e-3, 1e-3), COUPLING_NAMES),
    Quantity(OFFSET, "", "linear", (1e-3, 1e-3, 1e-4)),
    # a round 1 mN m at the motor shaft and a loss of 0.1 per unit of transmitted torque, from zero
    Quantity("motor_friction", "coulomb", "nonnegative", (1e-3, 1e-3, 1e-3), start=(0.0, 0.0, 0.0)),
    Quantity("motor_friction", "gearbox_loss", "nonnegative", (0.1, 0.1, 0.1), start=(0.0, 0.0, 0.0)),
    # the nominal ratios until the data say otherwise, searched in round steps of a tenth of a percent
    Quantity("transmission_error", "ratio_error", "linear", (1e-3, 1e-3, 1e-3), start=(0.0, 0.0, 0.0)),
)
"""The model's quantities in slot order (slot = 3 * quantity index + entry)."""
N_SLOTS = 3 * len(QUANTITIES)
(STIFFNESS, HARDENING, DAMPING, COULOMB, VISCOUS, LOAD_SCALE, COUPLING_DELTA, OFFSETS, MOTOR_COULOMB, GEARBOX_LOSS,
 RATIO_ERROR) = (slice(3 * i, 3 * i + 3) for i in range(len(QUANTITIES)))

DEFAULT_FIXED = ("cable_stretch.damping",)
"""Held at the base values unless asked otherwise: the cable damping multiplies the stretch rate,
a small difference of two differentiated encoder signals, so encoder noise biases it low (errors
in variables; a free fit on the virtual RAVEN-II returns 0.27 for the elbow's 0.4 N m s/rad). With
the default base set it is held at the round nominal of :mod:`~.nominal`, not at a simulator value."""
LOG_RANGE = 12.0
"""Positive scale parameters are searched within exp(+-LOG_RANGE) of their reference."""


def slot_names() -> tuple[str, ...]:
    """Name of every slot, e.g. ``cable_stretch.stiffness[shoulder]``, ``offset[z_ins]``."""
    return tuple(f"{q.prefix}[{entry}]" for q in QUANTITIES for entry in q.entries)


SLOT_NAMES = slot_names()


@dataclass(frozen=True)
class ParameterSpec:
    """One free parameter: its name, slot, transform, reference value and scale."""

    name: str
    slot: int
    transform: str
    reference: float
    scale: float

    def value(self, xi: float) -> float:
        return self.reference * np.exp(xi) if self.transform == "log" else self.reference + self.scale * xi

    def derivative(self, xi: float) -> float:
        """d(value)/d(xi), for the delta method."""
        return self.value(xi) if self.transform == "log" else self.scale

    def bounds(self) -> tuple[float, float]:
        """Search range of xi: non-negative parameters stay >= 0, log-scale ones within LOG_RANGE."""
        if self.transform == "log":
            return -LOG_RANGE, LOG_RANGE
        if self.transform == "nonnegative":
            return -self.reference / self.scale, np.inf
        return -np.inf, np.inf


def _slot_reference(params: RavenParameters, quantity: Quantity, offsets: np.ndarray) -> np.ndarray:
    if quantity.effect == OFFSET:
        return np.asarray(offsets, dtype=float)
    if quantity.start is not None and not params.is_enabled(quantity.effect):
        return np.asarray(quantity.start, dtype=float)
    # effects of every DOF (motor friction) hold the positioning joints first
    return np.asarray(getattr(params.effect(quantity.effect), quantity.field), dtype=float)[:3]


def _expand_fixed(fixed) -> set[str]:
    names = set()
    for item in fixed:
        if item in SLOT_NAMES:
            names.add(item)
            continue
        matches = [name for name in SLOT_NAMES if name.startswith(item + "[")]
        if not matches:
            raise ValueError(f"unknown parameter {item!r} in fixed; parameters are named like "
                             f"'cable_stretch.stiffness[shoulder]' or by field, 'cable_stretch.damping'")
        names.update(matches)
    return names


@dataclass(frozen=True)
class ParameterLayout:
    """The free parameters of one fit and the values of every other slot.

    Attributes
    ----------
    effects : the effects in the model.
    specs : the free parameters, in the order of the solver's unknowns.
    slot_values : (N_SLOTS,) reference value of every slot (zero for effects not in the model).
    rigid : True when ``cable_stretch`` is not in the model (the cable does not stretch).
    """

    effects: tuple[str, ...]
    specs: tuple[ParameterSpec, ...]
    slot_values: np.ndarray
    rigid: bool

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(spec.name for spec in self.specs)

    def __len__(self) -> int:
        return len(self.specs)

    def slots(self, xi) -> np.ndarray:
        """Every slot's physical value for the unknowns ``xi``."""
        values = self.slot_values.copy()
        for spec, x in zip(self.specs, np.asarray(xi, dtype=float)):
            values[spec.slot] = spec.value(x)
        return values

    def references(self) -> np.ndarray:
        """(2 p,) the free parameters' reference values, then their scales: the numbers
        :meth:`symbolic_slots` takes as an input, so that one compiled residual serves every fit
        of the same structure whatever its starting values."""
        return np.array([spec.reference for spec in self.specs] + [spec.scale for spec in self.specs], dtype=float)

    def symbolic_slots(self, xi: ca.SX, references: ca.SX) -> ca.SX:
        """:meth:`slots` as a casadi expression of the unknowns and of :meth:`references`."""
        p = len(self.specs)
        entries = [ca.SX(v) for v in self.slot_values]
        for k, spec in enumerate(self.specs):
            if spec.transform == "log":
                entries[spec.slot] = references[k] * ca.exp(xi[k])
            else:
                entries[spec.slot] = references[k] + references[p + k] * xi[k]
        return ca.vertcat(*entries)

    def derivatives(self, xi) -> np.ndarray:
        """d(value)/d(xi) of each free parameter."""
        return np.array([spec.derivative(x) for spec, x in zip(self.specs, np.asarray(xi, dtype=float))])

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the unknowns."""
        pairs = np.array([spec.bounds() for spec in self.specs]).reshape(-1, 2)
        return pairs[:, 0], pairs[:, 1]


def build_layout(effects, fixed, params: RavenParameters, offsets: np.ndarray) -> ParameterLayout:
    """The layout for a model of ``effects`` with the ``fixed`` parameters held at ``params``' values.

    Parameters
    ----------
    effects : names of the effects in the model, a subset of :data:`IDENTIFIABLE_EFFECTS`.
    fixed : parameter names (``"coupling.delta[c01]"``) or whole fields (``"cable_stretch.damping"``)
        held at their value in ``params``.
    params : base parameter set: initial guesses and fixed values.
    offsets : (3,) initial joint offsets (rad, rad, m).
    """
    effects = tuple(effects)
    unknown = [name for name in effects if name not in IDENTIFIABLE_EFFECTS]
    if unknown:
        raise ValueError(f"cannot identify effects {unknown}; identifiable effects: {', '.join(IDENTIFIABLE_EFFECTS)}")
    if len(set(effects)) != len(effects):
        raise ValueError(f"effects repeat a name: {effects}")
    held = _expand_fixed(fixed)
    values = np.zeros(N_SLOTS)
    specs = []
    for index, quantity in enumerate(QUANTITIES):
        in_model = quantity.effect == OFFSET or quantity.effect in effects
        if not in_model:
            continue
        reference = _slot_reference(params, quantity, offsets)
        for entry in range(3):
            slot = 3 * index + entry
            values[slot] = reference[entry]
            name = SLOT_NAMES[slot]
            if name in held:
                continue
            transform = quantity.transform
            if transform == "log" and not reference[entry] > 0:
                transform = "nonnegative"
            if transform == "nonnegative" and reference[entry] < 0:
                raise ValueError(f"{name} must be non-negative, the base value is {reference[entry]}")
            specs.append(ParameterSpec(name, slot, transform, float(reference[entry]),
                                       max(abs(float(reference[entry])), quantity.scale[entry])
                                       if transform == "nonnegative" else quantity.scale[entry]))
    if "cable_stretch" not in effects:
        values[STIFFNESS] = 1.0
        values[HARDENING] = 1.0
    return ParameterLayout(effects=effects, specs=tuple(specs), slot_values=values,
                           rigid="cable_stretch" not in effects)
