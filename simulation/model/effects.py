"""Named physical effects of the RAVEN-II cable transmission.

The virtual RAVEN-II's transmission is a composition of the effect objects below. Each one names
the physics it stands for, holds its parameters (SI, one value per positioning joint unless stated:
shoulder, elbow, insertion), and can be switched off. The same objects are the candidate library of
the model-discrepancy workflow, so an effect's ``name`` is part of the public vocabulary:

``cable_stretch``, ``gravity_stretch``, ``coupling``, ``coulomb_friction``, ``viscous_friction``,
``backlash``, ``hysteresis``, ``drift``, ``homing_offset``, ``quantization``, ``noise``,
``capstan_runout``, ``motor_friction``, ``capstan_friction``, ``gravity_model_error``,
``transmission_error``, ``registration_offset``.

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
hysteresis                form after Miyasaka et al. 2016; size from an assumed axial loss factor of
                          3 % of the operating tension amplitude (see :class:`Hysteresis`).
drift                     ``creep_rate``: casadi fit to Table III (linear regression, unloaded: the
                          part of the hour-5 RMSE operation added, ``sqrt(h5**2 - h0**2)``),
                          ``python -m simulation.default_fit``; ``stiffness_loss``, ``payload_gain``
                          and ``reference_speed``: tuning with the paper's II-G findings (joint 1
                          ages most, load ages faster, idle does not age).
homing_offset             the registration itself follows ``homing.cpp`` (controller facts);
                          ``repeatability``: tuning to the paper's II-I finding that joint 2 is the
                          joint that homing disturbs (0.2 deg per homing, others ~0.01 deg, 0.03 mm).
quantization              controller and encoder facts (``motor.h``; paper IV-B).
noise                     tuning: 10 mA of current ripple, 0.001 deg / 2 um of encoder jitter.
capstan_runout            5 um of capstan eccentricity over the joint pulley radii (``defines.h``).
motor_friction            maxon RE40/RE30 no-load current x torque constant; GP42/GP32 efficiency
                          (catalogue values, see :class:`MotorFriction`).
capstan_friction          capstan law; ``mu`` 0.01 and wrap angles from the cable routing (assumed).
gravity_model_error       10 %, the size of the mass corrections in ``grav_comp.cpp``'s history.
transmission_error        0.2 %, a caliper's resolution on the capstan radius of ``defines.h``.
registration_offset       ISO 2768-m tolerance on the hard stops over the pulley radii.
========================  ==========================================================================

The cable law and the creep rates were fitted with every effect above switched on; the five last
ones lie outside the UKF's model class (:mod:`simulation.model.mismatch`).
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
    stiffness: np.ndarray = field(default_factory=lambda: np.array([38.715259, 14.326731, 2095.225062]))
    hardening: np.ndarray = field(default_factory=lambda: np.array([0.017397, 0.048466, 0.009597]))
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
    averaged over ``response_time`` seconds, a first-order lag, 50 ms by default (the strands slip
    with the cable's mean stretch, not with the servo's millisecond chatter, which would otherwise
    dither the loop away); 0 makes it follow the stretch of every plant sub-step. ``stiffness`` in
    N m/rad, N/m; ``beta`` and ``gamma`` in 1/rad, 1/m; ``response_time`` in s. The joint error then
    traces a loop against the tension that turns smoothly after each reversal (unlike the jump of
    backlash).

    Size of the defaults: an assumption stated as a loss factor, since no measured loop size of the
    RAVEN-II's cables is among this project's sources (Miyasaka et al. identified the model's form
    on a rig; the paper cites it without sizes). The hysteretic tension amplitude
    ``stiffness / (beta + gamma)`` is ``(pi / 4) * eta`` times the cable's operating tension
    amplitude, for an axial loss factor ``eta = 0.03`` (a few per cent, the order of interwire
    friction losses in axially loaded stranded rope). The operating amplitudes, sqrt(2) times the
    tension's standard deviation over a 240 s random test with this effect off, are 1.08 N m,
    0.46 N m and 0.53 N, so the hysteretic amplitudes are 0.025 N m, 0.011 N m and 0.013 N. The loop
    turns within a tenth of the operating stretch amplitude (0.021 rad, 0.029 rad, 0.61 mm), which
    sets the yield stretch ``1 / (beta + gamma)``; ``beta / gamma = 2.5``. The hysteretic stiffness
    stays below the cable's own on every joint.
    """

    name: ClassVar[str] = "hysteresis"
    stiffness: np.ndarray = field(default_factory=lambda: np.array([12.0, 4.0, 200.0]))
    beta: np.ndarray = field(default_factory=lambda: np.array([340.0, 250.0, 12000.0]))
    gamma: np.ndarray = field(default_factory=lambda: np.array([140.0, 100.0, 4700.0]))
    response_time: np.ndarray = field(default_factory=lambda: np.full(3, 0.05))

    def __post_init__(self):
        object.__setattr__(self, "stiffness", _vector(self.stiffness, 3, "stiffness"))
        object.__setattr__(self, "beta", _vector(self.beta, 3, "beta"))
        object.__setattr__(self, "gamma", _vector(self.gamma, 3, "gamma"))
        object.__setattr__(self, "response_time", _vector(self.response_time, 3, "response_time"))
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
    creep_rate: np.ndarray = field(default_factory=lambda: np.array([2.068536e-03, 6.593772e-04, 3.735996e-05]))
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


