"""Named physical effects of the RAVEN-II cable transmission.

The virtual RAVEN-II's transmission is a composition of the effect objects below. Each one names
the physics it stands for, holds its parameters (SI, one value per positioning joint unless stated:
shoulder, elbow, insertion), and can be switched off. The same objects are the candidate library of
the model-discrepancy workflow, so an effect's ``name`` is part of the public vocabulary:

``cable_stretch``, ``gravity_stretch``, ``coupling``, ``coulomb_friction``, ``viscous_friction``,
``backlash``, ``hysteresis``, ``drift``, ``homing_offset``, ``quantization``, ``noise``,
``capstan_runout``.

Defaults: the virtual RAVEN-II
------------------------------
Every default value below is the virtual RAVEN-II's. Where each comes from:

========================  ==========================================================================
effect, parameter         source
========================  ==========================================================================
cable_stretch             ``stiffness`` and ``hardening``: casadi fit to the paper's Table I (J2-J3)
                          raw and fixed-offset RMSE, ``python -m simulation.default_fit``
                          (:mod:`simulation.default_fit`); ``damping``: tuning, a damping ratio of
                          about 0.3 on the link-on-cable mode of each joint.
gravity_stretch           masses and centres of mass of ``grav_comp.cpp`` (controller facts);
                          ``load_scale`` 1.
coupling                  tuning: 7 % of c01 and ~20 % of c02, c12, so joints 2 and 3 carry a
                          configuration-dependent error that the controller's averaged coefficients
                          miss; a learned model can remove it (paper II-K, joint positions matter).
coulomb_friction          tuning: a few tenths of the gravity torques (joints 1-2); small on the
                          insertion (0.2 N) so that joint 3's fixed-offset error is dominated by
                          load that the motor torque reveals (paper II-K: torques matter most for
                          joint 3); ``velocity_scale`` only smooths the law for the estimators.
viscous_friction          tuning: adds < 0.05 deg / 0.05 mm at the paper's joint speeds.
backlash                  tuning: dead bands of 0.02-0.03 deg and 0.02 mm, below the paper's
                          calibrated errors, so they remain in the learned residual.
hysteresis                tuning after Miyasaka et al. 2016 (loop widths of 0.02-0.05 deg, 0.2 mm).
drift                     ``creep_rate``: casadi fit to Table III (linear regression, unloaded, hour 5),
                          ``python -m simulation.default_fit``; ``stiffness_loss``, ``payload_gain``
                          and ``reference_speed``: tuning with the paper's II-G findings (joint 1
                          ages most, load ages faster, idle does not age).
homing_offset             the registration itself follows ``homing.cpp`` (controller facts);
                          ``repeatability``: tuning to the paper's II-I finding that joint 2 is the
                          joint that homing disturbs (0.2 deg per homing, others ~0.01 deg, 0.03 mm).
quantization              controller and encoder facts (``motor.h``; paper IV-B).
noise                     tuning: 10 mA of current ripple, 0.001 deg / 2 um of encoder jitter.
capstan_runout            5 um of capstan eccentricity over the joint pulley radii (``defines.h``).
========================  ==========================================================================
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np


def _vector(value, length: int, name: str, *, nonnegative: bool = True) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape == ():
        array = np.full(length, float(array))
    if array.shape != (length,):
        raise ValueError(f"{name} must have {length} values, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array}")
    if nonnegative and np.any(array < 0):
        raise ValueError(f"{name} must be non-negative, got {array}")
    array = array.copy()
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class Effect:
    """Base class: a named physical effect with parameters and an on/off switch.

    Subclasses are frozen dataclasses whose array fields are per-joint parameters in SI units.
    """

    name: ClassVar[str] = ""
    enabled: bool = True

    def parameters(self) -> dict[str, np.ndarray]:
        """The effect's parameters by name (SI arrays), without the on/off switch."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "enabled"}

    def with_enabled(self, enabled: bool) -> "Effect":
        return dataclasses.replace(self, enabled=bool(enabled))

    def replace(self, **changes) -> "Effect":
        return dataclasses.replace(self, **changes)

    def describe(self) -> str:
        """One line: the name, whether it is on, and its parameters."""
        parts = ", ".join(f"{k}={np.array2string(np.asarray(v), precision=4)}" for k, v in self.parameters().items())
        return f"{self.name} ({'on' if self.enabled else 'off'}): {parts}"


