"""Replay: drive a model with measured inputs and predict what the sensors should read.

For RAVEN-II data the model is the cable model of a :class:`~simulation.model.parameters.RavenParameters`
(the fitted model of the identification, or the simulator's): the measured motor positions drive
the cable coupling, the measured link motion and payload set the link loads (gravity, friction,
inertia), the cable law turns the loads into stretch, and the prediction is

    joint = play(A u) - creep - stretch(T) + offset,
    motor torque = (A^T T + J_u u'' + b_u u') * gearbox / transmission ratio,

with ``A`` the cable coupling (each motor's column over ``1 + ratio_error`` with a transmission
error, as in the simulator's engine), evaluated sample by sample with the model layer's laws
(:mod:`simulation.model.laws`: cable tension and its inverse, tangent stiffness, gravity load,
play, Bouc-Wen hysteresis, whose state follows the logged stretch sample by sample: the workflow's
replay has no ``Hysteresis.response_time``). The replay keeps no state of the links' vibration on their cables: the
links' inertia enters through their measured accelerations. That vibration is not far above the
30 Hz log (at zero tension, about 3 Hz for the shoulder and the elbow and 15 Hz for the insertion
axis, from the kinematics' mass matrix at one pose and the default cable stiffness), which is one
reason the replay is not the simulator's equal: the simulator's plant driven by the logged motor
positions (:mod:`simulation.engine.plant_replay`, about a hundred times slower) leaves a third less
held-out residual with nothing hidden (``python studies/discrepancy_floor.py --dynamic``), and
scores the final models of a RAVEN-II analysis (:mod:`studies.common.plant_scoring`). For generic data the nominal model is
``joint = reported + offset``. The residual the workflow studies is measured minus predicted, for
the joints and, when the data has them, for the motor torques, which is what tells effects that
look alike in the joints apart.
"""

from __future__ import annotations

import functools
from collections import OrderedDict
from dataclasses import dataclass, replace

import numpy as np
from numba import njit

from simulation.model.laws import (
    bouc_wen_rate,
    bouc_wen_slope,
    cable_stiffness,
    cable_tension_curve,
    coupling_matrix,
    gravity_load,
    motor_friction,
    MOTOR_STICTION_SPEED,
    play,
    stiffness_tension,
    stretch_from_tension,
)
from simulation.model.parameters import RavenParameters

from simulation.discrepancy.signals import MeasuredSignals


@njit(cache=True)
def play_series(position: np.ndarray, half_width: float, restart: np.ndarray) -> np.ndarray:
    """Backlash operator over a time series, starting centred (output = input) at every ``restart``."""
    out = np.empty_like(position)
    state = position[0]
    for n in range(position.shape[0]):
        if restart[n]:
            state = position[n]
        state = play(position[n], state, half_width)
        out[n] = state
    return out


@njit(cache=True)
def bouc_wen_series(rate: np.ndarray, time: np.ndarray, beta: float, gamma: float) -> np.ndarray:
    """Bouc-Wen state (n = 1) driven by a rate series, integrated with sub-steps between samples."""
    z = np.zeros_like(rate)
    state = 0.0
    for n in range(1, rate.shape[0]):
        dt = time[n] - time[n - 1]
        r = 0.5 * (rate[n] + rate[n - 1])
        steps = 1 + int(abs(r) * dt * (beta + gamma) * 10.0)
        h = dt / steps
        for _ in range(steps):
            state += h * bouc_wen_rate(state, r, beta, gamma)
        z[n] = state
    return z


