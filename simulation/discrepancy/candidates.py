"""The candidate library: the simulator's named effects, as parameterized additions to a model.

A :class:`Candidate` knows which effect it adds, its free parameters (with bounds and a typical
scale), and how to put an effect with given parameter values into a model. For RAVEN-II models
the addition is the simulator's own effect object (:mod:`simulation.model.effects`), so "adding the
missing effect" is adding that object to the model's parameter set; for generic models it is the
effect's joint-space form (:mod:`simulation.discrepancy.generic`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from simulation.model.effects import (Backlash, CapstanFriction, CapstanRunout, CoulombFriction, Coupling, Drift,
                                      GravityModelError, GravityStretch, Hysteresis, MotorFriction, TransmissionError,
                                      ViscousFriction)

from simulation.discrepancy.generic import (HYSTERESIS_WIDTH_FRACTIONS, NominalModel, coupled_hysteresis_basis,
                                            play_widths)
from simulation.discrepancy.replay import RavenModel
from simulation.discrepancy.signals import MeasuredSignals


@dataclass(frozen=True)
class ParameterBlock:
    """One named parameter of a candidate, one value per joint (or a matrix flattened).

    ``unit`` is the SI unit of each value (a tuple of ``size`` strings, or one string for all),
    e.g. ``("rad", "rad", "m")`` for a per-joint play; reports turn "rad" into degrees and "m" into
    millimetres and keep composite units in SI.
    """

    name: str
    size: int
    lower: float | np.ndarray
    upper: float | np.ndarray
    scale: float | tuple | np.ndarray
    initial: float | tuple | np.ndarray
    unit: str | tuple[str, ...] = ""

    def units(self) -> tuple[str, ...]:
        """The unit of each of the block's ``size`` values."""
        if isinstance(self.unit, str):
            return (self.unit,) * self.size
        if len(self.unit) != self.size:
            raise ValueError(f"parameter {self.name!r} has {self.size} values but {len(self.unit)} units")
        return tuple(self.unit)