@dataclass(frozen=True)
class CableStretch(Effect):
    """Elastic stretch of the steel cables between capstan and joint pulley.

    A wire rope first lengthens easily as its strands bed in (constructional stretch) and then
    stiffens as they lock; each RAVEN-II joint is driven by an antagonistic pair, so the law is odd
    in the stretch. In joint units (N m per rad of joint rotation, N per m of insertion):

        T(s) = stiffness * hardening * sinh(s / hardening),   s(T) = hardening * asinh(T / (stiffness * hardening)),

    a hardening spring with tangent stiffness ``stiffness * cosh(s / hardening)``: ``stiffness``
    at zero tension, growing by half again over a stretch of ``hardening`` (rad, rad, m). The form
    has one parameter more than a linear spring, is smooth, and its inverse is closed-form, so
    stretch as a function of tension is explicit for the identification and the UKF (a linear +
    cubic law would need a root solve). ``damping`` is the cable's internal viscous damping on the
    stretch rate (N m s/rad, N s/m). Switched off, the cables are rigid (the tool cables too).
    """

    name: ClassVar[str] = "cable_stretch"
    stiffness: np.ndarray = field(default_factory=lambda: np.array([40.6049, 13.361167, 774.623951]))
    hardening: np.ndarray = field(default_factory=lambda: np.array([0.019015, 0.04312, 0.004775]))
    damping: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.4, 60.0]))

    def __post_init__(self):
        for name in ("stiffness", "hardening", "damping"):
            object.__setattr__(self, name, _vector(getattr(self, name), 3, name))
        if np.any(self.stiffness <= 0) or np.any(self.hardening <= 0):
            raise ValueError("cable stiffness and hardening stretch must be positive")


@dataclass(frozen=True)
class GravityStretch(Effect):
    """Cable tension from the weight of the links and of a payload hanging at the tool tip.

    Gravity torques come from the kinematics layer's model (link masses and centres of mass of
    ``grav_comp.cpp``, payload as a point mass at the tool tip). ``load_scale`` multiplies the
    gravity load each positioning joint's cable carries (1 = the modelled weights; below 1 for a
    counterbalanced joint). Switched off, the links are weightless: no gravity term loads the
    cables (the controller still adds its gravity-compensation torque, as the real one would).
    """

    name: ClassVar[str] = "gravity_stretch"
    load_scale: np.ndarray = field(default_factory=lambda: np.ones(3))

    def __post_init__(self):
        object.__setattr__(self, "load_scale", _vector(self.load_scale, 3, "load_scale"))


@dataclass(frozen=True)
class Coupling(Effect):
    """Cable coupling between the positioning joints that differs from the controller's.

    Joint 2's cables pass over joint 1's axis and joint 3's over both, so a joint-1 rotation
    moves the other joints with their motors still. The controller removes this with fixed
    coefficients (c01, c02, c12) = (0.14545, 0.0077974, 0.0080774) "averaged from calculations"
    (``fwd_cable_coupling.h``). ``delta`` is how far the real cable routing's coefficients sit from
    those (dimensionless; c02 and c12 in m/rad). Switched off, the true coupling equals the
    controller's.
    """

    name: ClassVar[str] = "coupling"
    delta: np.ndarray = field(default_factory=lambda: np.array([0.010, 0.0015, -0.0012]))

    def __post_init__(self):
        object.__setattr__(self, "delta", _vector(self.delta, 3, "delta", nonnegative=False))


@dataclass(frozen=True)
class CoulombFriction(Effect):
    """Dry friction on the joint side (bearings, cable-pulley contact, tool shaft in its cannula).

    Opposes joint motion with magnitude ``force`` (N m, N m, N), smoothed over ``velocity_scale``
    (tanh law) so the dynamics stay integrable. Because it acts on the link, the cable must carry
    it: the stretch, and so the joint error, flips with the direction of motion, and so does the
    motor torque. The simulator integrates it exactly (set-valued: a joint sticks while the net
    force is within ``force``); ``velocity_scale`` smooths it into ``force * tanh(v / scale)`` for
    the model-based estimators and fits, which need a differentiable law.
    """

    name: ClassVar[str] = "coulomb_friction"
    force: np.ndarray = field(default_factory=lambda: np.array([0.25, 0.15, 0.2]))
    velocity_scale: np.ndarray = field(default_factory=lambda: np.array([2e-3, 2e-3, 5e-5]))

    def __post_init__(self):
        object.__setattr__(self, "force", _vector(self.force, 3, "force"))
        object.__setattr__(self, "velocity_scale", _vector(self.velocity_scale, 3, "velocity_scale"))
        if np.any(self.velocity_scale <= 0):
            raise ValueError("velocity_scale must be positive")


@dataclass(frozen=True)
class ViscousFriction(Effect):
    """Viscous (speed-proportional) joint-side friction, N m s/rad, N m s/rad, N s/m.

    Loads the cable in proportion to joint speed, so the joint error grows with velocity.
    """

    name: ClassVar[str] = "viscous_friction"
    coefficient: np.ndarray = field(default_factory=lambda: np.array([0.5, 0.3, 8.0]))

    def __post_init__(self):
        object.__setattr__(self, "coefficient", _vector(self.coefficient, 3, "coefficient"))