@njit(cache=True)
def _bouc_wen_after(z: float, stretch_change: float, beta: float, gamma: float) -> float:
    """Bouc-Wen state after the stretch changes by ``stretch_change`` (dz/ds = 1 - beta sgn z - gamma |z|).

    Explicit Euler sub-steps of at most a tenth of the hysteresis width (``1 / (beta + gamma)``).
    Once the state has the sign of the motion the slope is linear in it, ``1 - (beta + gamma) |z|``,
    so the remaining sub-steps are a geometric series, summed in closed form when there are many
    (a stretch change of many widths, as a nearly closed loop of a fitted width gives): the same
    sub-steps, without a loop whose length grows as the width shrinks.
    """
    if stretch_change == 0.0:
        return z
    steps = 1 + int(abs(stretch_change) * (beta + gamma) * 10.0)
    ds = stretch_change / steps
    sign = 1.0 if ds > 0.0 else -1.0
    k = 0
    while k < steps and (z * sign < 0.0 or steps - k <= _SUMMED_AFTER):
        z += ds * bouc_wen_slope(z, sign, beta, gamma)
        k += 1
    if k < steps:
        # z' = z + ds (1 - c z) with c = (beta + gamma) sgn(ds): the fixed point 1/c, approached by (1 - c ds) per step
        fixed = sign / (beta + gamma)
        z = fixed + (1.0 - abs(ds) * (beta + gamma)) ** (steps - k) * (z - fixed)
    return z


_SUMMED_AFTER = 16
"""Sub-steps of one sign beyond which :func:`_bouc_wen_after` sums them in closed form; below it
they run one by one (the two agree to rounding)."""


@njit(cache=True)
def _balanced_stretch(target, previous, z, lower, upper, stiffness, hardening, softening, k_h, beta, gamma,
                      fraction):
    """Stretch whose elastic plus hysteretic tension equals ``target``.

    The Bouc-Wen state moves with ``fraction`` of the stretch's change from ``previous`` (1: the
    stretch itself; less: a stretch followed with a lag). The tension grows monotonically with the
    stretch, so Newton steps kept inside a shrinking bracket (bisection when a step leaves it)
    converge in a few iterations.
    """
    x = 0.5 * (lower + upper)
    for _ in range(50):
        z_x = _bouc_wen_after(z, fraction * (x - previous), beta, gamma)
        value = stiffness_tension(x, stiffness, hardening) / softening + k_h * z_x - target
        if value > 0.0:
            upper = x
        else:
            lower = x
        sign = 1.0 if x >= previous else -1.0
        slope = (cable_stiffness(x, stiffness, hardening) / softening
                 + k_h * fraction * max(bouc_wen_slope(z_x, sign, beta, gamma), 0.0))
        step = x - value / slope
        if not (lower < step < upper):
            step = 0.5 * (lower + upper)
        if abs(step - x) < 1e-12 * (1.0 + abs(x)):
            return step
        x = step
    return x


