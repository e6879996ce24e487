"""The measured signals the discrepancy workflow replays a model against.

Two kinds of data reach the workflow. A RAVEN-II log (simulated or read from bags) has motor
positions, commanded motor torques and ground-truth joints, so the model is the cable model
driven by the motors. A generic log, such as the dVRK data, has only the joint positions the
controller reports and the measured ones, so the nominal model is "measured = reported".
:class:`MeasuredSignals` holds either, in SI units, with the derived signals every candidate
effect needs (velocities, accelerations, cumulative motion) computed once.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from simulation.model.constants import POSITIONING_NAMES

RAVEN_JOINTS = POSITIONING_NAMES
RAVEN_UNITS = ("rad", "rad", "m")
VELOCITY_SPAN_S = 4 / 30
"""Time (s) each RAVEN-II velocity is fitted over, from the present sample back: four intervals of
the 30 Hz log the workflow was built on (five samples). A span in time, not a count of samples:
the encoders' quantization, differentiated over a fixed count of samples, grows with the log's rate
(replaying the simulator's own parameters on a 300 Hz log, five-sample velocities and seven-sample
accelerations left 18 times the shoulder residual and 29 times the elbow's of the same motion
logged at 30 Hz)."""

ACCELERATION_SPAN_S = 6 / 30
"""Time (s) each RAVEN-II acceleration is fitted over (seven samples of a 30 Hz log; see
:attr:`MeasuredSignals.acceleration`)."""


def median_interval(time: np.ndarray) -> float:
    """A record's median sample interval (s): its log period, robust to a dropped sample or a gap;
    0 for fewer than two samples."""
    time = np.asarray(time, dtype=float)
    return float(np.median(np.diff(time))) if time.size > 1 else 0.0


def samples_spanning(time: np.ndarray, span: float) -> int:
    """The number of consecutive samples (at least 2) whose first and last lie ``span`` seconds apart
    at the record's median sample interval, rounded to the nearest interval."""
    step = median_interval(time)
    if not (np.isfinite(step) and step > 0.0):
        raise ValueError(f"a derivative window needs a record whose samples advance in time, "
                         f"got a median step of {step}")
    return max(2, 1 + int(round(span / step)))


def _causal_derivative(values: np.ndarray, time: np.ndarray, window: int, order: int = 2) -> np.ndarray:
    """Time derivative of each column from the present and past samples only (no look-ahead).

    At each sample a polynomial of ``order`` (a line for ``window <= 2``) is fitted by least squares
    to the last ``window`` samples at their actual times, and its slope at the present sample is
    the derivative. With ``order=2`` it is exact for motion up to that order, so it does not lag a
    smooth motion as a trailing moving average would; with ``order=1`` the slope is the window's
    mean slope, less noisy but late by half the window. Before the first sample the record is taken
    as at rest (the first value held), so the first derivative is zero.
    """
    window = max(int(window), 2)
    order = 1 if window <= 2 else order
    n = values.shape[0]
    step = float(np.median(np.diff(time))) if n > 1 else 1.0
    pad = window - 1
    t = np.concatenate([time[0] - step * np.arange(pad, 0, -1), time])
    v = np.concatenate([np.repeat(values[:1], pad, axis=0), values])
    windows_t = np.lib.stride_tricks.sliding_window_view(t, window)            # (N, w)
    windows_v = np.lib.stride_tricks.sliding_window_view(v, window, axis=0)    # (N, J, w)
    lags = windows_t - windows_t[:, -1:]                                       # <= 0, present sample at 0
    design = np.stack([lags ** k for k in range(order + 1)], axis=-1)          # (N, w, order+1)
    # slope at lag 0 = second row of the least-squares solution (design^+ values)
    slope_weights = np.linalg.pinv(design)[:, 1, :]                            # (N, w)
    return np.einsum("nw,njw->nj", slope_weights, windows_v)


