"""Physical limits of recorded RAVEN-II data, and the one check every reader applies.

A recording can hold values no RAVEN-II can produce: a damaged file, a glitch of the logging
computer, a unit mistake. Every reader of this package (``bags.read_bag``,
``CalibrationDataset.read_parquet`` and ``read_csv``) passes its samples through
:func:`find_invalid` and then :func:`resolve_invalid`, so the same limits hold wherever the data
come from. The limits are those of the hardware, never of one data set:

- joint and motor positions within the joints' range: the controller's limits
  (``kinematics.joint_limits.CONTROLLER_JOINT_LIMITS``), its hard stops and home pose
  (``RavenConstants.hard_stop``, ``home_pose``), widened by ``joint_margin``; motor positions are
  the same range through the controller's cable coupling. Before the arm is homed (run level
  E-STOP or INIT) the controller's positions count from the power-on encoder offsets, so only
  the joints' travel is checked then (``|q| <= max(|bound|) + range``);
- a motor speed at most its no-load speed (``speed_margin`` above it): Maxon RE40 148877 (48 V,
  shoulder, elbow, insertion) 7580 rpm, Maxon RE30 310007 (48 V, tool) 8170 rpm (datasheets);
  joint speeds follow through the transmission and the coupling. From them: ``mvel``, ``jvel``,
  the tool twist, and the largest jump a motor, its encoder or a joint can make between two
  samples (``rate * elapsed time`` plus two encoder counts);
- the commanded current within the controller's DAC clip (``RavenConstants.dac_max``, counts) and
  the commanded torque within the motor's stall torque at the gearbox output: RE40 2.50 N m, RE30
  1.02 N m (datasheets: torque constant 60.3 / 53.8 mN m/A, as ``RavenConstants.torque_per_amp``)
  times the gearbox;
- the controller's own arithmetic: ``jpos`` of joints 1-3 is ``A @ (mpos / tr)`` of the same tick
  (``fwd_cable_coupling.cpp``), within ``coupling_tolerance``; a rotation matrix is orthonormal;
  the arm's serial number is its own;
- finite values, time that increases no faster than the servo loop can publish (two stamps at
  least half a servo tick apart) and a log period of at most ``max_log_period`` (time in seconds).

Time running backwards in a bag, a truncated or foreign file, are errors of the file's structure
and stay errors in every mode; scenario labels are not robot values and are not checked.

Modes (``on_invalid``): ``"flag"`` (default) keeps every sample and marks the impossible ones
(``RavenStateLog.valid``, ``GroundTruthLog.valid``, the boolean ``valid`` column of a
``CalibrationDataset``), warning once per file with :class:`ImpossibleValueWarning`; ``"drop"``
removes them (same warning); ``"raise"`` raises :class:`ImpossibleValueError`. The message names
the file, the number of samples, and the first one's column, sample index, time, value and limit.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from kinematics.joint_limits import CONTROLLER_JOINT_LIMITS, JointLimits
from simulation.model.constants import ARM_SERIAL, SLOT_OF_DOF, RavenConstants
from simulation.recordings.ravenstate import ARM_NAMES, DOF_NAMES, GROUND_TRUTH_JOINTS, RAVENSTATE_FIELDS, check_arm

ON_INVALID = ("flag", "drop", "raise")
"""What a reader does with samples outside the limits."""

VALID_COLUMN = "valid"
"""Boolean column of a dataset table: False for a sample that holds an impossible value."""

RPM = 2.0 * np.pi / 60.0
RE40_NO_LOAD_SPEED = 7580.0 * RPM
"""Maxon RE40 148877 (48 V) no-load speed, rad/s (datasheet: 7580 rpm)."""
RE30_NO_LOAD_SPEED = 8170.0 * RPM
"""Maxon RE30 310007 (48 V) no-load speed, rad/s (datasheet: 8170 rpm)."""
RE40_STALL_TORQUE = 2.50
"""Maxon RE40 148877 stall torque, N m at the motor shaft (datasheet: 2500 mN m)."""
RE30_STALL_TORQUE = 1.02
"""Maxon RE30 310007 stall torque, N m at the motor shaft (datasheet: 1020 mN m)."""

WORKSPACE_RADIUS = 0.35
"""Bound on each coordinate of the tool position ``pos``/``pos_d``, m: forward kinematics over the
joint range widened by the margins reaches 0.273 m from the base frame (``kinematics.RavenII``)."""

JAW_RANGE = np.pi
"""Bound on each grasp jaw's angle, rad: the controller limits the grasp (the jaws' half
difference, ``CONTROLLER_JOINT_LIMITS``) but not a single jaw, which cannot turn past its wrist link."""

_N_SLOTS = 8
_POSITIONING = 3
# Entry of CONTROLLER_JOINT_LIMITS for each DOF of the simulator up to the wrist.
_LIMIT_OF_DOF = (0, 1, 2, 3, 4)


class ImpossibleValueError(ValueError):
    """A recording holds values the robot cannot produce (``on_invalid="raise"``)."""


class ImpossibleValueWarning(UserWarning):
    """A recording holds values the robot cannot produce; they were flagged or dropped."""


def _slots(values7, fill) -> np.ndarray:
    out = np.full(_N_SLOTS, float(fill))
    out[SLOT_OF_DOF] = values7
    return out


def _box_through(matrix: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of ``matrix @ x`` over the box ``lower <= x <= upper`` (interval arithmetic)."""
    low, high = matrix * lower, matrix * upper
    return np.minimum(low, high).sum(axis=1), np.maximum(low, high).sum(axis=1)