@njit(cache=True)
def cable_link_series(base, load, dry, softening, stiffness, hardening, hysteresis_stiffness, beta, gamma,
                      start, restart, capstan, follow, lagged):
    """Link position of one joint hanging on its cable, sample by sample.

    The link stays put while the cable's tension (elastic ``k x0 sinh(s/x0)`` divided by the
    fatigue ``softening``, plus the hysteretic ``hysteresis_stiffness * z``) balances the load
    within the dry friction: ``dry`` (one bound per sample) plus, with a ``capstan`` coefficient,
    the pulley friction ``capstan * |T|`` of the tension ``T`` that moves the link, solved for
    ``T`` (so moving against the load costs more than moving with it); otherwise it moves until the tension equals load plus or minus the
    friction, solved implicitly because the hysteretic tension changes with the stretch (Bouc-Wen)
    and may be stiffer than the cable itself. Friction and hysteresis thus interact as they do in
    the simulator. ``start`` (N,) are the measured link positions the series (re)starts from at
    the samples where ``restart`` holds (the first, and the first after each re-homing, where the
    encoders were re-registered). The Bouc-Wen state follows the stretch sample by sample, or, with
    ``lagged``, a first-order lag of it that moves ``follow[k]`` (N,) of the way to the stretch at
    sample ``k`` (``1 - exp(-dt / response_time)``; a diagnostic's, never the workflow's). Returns
    the link positions and the hysteresis state.
    """
    n = base.shape[0]
    link = np.empty(n)
    zs = np.zeros(n)
    state = start[0]
    z = 0.0
    previous = base[0] - start[0]
    for k in range(n):
        if restart[k]:
            state = start[k]
            z = 0.0
            previous = base[k] - state
        stretch = base[k] - state
        z_stick = _bouc_wen_after(z, follow[k] * (stretch - previous), beta, gamma)
        tension = stiffness_tension(stretch, stiffness, hardening) / softening[k] + hysteresis_stiffness * z_stick
        high = load[k] + dry[k]
        low = load[k] - dry[k]
        if capstan > 0.0:
            # T = load +- (dry + capstan |T|), solved for T on each side
            high = high / (1.0 - capstan) if high > 0.0 else high / (1.0 + capstan)
            low = low / (1.0 + capstan) if low > 0.0 else low / (1.0 - capstan)
        if tension > high or tension < low:
            target = high if tension > high else low
            if hysteresis_stiffness == 0.0:
                stretch = stretch_from_tension(target * softening[k], stiffness, hardening)
            else:
                # bracket: the elastic-only stretches for the target shifted by the largest hysteretic tension
                reach = hysteresis_stiffness / (beta + gamma) + 1e-9
                lower = stretch_from_tension((target - reach) * softening[k], stiffness, hardening) - 1e-9
                upper = stretch_from_tension((target + reach) * softening[k], stiffness, hardening) + 1e-9
                stretch = _balanced_stretch(target, previous, z, lower, upper, stiffness, hardening, softening[k],
                                            hysteresis_stiffness, beta, gamma, follow[k])
            z_stick = _bouc_wen_after(z, follow[k] * (stretch - previous), beta, gamma)
            state = base[k] - stretch
        z = z_stick
        # the stretch the state follows: the stretch itself, or its lag
        previous = previous + follow[k] * (stretch - previous) if lagged else stretch
        link[k] = state
        zs[k] = z
    return link, zs