@dataclass(frozen=True)
class MotorFriction(Effect):
    """Dry friction of the motors and the load-dependent loss of their planetary gearboxes.

    Acts on the motor side of the cable, so the torque that reaches the capstan is the amplifier's
    torque less this friction: the logged command ``tau`` and the ``applied_torque`` channel (with
    this effect on, the torque delivered at the gearbox output, averaged over the previous servo
    tick) differ by it, with a sign that follows the motor velocity. Two terms, as a set-valued
    (stick-slip) Coulomb law on the motor velocity, in the servo loop's joint units:

        bound = coulomb * tr + gearbox_loss * |transmitted torque|,

    with ``tr`` the transmission ratio, so ``coulomb * tr`` is the motor-shaft friction seen at the
    joint; the transmitted torque is the cable's reaction at the gearbox output (positioning
    joints) or the motor's command (tool joints, whose cables are not modelled as springs). The
    motor sticks while the net torque on it is within ``bound``.

    Sources of the defaults (seven DOFs: three RE40 + GP42, four RE30 + GP32):

    * ``coulomb`` (N m at the motor shaft): no-load current times torque constant, the friction
      torque a brushed DC motor's datasheet implies (maxon RE40 148877, 48 V: 69 mA x 60.3 mN m/A =
      4.2 mN m; RE30 310007, 48 V: 88.2 mA x 53.8 mN m/A = 4.7 mN m; catalogue values).
      ``RavenConstants.motor_damping`` turns the same datasheet figures into a tiny viscous term;
      this effect keeps them as what they are, a speed-independent friction.
    * ``gearbox_loss`` (dimensionless, >= 0): the friction per unit of transmitted torque of a
      gearbox of efficiency ``eta``, ``(1 - eta) / eta`` (the input torque is the output over
      ``eta``). Maxon GP42C, two-stage 12.25:1 as ``defines.h`` GEAR_BOX_GP42_TR = 49/4: maximum
      efficiency 81 % (three-stage: 72 %); GP32 one-stage 3.7:1 as GEAR_BOX_GP32_TR = 26/7: 80 %.
      The datasheet figure is the forward efficiency at nominal torque; the loss is taken equal in
      both directions. :meth:`from_efficiency` builds the effect from efficiencies.
    """

    name: ClassVar[str] = "motor_friction"
    coulomb: np.ndarray = field(default_factory=lambda: np.array([0.069 * 0.0603] * 3 + [0.0882 * 0.0538] * 4))
    gearbox_loss: np.ndarray = field(default_factory=lambda: (1.0 - np.array([0.81] * 3 + [0.80] * 4))
                                     / np.array([0.81] * 3 + [0.80] * 4))

    def __post_init__(self):
        object.__setattr__(self, "coulomb", _vector(self.coulomb, 7, "coulomb"))
        object.__setattr__(self, "gearbox_loss", _vector(self.gearbox_loss, 7, "gearbox_loss"))

    @classmethod
    def from_efficiency(cls, efficiency, **fields) -> "MotorFriction":
        """The effect with the gearbox loss of the given efficiencies (7 values in (0, 1])."""
        eta = _vector(efficiency, 7, "efficiency")
        if np.any(eta <= 0) or np.any(eta > 1):
            raise ValueError(f"efficiency must be in (0, 1], got {eta}")
        return cls(gearbox_loss=(1.0 - eta) / eta, **fields)

    @property
    def efficiency(self) -> np.ndarray:
        """Gearbox efficiency of each DOF, ``1 / (1 + gearbox_loss)``."""
        return 1.0 / (1.0 + self.gearbox_loss)