@dataclass(frozen=True)
class RecordingLimits:
    """What one RAVEN-II arm can physically record, SI units, per controller slot (8 per arm).

    Slots are ``ravenstate.DOF_NAMES`` (shoulder, elbow, z_ins, no_connection, tool_rot, wrist,
    grasp1, grasp2); the unused no_connection slot gets the widest bound of the others. Build it
    with :meth:`for_arm`, which documents the choices and margins.

    Attributes
    ----------
    arm : str
    joint_lower, joint_upper : (8,) joint range once homed, rad (m for z_ins): controller limits,
        hard stops and home pose, widened by the margins.
    joint_travel : (8,) bound on ``|jpos|`` before homing (positions from power-on offsets).
    motor_lower, motor_upper, motor_travel : (8,) the same for motor positions, rad, through the
        inverse cable coupling and the transmission ratios (the tool motors also turn with the
        insertion motor, ``tool_gb_ratio``).
    motor_speed : (8,) largest motor speed, rad/s: no-load speed (RE40 / RE30) times
        ``1 + speed_margin``.
    joint_speed : (8,) largest joint speed, rad/s (m/s for z_ins), from ``motor_speed``.
    dac_max : (8,) the controller's DAC clip, counts (``RavenConstants.dac_max``).
    torque_max : (8,) stall torque at the gearbox output, N m.
    grasp_max : bound on ``grasp_d`` (sum of the jaws' desired angles), rad.
    counts_per_rad : motor encoder counts per motor radian.
    transmission_ratio : (8,) motor rad per joint rad (per m for z_ins); 1 in the unused slot.
    coupling : (3, 3) the controller's forward cable coupling ``A`` of joints 1-3.
    coupling_tolerance : (3,) largest ``|jpos - A @ (mpos / tr)|``, rad, rad, m.
    workspace_radius : bound on each tool-position coordinate, m (``WORKSPACE_RADIUS``).
    tool_speed, tool_rate : bounds on the tool twist's linear (m/s) and angular (rad/s) entries:
        ``workspace_radius`` times the sum of the revolute joint speeds plus the insertion
        speed, and that sum.
    servo_period : the controller's tick, s; two samples are at least half a tick apart.
    max_log_period : longest median sample interval of a log, s.
    serials : the arms' serial numbers (``ravenstate.type``).
    """

    arm: str
    joint_lower: np.ndarray
    joint_upper: np.ndarray
    joint_travel: np.ndarray
    motor_lower: np.ndarray
    motor_upper: np.ndarray
    motor_travel: np.ndarray
    motor_speed: np.ndarray
    joint_speed: np.ndarray
    dac_max: np.ndarray
    torque_max: np.ndarray
    grasp_max: float
    counts_per_rad: float
    transmission_ratio: np.ndarray
    coupling: np.ndarray
    coupling_tolerance: np.ndarray
    workspace_radius: float
    tool_speed: float
    tool_rate: float
    servo_period: float
    max_log_period: float
    serials: Mapping[str, int] = field(default_factory=lambda: MappingProxyType(dict(ARM_SERIAL)))

    def __post_init__(self) -> None:
        check_arm(self.arm)
        for name, value in vars(self).items():
            if isinstance(value, np.ndarray):
                value = np.array(value, dtype=np.float64)
                if not np.all(np.isfinite(value)):
                    raise ValueError(f"RecordingLimits.{name} must be finite")
                value.setflags(write=False)
                object.__setattr__(self, name, value)

    @classmethod
    def for_arm(cls, arm: str = "left", constants: RavenConstants | None = None,
                joint_limits: JointLimits = CONTROLLER_JOINT_LIMITS, *, joint_margin: float = np.deg2rad(5.0),
                insertion_margin: float = 0.005, speed_margin: float = 0.10,
                coupling_tolerance: Sequence[float] = (1e-3, 1e-3, 1e-4),
                max_log_period: float = 1.0) -> RecordingLimits:
        """The limits of ``arm`` from its hardware constants.

        Parameters
        ----------
        arm : {"left", "right"}
        constants : RavenConstants, optional
            Default: ``RavenConstants(arm=arm)``. Gives transmission ratios, cable coupling,
            gearboxes, DAC clip, encoder resolution, hard stops, home pose and servo period.
        joint_limits : JointLimits
            The controller's joint limits (rad, m); each jaw is bounded by ``JAW_RANGE``, two
            jaws' sum (``grasp_d``) by twice the grasp limit.
        joint_margin, insertion_margin : float
            Widening of the joint range beyond the limits and hard stops, rad and m (a joint
            overshoots its limit a little, and the homing search pushes into the hard stops).
        speed_margin : float
            Fraction above the no-load speed a motor may reach (back-driving, supply tolerance).
        coupling_tolerance : 3 floats
            Largest ``|jpos - A @ (mpos / tr)|`` of joints 1-3 (rad, rad, m): float32 rounding
            of the published degrees is below 1e-5.
        max_log_period : float
            Longest median interval between samples of a log, s (RAVEN-II logs at 30 Hz to
            1 kHz, the joint encoders at 100 Hz); a longer one means time is not in seconds.
        """
        check_arm(arm)
        c = constants or RavenConstants(arm=arm)
        lower7 = np.array([joint_limits.lower[k] for k in _LIMIT_OF_DOF] + [-JAW_RANGE] * 2)
        upper7 = np.array([joint_limits.upper[k] for k in _LIMIT_OF_DOF] + [JAW_RANGE] * 2)
        lower7[:3] = np.minimum(lower7[:3], c.hard_stop)
        upper7[:3] = np.maximum(upper7[:3], c.hard_stop)
        lower7, upper7 = np.minimum(lower7, c.home_pose), np.maximum(upper7, c.home_pose)
        margin = np.full(7, joint_margin)
        margin[2] = insertion_margin
        lower7, upper7 = lower7 - margin, upper7 + margin
        travel7 = np.maximum(np.abs(lower7), np.abs(upper7)) + (upper7 - lower7)

        tr = np.asarray(c.transmission_ratio, dtype=float)
        inverse = np.linalg.inv(c.nominal_coupling())
        motor_lower7, motor_upper7 = np.empty(7), np.empty(7)
        motor_lower7[:3], motor_upper7[:3] = _box_through(inverse * tr[:3, None], lower7[:3], upper7[:3])
        insertion_share = np.max(np.abs([motor_lower7[2], motor_upper7[2]])) / c.tool_gb_ratio
        motor_lower7[3:] = tr[3:] * lower7[3:] - insertion_share
        motor_upper7[3:] = tr[3:] * upper7[3:] + insertion_share
        wide_lower, wide_upper = _box_through(inverse * tr[:3, None], -travel7[:3], travel7[:3])
        motor_travel7 = np.empty(7)
        motor_travel7[:3] = np.maximum(np.abs(wide_lower), np.abs(wide_upper))
        motor_travel7[3:] = tr[3:] * travel7[3:] + motor_travel7[2] / c.tool_gb_ratio

        no_load = np.array([RE40_NO_LOAD_SPEED] * 3 + [RE30_NO_LOAD_SPEED] * 4)
        motor_speed7 = no_load * (1.0 + speed_margin)
        joint_speed7 = np.empty(7)
        joint_speed7[:3] = np.abs(c.nominal_coupling()) @ (motor_speed7[:3] / tr[:3])
        joint_speed7[3:] = (motor_speed7[3:] + motor_speed7[2] / c.tool_gb_ratio) / tr[3:]
        stall = np.array([RE40_STALL_TORQUE] * 3 + [RE30_STALL_TORQUE] * 4)
        revolute = np.r_[joint_speed7[:2], joint_speed7[3:5], 0.5 * (joint_speed7[5] + joint_speed7[6])]
        return cls(
            arm=arm,
            joint_lower=_slots(lower7, -travel7.max()),
            joint_upper=_slots(upper7, travel7.max()),
            joint_travel=_slots(travel7, travel7.max()),
            motor_lower=_slots(motor_lower7, -motor_travel7.max()),
            motor_upper=_slots(motor_upper7, motor_travel7.max()),
            motor_travel=_slots(motor_travel7, motor_travel7.max()),
            motor_speed=_slots(motor_speed7, motor_speed7.max()),
            joint_speed=_slots(joint_speed7, joint_speed7.max()),
            dac_max=_slots(c.dac_max, np.max(c.dac_max)),
            torque_max=_slots(stall * c.gearbox, np.max(stall * c.gearbox)),
            grasp_max=2.0 * (joint_limits.upper[5] + joint_margin),
            counts_per_rad=c.encoder_counts_per_rev / (2.0 * np.pi),
            transmission_ratio=_slots(tr, 1.0),
            coupling=c.nominal_coupling(),
            coupling_tolerance=np.asarray(coupling_tolerance, dtype=float),
            workspace_radius=WORKSPACE_RADIUS,
            tool_speed=WORKSPACE_RADIUS * revolute.sum() + joint_speed7[2],
            tool_rate=revolute.sum(),
            servo_period=c.servo_period,
            max_log_period=max_log_period,
        )