@dataclass(frozen=True)
class Candidate:
    """A named effect that the workflow can fit to a residual and add to a model.

    Attributes
    ----------
    name : the effect's name (the simulator's vocabulary).
    blocks : the free parameters.
    build : maps (model, {block name: values}) to the model with the effect added.
    applies : whether the effect can be added to this model and data (and why not).
    partners : effects of the model that trade with this one, refitted together with it (the
        Coulomb force is the tension-independent part of what capstan friction adds).
    basis : for an effect whose contribution to the joints is linear in its parameters, the map
        from the whole record's signals to that contribution per unit of each parameter, (N, J, P):
        the workflow then fits it by bounded linear least squares in closed form, with a ridge
        penalty chosen by cross-validation on the fit part
        (:func:`~simulation.discrepancy.fitting.fit_linear_candidate`), instead of by IPOPT on
        finite differences. None for the others.
    """

    name: str
    blocks: tuple[ParameterBlock, ...]
    build: Callable
    applies: Callable
    partners: tuple[str, ...] = ()
    basis: Callable | None = None

    @property
    def n_parameters(self) -> int:
        return sum(b.size for b in self.blocks)

    def unpack(self, theta: np.ndarray) -> dict[str, np.ndarray]:
        values, start = {}, 0
        for block in self.blocks:
            values[block.name] = np.asarray(theta[start:start + block.size], dtype=float)
            start += block.size
        return values

    def bounds(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(lower, upper, scale, initial) for the flattened parameter vector."""
        def spread(value, size):
            return np.broadcast_to(np.asarray(value, dtype=float), (size,))

        parts = [(spread(b.lower, b.size), spread(b.upper, b.size), spread(b.scale, b.size), spread(b.initial, b.size))
                 for b in self.blocks]
        return tuple(np.concatenate(p) for p in zip(*parts))

    def apply(self, model, theta: np.ndarray):
        return self.build(model, self.unpack(theta))


def _not_in(model, name):
    if name in model.enabled_effects:
        return False, f"{name} is already in the model"
    return True, ""


def _raven_only(model, signals, name):
    if not isinstance(model, RavenModel):
        return False, f"{name} needs a RAVEN-II cable model"
    return _not_in(model, name)


def _any(model, signals, name):
    return _not_in(model, name)


def _homing_applies(model, signals, name):
    if not isinstance(model, RavenModel):
        return False, "homing offsets need RAVEN-II homing labels"
    if len(np.unique(signals.homing)) < 2:
        return False, "the data spans a single homing"
    return _not_in(model, name)


def _not_replayable(model, signals, name):
    return False, ("the transmission replay drives the cables with the measured motor positions, so an error "
                   "in the controller's gravity compensation (which moves only where the motors settle) leaves "
                   "no residual in joints or torques; the controller replay fits it on the logged commands")


def _payload_applies(model, signals, name):
    if not isinstance(model, RavenModel):
        return False, "a payload needs the RAVEN-II kinematics"
    return _not_in(model, name)


def _raven_effect(effect_factory):
    def build(model, values):
        if isinstance(model, RavenModel):
            return model.with_effect(effect_factory(model, values))
        raise TypeError("this candidate builds RAVEN-II effects")
    return build


def _generic(name):
    def build(model, values):
        return model.with_effect(name, values)
    return build


JOINT_UNITS = ("rad", "rad", "m")
LOAD_UNITS = ("N m", "N m", "N")
LOAD_PER_SPEED_UNITS = ("N m s/rad", "N m s/rad", "N s/m")
LOAD_PER_STRETCH_UNITS = ("N m/rad", "N m/rad", "N/m")


def _velocity_scale(model) -> np.ndarray:
    """The friction law's velocity scale of ``model`` (the identification's nominal one), which a
    refitted Coulomb force keeps."""
    return model.params.effect("coulomb_friction").velocity_scale


HYSTERESIS_RESPONSE_TIME = 0.1
"""Lag (s) of the hysteresis candidate's Bouc-Wen state behind the stretch as the candidate builds
it: a round tenth of a second, the same round value the plant score's lag search starts from
(``studies/common/plant_scoring.py``), and not the simulator's default (``Hysteresis.response_time``,
0.05 s), which the candidate held until 2026-12-06: no constant of a candidate is the generator's.
The quasi-static replay, where the candidate is fitted, has no lag, and only a plant replay reads
it. The plant score of an analysis fits the lag (from that 0.1 s) and takes nothing from this
value; it is read where a plant replay does not fit the lag: ``studies/discrepancy.py
--fixed-plant-lag`` and the diagnostics measured that way (the floor study's refinements, the
shape study without ``--fit-scorer-lag``). Every figure of those measured before 2026-12-06 was
measured with 0.05 s. A lag keeps the plant's millisecond chatter from dithering the loop away.
``studies/discrepancy_hysteresis_shape.py`` changes both together (``--response-time``) or this
one alone (``--scorer-lag``; ``--scorer-lag 0.05`` gives a scorer the earlier constant)."""


DRIFT_REFERENCE_SPEED = np.array([0.1, 0.1, 0.01])
"""Speed (rad/s, rad/s, m/s) at which the drift candidate's fatigue dose runs one hour per hour of
motion: a round typical joint speed during calibration. The candidate's rates are per such hour
of the log's own clock (``time_scale`` 1: a log's time is not compressed); it ages the cables with
travel alone (no payload term), since how a payload speeds aging is not something a log states."""


def raven_candidates(signals: MeasuredSignals) -> list[Candidate]:
    """Every candidate the cable model can take for RAVEN-II data (the simulator's named effects).

    The workflow on RAVEN-II data screens only those of :data:`RAVEN_LIBRARY` (the others are the
    starting structure's own effects, candidates only for ablation studies).
    """
    homings = np.unique(signals.homing)
    extra_homings = tuple(int(h) for h in homings[1:])

    def per_homing(name):
        def build(model, values):
            offsets = values["offset"].reshape(-1, 3)
            return model.with_homing_offsets({c: offsets[i] for i, c in enumerate(extra_homings)}, name)
        return build

    def per_homing_candidate(name):
        return Candidate(name, (ParameterBlock("offset", 3 * len(extra_homings), -0.1, 0.1, 1e-3, 0.0,
                                               JOINT_UNITS * len(extra_homings)),),
                         per_homing(name), _homing_applies)

    def zeros_for_tools(values):
        return np.concatenate([values, np.zeros(4)])

    return [
        Candidate("backlash", (ParameterBlock("half_width", 3, 0.0, 0.02, (1e-3, 1e-3, 5e-5), 0.0, JOINT_UNITS),),
                  _raven_effect(lambda m, v: Backlash(half_width=v["half_width"])), _raven_only),
        Candidate("coulomb_friction", (ParameterBlock("force", 3, 0.0, 20.0, (0.2, 0.2, 1.0), 0.0, LOAD_UNITS),),
                  _raven_effect(lambda m, v: CoulombFriction(force=v["force"], velocity_scale=_velocity_scale(m))),
                  _raven_only),
        Candidate("viscous_friction", (ParameterBlock("coefficient", 3, 0.0, 500.0, (0.5, 0.5, 10.0), 0.0,
                                                      LOAD_PER_SPEED_UNITS),),
                  _raven_effect(lambda m, v: ViscousFriction(coefficient=v["coefficient"])), _raven_only),
        Candidate("hysteresis", (ParameterBlock("stiffness", 3, 0.0, 1e5, (20.0, 10.0, 1000.0), 0.0,
                                                LOAD_PER_STRETCH_UNITS),
                                 ParameterBlock("width", 3, 1e-6, 0.05, (1e-2, 1e-2, 1e-3), (1e-2, 1e-2, 1e-3),
                                                JOINT_UNITS),
                                 ParameterBlock("shape", 3, 0.0, 1.0, 0.2, 0.0, "1")),
                  _raven_effect(lambda m, v: Hysteresis(stiffness=v["stiffness"], beta=1.0 / v["width"],
                                                        gamma=v["shape"] / v["width"],
                                                        response_time=HYSTERESIS_RESPONSE_TIME)), _raven_only),
        Candidate("gravity_stretch", (ParameterBlock("load_scale", 3, 0.0, 3.0, 1.0, 0.0, "1"),),
                  _raven_effect(lambda m, v: GravityStretch(load_scale=v["load_scale"])), _raven_only),
        Candidate("coupling", (ParameterBlock("delta", 3, -0.1, 0.1, (0.01, 0.002, 0.002), 0.0, "1"),),
                  _raven_effect(lambda m, v: Coupling(delta=v["delta"])), _raven_only),
        Candidate("drift", (ParameterBlock("creep_rate", 3, 0.0, 10.0, (3e-2, 3e-2, 3e-4), 0.0,
                                           ("rad/h", "rad/h", "m/h")),
                            ParameterBlock("stiffness_loss", 3, 0.0, 1000.0, 0.5, 0.0, "1/h")),
                  _raven_effect(lambda m, v: Drift(creep_rate=v["creep_rate"], stiffness_loss=v["stiffness_loss"],
                                                   reference_speed=DRIFT_REFERENCE_SPEED, payload_gain=np.zeros(3),
                                                   time_scale=1.0)),
                  _raven_only),
        Candidate("transmission_error", (ParameterBlock("ratio_error", 3, -0.1, 0.1, 1e-3, 0.0, "1"),),
                  _raven_effect(lambda m, v: TransmissionError(ratio_error=v["ratio_error"])), _raven_only),
        per_homing_candidate("homing_offset"),
        per_homing_candidate("registration_offset"),
        Candidate("motor_friction", (ParameterBlock("coulomb", 3, 0.0, 0.1, 1e-3, 0.0, "N m"),
                                     ParameterBlock("gearbox_loss", 3, 0.0, 1.0, 0.1, 0.0, "1")),
                  _raven_effect(lambda m, v: MotorFriction(coulomb=zeros_for_tools(v["coulomb"]),
                                                           gearbox_loss=zeros_for_tools(v["gearbox_loss"]))),
                  _raven_only),
        Candidate("capstan_friction", (ParameterBlock("coefficient", 3, 0.0, 0.5, 0.05, 0.0, "1"),),
                  _raven_effect(lambda m, v: CapstanFriction(mu=v["coefficient"], wrap_angle=np.ones(3))),
                  _raven_only, partners=("coulomb_friction",)),
        Candidate("gravity_model_error", (ParameterBlock("scale_error", 3, -0.5, 0.5, 0.05, 0.0, "1"),),
                  _raven_effect(lambda m, v: GravityModelError(scale_error=v["scale_error"])), _not_replayable),
        Candidate("payload", (ParameterBlock("mass", 1, 0.0, 3.0, 0.1, 0.0, "kg"),),
                  lambda m, v: m.with_payload(float(v["mass"][0])), _payload_applies),
    ]


def oracle_candidates(signals: MeasuredSignals) -> list[Candidate]:
    """Candidates for effects the library deliberately lacks (``capstan_runout``).

    Only a study that knows what generated the data uses them, to fit the generator's true
    structure (the oracle); the workflow never screens them.
    """
    return [
        Candidate("capstan_runout", (ParameterBlock("amplitude", 3, 0.0, 0.02, (1e-3, 1e-3, 5e-5), 0.0, JOINT_UNITS),),
                  _raven_effect(lambda m, v: CapstanRunout(amplitude=v["amplitude"])), _raven_only),
    ]


def generic_candidates(signals: MeasuredSignals, play_fractions=HYSTERESIS_WIDTH_FRACTIONS,
                       play_drivers: str = "every") -> list[Candidate]:
    """The library for generic data (joint-space forms of the same effects); ``play_fractions`` are
    the half-widths of ``coupled_hysteresis``'s play operators as fractions of each joint's range, and
    ``play_drivers`` which joints' motion drives each joint's (:data:`PLAY_DRIVERS`)."""
    j = signals.n_joints
    span = np.max(np.ptp(signals.reported, axis=0))
    joint = tuple(signals.units)
    per_speed = ("s",) * j
    travel = tuple(f"{u}/{u}" for u in joint)
    pairs = tuple(f"{joint[r]}/{joint[c]}" for r in range(j) for c in range(j) if r != c)
    return [
        Candidate("backlash", (ParameterBlock("half_width", j, 0.0, 0.5 * span, 1e-2, 1e-3, joint),),
                  _generic("backlash"), _any),
        Candidate("coulomb_friction", (ParameterBlock("lag", j, -0.5 * span, 0.5 * span, 1e-2, 0.0, joint),),
                  _generic("coulomb_friction"), _any),
        Candidate("viscous_friction", (ParameterBlock("lag_per_speed", j, -10.0, 10.0, 0.1, 0.0, per_speed),),
                  _generic("viscous_friction"), _any),
        Candidate("hysteresis", (ParameterBlock("amplitude", j, -0.5 * span, 0.5 * span, 1e-2, 0.0, joint),
                                 ParameterBlock("width", j, 1e-4, span, 0.05, 0.05, joint),
                                 ParameterBlock("shape", j, 0.0, 1.0, 0.2, 0.0, "1")), _generic("hysteresis"), _any),
        Candidate("coupling", (ParameterBlock("matrix", j * (j - 1), -1.0, 1.0, 0.05, 0.0, pairs),),
                  _generic("coupling"), _any),
        Candidate("drift", (ParameterBlock("creep", j, -0.1, 0.1, 1e-3, 0.0, travel),), _generic("drift"), _any),
        Candidate("transmission_error", (ParameterBlock("ratio_error", j, -0.5, 0.5, 1e-2, 0.0, "1"),),
                  _generic("transmission_error"), _any),
        Candidate("coupled_viscous_friction", (ParameterBlock("lag_per_speed", j * (j - 1), -10.0, 10.0, 0.1, 0.0,
                                                              tuple(f"{joint[r]} s/{joint[c]}" for r in range(j)
                                                                    for c in range(j) if r != c)),),
                  _generic("coupled_viscous_friction"), _any),
        _coupled_hysteresis(signals, play_fractions, play_drivers),
    ]


PLAY_DRIVERS = ("every", "own")
"""Which joints' motion drives each joint's ``coupled_hysteresis``: every joint's (the library's form)
or its own alone (one weight per joint and width, a Prandtl-Ishlinskii hysteresis per joint)."""


def check_play_drivers(drivers: str) -> str:
    """``drivers`` if it names one of :data:`PLAY_DRIVERS`; otherwise a one-line ValueError naming the choices."""
    if drivers not in PLAY_DRIVERS:
        raise ValueError(f"unknown play drivers {drivers!r}; choose from {', '.join(PLAY_DRIVERS)}")
    return drivers


def _coupled_hysteresis(signals: MeasuredSignals, fractions, drivers: str = "every") -> Candidate:
    """Hysteresis of each joint driven by every joint's motion: a joint whose cables run over the
    pulleys of other joints (the wrist pitch and the two jaw cables of a da Vinci instrument) drags
    with their friction whichever way those joints last moved. A weighted sum of play operators of
    each joint's reported motion (:data:`~simulation.discrepancy.generic.HYSTERESIS_WIDTH_FRACTIONS`
    of its range), one weight per (moved joint, moving joint, width); linear in the weights, so fitted
    in closed form, with a ridge penalty chosen on blocks of the fit part
    (:func:`~simulation.discrepancy.fitting.fit_linear_candidate`). With ``drivers="own"`` each
    joint is driven by its own motion alone: the weights of (moved joint, its own motion, width)."""
    check_play_drivers(drivers)
    j = signals.n_joints
    widths = play_widths(signals, fractions)
    n_widths = widths.shape[1]
    joint = tuple(signals.units)
    pairs = [(r, c) for r in range(j) for c in range(j) if drivers == "every" or r == c]
    units = tuple(f"{joint[r]}/{joint[c]}" for r, c in pairs for _ in range(n_widths))
    # the columns of coupled_hysteresis_basis (moved joint, moving joint, width) these weights are
    columns = np.array([(r * j + c) * n_widths + w for r, c in pairs for w in range(n_widths)])

    def every_weight(weight):
        full = np.zeros(j * j * n_widths)
        full[columns] = weight
        return full

    def build(model, values):
        return model.with_effect("coupled_hysteresis", {"weight": every_weight(values["weight"]), "widths": widths})

    return Candidate("coupled_hysteresis",
                     (ParameterBlock("weight", len(columns), -10.0, 10.0, 0.1, 0.0, units),),
                     build, _any, basis=lambda s: coupled_hysteresis_basis(s, widths)[:, :, columns])


def library(signals: MeasuredSignals) -> list[Candidate]:
    """The candidate library for this kind of data."""
    return raven_candidates(signals) if signals.kind == "raven" else generic_candidates(signals)


RAVEN_LIBRARY = ("backlash", "hysteresis", "drift", "homing_offset", "registration_offset", "transmission_error",
                 "motor_friction", "capstan_friction", "gravity_model_error", "payload")
"""The candidates the workflow screens on every RAVEN-II input, whatever the data: effects that the
starting structure (the identified cable model of
:data:`studies.common.discrepancy_runs.STARTING_STRUCTURE`) does not hold."""

CONTROLLER_CANDIDATES = ("gravity_model_error",)
"""Candidates of the controller rather than the transmission: fitted by the controller replay on the
logged commands (:mod:`simulation.discrepancy.controller`), never by the transmission replay."""

LIBRARY_NAMES = ("backlash", "coulomb_friction", "viscous_friction", "hysteresis", "gravity_stretch", "coupling",
                 "drift", "homing_offset", "registration_offset", "transmission_error", "motor_friction",
                 "capstan_friction", "gravity_model_error", "payload", "coupled_viscous_friction",
                 "coupled_hysteresis")
"""Effect names the workflow can name. The simulator has more (``capstan_runout``), which the
library deliberately lacks: a residual they cause is reported as unexplained."""

__all__ = ["CONTROLLER_CANDIDATES", "Candidate", "LIBRARY_NAMES", "NominalModel", "PLAY_DRIVERS", "ParameterBlock",
           "RAVEN_LIBRARY", "check_play_drivers", "library", "oracle_candidates"]