@dataclass(frozen=True)
class CapstanFriction(Effect):
    """Cable-pulley friction that grows with the cable tension (capstan friction).

    A cable bent over a pulley through a wrap angle ``theta`` transmits at most ``T exp(mu theta)``
    against friction coefficient ``mu`` (capstan equation); for small ``mu theta`` the friction is
    ``mu theta |T|``. Miyasaka et al. (IROS 2015, "Measurement of the cable-pulley Coulomb and
    viscous friction for a cable-driven surgical robotic system", test rigs built to the RAVEN II's
    cables and pulleys) found the cable-pulley friction to be a function of the tension, the wrap
    angle and the number of pulleys, not of the cable speed. The servo loop applies it as a
    joint-side dry friction (set-valued, like ``coulomb_friction``) whose bound is

        bound = mu * wrap_angle * |T|,

    ``T`` the cable tension of the previous integration sub-step (joint units), so under a payload
    the friction, and the stretch the cable carries for it, grow with the load, unlike the fixed
    ``coulomb_friction``.

    Defaults. ``wrap_angle`` (rad): total wrap over the idler pulleys between capstan and joint
    (the capstan and the joint pulley, where the cable is terminated, do not slip): joint 1 is a
    single alpha-wrapped partial pulley (``defines.h`` PARTIAL_PULLEY_LINK1_RADIUS) with a short
    run, joint 2's cable passes the shoulder's idlers, joint 3's passes the shoulder's and the
    elbow's and runs along the tool carriage; pi, 2 pi, 4 pi are estimates from that routing, not
    measurements. ``mu`` (dimensionless): an effective coefficient of 0.01 per radian for a steel
    rope over ball-bearing idlers (bending and bearing losses). Handbook dry sliding coefficients
    (steel on aluminium about 0.5, steel on steel 0.5-0.8) apply only where a cable slides over a
    fixed surface; on rotating pulleys they are an upper bound, far above it. Both defaults
    are assumptions to be replaced by the Miyasaka measurements.
    """

    name: ClassVar[str] = "capstan_friction"
    mu: np.ndarray = field(default_factory=lambda: np.full(3, 0.01))
    wrap_angle: np.ndarray = field(default_factory=lambda: np.array([np.pi, 2 * np.pi, 4 * np.pi]))

    def __post_init__(self):
        object.__setattr__(self, "mu", _vector(self.mu, 3, "mu"))
        object.__setattr__(self, "wrap_angle", _vector(self.wrap_angle, 3, "wrap_angle"))

    @property
    def coefficient(self) -> np.ndarray:
        """Friction per unit tension, ``mu * wrap_angle`` (dimensionless)."""
        return self.mu * self.wrap_angle


@dataclass(frozen=True)
class GravityModelError(Effect):
    """The controller's gravity compensation uses masses that differ from the arm's true ones.

    The plant's links weigh what the kinematics model says (masses and centres of mass of
    ``grav_comp.cpp``, with any payload); the controller's gravity compensation adds
    ``(1 + scale_error[j])`` times the unloaded model's torque on positioning joint ``j``. The
    difference is held by the PD loop on the motor encoders, so each motor settles off its desired
    position by ``scale_error * g`` over the loop's stiffness ``kp * tr**2 / gearbox`` (joint
    units; ``g`` the model's torque at the joints the controller measures), and the joints by that
    through the coupling: a static error proportional to the gravity torque. ``scale_error`` is
    dimensionless, per joint.

    Default: 0.1 on every joint, an assumption of the size the controller's own history shows:
    ``grav_comp.cpp`` replaced its masses 2.7 x (0.2395, 0.3568, 0.1500) kg = 0.6465, 0.9637,
    0.405 kg by 0.494, 0.750, 0.231 kg ("masses updated using fresh links from raven 2.1 build"),
    changes of 24 %, 22 % and 43 %; an individual arm, its cabling and its instrument adapter sit
    some fraction of that from the values in the code.
    """

    name: ClassVar[str] = "gravity_model_error"
    scale_error: np.ndarray = field(default_factory=lambda: np.full(3, 0.1))

    def __post_init__(self):
        object.__setattr__(self, "scale_error", _vector(self.scale_error, 3, "scale_error", nonnegative=False))
        if np.any(self.scale_error <= -1):
            raise ValueError(f"scale_error must be above -1, got {self.scale_error}")