@functools.cache
def default_limits(arm: str) -> RecordingLimits:
    """``RecordingLimits.for_arm(arm)``, built once."""
    return RecordingLimits.for_arm(arm)


# ---------------------------------------------------------------------------------------------
# Column names


def field_column_names(spec) -> tuple[str, ...]:
    """Dataset column names of one arm's entries of a ravenstate field (``mpos.elbow``, ``type``...)."""
    if spec.per_arm <= 1:
        return (spec.name,)
    return tuple(f"{spec.name}.{entry}" for entry in spec.entry_names)


def other_arm_suffix(arm: str) -> str:
    """Suffix of the other arm's columns in :func:`state_columns` (``" (right arm)"``)."""
    return f" ({arm} arm)"


def state_columns(fields: Mapping[str, np.ndarray], arm: str, *, other_arm: bool = True) -> dict[str, np.ndarray]:
    """The ravenstate fields as named (N,) columns: the arm's as in a dataset table, the other arm's
    with :func:`other_arm_suffix` (when ``other_arm``)."""
    columns = {}
    arms = [arm] + ([name for name in ARM_NAMES if name != arm] if other_arm else [])
    for which in arms:
        for spec in RAVENSTATE_FIELDS:
            if spec.per_arm == 0 and which != arm:
                continue
            values = np.asarray(fields[spec.name])
            block = values[:, spec.arm_slice(which)] if spec.is_array else values[:, None]
            suffix = "" if which == arm else other_arm_suffix(which)
            for entry, name in enumerate(field_column_names(spec)):
                columns[name + suffix] = block[:, entry]
    return columns