@dataclass(frozen=True)
class Backlash(Effect):
    """Play between the capstan-side cable and the joint pulley (a dead band).

    Slack in the cable wrap lets the motor side travel ``half_width`` (rad, rad, m) either way
    before the joint follows, so after a reversal the joint lags the motor by the dead band: the
    joint error flips sign with the direction of motion, with amplitude ``half_width``, while the
    motor torque barely changes (unlike Coulomb friction).
    """

    name: ClassVar[str] = "backlash"
    half_width: np.ndarray = field(default_factory=lambda: np.array([4e-4, 5e-4, 2e-5]))

    def __post_init__(self):
        object.__setattr__(self, "half_width", _vector(self.half_width, 3, "half_width"))


@dataclass(frozen=True)
class Hysteresis(Effect):
    """Bouc-Wen hysteresis of the loaded cable (Miyasaka et al., ICRA 2016).

    Strands rubbing inside the rope make the tension depend on the stretch history. The cable
    tension gains a hysteretic term ``stiffness * z`` with the Bouc-Wen state (n = 1)

        dz/dt = ds/dt - beta * |ds/dt| * z - gamma * ds/dt * |z|,

    which saturates at ``z = 1/(beta + gamma)`` (stretch units). The state follows the stretch
    averaged over 50 ms (the strands slip with the cable's mean stretch, not with the servo's
    millisecond chatter, which would otherwise dither the loop away). ``stiffness`` in N m/rad, N/m;
    ``beta`` and ``gamma`` in 1/rad, 1/m. The joint error then traces a loop against the tension
    that turns smoothly after each reversal (unlike the jump of backlash).
    """

    name: ClassVar[str] = "hysteresis"
    stiffness: np.ndarray = field(default_factory=lambda: np.array([30.0, 5.0, 1200.0]))
    beta: np.ndarray = field(default_factory=lambda: np.array([250.0, 150.0, 4000.0]))
    gamma: np.ndarray = field(default_factory=lambda: np.array([100.0, 60.0, 1500.0]))

    def __post_init__(self):
        object.__setattr__(self, "stiffness", _vector(self.stiffness, 3, "stiffness"))
        object.__setattr__(self, "beta", _vector(self.beta, 3, "beta"))
        object.__setattr__(self, "gamma", _vector(self.gamma, 3, "gamma"))
        if np.any(self.beta + self.gamma <= 0):
            raise ValueError("beta + gamma must be positive")


@dataclass(frozen=True)
class Drift(Effect):
    """Cable fatigue and creep: stiffness and offsets that change with operating time and load.

    RAVEN-II's cables run over small sheaves with large wrap angles under high tension, so they age
    within hours (paper II-G; Miyasaka 2017). Each positioning joint accumulates a fatigue dose in
    equivalent operating hours while it moves,

        d(dose)/dt = time_scale / 3600 * |q_dot| / reference_speed * (1 + payload_gain * payload_kg),

    zero while the joint is still (idle operation does not age the cable, as the paper's 6-hour
    idle run showed). The cable stiffness is divided by ``1 + stiffness_loss * dose`` and the cable
    lengthens by ``creep_rate * dose`` (rad, rad, m), which the joint sees as a growing offset.
    ``payload_gain`` (1/kg) encodes the paper's observation that a 500 g payload ages the cables
    faster, joint 1 most, although the payload hardly changes joint 1's static torque: it is an
    empirical term, not a derived one. ``time_scale`` compresses time for tests (3600 makes one
    simulated second one hour).
    """

    name: ClassVar[str] = "drift"
    stiffness_loss: np.ndarray = field(default_factory=lambda: np.array([0.04, 0.02, 0.01]))
    creep_rate: np.ndarray = field(default_factory=lambda: np.array([2.463342e-03, 9.549788e-04, 1.096092e-05]))
    payload_gain: np.ndarray = field(default_factory=lambda: np.array([2.0, 1.0, 1.0]))
    reference_speed: np.ndarray = field(default_factory=lambda: np.array([0.035, 0.035, 0.004]))
    time_scale: float = 1.0

    def __post_init__(self):
        for name in ("stiffness_loss", "creep_rate", "payload_gain", "reference_speed"):
            object.__setattr__(self, name, _vector(getattr(self, name), 3, name))
        if np.any(self.reference_speed <= 0):
            raise ValueError("reference_speed must be positive")
        if not (np.isfinite(self.time_scale) and self.time_scale > 0):
            raise ValueError(f"time_scale must be positive, got {self.time_scale}")


