"""The RAVEN-II robot state ('ravenstate') as recorded data: field specification and log containers.

The field list mirrors ``msg/raven_state.msg`` of the RAVEN-II controller (repository
``uw-biorobotics/raven2``, commit d2307c50) in message order, and each field records how the robot
fills it in ``publish_ravenstate_ros`` (``src/raven/local_io.cpp``, lines 439-516): which
controller variable, which scale and which unit. Inside the project every value is SI; the
published scale is applied only when a bag is written or read (``simulation.recordings.bags``).

Array fields of width 16 hold 2 arms x 8 controller slots: the slot of a DOF is its joint type
(``include/raven/defines.h`` lines 137-167), the gold arm (serial 49) in slots 0-7 and the green arm
(serial 22) in slots 8-15. The project calls the gold arm "left" and the green arm "right". Fields of
other widths hold one block per arm in the same arm order (``j * 3``, ``j * 9``, ``j * 6``, ``j``).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

ARM_NAMES = ("left", "right")
ARM_SERIALS = {"left": 49, "right": 22}
ARM_SLOTS = {"left": slice(0, 8), "right": slice(8, 16)}
DOF_NAMES = ("shoulder", "elbow", "z_ins", "no_connection", "tool_rot", "wrist", "grasp1", "grasp2")
GROUND_TRUTH_JOINTS = ("shoulder", "elbow", "z_ins")
GROUND_TRUTH_UNITS = ("rad", "rad", "m")

RAD_TO_DEG = 180.0 / np.pi
METRES_TO_MICROMETRES = 1.0e6

_XYZ = ("x", "y", "z")
_ROTATION_ENTRIES = tuple(f"R{row}{col}" for row in range(3) for col in range(3))
_JOINT_UNITS = ("rad", "rad", "m", "rad", "rad", "rad", "rad", "rad")
_JOINT_RATE_UNITS = ("rad/s", "rad/s", "m/s", "rad/s", "rad/s", "rad/s", "rad/s", "rad/s")
_LOCAL_IO = "src/raven/local_io.cpp"


@dataclass(frozen=True)
class FieldSpec:
    """One field of the ravenstate message and how the robot publishes it.

    Parameters
    ----------
    name : str
        Field name in ``msg/raven_state.msg``.
    ros_type : str
        Type as written in the message definition (``"float32[16]"``, ``"duration"``...).
    width : int
        Entries per sample (1 for scalar fields).
    per_arm : int
        Entries that belong to one arm; 0 for status fields shared by both arms.
    entry_names : tuple of str
        Name of each entry of one arm's block (``(name,)`` for shared and one-entry fields).
    si_units : tuple of str
        Unit of each entry of one arm's block inside the project (SI).
    published_scale : float
        ``published = si * published_scale`` (then rounded for integer types).
    published_unit : str
        The unit of the value on the ROS topic, as the robot publishes it.
    source : str
        File and line of the RAVEN-II controller that fills the field.
    description : str
        What the value is.
    """

    name: str
    ros_type: str
    width: int
    per_arm: int
    entry_names: tuple[str, ...]
    si_units: tuple[str, ...]
    published_scale: float
    published_unit: str
    source: str
    description: str

    @property
    def ros_element(self) -> str:
        """The element type of the field (``"int32"``, ``"float32"`` or ``"duration"``)."""
        return self.ros_type.split("[", 1)[0]

    @property
    def is_array(self) -> bool:
        """True for fixed-size array fields (stored as ``(N, width)``), False for scalars."""
        return "[" in self.ros_type

    @property
    def is_count(self) -> bool:
        """True when the log holds exact integers (integer ROS type without scaling)."""
        return self.ros_element == "int32" and self.published_scale == 1.0

    def arm_slice(self, arm: str) -> slice:
        """The entries of ``arm`` in this field (all entries for a shared status field)."""
        check_arm(arm)
        if self.per_arm == 0:
            return slice(0, self.width)
        start = ARM_NAMES.index(arm) * self.per_arm
        return slice(start, start + self.per_arm)


def _slot_field(name, ros_element, units, scale, published_unit, line, description) -> FieldSpec:
    return FieldSpec(
        name=name,
        ros_type=f"{ros_element}[16]",
        width=16,
        per_arm=8,
        entry_names=DOF_NAMES,
        si_units=units,
        published_scale=scale,
        published_unit=published_unit,
        source=f"{_LOCAL_IO}:{line}",
        description=description,
    )


def _status_field(name, line, description) -> FieldSpec:
    return FieldSpec(name, "int32", 1, 0, (name,), ("1",), 1.0, "1", f"{_LOCAL_IO}:{line}", description)


_DEG_PUBLISHED = "deg (x180/pi; the insertion slot is metres x180/pi)"

RAVENSTATE_FIELDS: tuple[FieldSpec, ...] = (
    _status_field("runlevel", 511, "controller run level (currParams->runlevel)"),
    _status_field("sublevel", 512, "controller sub level (currParams->sublevel)"),
    _status_field("last_seq", 446, "sequence number of the last teleoperation packet"),
    FieldSpec("type", "int32[2]", 2, 1, ("type",), ("serial",), 1.0, "serial number",
              f"{_LOCAL_IO}:468", "arm serial number (49 gold/left, 22 green/right)"),
    FieldSpec("pos", "int32[6]", 6, 3, _XYZ, ("m",) * 3, METRES_TO_MICROMETRES, "um (int)",
              f"{_LOCAL_IO}:469-471; src/raven/r2_kinematics.cpp:150-152",
              "tool position from forward kinematics, base (RCM) frame"),
    FieldSpec("ori", "float32[18]", 18, 9, _ROTATION_ENTRIES, ("1",) * 9, 1.0, "1",
              f"{_LOCAL_IO}:479", "tool orientation, rotation matrix R[row][col] row-major"),
    FieldSpec("ori_d", "float32[18]", 18, 9, _ROTATION_ENTRIES, ("1",) * 9, 1.0, "1",
              f"{_LOCAL_IO}:480", "desired tool orientation, rotation matrix row-major"),
    FieldSpec("pos_d", "int32[6]", 6, 3, _XYZ, ("m",) * 3, METRES_TO_MICROMETRES, "um (int)",
              f"{_LOCAL_IO}:472-474; src/raven/r2_kinematics.cpp:393-395",
              "desired tool position, base (RCM) frame"),
    FieldSpec("dt", "duration", 1, 0, ("dt",), ("s",), 1.0, "s (ROS duration)",
              f"{_LOCAL_IO}:453-458", "time since the previous published message"),
    _slot_field("encVals", "int32", ("count",) * 8, 1.0, "count", 486,
                "motor encoder value (joint[m].enc_val)"),
    _slot_field("dac_val", "int32", ("count",) * 8, 1.0, "DAC count", 495,
                "motor current command sent to the DAC (joint[m].current_cmd)"),
    _slot_field("tau", "float32", ("N m",) * 8, 1.0, "N m", 487,
                "desired motor torque at the capstan after the gearbox (joint[m].tau_d)"),
    _slot_field("mpos", "float32", ("rad",) * 8, RAD_TO_DEG, "deg", 488,
                "motor position (joint[m].mpos)"),
    _slot_field("jpos", "float32", _JOINT_UNITS, RAD_TO_DEG, _DEG_PUBLISHED, 489,
                "joint position from the motor encoders through the cable coupling (joint[m].jpos)"),
    _slot_field("mvel", "float32", ("rad/s",) * 8, RAD_TO_DEG, "deg/s", 490,
                "motor velocity (joint[m].mvel)"),
    _slot_field("jvel", "float32", _JOINT_RATE_UNITS, RAD_TO_DEG,
                "deg/s (x180/pi; the insertion slot is m/s x180/pi)", 491,
                "joint velocity (joint[m].jvel)"),
    _slot_field("mpos_d", "float32", ("rad",) * 8, RAD_TO_DEG, "deg", 493,
                "desired motor position (joint[m].mpos_d)"),
    _slot_field("jpos_d", "float32", _JOINT_UNITS, RAD_TO_DEG, _DEG_PUBLISHED, 492,
                "desired joint position (joint[m].jpos_d)"),
    FieldSpec("grasp_d", "float32[2]", 2, 1, ("grasp_d",), ("rad",), 1.0, "rad",
              f"{_LOCAL_IO}:475", "desired grasp angle (ori_d.grasp, integer mrad, / 1000)"),
    _slot_field("encoffsets", "float32", ("count",) * 8, 1.0, "count", 494,
                "motor encoder offset registered at homing (joint[m].enc_offset, an int)"),
    FieldSpec("jac_vel", "float32[12]", 12, 6, ("vx", "vy", "vz", "wx", "wy", "wz"),
              ("m/s",) * 3 + ("rad/s",) * 3, 1.0, "m/s, rad/s", f"{_LOCAL_IO}:502,505",
              "tool twist J(q) qdot (src/raven/r2_jacobian.cpp calc_velocities)"),
    FieldSpec("jac_f", "float32[12]", 12, 6, ("fx", "fy", "fz", "mx", "my", "mz"),
              ("N",) * 3 + ("N m",) * 3, 1.0, "N, N m by its name; see description",
              f"{_LOCAL_IO}:503,506",
              "tool wrench J^-T tau by its name; the controller fills it with get_vel (line 503), "
              "so a real robot publishes the twist of jac_vel here"),
)
FIELD_SPECS: Mapping[str, FieldSpec] = MappingProxyType({spec.name: spec for spec in RAVENSTATE_FIELDS})


def check_arm(arm: str) -> str:
    """Return ``arm`` if it names a RAVEN-II arm ("left" or "right"), else raise ValueError."""
    if arm not in ARM_NAMES:
        raise ValueError(f"arm must be one of {ARM_NAMES}, got {arm!r}")
    return arm


def _first_bad_sample(bad: np.ndarray) -> int:
    return int(np.flatnonzero(bad.reshape(bad.shape[0], -1).any(axis=1))[0])


def _validated_time(time, owner: str) -> np.ndarray:
    time = np.array(time, dtype=np.float64)
    if time.ndim != 1:
        raise ValueError(f"{owner}: time must have shape (N,), got {time.shape}")
    if not np.all(np.isfinite(time)):
        raise ValueError(f"{owner}: time is not finite at sample {_first_bad_sample(~np.isfinite(time))}")
    steps = np.diff(time)
    if np.any(steps <= 0.0):
        index = int(np.flatnonzero(steps <= 0.0)[0]) + 1
        raise ValueError(
            f"{owner}: time is not strictly increasing at sample {index} "
            f"({float(time[index - 1])} s then {float(time[index])} s)"
        )
    time.setflags(write=False)
    return time


def _validated_mask(valid, n_samples: int, owner: str) -> np.ndarray:
    if valid is None:
        mask = np.ones(n_samples, dtype=bool)
    else:
        mask = np.array(valid)
        if mask.shape != (n_samples,) or mask.dtype != np.bool_:
            raise ValueError(f"{owner}: valid must be a boolean array of shape ({n_samples},), "
                             f"got {mask.dtype} {mask.shape}")
    mask.setflags(write=False)
    return mask


def _validated_field(spec: FieldSpec, values, n_samples: int, valid: np.ndarray) -> np.ndarray:
    values = np.array(values)
    expected = (n_samples, spec.width) if spec.is_array else (n_samples,)
    if values.shape != expected:
        raise ValueError(f"RavenStateLog field {spec.name!r} has shape {values.shape}, expected {expected}")
    if not (np.issubdtype(values.dtype, np.number) or values.dtype == np.bool_):
        raise ValueError(f"RavenStateLog field {spec.name!r} must be numeric, got dtype {values.dtype}")
    finite = np.isfinite(values)
    if not spec.is_count:
        finite |= ~valid.reshape((n_samples,) + (1,) * (values.ndim - 1))
    if not np.all(finite):
        raise ValueError(
            f"RavenStateLog field {spec.name!r} is not finite at sample {_first_bad_sample(~finite)}"
        )
    if spec.is_count:
        integral = values == np.round(values)
        if not np.all(integral):
            raise ValueError(
                f"RavenStateLog field {spec.name!r} holds integer counts but is not integral at "
                f"sample {_first_bad_sample(~integral)}"
            )
        values = values.astype(np.int64)
    else:
        values = values.astype(np.float64)
    values.setflags(write=False)
    return values


def _validated_labels(labels: Mapping[str, np.ndarray], n_samples: int) -> Mapping[str, np.ndarray]:
    checked = {}
    for name, values in labels.items():
        if not isinstance(name, str) or not name:
            raise ValueError(f"label names must be non-empty strings, got {name!r}")
        values = np.array(values)
        if values.shape != (n_samples,):
            raise ValueError(f"label {name!r} has shape {values.shape}, expected ({n_samples},)")
        if not (np.issubdtype(values.dtype, np.number) or values.dtype == np.bool_):
            raise ValueError(f"label {name!r} must be numeric or boolean, got dtype {values.dtype}")
        finite = np.isfinite(values)
        if not np.all(finite):
            raise ValueError(f"label {name!r} is not finite at sample {_first_bad_sample(~finite)}")
        values.setflags(write=False)
        checked[name] = values
    return MappingProxyType(checked)


def _as_index(selector, n_samples: int):
    if isinstance(selector, slice):
        return selector
    selector = np.asarray(selector)
    if selector.dtype == np.bool_:
        if selector.shape != (n_samples,):
            raise ValueError(f"boolean mask has shape {selector.shape}, expected ({n_samples},)")
        return selector
    if selector.ndim != 1 or not np.issubdtype(selector.dtype, np.integer):
        raise ValueError("select expects a slice, a boolean mask or a 1-D array of sample indices")
    return selector


@dataclass(frozen=True, eq=False)
class RavenStateLog:
    """Recorded RAVEN-II robot state: every ravenstate field over time, in SI units.

    Parameters
    ----------
    time : ndarray, shape (N,)
        Message time stamps (``hdr.stamp``), s, strictly increasing.
    fields : mapping of str to ndarray
        One entry per ravenstate field except ``hdr`` (see ``RAVENSTATE_FIELDS``): scalar fields
        (N,), array fields (N, width). SI units: rad, m, rad/s, m/s, N m, s; ``pos``/``pos_d`` in
        metres, ``ori``/``ori_d`` rotation-matrix entries, ``encVals``/``dac_val`` integer counts,
        ``encoffsets`` counts, ``dt`` seconds, ``type`` arm serial numbers. Integer-count fields
        are stored as int64, all others as float64; the arrays are read-only copies.
    labels : mapping of str to ndarray, optional
        Per-sample scenario labels, shape (N,) each (e.g. ``payload_kg``, ``operating_hours``,
        ``homing_count``, ``segment``).
    arm : {"left", "right"}
        The arm whose state is the calibration input.
    valid : ndarray of bool, shape (N,), optional
        False for a sample a reader found to hold a value the robot cannot produce
        (``simulation.recordings.limits``); such a sample may hold non-finite values in its
        float fields. Default: every sample valid.

    Raises
    ------
    ValueError
        A field is missing or unknown, has the wrong shape, holds a non-finite value in a valid
        sample, an integer field holds a fraction, or time is not strictly increasing; the message
        names the field and the first bad sample.
    """

    time: np.ndarray
    fields: Mapping[str, np.ndarray]
    labels: Mapping[str, np.ndarray] = field(default_factory=dict)
    arm: str = "left"
    valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        check_arm(self.arm)
        time = _validated_time(self.time, "RavenStateLog")
        valid = _validated_mask(self.valid, time.size, "RavenStateLog")
        missing = [name for name in FIELD_SPECS if name not in self.fields]
        unknown = [name for name in self.fields if name not in FIELD_SPECS]
        if missing or unknown:
            raise ValueError(f"RavenStateLog fields: missing {missing}, unknown {unknown}")
        fields = {name: _validated_field(spec, self.fields[name], time.size, valid)
                  for name, spec in FIELD_SPECS.items()}
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "fields", MappingProxyType(fields))
        object.__setattr__(self, "labels", _validated_labels(self.labels, time.size))
        object.__setattr__(self, "valid", valid)

    def __len__(self) -> int:
        return self.time.size

    def arm_values(self, name: str, arm: str | None = None) -> np.ndarray:
        """The entries of field ``name`` that belong to ``arm`` (default: this log's arm).

        Returns (N, per_arm) for per-arm array fields, (N,) for one-entry-per-arm and shared
        scalar fields, in the SI units of ``FieldSpec.si_units``.
        """
        spec = FIELD_SPECS[name]
        values = self.fields[name]
        if not spec.is_array:
            return values
        block = values[:, spec.arm_slice(arm or self.arm)]
        return block[:, 0] if spec.per_arm == 1 else block

    def select(self, selector) -> RavenStateLog:
        """A new log with the samples picked by a slice, a boolean mask (N,) or sample indices."""
        index = _as_index(selector, len(self))
        return RavenStateLog(
            time=self.time[index],
            fields={name: values[index] for name, values in self.fields.items()},
            labels={name: values[index] for name, values in self.labels.items()},
            arm=self.arm,
            valid=self.valid[index],
        )

    def with_arm(self, arm: str) -> RavenStateLog:
        """The same recording with another arm as the calibration input (validity kept)."""
        return RavenStateLog(self.time, self.fields, self.labels, arm, self.valid)

    @classmethod
    def concatenate(cls, logs: Sequence[RavenStateLog]) -> RavenStateLog:
        """Join logs recorded one after the other (same arm, same labels, increasing time)."""
        logs = list(logs)
        if not logs:
            raise ValueError("concatenate needs at least one RavenStateLog")
        _check_joinable(logs, "RavenStateLog")
        label_names = set(logs[0].labels)
        for position, log in enumerate(logs[1:], start=1):
            if log.arm != logs[0].arm:
                raise ValueError(f"log {position} is for arm {log.arm!r}, log 0 for {logs[0].arm!r}")
            if set(log.labels) != label_names:
                raise ValueError(f"log {position} has labels {sorted(log.labels)}, log 0 has {sorted(label_names)}")
        return cls(
            time=np.concatenate([log.time for log in logs]),
            fields={name: np.concatenate([log.fields[name] for log in logs]) for name in FIELD_SPECS},
            labels={name: np.concatenate([log.labels[name] for log in logs]) for name in label_names},
            arm=logs[0].arm,
            valid=np.concatenate([log.valid for log in logs]),
        )


@dataclass(frozen=True, eq=False)
class GroundTruthLog:
    """External joint-encoder measurements: the ground truth of joints 1-3.

    Parameters
    ----------
    time : ndarray, shape (M,)
        Measurement time stamps, s, strictly increasing.
    joints : ndarray, shape (M, 3)
        Shoulder (rad), elbow (rad) and insertion (m), in the controller's joint convention.
    valid : ndarray of bool, shape (M,), optional
        False for a sample found impossible by a reader (it may hold non-finite values).
        Default: every sample valid.

    Raises
    ------
    ValueError
        Wrong shape, a non-finite value in a valid sample or time not strictly increasing
        (naming the sample).
    """

    time: np.ndarray
    joints: np.ndarray
    valid: np.ndarray | None = None

    def __post_init__(self) -> None:
        time = _validated_time(self.time, "GroundTruthLog")
        valid = _validated_mask(self.valid, time.size, "GroundTruthLog")
        joints = np.array(self.joints, dtype=np.float64)
        if joints.shape != (time.size, 3):
            raise ValueError(f"GroundTruthLog: joints has shape {joints.shape}, expected ({time.size}, 3)")
        finite = np.isfinite(joints) | ~valid[:, None]
        if not np.all(finite):
            raise ValueError(f"GroundTruthLog: joints is not finite at sample {_first_bad_sample(~finite)}")
        joints.setflags(write=False)
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "valid", valid)

    def __len__(self) -> int:
        return self.time.size

    def select(self, selector) -> GroundTruthLog:
        """A new log with the samples picked by a slice, a boolean mask (M,) or sample indices."""
        index = _as_index(selector, len(self))
        return GroundTruthLog(self.time[index], self.joints[index], self.valid[index])

    @classmethod
    def concatenate(cls, logs: Sequence[GroundTruthLog]) -> GroundTruthLog:
        """Join logs recorded one after the other (increasing time)."""
        logs = list(logs)
        if not logs:
            raise ValueError("concatenate needs at least one GroundTruthLog")
        _check_joinable(logs, "GroundTruthLog")
        return cls(np.concatenate([log.time for log in logs]), np.concatenate([log.joints for log in logs]),
                   np.concatenate([log.valid for log in logs]))


def _check_joinable(logs, owner: str) -> None:
    for position in range(1, len(logs)):
        before, after = logs[position - 1], logs[position]
        if len(before) and len(after) and after.time[0] <= before.time[-1]:
            raise ValueError(
                f"{owner}.concatenate: log {position} starts at {float(after.time[0])} s, not after the end "
                f"of log {position - 1} ({float(before.time[-1])} s)"
            )