# ---------------------------------------------------------------------------------------------
# The check


@dataclass(frozen=True)
class Violation:
    """One impossible value: where it is and which limit it breaks."""

    column: str
    index: int
    time: float
    value: float
    limit: str

    def describe(self) -> str:
        return (f"column {self.column!r}, sample {self.index}, t = {self.time:.6f} s, "
                f"value {self.value:.6g}, limit {self.limit}")


@dataclass(frozen=True)
class InvalidSamples:
    """Result of :func:`find_invalid` for one log.

    Attributes
    ----------
    mask : ndarray of bool, shape (N,)
        True for a sample holding at least one impossible value.
    counts : mapping of str to int
        Flagged samples per column.
    first : Violation or None
        The first impossible value in sample order (column order within a sample).
    """

    mask: np.ndarray
    counts: Mapping[str, int]
    first: Violation | None

    @property
    def count(self) -> int:
        return int(self.mask.sum())


class _Collector:
    def __init__(self, time: np.ndarray, order: Sequence[str]):
        self.time = time
        self.mask = np.zeros(time.size, dtype=bool)
        self.counts: dict[str, int] = {}
        self.order = {name: position for position, name in enumerate(order)}
        self.first: Violation | None = None
        self._first_key = None

    def add(self, column: str, bad: np.ndarray, values: np.ndarray, limit) -> None:
        if not bad.any():
            return
        self.mask |= bad
        self.counts[column] = self.counts.get(column, 0) + int(bad.sum())
        index = int(np.flatnonzero(bad)[0])
        key = (index, self.order.get(column, len(self.order)))
        if self._first_key is None or key < self._first_key:
            self._first_key = key
            text = limit(index) if callable(limit) else limit
            self.first = Violation(column, index, float(self.time[index]), float(values[index]), text)

    def result(self) -> InvalidSamples:
        self.mask.setflags(write=False)
        return InvalidSamples(self.mask, dict(self.counts), self.first)