@dataclass(frozen=True)
class HomingOffset(Effect):
    """Encoder registration at the hard stops while the cables are under homing tension.

    Homing drives each joint into its hard stop until the motor current reaches a threshold
    (``homing.cpp``), waits 200 ms, and declares the motor position to correspond to the stop.
    But at that moment the motor has wound the cable tight against the stop: the registered zero
    includes the stretch under homing tension, which the joints carry as an offset afterwards
    (the paper's large raw error). On top, each homing lands differently (contact, the current
    ramp crossing the threshold between servo ticks, the coupled elbow cable over the shoulder):
    ``repeatability`` is the standard deviation of that registration per homing (rad, rad, m for
    the positioning joints; ``tool_repeatability`` rad for the tool joints). Switched off, the
    registration is ideal: the encoders are zeroed where an unstretched cable puts the joint.
    """

    name: ClassVar[str] = "homing_offset"
    repeatability: np.ndarray = field(default_factory=lambda: np.array([2e-4, 3.5e-3, 3e-5]))
    tool_repeatability: np.ndarray = field(default_factory=lambda: np.array([5e-3, 5e-3, 5e-3, 5e-3]))

    def __post_init__(self):
        object.__setattr__(self, "repeatability", _vector(self.repeatability, 3, "repeatability"))
        object.__setattr__(self, "tool_repeatability", _vector(self.tool_repeatability, 4, "tool_repeatability"))


@dataclass(frozen=True)
class Quantization(Effect):
    """Finite resolution of the motor encoders, the external joint encoders and the DAC.

    Motor encoders count ``motor_counts_per_rev`` per motor revolution (``motor.h``: 4000); the
    ground-truth encoders resolve ``truth_resolution`` (AEDA-3300 80000 counts per revolution on
    joints 1-2, Mercury II 1600 with 5 um on joint 3; paper IV-B); current commands are integer
    DAC counts. Switched off, all three are continuous.
    """

    name: ClassVar[str] = "quantization"
    motor_counts_per_rev: float = 4000.0
    truth_resolution: np.ndarray = field(default_factory=lambda: np.array([2 * np.pi / 80000, 2 * np.pi / 80000, 5e-6]))

    def __post_init__(self):
        object.__setattr__(self, "truth_resolution", _vector(self.truth_resolution, 3, "truth_resolution"))
        if not self.motor_counts_per_rev > 0:
            raise ValueError("motor_counts_per_rev must be positive")


@dataclass(frozen=True)
class Noise(Effect):
    """Electrical noise: motor current ripple and ground-truth encoder jitter.

    ``current_noise`` is the standard deviation of the motor current about its command at each
    servo tick (A, seven DOFs; PWM amplifier ripple), so the torque that reaches the cable is not
    exactly the logged ``tau``. ``truth_noise`` is the standard deviation of the external encoder
    reading (rad, rad, m), e.g. from frame vibration.
    """

    name: ClassVar[str] = "noise"
    current_noise: np.ndarray = field(default_factory=lambda: np.full(7, 0.01))
    truth_noise: np.ndarray = field(default_factory=lambda: np.array([2e-5, 2e-5, 2e-6]))

    def __post_init__(self):
        object.__setattr__(self, "current_noise", _vector(self.current_noise, 7, "current_noise"))
        object.__setattr__(self, "truth_noise", _vector(self.truth_noise, 3, "truth_noise"))


@dataclass(frozen=True)
class CapstanRunout(Effect):
    """Eccentric capstans: a transmission error periodic in the motor angle.

    A capstan whose cable groove is off-centre by ``eccentricity`` (m) winds cable unevenly over
    each revolution of the capstan shaft (the gearbox output), so the joint moves ahead and behind
    the motor with one period per capstan turn, amplitude ``eccentricity / pulley radius`` in joint
    units. ``amplitude`` is that joint-side amplitude (rad, rad, m). The error repeats every 2 pi
    of the capstan shaft, far faster in joint space than any other effect here.
    """

    name: ClassVar[str] = "capstan_runout"
    amplitude: np.ndarray = field(default_factory=lambda: np.array([8e-5, 1.2e-4, 5e-6]))

    def __post_init__(self):
        object.__setattr__(self, "amplitude", _vector(self.amplitude, 3, "amplitude"))


EFFECT_TYPES: tuple[type[Effect], ...] = (
    CableStretch,
    GravityStretch,
    Coupling,
    CoulombFriction,
    ViscousFriction,
    Backlash,
    Hysteresis,
    Drift,
    HomingOffset,
    Quantization,
    Noise,
    CapstanRunout,
)
"""Every effect the virtual RAVEN-II implements, in the order the engine applies them."""

EFFECT_NAMES: tuple[str, ...] = tuple(t.name for t in EFFECT_TYPES)
EFFECT_BY_NAME: dict[str, type[Effect]] = {t.name: t for t in EFFECT_TYPES}


def effect_type(name: str) -> type[Effect]:
    """The effect class of a name, with a clear error for an unknown one."""
    try:
        return EFFECT_BY_NAME[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECT_NAMES)}") from None