def per_homing(derivative, values: np.ndarray, time: np.ndarray, homing: np.ndarray, *args) -> np.ndarray:
    """``derivative`` of each stretch of samples of one homing on its own: a re-homing re-registers
    the encoders, so the motor positions jump there and no derivative may span it."""
    starts = np.flatnonzero(np.r_[True, homing[1:] != homing[:-1]])
    if starts.size == 1:
        return derivative(values, time, *args)
    ends = np.r_[starts[1:], homing.size]
    return np.concatenate([derivative(values[a:b], time[a:b], *args) for a, b in zip(starts, ends)])


@dataclass(frozen=True, eq=False)
class MeasuredSignals:
    """Time-ordered measurements of one or more joints, SI units.

    Attributes
    ----------
    time : (N,) s, strictly increasing.
    truth : (N, J) measured joint positions (the ground truth).
    reported : (N, J) joint positions the robot reports (uncorrected).
    drive : (N, J) the transmission's input in joint units: RAVEN-II motor coordinates
        ``motor angle / transmission ratio`` (before the cable coupling), else the reported joints.
    torque : (N, J) commanded motor torques at the gearbox output (N m), or None.
    payload_kg : (N,) payload at the tool tip.
    homing : (N,) homing count of each sample.
    joint_names, units : per joint.
    kind : "raven" (motor-side data and a cable model) or "generic".
    arm : "left" or "right" for RAVEN-II data.
    tool_joints : (N, 3) reported tool joints J3..J5 (rad) for the kinematics, RAVEN-II only.
    smoothing : samples (present and past) each velocity is fitted over; no derivative looks
        ahead, so a replay at a sample uses nothing measured after it. None (the default): the
        samples spanning :data:`VELOCITY_SPAN_S` at the record's median interval (5 at 30 Hz).
    acceleration_window : samples (present and past) each acceleration is fitted over. None (the
        default): the samples spanning :data:`ACCELERATION_SPAN_S` (7 at 30 Hz). Both are resolved
        once, on the whole record, so a selection or a head keeps them.
    travel, loaded_travel : accumulated joint travel (and payload-weighted travel) since the start
        of the record; computed on construction unless given (a selection keeps the session's).
    """

    time: np.ndarray
    truth: np.ndarray
    reported: np.ndarray
    drive: np.ndarray
    torque: np.ndarray | None
    payload_kg: np.ndarray
    homing: np.ndarray
    joint_names: tuple[str, ...]
    units: tuple[str, ...]
    kind: str = "generic"
    arm: str = "left"
    tool_joints: np.ndarray | None = None
    smoothing: int | None = None
    acceleration_window: int | None = None
    travel: np.ndarray | None = None
    loaded_travel: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = self.time.shape[0]
        if n < 20:
            raise ValueError(f"the discrepancy workflow needs at least 20 samples, got {n}")
        if np.any(np.diff(self.time) <= 0):
            bad = int(np.argmax(np.diff(self.time) <= 0)) + 1
            raise ValueError(f"time must increase strictly; it does not at sample {bad} "
                             f"(t = {self.time[bad]:.6f} s after {self.time[bad - 1]:.6f} s)")
        for name in ("truth", "reported", "drive"):
            value = getattr(self, name)
            if value.shape != (n, len(self.joint_names)):
                raise ValueError(f"{name} must have shape {(n, len(self.joint_names))}, got {value.shape}")
            if not np.all(np.isfinite(value)):
                bad = int(np.argmax(~np.isfinite(value).all(axis=1)))
                raise ValueError(f"{name} is not finite at sample {bad}")
        if self.torque is not None and (self.torque.shape != self.truth.shape or not np.all(np.isfinite(self.torque))):
            raise ValueError("torque must be finite with the shape of truth")
        if self.kind not in ("raven", "generic"):
            raise ValueError(f"kind must be 'raven' or 'generic', got {self.kind!r}")
        for name, span in (("smoothing", VELOCITY_SPAN_S), ("acceleration_window", ACCELERATION_SPAN_S)):
            window = getattr(self, name)
            if window is None:
                object.__setattr__(self, name, samples_spanning(self.time, span))
            elif isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1:
                raise ValueError(f"{name} must be a positive number of samples, got {window!r}")
        if self.travel is None:
            # accumulated once over the whole record, so a selection keeps the session's history
            speed = np.abs(self.velocity)
            object.__setattr__(self, "travel", _accumulate(speed, self.time))
            object.__setattr__(self, "loaded_travel", _accumulate(speed * self.payload_kg[:, None], self.time))

    def __len__(self) -> int:
        return self.time.shape[0]

    @cached_property
    def restarts(self) -> np.ndarray:
        """(N,) True at the first sample and at the first sample after each re-homing, where the
        replay restarts its history-dependent states from the measured joints."""
        return np.r_[True, self.homing[1:] != self.homing[:-1]]

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    # ---- derived signals (cheap, recomputed on demand) ---------------------------------------

    @cached_property
    def velocity(self) -> np.ndarray:
        """Joint velocity from the measured positions (rad/s, m/s), causal: each sample's velocity
        uses that sample and the ``smoothing - 1`` before it (see :func:`_causal_derivative`)."""
        return per_homing(_causal_derivative, self.truth, self.time, self.homing, self.smoothing)

    @cached_property
    def acceleration(self) -> np.ndarray:
        """Joint acceleration (rad/s^2, m/s^2): the mean slope of :attr:`velocity` over the present
        and the ``acceleration_window - 1`` samples before it (causal; a second lag-free derivative
        would double the encoders' noise in the inertial loads, which matters more than its lag of
        about a tenth of a second)."""
        return per_homing(_causal_derivative, self.velocity, self.time, self.homing, self.acceleration_window, 1)

    @cached_property
    def drive_velocity(self) -> np.ndarray:
        """Velocity of the transmission's input (joint units per s), causal like :attr:`velocity`."""
        return per_homing(_causal_derivative, self.drive, self.time, self.homing, self.smoothing)

    @cached_property
    def drive_acceleration(self) -> np.ndarray:
        """Acceleration of the transmission's input, causal like :attr:`acceleration`."""
        return per_homing(_causal_derivative, self.drive_velocity, self.time, self.homing, self.acceleration_window, 1)

    def cumulative_motion(self, per_kg: float = 0.0) -> np.ndarray:
        """Accumulated joint travel since the start of the record (rad, rad, m), optionally load-weighted.

        The operating-time signal of cable fatigue: a joint that does not move does not age.
        """
        return self.travel + per_kg * self.loaded_travel

    def link_loads(self, robot) -> tuple[np.ndarray, np.ndarray]:
        """Gravity holding loads and inertial loads ``M(q) q''`` of the links (RAVEN-II; cached).

        Computed once per signal set from the measured joints, payload and tool joints with the
        kinematics model, since every replay of every candidate needs them.
        """
        cache = self.__dict__.setdefault("_loads", {})
        key = (robot.arm, tuple(np.round(robot.gravity, 12)))
        if key not in cache:
            q6 = np.column_stack([self.truth, self.tool_joints])
            gravity = np.zeros_like(self.truth)
            inertial = np.zeros_like(self.truth)
            for payload in np.unique(self.payload_kg):
                rows = self.payload_kg == payload
                gravity[rows] = robot.gravity_torques(q6[rows], payload_kg=float(payload))
                mass = robot.mass_matrix(q6[rows], payload_kg=float(payload))
                inertial[rows] = np.einsum("nij,nj->ni", mass, self.acceleration[rows])
            cache[key] = (gravity, inertial)
        return cache[key]

    def payload_loads(self, robot) -> tuple[np.ndarray, np.ndarray]:
        """Gravity and inertial loads of one more kilogram at the tool tip (per kg; cached).

        The loads of a point payload are linear in its mass, so these increments price any payload
        the log does not declare: ``link_loads + m * payload_loads``.
        """
        cache = self.__dict__.setdefault("_payload_loads", {})
        key = (robot.arm, tuple(np.round(robot.gravity, 12)))
        if key not in cache:
            q6 = np.column_stack([self.truth, self.tool_joints])
            gravity, inertial = self.link_loads(robot)
            heavier_gravity = np.zeros_like(self.truth)
            heavier_inertial = np.zeros_like(self.truth)
            for payload in np.unique(self.payload_kg):
                rows = self.payload_kg == payload
                heavier_gravity[rows] = robot.gravity_torques(q6[rows], payload_kg=float(payload) + 1.0)
                mass = robot.mass_matrix(q6[rows], payload_kg=float(payload) + 1.0)
                heavier_inertial[rows] = np.einsum("nij,nj->ni", mass, self.acceleration[rows])
            cache[key] = (heavier_gravity - gravity, heavier_inertial - inertial)
        return cache[key]

    def motor_loads(self, inertia: np.ndarray, damping: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The motors' inertial and damping loads ``inertia * u''`` and ``damping * u'`` along the
        transmission's input (joint units; cached per ``inertia`` and ``damping``, (J,) each, in the
        same units referred to the joints), which every replay of a RAVEN-II model adds to its
        motor torques."""
        cache = self.__dict__.setdefault("_motor_loads", {})
        key = (np.asarray(inertia, dtype=float).tobytes(), np.asarray(damping, dtype=float).tobytes())
        if key not in cache:
            loads = (inertia * self.drive_acceleration, damping * self.drive_velocity)
            for array in loads:
                array.setflags(write=False)
            cache[key] = loads
        return cache[key]

    def head(self, n: int) -> "MeasuredSignals":
        """The first ``n`` samples (cached), with this record's derivatives and loads: every
        derivative is causal, so the first samples' values do not depend on what follows, and a
        replay of the head equals the head of the replay."""
        if n >= len(self):
            return self
        heads = self.__dict__.setdefault("_heads", {})
        if n not in heads:
            head = self.select(np.arange(len(self)) < n)
            for name in ("velocity", "acceleration", "drive_velocity", "drive_acceleration", "restarts"):
                head.__dict__[name] = getattr(self, name)[:n]
            for cache in ("_loads", "_payload_loads"):
                if cache in self.__dict__:
                    head.__dict__[cache] = {k: tuple(v[:n] for v in value) for k, value in self.__dict__[cache].items()}
            heads[n] = head
        return heads[n]

    def select(self, mask: np.ndarray) -> "MeasuredSignals":
        """The samples where ``mask`` holds (keep blocks contiguous: derivatives are recomputed)."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.time.shape:
            raise ValueError(f"mask must have shape {self.time.shape}")

        def pick(value):
            return None if value is None else value[mask]

        return replace(
            self,
            time=self.time[mask],
            truth=self.truth[mask],
            reported=self.reported[mask],
            drive=self.drive[mask],
            torque=pick(self.torque),
            payload_kg=self.payload_kg[mask],
            homing=self.homing[mask],
            tool_joints=pick(self.tool_joints),
            travel=self.travel[mask],
            loaded_travel=self.loaded_travel[mask],
        )

    def with_derivatives(self, *, velocity: np.ndarray | None = None,
                         acceleration: np.ndarray | None = None) -> "MeasuredSignals":
        """These signals with the links' ``velocity`` and/or ``acceleration`` ((N, J), SI) in place of
        the causal estimates (:attr:`velocity`, :attr:`acceleration`), so that the viscous and the
        inertial loads of a replay follow them; one not given stays this record's (an acceleration
        is not derived again from a velocity given). The accumulated travel stays this record's.

        For diagnostics of the replay only (``studies/discrepancy_floor.py`` replays without the
        inertial loads, or with derivatives that look ahead); the workflow never calls it.
        """
        given = {name: value for name, value in (("velocity", velocity), ("acceleration", acceleration))
                 if value is not None}
        if not given:
            raise ValueError("with_derivatives needs a velocity, an acceleration or both")
        for name, value in list(given.items()):
            value = np.array(value, dtype=float)
            if value.shape != self.truth.shape:
                raise ValueError(f"the {name} must have the shape of the joints, {self.truth.shape}, got {value.shape}")
            if not np.all(np.isfinite(value)):
                bad = int(np.argmax(~np.isfinite(value).all(axis=1)))
                raise ValueError(f"the {name} is not finite at sample {bad}")
            value.setflags(write=False)
            given[name] = value
        kept = {name: getattr(self, name) for name in ("velocity", "acceleration") if name not in given}
        copy = replace(self)
        for name in ("drive_velocity", "drive_acceleration", "restarts"):
            if name in self.__dict__:
                copy.__dict__[name] = self.__dict__[name]
        copy.__dict__.update({**kept, **given})
        return copy

    # ---- construction -------------------------------------------------------------------------

    @classmethod
    def from_dataset(cls, dataset, constants=None) -> "MeasuredSignals":
        """Signals of a RAVEN-II :class:`~simulation.recordings.dataset.CalibrationDataset` (simulated or from bags)."""
        from simulation.model.constants import RavenConstants

        c = constants or RavenConstants(arm=dataset.arm)
        table = dataset.table
        names = ("shoulder", "elbow", "z_ins")
        required = [f"mpos.{n}" for n in names] + [f"tau.{n}" for n in names]
        missing = [col for col in required if col not in table.columns]
        if missing:
            raise ValueError(f"RAVEN-II signals need the motor columns {missing} (the 'all' feature group)")
        mpos = table[[f"mpos.{n}" for n in names]].to_numpy(float)
        labels = dataset.labels
        payload = labels["payload_kg"].to_numpy(float) if "payload_kg" in labels else np.zeros(len(table))
        homing = labels["homing_count"].to_numpy(int) if "homing_count" in labels else np.zeros(len(table), int)
        tool = table[["jpos.tool_rot", "jpos.wrist", "jpos.grasp1", "jpos.grasp2"]].to_numpy(float)
        return cls(
            time=dataset.time.astype(float),
            truth=dataset.targets.astype(float),
            reported=dataset.raw_joints.astype(float),
            drive=mpos / c.transmission_ratio[:3],
            torque=table[[f"tau.{n}" for n in names]].to_numpy(float),
            payload_kg=payload,
            homing=homing,
            joint_names=RAVEN_JOINTS,
            units=RAVEN_UNITS,
            kind="raven",
            arm=dataset.arm,
            tool_joints=np.column_stack([tool[:, 0], tool[:, 1], 0.5 * (tool[:, 3] - tool[:, 2])]),
        )

    @classmethod
    def generic(cls, time, reported, truth, joint_names, units) -> "MeasuredSignals":
        """Signals of a robot whose nominal model is "measured = reported" (e.g. the dVRK data)."""
        reported = np.asarray(reported, dtype=float)
        n = reported.shape[0]
        return cls(
            time=np.asarray(time, dtype=float),
            truth=np.asarray(truth, dtype=float),
            reported=reported,
            drive=reported,
            torque=None,
            payload_kg=np.zeros(n),
            homing=np.zeros(n, dtype=int),
            joint_names=tuple(joint_names),
            units=tuple(units),
            kind="generic",
            smoothing=1,
        )


def _accumulate(rate: np.ndarray, time: np.ndarray) -> np.ndarray:
    steps = 0.5 * (rate[1:] + rate[:-1]) * np.diff(time)[:, None]
    return np.vstack([np.zeros((1, rate.shape[1])), np.cumsum(steps, axis=0)])


def report_scale(units) -> np.ndarray:
    """Factors to degrees (rad) and millimetres (m), the paper's reporting units."""
    return np.array([180.0 / np.pi if u == "rad" else 1000.0 for u in units])


def pooled_rmse(residual: np.ndarray, units) -> float:
    """RMSE over joints and samples with rad in degrees and m in millimetres (the paper's weighting)."""
    scaled = residual * report_scale(units)
    return float(np.sqrt(np.mean(np.square(scaled))))


def joint_rmse(residual: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(np.square(residual), axis=0))