def _scan(time: np.ndarray, values: np.ndarray, rate: float, tolerance: float, boundary: np.ndarray) -> np.ndarray:
    """Samples farther than ``rate * elapsed + tolerance`` from the last accepted sample, in the
    given order; ``boundary[k]`` restarts the comparison at sample k. A sample-by-sample loop
    runs only over the rejected stretches."""
    m = values.size
    steps_ok = np.ones(m, dtype=bool)
    steps_ok[1:] = np.abs(np.diff(values)) <= rate * np.abs(np.diff(time)) + tolerance
    steps_ok |= boundary
    bad = np.zeros(m, dtype=bool)
    resume = 0
    for start in np.flatnonzero(~steps_ok):
        if start < resume:
            continue
        reference, k = start - 1, start
        while k < m and not boundary[k] and (
                abs(values[k] - values[reference]) > rate * abs(time[k] - time[reference]) + tolerance):
            bad[k] = True
            k += 1
        resume = k + 1
    return bad


def _jumps(time: np.ndarray, values: np.ndarray, rate: float, tolerance: float, reset: np.ndarray) -> np.ndarray:
    """Samples that jump farther than a motor can move from the last plausible sample, seen both
    forward and backward in time, so that a glitch is marked and not its neighbours.

    ``reset[i]`` means sample i starts afresh (a new recording, a new encoder offset); non-finite
    samples are skipped (they are flagged as such).
    """
    bad = np.zeros(values.size, dtype=bool)
    finite = np.isfinite(values) & np.isfinite(time)
    if finite.all():
        if np.all(np.abs(np.diff(values)) <= rate * np.abs(np.diff(time)) + tolerance):
            return bad
        index = np.arange(values.size)
        boundary = reset.copy()
        boundary[0] = True
    else:
        index = np.flatnonzero(finite)
        if index.size < 2:
            return bad
        crossed = np.cumsum(reset)[index]
        boundary = np.r_[True, np.diff(crossed) > 0]
    t, v = time[index], values[index]
    forward = _scan(t, v, rate, tolerance, boundary)
    backward = _scan(t[::-1], v[::-1], rate, tolerance, np.r_[True, boundary[1:][::-1]])[::-1]
    bad[index] = forward & backward
    return bad


def _range(lower, upper, unit: str, what: str) -> str:
    return f"[{lower:.6g}, {upper:.6g}] {unit} ({what})"


def _check_time(out: _Collector, time: np.ndarray, limits: RecordingLimits) -> np.ndarray:
    """Time rules; returns where a new recording starts (time not increasing, in a table)."""
    finite = np.isfinite(time)
    out.add("time", ~finite, time, "finite")
    steps = np.diff(time)
    restart = np.r_[False, ~(steps > 0)]
    short = np.r_[False, (steps > 0) & (steps < 0.5 * limits.servo_period)]
    out.add("time", short, time, lambda i: f"step >= {0.5 * limits.servo_period:.6g} s after "
                                           f"{float(time[i - 1]):.6f} s (half a servo tick)")
    positive = steps[steps > 0]
    if positive.size >= 2 and np.median(positive) > limits.max_log_period:
        period = float(np.median(positive))
        out.add("time", np.ones(time.size, dtype=bool), time,
                f"median step <= {limits.max_log_period:.6g} s, the log's is {period:.6g} s (time not in seconds?)")
    return restart


def _slot_of(column: str) -> int | None:
    entry = column.split(".", 1)[1] if "." in column else None
    return DOF_NAMES.index(entry) if entry in DOF_NAMES else None