@dataclass(frozen=True)
class TransmissionError(Effect):
    """The effective pulley and capstan radii differ from the controller's nominal ones.

    The transmission ratios of ``defines.h`` are ratios of effective radii (groove radius plus
    cable radius, e.g. PARTIAL_PULLEY_LINK1_RADIUS = 62.5 + 1.19 / 2 mm over CAPSTAN_RADIUS_GP42).
    Where the cable really runs depends on its diameter tolerance and on how it seats in the
    groove, so the true ratio is ``nominal * (1 + ratio_error)`` per positioning joint
    (dimensionless): the joint moves ``1 / (1 + ratio_error)`` of what the controller computes
    from its motor, and the controller's joint estimate is off by ``ratio_error`` times the true
    distance from the pose where the encoders were registered (the hard stops with
    ``homing_offset`` on, the power-on zero without it).

    Default: 0.2 % on every joint. ``defines.h`` sets CAPSTAN_RADIUS_GP42 to 11.35 / 2 mm
    "measured using caliper, plus validated empirically", replacing a design value of 6.0 mm
    (5.4 + CABLE_RADIUS_1050): the nominal radius itself moved by 5.6 %, and a caliper's
    0.02 mm on an 11.35 mm diameter leaves 0.18 % on the smallest radius of each ratio.
    """

    name: ClassVar[str] = "transmission_error"
    ratio_error: np.ndarray = field(default_factory=lambda: np.full(3, 0.002))

    def __post_init__(self):
        object.__setattr__(self, "ratio_error", _vector(self.ratio_error, 3, "ratio_error", nonnegative=False))
        if np.any(self.ratio_error <= -1):
            raise ValueError(f"ratio_error must be above -1, got {self.ratio_error}")


@dataclass(frozen=True)
class RegistrationOffset(Effect):
    """The hard stops are not where the controller's registration says they are.

    At homing the controller declares each positioning joint to be at its stop position of
    ``defines.h`` (SHOULDER_MAX_ANGLE 0, ELBOW_MAX_ANGLE 3 pi / 4 + 2.5 deg, Z_INS_MAX_ANGLE
    0.562 m). The real stop differs from that by its machining and assembly tolerance and by the
    stop's own compliance under the homing torque: the controller's joint estimate is then off by
    ``offset + repeatability * N(0, 1)`` (rad, rad, m), a new draw per homing, constant between
    homings. With ``repeatability`` zero the offset is deterministic, the same at every homing.

    This differs from ``homing_offset``: that effect is the registration taken while the cable is
    stretched under the homing tension (its constant part scales with the cable stiffness and the
    homing current, and disappears with rigid cables) and the scatter of where the motors end at
    the threshold crossing (``repeatability`` there). This one is a property of the stops
    themselves: it is there with rigid cables, does not depend on the homing current or the
    cable stiffness, and its scatter is the stop contact's, not the homing search's.

    Defaults (assumptions, stated as tolerances): ``offset`` = one standard deviation of a uniform
    +-0.2 mm tolerance (ISO 2768-m for 6-30 mm features) on the stop face, 0.115 mm, over the
    joints' pulley radii (62.5 and 40.85 mm, ``defines.h``) and directly on the insertion axis;
    ``repeatability`` = 5 um of contact scatter over the same radii. The hand-made
    ``+ 2.5 * M_PI / 180`` in ELBOW_MAX_ANGLE shows stop positions are corrected empirically.
    """

    name: ClassVar[str] = "registration_offset"
    offset: np.ndarray = field(default_factory=lambda: np.array([0.115 / 62.5, 0.115 / 40.85, 0.115e-3]))
    repeatability: np.ndarray = field(default_factory=lambda: np.array([5e-3 / 62.5, 5e-3 / 40.85, 5e-6]))

    def __post_init__(self):
        object.__setattr__(self, "offset", _vector(self.offset, 3, "offset", nonnegative=False))
        object.__setattr__(self, "repeatability", _vector(self.repeatability, 3, "repeatability"))


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
    MotorFriction,
    CapstanFriction,
    GravityModelError,
    TransmissionError,
    RegistrationOffset,
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