class _SeriesMemo:
    """The last results of :func:`cable_link_series`, with the cable's elastic tension along them,
    looked up by their inputs.

    A candidate's fit perturbs one parameter at a time to take its gradient, and a parameter of
    one joint leaves the other joints' series unchanged: their results are taken from here instead
    of being run again (about a third of the replays' time for per-joint candidates). Entries are
    indexed by a cheap fingerprint of the inputs (a weighted sum of each array and the scalars),
    and a hit is accepted only when every input equals the remembered one exactly. Both run
    compiled: as numpy calls, hashing and comparing six arrays cost about as much as the series.
    """

    def __init__(self, size: int = 48, max_bytes: int = 256 * 2 ** 20):
        self._size = size
        self._max_bytes = max_bytes
        self._bytes = 0
        self._count = 0
        self._results: OrderedDict[tuple, list] = OrderedDict()

    def series(self, base, load, dry, softening, stiffness, hardening, hysteresis_stiffness, beta, gamma,
               start, restart, capstan, follow, lagged, lag) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The link positions, the hysteresis state and the elastic tension ``k x0 sinh(s / x0)`` of
        the stretch ``s = base - link`` (before the cable's softening), each (N,). ``follow`` derives
        from the record's times and the hysteresis's ``lag`` (s), which the memo's key holds instead."""
        arrays = (base, load, dry, softening, start, restart)
        scalars = (stiffness, hardening, hysteresis_stiffness, beta, gamma, capstan, lag)
        key = (base.shape[0], _series_fingerprint(*arrays)) + tuple(float(v) for v in scalars)
        for remembered, result in self._results.get(key, ()):
            if _same_series_inputs(*arrays, *remembered):
                self._results.move_to_end(key)
                return result
        link, z = cable_link_series(base, load, dry, softening, stiffness, hardening, hysteresis_stiffness, beta,
                                    gamma, start, restart, capstan, follow, lagged)
        # the elastic tension of this joint's stretch, element by element as the whole table's
        result = (link, z, cable_tension_curve(base - link, stiffness, hardening))
        for array in result:
            array.setflags(write=False)
        copies = tuple(np.array(a, copy=True) for a in arrays)
        self._results.setdefault(key, []).append((copies, result))
        self._results.move_to_end(key)
        self._bytes += _nbytes(copies, result)
        self._count += 1
        while self._results and (self._bytes > self._max_bytes or self._count > self._size):
            oldest = next(iter(self._results))
            self._bytes -= _nbytes(*self._results[oldest].pop(0))
            self._count -= 1
            if not self._results[oldest]:
                del self._results[oldest]
        return result


def _nbytes(*groups) -> int:
    return sum(a.nbytes for group in groups for a in group)


@njit(cache=True)
def _series_fingerprint(base, load, dry, softening, start, restart):
    """Weighted sums of the series inputs (weights in [1, 2) that vary along the record), one per input."""
    sums = np.zeros(6)
    for k in range(base.shape[0]):
        weight = 1.0 + (k * 0.6180339887498949) % 1.0
        sums[0] += weight * base[k]
        sums[1] += weight * load[k]
        sums[2] += weight * dry[k]
        sums[3] += weight * softening[k]
        sums[4] += weight * start[k]
        sums[5] += weight * restart[k]
    return sums[0], sums[1], sums[2], sums[3], sums[4], sums[5]


@njit(cache=True)
def _same_series_inputs(base, load, dry, softening, start, restart, base_, load_, dry_, softening_, start_,
                        restart_):
    """Whether two sets of series inputs are equal, element by element."""
    if base.shape[0] != base_.shape[0] or restart.shape[0] != restart_.shape[0]:
        return False
    for k in range(base.shape[0]):
        if (base[k] != base_[k] or load[k] != load_[k] or dry[k] != dry_[k] or softening[k] != softening_[k]
                or start[k] != start_[k] or restart[k] != restart_[k]):
            return False
    return True


_SERIES = _SeriesMemo()


@functools.lru_cache(maxsize=8)
def _ones(shape: tuple) -> np.ndarray:
    """A read-only array of ones (the cable's softening where it does not age), shared by every replay."""
    ones = np.ones(shape)
    ones.setflags(write=False)
    return ones


@functools.lru_cache(maxsize=64)
def _constant(n: int, value: float) -> np.ndarray:
    """A read-only (n,) array of ``value`` (a joint's dry friction bound), shared by every replay
    that asks for the same one."""
    array = np.full(n, value)
    array.setflags(write=False)
    return array


def _lag_fractions(time: np.ndarray, response_time: float) -> np.ndarray:
    """(N,) fraction of the way a first-order lag of ``response_time`` s moves towards its input
    between each sample and the one before, ``1 - exp(-dt / response_time)`` (1 at the first)."""
    fractions = np.ones(time.shape[0])
    fractions[1:] = -np.expm1(-np.diff(time) / response_time)
    fractions.setflags(write=False)
    return fractions


@dataclass(frozen=True, eq=False)
class ReplayState:
    """A model's prediction along measured signals, with the internals behind it.

    Attributes
    ----------
    joints : (N, J) predicted joint positions.
    torque : (N, J) predicted motor torques at the gearbox output, or None.
    tension : (N, J) predicted cable tension (joint units), or None.
    stretch : (N, J) predicted cable stretch, zeros for generic data.
    gravity : (N, J) gravity holding load of the links with the payload (N m, N), or None.
    """

    joints: np.ndarray
    torque: np.ndarray | None
    tension: np.ndarray | None
    stretch: np.ndarray
    gravity: np.ndarray | None


@dataclass(frozen=True, eq=False)
class RavenModel:
    """The cable model of a RAVEN-II parameter set plus the session's registration offsets.

    ``offsets`` (3,) are added to every predicted joint; ``homing_offsets`` maps a homing count to
    extra offsets of the samples recorded after that homing, under the effect name
    ``homing_offset_name`` (``homing_offset`` or ``registration_offset``: in a log both are a
    constant per homing). ``payload_kg`` is a payload at the tool tip that the log does not
    declare (kg), added to the one it does. ``standard_errors`` maps the names of the parameters an
    identification fitted to ``params`` (e.g. ``"cable_stretch.stiffness[shoulder]"``) to their
    standard errors (SI); a model whose effects or loads change no longer has them (None). With
    ``follows_hysteresis_lag`` the Bouc-Wen state of a hysteresis follows the stretch over its
    ``Hysteresis.response_time`` (a first-order lag, as in the simulator) instead of sample by
    sample: for diagnostics that give the replay the generator's lag
    (``studies/discrepancy_replay_bias.py``); no analysis sets it.
    """

    params: RavenParameters
    offsets: np.ndarray
    homing_offsets: dict | None = None
    homing_offset_name: str = "homing_offset"
    payload_kg: float = 0.0
    standard_errors: dict | None = None
    follows_hysteresis_lag: bool = False

    @property
    def enabled_effects(self) -> tuple[str, ...]:
        names = self.params.enabled_effects
        if self.homing_offsets:
            names = names + (self.homing_offset_name,)
        return names + (("payload",) if self.payload_kg != 0.0 else ())

    def with_effect(self, effect) -> "RavenModel":
        """The model with ``effect`` (an :class:`~simulation.model.effects.Effect`) added or replaced."""
        return replace(self, params=self.params.with_effect(effect), standard_errors=None)

    def with_offsets(self, offsets) -> "RavenModel":
        return replace(self, offsets=np.asarray(offsets, dtype=float))

    def with_homing_offsets(self, homing_offsets: dict | None, name: str | None = None) -> "RavenModel":
        return replace(self, homing_offsets=homing_offsets, homing_offset_name=name or self.homing_offset_name)

    def with_payload(self, payload_kg: float) -> "RavenModel":
        """The model with an undeclared payload of ``payload_kg`` at the tool tip."""
        return replace(self, payload_kg=float(payload_kg), standard_errors=None)

    def without_extras(self, names) -> "RavenModel":
        """The model without the effects ``names`` (simulator effects, per-homing offsets, payload)."""
        model = replace(self, params=self.params.without(*[n for n in names if n in self.params.enabled_effects]),
                        standard_errors=None)
        if self.homing_offset_name in names:
            model = replace(model, homing_offsets=None)
        if "payload" in names:
            model = replace(model, payload_kg=0.0)
        return model

    def replay(self, signals: MeasuredSignals, robot=None) -> ReplayState:
        from kinematics import RavenII

        if signals.kind != "raven":
            raise ValueError("a RAVEN-II model needs RAVEN-II signals (motor positions and torques)")
        p = self.params
        c = p.constants
        robot = robot or RavenII(signals.arm, check_limits=False)
        coupling = p.effect("coupling")
        delta = coupling.delta if coupling.enabled else np.zeros(3)
        a = coupling_matrix(*(np.asarray(c.cable_coupling) + delta))
        if p.is_enabled("transmission_error"):
            # the true ratios are the nominal ones times (1 + ratio_error): each motor moves its cables,
            # and feels their tension, 1 / (1 + ratio_error) as much as the nominal coupling says
            a = a / (1.0 + p.effect("transmission_error").ratio_error)[None, :]
        u = signals.drive
        cable = u @ a.T
        if p.is_enabled("capstan_runout"):
            cable = cable + p.effect("capstan_runout").amplitude * np.sin(u * c.transmission_ratio[:3] / c.gearbox[:3])
        side = cable.copy()
        if p.is_enabled("backlash"):
            half = p.effect("backlash").half_width
            side = np.column_stack([play_series(np.ascontiguousarray(cable[:, i]), half[i], signals.restarts)
                                    for i in range(3)])

        velocity = signals.velocity
        gravity, inertial = signals.link_loads(robot)
        if self.payload_kg != 0.0:
            gravity_per_kg, inertial_per_kg = signals.payload_loads(robot)
            gravity = gravity + self.payload_kg * gravity_per_kg
            inertial = inertial + self.payload_kg * inertial_per_kg
        load = inertial.copy()
        if p.is_enabled("gravity_stretch"):
            load = load + gravity_load(gravity, p.effect("gravity_stretch").load_scale)
        if p.is_enabled("viscous_friction"):
            load = load + p.effect("viscous_friction").coefficient * velocity
        force = p.effect("coulomb_friction").force if p.is_enabled("coulomb_friction") else np.zeros(3)
        capstan = p.effect("capstan_friction").coefficient if p.is_enabled("capstan_friction") else np.zeros(3)

        n = u.shape[0]
        drifts = p.is_enabled("drift")
        if drifts:
            d = p.effect("drift")
            dose = d.time_scale / 3600.0 * (signals.travel + d.payload_gain * signals.loaded_travel) / d.reference_speed
            base = side - d.creep_rate * dose
            softening = 1.0 + d.stiffness_loss * dose
        else:
            base = side
            softening = _ones((n, 3))

        first = signals.truth - self.offsets
        if self.homing_offsets:
            for count, extra in self.homing_offsets.items():
                first[signals.homing == count] -= extra
        if p.is_enabled("cable_stretch"):
            law = p.effect("cable_stretch")
            hyst = p.effect("hysteresis")
            k_h = hyst.stiffness if hyst.enabled else np.zeros(3)
            beta = hyst.beta if hyst.enabled else np.ones(3)
            gamma = hyst.gamma if hyst.enabled else np.ones(3)
            link = np.empty_like(u)
            z = np.empty_like(u)
            tension = np.empty(u.shape)
            lags = (hyst.response_time if hyst.enabled and self.follows_hysteresis_lag else np.zeros(3))
            columns = [np.ascontiguousarray(a.T) for a in (base, load, softening, first)]
            for i in range(3):
                follow = _ones((n,)) if lags[i] == 0.0 else _lag_fractions(signals.time, float(lags[i]))
                link[:, i], z[:, i], tension[:, i] = _SERIES.series(
                    columns[0][i], columns[1][i], _constant(n, float(force[i])), columns[2][i], law.stiffness[i],
                    law.hardening[i], k_h[i], beta[i], gamma[i], columns[3][i], signals.restarts, capstan[i],
                    follow, bool(lags[i] > 0.0), float(lags[i]))
            stretch = base - link
            if drifts:
                tension = tension / softening
            tension = tension + k_h * z
        else:
            # rigid cable: the link rides on the capstans, friction only loads the motors
            link = base
            stretch = np.zeros_like(u)
            tension = load + force * np.sign(velocity)
            tension = tension + capstan * np.abs(tension) * np.sign(velocity)

        joints = link + self.offsets
        if self.homing_offsets:
            for count, extra in self.homing_offsets.items():
                joints[signals.homing == count] += extra

        ratio = c.transmission_ratio[:3]
        gear = c.gearbox[:3]
        inertial, damping = signals.motor_loads(c.motor_inertia[:3] * ratio ** 2, c.motor_damping[:3] * ratio ** 2)
        motor_side = tension @ a + inertial + damping
        if p.is_enabled("motor_friction"):
            # the amplifier's torque also overcomes the motor's and gearbox's friction (joint units)
            friction = p.effect("motor_friction")
            motor_side = motor_side + motor_friction(signals.drive_velocity, friction.coulomb[:3] * ratio,
                                                     friction.gearbox_loss[:3], tension @ a, MOTOR_STICTION_SPEED)
        torque = motor_side * gear / ratio
        return ReplayState(joints=joints, torque=torque, tension=tension, stretch=stretch, gravity=gravity)