def find_invalid(time, columns: Mapping[str, np.ndarray], arm: str = "left",
                 limits: RecordingLimits | None = None) -> InvalidSamples:
    """Samples of a log that hold values outside the physical limits of ``arm``.

    Parameters
    ----------
    time : array_like, shape (N,)
        Sample times, s. Where time does not increase a new recording starts (a joined table);
        a bag's reader refuses such a log before calling this.
    columns : mapping of str to array_like, each (N,)
        Named as in a ``CalibrationDataset`` table (``mpos.elbow``, ``type``, ``truth.z_ins``,
        ``raw.shoulder``...); the other arm's entries with :func:`other_arm_suffix`. Columns this
        module does not know (labels, ``valid``) are not checked.
    arm : {"left", "right"}
    limits : RecordingLimits, optional
        Default: ``default_limits(arm)``.

    Returns
    -------
    InvalidSamples
    """
    check_arm(arm)
    with np.errstate(invalid="ignore", over="ignore"):
        return _find_invalid(np.asarray(time, dtype=np.float64), columns, arm, limits or default_limits(arm))


def _find_invalid(time: np.ndarray, columns, arm: str, lim: RecordingLimits) -> InvalidSamples:
    n = time.size
    out = _Collector(time, ["time", *columns])
    restart = _check_time(out, time, lim)
    other = [name for name in ARM_NAMES if name != arm][0]
    suffix = other_arm_suffix(other)

    runlevel = columns.get("runlevel")
    homed = (np.isin(np.asarray(runlevel), (2, 3)) if runlevel is not None else np.ones(n, dtype=bool))

    for column, raw in columns.items():
        values = np.asarray(raw)
        if values.dtype == np.bool_ or not np.issubdtype(values.dtype, np.number):
            continue
        values = values.astype(np.float64, copy=False)
        foreign = column.endswith(suffix)
        base = column[: -len(suffix)] if foreign else column
        field, _, entry = base.partition(".")
        if field in ("label", VALID_COLUMN, "time", ""):
            continue
        finite = np.isfinite(values)
        out.add(column, ~finite, values, "finite")
        _check_column(out, column, field, entry, _slot_of(base), values, finite, foreign, homed, lim, arm, other,
                      columns)

    _check_coupling(out, columns, lim)
    _check_rotations(out, columns, suffix)
    _check_jumps(out, time, columns, lim, restart, suffix)
    return out.result()


def _bound(out, column, values, finite, lower, upper, unit, what):
    bad = finite & ((values < lower) | (values > upper))
    out.add(column, bad, values, lambda i: _range(lower, upper, unit, what))


def _positions(out, column, values, finite, slot, foreign, homed, lower, upper, travel, unit):
    if foreign:
        _bound(out, column, values, finite, -travel[slot], travel[slot], unit, "travel")
        return
    bad_homed = finite & homed & ((values < lower[slot]) | (values > upper[slot]))
    out.add(column, bad_homed, values, lambda i: _range(lower[slot], upper[slot], unit, "range once homed"))
    bad_travel = finite & ~homed & (np.abs(values) > travel[slot])
    out.add(column, bad_travel, values, lambda i: _range(-travel[slot], travel[slot], unit, "travel before homing"))


def _check_column(out, column, field, entry, slot, values, finite, foreign, homed, lim, arm, other, columns):
    joint_unit = "m" if slot == 2 else "rad"
    if field in ("runlevel", "sublevel"):
        _bound(out, column, values, finite, 0, 3, "", "defines.h RL_*/SL_*")
    elif field == "last_seq":
        _bound(out, column, values, finite, 0, np.iinfo(np.int32).max, "", "sequence number")
    elif field == "dt":
        _bound(out, column, values, finite, 0.0, lim.max_log_period, "s", "time since the previous message")
    elif field == "type":
        owner = other if foreign else arm
        allowed = (0, lim.serials[owner]) if foreign else (lim.serials[owner],)
        out.add(column, finite & ~np.isin(values, allowed), values, f"serial in {allowed} ({owner} arm)")
    elif field in ("pos", "pos_d"):
        r = lim.workspace_radius
        _bound(out, column, values, finite, -r, r, "m", "workspace")
    elif field in ("ori", "ori_d"):
        _bound(out, column, values, finite, -1.001, 1.001, "", "rotation matrix entry")
    elif field == "grasp_d":
        _bound(out, column, values, finite, -lim.grasp_max, lim.grasp_max, "rad", "two jaws' range")
    elif field in ("jac_vel", "jac_f"):
        if entry.startswith("v") or entry.startswith("f"):
            _bound(out, column, values, finite, -lim.tool_speed, lim.tool_speed, "m/s", "tool speed")
        else:
            _bound(out, column, values, finite, -lim.tool_rate, lim.tool_rate, "rad/s", "tool rotation rate")
    elif field == "encoffsets":
        _bound(out, column, values, finite, -2.0**31, 2.0**31, "count", "int32 encoder offset")
    elif field in ("truth", "raw"):
        index = GROUND_TRUTH_JOINTS.index(entry) if entry in GROUND_TRUTH_JOINTS else None
        if index is None:
            return
        if field == "raw":
            jpos = columns.get(f"jpos.{entry}")
            if jpos is not None:
                out.add(column, finite & (values != np.asarray(jpos, dtype=np.float64)), values,
                        f"equal to jpos.{entry}")
            return
        _bound(out, column, values, finite, lim.joint_lower[index], lim.joint_upper[index],
               "m" if index == 2 else "rad", "joint range")
    elif slot is None:
        return
    elif field in ("jpos", "jpos_d"):
        _positions(out, column, values, finite, slot, foreign, homed, lim.joint_lower, lim.joint_upper,
                   lim.joint_travel, joint_unit)
    elif field in ("mpos", "mpos_d"):
        _positions(out, column, values, finite, slot, foreign, homed, lim.motor_lower, lim.motor_upper,
                   lim.motor_travel, "rad")
    elif field == "mvel":
        top = lim.motor_speed[slot] + 1.0 / (lim.counts_per_rad * lim.servo_period)
        _bound(out, column, values, finite, -top, top, "rad/s", "no-load speed")
    elif field == "jvel":
        top = lim.joint_speed[slot] + 1.0 / (lim.counts_per_rad * lim.servo_period * lim.transmission_ratio[slot])
        _bound(out, column, values, finite, -top, top, "m/s" if slot == 2 else "rad/s", "no-load speed")
    elif field == "dac_val":
        _bound(out, column, values, finite, -lim.dac_max[slot], lim.dac_max[slot], "count", "DAC clip")
    elif field == "tau":
        _bound(out, column, values, finite, -lim.torque_max[slot], lim.torque_max[slot], "N m", "stall torque")


def _arm_blocks(columns, field, names, tail=""):
    """Columns ``<field>.<name><tail>`` as an (N, len(names)) array, or None if one is missing."""
    try:
        return np.column_stack([np.asarray(columns[f"{field}.{name}{tail}"], dtype=np.float64) for name in names])
    except KeyError:
        return None


def _check_coupling(out, columns, lim: RecordingLimits) -> None:
    names = DOF_NAMES[:_POSITIONING]
    for joint_field, motor_field in (("jpos", "mpos"), ("jpos_d", "mpos_d")):
        joints, motors = _arm_blocks(columns, joint_field, names), _arm_blocks(columns, motor_field, names)
        if joints is None or motors is None:
            continue
        expected = (motors / lim.transmission_ratio[:_POSITIONING]) @ lim.coupling.T
        with np.errstate(invalid="ignore"):
            off = np.abs(joints - expected) > lim.coupling_tolerance
        for j, name in enumerate(names):
            unit = "m" if j == 2 else "rad"
            out.add(f"{joint_field}.{name}", off[:, j], joints[:, j],
                    lambda i, j=j, unit=unit, e=expected: (
                        f"{e[i, j]:.6g} +- {lim.coupling_tolerance[j]:.3g} {unit} "
                        f"(cable coupling of {motor_field})"))


def _check_rotations(out, columns, suffix) -> None:
    entries = [f"R{row}{col}" for row in range(3) for col in range(3)]
    for block_name in ("ori", "ori_d"):
        for tail in ("", suffix):
            block = _arm_blocks(columns, block_name, entries, tail)
            if block is None:
                continue
            matrices = block.reshape(-1, 3, 3)
            absent = np.all(np.abs(block) <= 1e-6, axis=1)
            with np.errstate(invalid="ignore", over="ignore"):
                error = np.abs(matrices @ matrices.transpose(0, 2, 1) - np.eye(3)).max(axis=(1, 2))
            bad = np.isfinite(error) & (error > 1e-3) & ~absent
            out.add(f"{block_name}{tail}", bad, error, "R R^T = I within 1e-3 (or all zero)")


def _check_jumps(out, time, columns, lim: RecordingLimits, restart: np.ndarray, suffix: str) -> None:
    """Jumps farther than the motors can move, per arm; and motor positions that move unlike their
    encoders (``mpos`` is the encoder count less the homing offset, over counts per radian)."""
    count = 2.0 / lim.counts_per_rad
    for tail in ("", suffix):
        offsets = _arm_blocks(columns, "encoffsets", DOF_NAMES, tail)
        reset = restart.copy()
        if offsets is not None:
            reset[1:] |= np.any(offsets[1:] != offsets[:-1], axis=1)
        checks = [
            ("mpos", DOF_NAMES, lim.motor_speed, np.full(_N_SLOTS, count), reset, "rad"),
            ("encVals", DOF_NAMES, lim.motor_speed * lim.counts_per_rad, np.full(_N_SLOTS, 2.0), restart, "count"),
            ("jpos", DOF_NAMES, lim.joint_speed, count / lim.transmission_ratio * 4.0, reset, None),
        ]
        if not tail:
            checks.append(("truth", GROUND_TRUTH_JOINTS, lim.joint_speed[:3], np.full(3, 1e-6), restart, None))
        for block_name, names, rate, tolerance, reset_here, unit in checks:
            block = _arm_blocks(columns, block_name, names, tail)
            if block is None or block.shape[0] < 2:
                continue
            scale = np.max(np.where(np.isfinite(block), np.abs(block), 0.0), axis=0)
            # float32 publication rounds values by a relative 6e-8
            bad = np.column_stack([_jumps(time, block[:, j], rate[j], tolerance[j] + 1e-6 * scale[j], reset_here)
                                   for j in range(len(names))])
            for j, name in enumerate(names):
                u = unit or ("m" if j == 2 else "rad")
                out.add(f"{block_name}.{name}{tail}", bad[:, j], block[:, j],
                        lambda i, j=j, u=u, rate=rate: f"|jump| <= {rate[j]:.6g} {u}/s x elapsed time "
                                                       "(motor no-load speed)")
        motors, counts = _arm_blocks(columns, "mpos", DOF_NAMES, tail), _arm_blocks(columns, "encVals", DOF_NAMES, tail)
        if motors is None or counts is None or motors.shape[0] < 2:
            continue
        # a sample whose steps to both neighbours disagree; differences cancel the homing offset,
        # magnitudes the encoder's sign
        scale = np.max(np.where(np.isfinite(motors), np.abs(motors), 0.0), axis=0)
        tolerance = 2.0 + 1e-6 * scale * lim.counts_per_rad
        moved = np.abs(np.diff(motors, axis=0)) * lim.counts_per_rad
        disagree = np.abs(moved - np.abs(np.diff(counts, axis=0))) > tolerance
        disagree &= ~reset[1:, None]
        before = np.vstack([disagree[:1], disagree])
        after = np.vstack([disagree, disagree[-1:]])
        bad = before & after
        for j, name in enumerate(DOF_NAMES):
            out.add(f"mpos.{name}{tail}", bad[:, j], motors[:, j],
                    lambda i, j=j: f"moves with encVals.{DOF_NAMES[j]}{tail} within 2 counts "
                                   f"({lim.counts_per_rad:.6g} counts/rad)")


# ---------------------------------------------------------------------------------------------
# Acting on the result


def check_on_invalid(on_invalid: str) -> str:
    """Return ``on_invalid`` if it is one of ``ON_INVALID``, else raise ValueError."""
    if on_invalid not in ON_INVALID:
        raise ValueError(f"on_invalid must be one of {ON_INVALID}, got {on_invalid!r}")
    return on_invalid


def resolve_invalid(source, parts: Sequence[tuple[str, InvalidSamples]], on_invalid: str,
                    *, stacklevel: int = 3) -> None:
    """Raise or warn about the impossible samples of a file, once.

    Parameters
    ----------
    source : path-like or str
        The file, named first in the message.
    parts : sequence of (str, InvalidSamples)
        One entry per log of the file (e.g. ``("topic '/ravenstate'", ...)``; ``""`` for a table).
    on_invalid : {"flag", "drop", "raise"}
        ``"raise"`` raises ImpossibleValueError; the others warn with ImpossibleValueWarning
        (the caller then marks or removes the samples).
    """
    check_on_invalid(on_invalid)
    flagged = [(what, found) for what, found in parts if found.count]
    if not flagged:
        return
    counts = ", ".join(f"{found.count} of {found.mask.size} samples" + (f" of {what}" if what else "")
                       for what, found in flagged)
    what, found = flagged[0]
    first = f"first: {what + ', ' if what else ''}{found.first.describe()}"
    if on_invalid == "raise":
        raise ImpossibleValueError(f"{source}: impossible values in {counts}; {first}")
    action = "dropped" if on_invalid == "drop" else "flagged (valid = False)"
    warnings.warn(f"{source}: impossible values in {counts}, {action}; {first}", ImpossibleValueWarning,
                  stacklevel=stacklevel)
