"""ROS1 bags of RAVEN-II recordings: the robot state and the external joint encoders.

A bag holds the topics a real RAVEN-II calibration session records, so the same reader takes the
simulator's bags and the robot's:

``/ravenstate`` (``raven_2/msg/raven_state``)
    The robot state, in the units the robot publishes (``simulation.recordings.ravenstate.RAVENSTATE_FIELDS``:
    angles and joint positions in degrees, the insertion slot in metres x 180/pi, ``pos``/``pos_d``
    in integer micrometres, ``tau`` in N m...). The message definition is the one of the RAVEN-II
    controller (``msg/raven_state.msg``, package ``raven_2``), so the MD5 sum matches the robot's.
``/ext_jpos`` (``sensor_msgs/msg/JointState``)
    The external joint encoders as the CRTK Python controller publishes them
    (``joint_encoder/func_raven_joint_encodersIII.py``, ``ros_pub``): ``position`` =
    [shoulder rad, elbow rad, insertion m], ``name`` empty, ``header.stamp`` the measurement time.
``/scenario`` (``sensor_msgs/msg/JointState``, written by this project only)
    The scenario labels of each robot-state sample, one message per ``/ravenstate`` message with
    the same stamp: ``name[i]`` = ``"<label>[<dtype>]"`` (e.g. ``"payload_kg[float64]"``),
    ``position[i]`` = the value. Labels round-trip exactly (integers up to 2**53). A bag without
    this topic (a real robot's) reads with no labels.

The robot's other topics (``joint_enc`` raw counts, CRTK ``measured_js``) are neither written nor
needed. Each message's bag time equals its header stamp. The sample time of a log is the header
stamp (ROS time, so it must be >= 0 s).

Reading checks every value against the arm's physical limits (``simulation.recordings.limits``):
by default impossible samples are kept and marked (``RavenStateLog.valid``,
``GroundTruthLog.valid``) with one warning per bag; ``on_invalid="drop"`` removes them,
``on_invalid="raise"`` raises ``ImpossibleValueError``. A damaged structure (not a bag, a
truncated bag, a missing topic or another message type, time running backwards, labels out of
step) is a ``BagFormatError`` in every mode.
"""

from __future__ import annotations

import bz2
import functools
import os
import re
import struct
from collections.abc import Iterator, Mapping
from pathlib import Path

import numpy as np
from rosbags.rosbag1 import Reader, ReaderError, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from simulation.recordings.limits import (
    RecordingLimits,
    check_on_invalid,
    find_invalid,
    resolve_invalid,
    state_columns,
)
from simulation.recordings.ravenstate import (
    GROUND_TRUTH_JOINTS,
    RAVENSTATE_FIELDS,
    GroundTruthLog,
    RavenStateLog,
    check_arm,
)
from simulation.recordings.tables import atomic_output

STATE_TOPIC = "/ravenstate"
TRUTH_TOPIC = "/ext_jpos"
SCENARIO_TOPIC = "/scenario"
STATE_MSGTYPE = "raven_2/msg/raven_state"
JOINT_STATE_MSGTYPE = "sensor_msgs/msg/JointState"

# msg/raven_state.msg of uw-biorobotics/raven2 (commit d2307c50), field for field.
RAVEN_STATE_MSG = """\
Header      \thdr
int32       \trunlevel
int32       \tsublevel
int32       \tlast_seq
int32[2]    \ttype
int32[6]    \tpos
float32[18]   \tori
float32[18]   \tori_d
int32[6]    \tpos_d
duration    \tdt
int32[16]   \tencVals
int32[16]       dac_val
float32[16] \ttau
float32[16] \tmpos
float32[16] \tjpos
float32[16] \tmvel
float32[16] \tjvel
float32[16] \tmpos_d
float32[16] \tjpos_d
float32[2]  \tgrasp_d
float32[16] \tencoffsets
float32[12] \tjac_vel
float32[12] \tjac_f
"""

_NANOSECONDS = 1_000_000_000
_INT32 = np.iinfo(np.int32)
_MAX_EXACT_LABEL = 2**53
_LABEL_NAME = re.compile(r"^(?P<key>.+)\[(?P<dtype>[a-z0-9]+)\]$")


class BagFormatError(ValueError):
    """A bag that cannot be read as a RAVEN-II recording; the message names file, topic and sample."""


@functools.cache
def raven_typestore():
    """The ROS1 Noetic type store with ``raven_2/msg/raven_state`` registered.

    Returns
    -------
    rosbags.typesys.store.Typestore
        Shared, do not register further types on it.
    """
    typestore = get_typestore(Stores.ROS1_NOETIC)
    typestore.register(get_types_from_msg(RAVEN_STATE_MSG, STATE_MSGTYPE))
    return typestore


def raven_state_md5() -> str:
    """The ROS1 MD5 sum of ``raven_2/raven_state`` (identical to the one a real robot's bag carries)."""
    return raven_typestore().generate_msgdef(STATE_MSGTYPE)[1]


# ---------------------------------------------------------------------------------------------
# SI <-> published units


def _to_nanoseconds(seconds: np.ndarray, what: str) -> np.ndarray:
    nanoseconds = np.rint(np.asarray(seconds, dtype=np.float64) * _NANOSECONDS)
    if np.any(np.abs(nanoseconds) >= 2**62):
        raise ValueError(f"{what} is out of the range of ROS time")
    return nanoseconds.astype(np.int64)


def published_fields(state_log: RavenStateLog) -> dict[str, np.ndarray]:
    """The fields of ``state_log`` in the robot's published units and ROS types.

    Returns
    -------
    dict of str to ndarray
        int32 or float32 arrays (``dt`` as int64 nanoseconds), shapes as in the log.

    Raises
    ------
    ValueError
        A value does not fit the ROS type once scaled (naming the field and the sample).
    """
    published = {}
    for spec in RAVENSTATE_FIELDS:
        values = state_log.fields[spec.name]
        if spec.ros_element == "duration":
            published[spec.name] = _to_nanoseconds(values, "field 'dt'")
            continue
        scaled = values * spec.published_scale
        if spec.ros_element == "int32":
            scaled = np.rint(scaled)
            bad = (scaled < _INT32.min) | (scaled > _INT32.max)
            dtype = np.int32
        else:
            bad = np.abs(scaled) > np.finfo(np.float32).max
            dtype = np.float32
        if np.any(bad):
            sample = int(np.flatnonzero(bad.reshape(len(values), -1).any(axis=1))[0])
            raise ValueError(
                f"field {spec.name!r} at sample {sample} does not fit {spec.ros_element} "
                f"in {spec.published_unit}"
            )
        published[spec.name] = scaled.astype(dtype)
    return published


def si_fields(published: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Inverse of ``published_fields``: the robot's published values in SI units (float64/int64)."""
    fields = {}
    for spec in RAVENSTATE_FIELDS:
        values = published[spec.name]
        if spec.ros_element == "duration":
            fields[spec.name] = values.astype(np.float64) / _NANOSECONDS
        elif spec.is_count:
            fields[spec.name] = values.astype(np.int64)
        else:
            fields[spec.name] = values.astype(np.float64) / spec.published_scale
    return fields


# ---------------------------------------------------------------------------------------------
# Writing


def _time_message(types, nanoseconds: int):
    return types["builtin_interfaces/msg/Time"](sec=int(nanoseconds // _NANOSECONDS),
                                                nanosec=int(nanoseconds % _NANOSECONDS))


def _header(types, seq: int, nanoseconds: int):
    return types["std_msgs/msg/Header"](seq=seq, stamp=_time_message(types, nanoseconds), frame_id="")


def _state_messages(state_log: RavenStateLog, stamps: np.ndarray) -> Iterator[object]:
    types = raven_typestore().types
    message_type = types[STATE_MSGTYPE]
    duration_type = types["builtin_interfaces/msg/Duration"]
    published = published_fields(state_log)
    for index, stamp in enumerate(stamps):
        values = {}
        for spec in RAVENSTATE_FIELDS:
            value = published[spec.name][index]
            if spec.ros_element == "duration":
                value = duration_type(sec=int(value // _NANOSECONDS), nanosec=int(value % _NANOSECONDS))
            elif not spec.is_array:
                value = int(value)
            values[spec.name] = value
        yield message_type(hdr=_header(types, index, int(stamp)), **values)


def _joint_state(types, seq: int, stamp: int, names: list[str], position: np.ndarray):
    empty = np.zeros(0, dtype=np.float64)
    return types[JOINT_STATE_MSGTYPE](header=_header(types, seq, stamp), name=names,
                                      position=np.asarray(position, dtype=np.float64),
                                      velocity=empty, effort=empty)


def _scenario_names(labels: Mapping[str, np.ndarray]) -> list[str]:
    names = []
    for key, values in labels.items():
        if np.issubdtype(values.dtype, np.integer) and np.any(np.abs(values) > _MAX_EXACT_LABEL):
            raise ValueError(f"label {key!r} holds integers beyond 2**53, which a bag cannot carry exactly")
        names.append(f"{key}[{values.dtype.name}]")
    return names


def _stamps(time: np.ndarray, owner: str) -> np.ndarray:
    if time.size and time[0] < 0.0:
        raise ValueError(f"{owner}: time starts at {float(time[0])} s; ROS time stamps must be >= 0 s")
    stamps = _to_nanoseconds(time, f"{owner} time")
    if np.any(np.diff(stamps) <= 0):
        raise ValueError(f"{owner}: two samples closer than 1 ns cannot be told apart in a bag")
    return stamps


def write_bag(path: str | os.PathLike, state_log: RavenStateLog, truth_log: GroundTruthLog,
              *, overwrite: bool = False) -> Path:
    """Write a recording as a ROS1 bag in the robot's published units.

    Parameters
    ----------
    path : path-like
        Destination ``.bag`` file (written atomically: a failure leaves no file).
    state_log : RavenStateLog
        Written to ``/ravenstate`` (and its labels to ``/scenario`` when it has any).
    truth_log : GroundTruthLog
        Written to ``/ext_jpos``.
    overwrite : bool
        Whether an existing file may be replaced.

    Returns
    -------
    Path
        The written bag.

    Raises
    ------
    ValueError
        A time stamp before 0 s, or a value that does not fit its ROS type once scaled.
    FileExistsError
        ``path`` exists and ``overwrite`` is False.
    """
    if not isinstance(state_log, RavenStateLog) or not isinstance(truth_log, GroundTruthLog):
        raise TypeError("write_bag expects a RavenStateLog and a GroundTruthLog")
    typestore = raven_typestore()
    types = typestore.types
    state_stamps = _stamps(state_log.time, "RavenStateLog")
    truth_stamps = _stamps(truth_log.time, "GroundTruthLog")
    label_names = _scenario_names(state_log.labels)
    label_values = np.column_stack([state_log.labels[key].astype(np.float64) for key in state_log.labels]
                                   ) if label_names else None
    state_messages = _state_messages(state_log, state_stamps)

    # Messages in time order; at equal stamps robot state, then labels, then ground truth.
    order = sorted(
        [(int(stamp), 0, index) for index, stamp in enumerate(state_stamps)]
        + ([(int(stamp), 1, index) for index, stamp in enumerate(state_stamps)] if label_names else [])
        + [(int(stamp), 2, index) for index, stamp in enumerate(truth_stamps)]
    )
    with atomic_output(path, overwrite=overwrite) as temporary, Writer(temporary) as writer:
        state_connection = writer.add_connection(STATE_TOPIC, STATE_MSGTYPE, typestore=typestore)
        truth_connection = writer.add_connection(TRUTH_TOPIC, JOINT_STATE_MSGTYPE, typestore=typestore)
        scenario_connection = (writer.add_connection(SCENARIO_TOPIC, JOINT_STATE_MSGTYPE, typestore=typestore)
                               if label_names else None)
        for stamp, topic, index in order:
            if topic == 0:
                connection, msgtype, message = state_connection, STATE_MSGTYPE, next(state_messages)
            elif topic == 1:
                connection, msgtype = scenario_connection, JOINT_STATE_MSGTYPE
                message = _joint_state(types, index, stamp, label_names, label_values[index])
            else:
                connection, msgtype = truth_connection, JOINT_STATE_MSGTYPE
                message = _joint_state(types, index, stamp, [], truth_log.joints[index])
            writer.write(connection, stamp, typestore.serialize_ros1(message, msgtype))
    return Path(path)


# ---------------------------------------------------------------------------------------------
# Reading


def _stamp_nanoseconds(stamp) -> int:
    return int(stamp.sec) * _NANOSECONDS + int(stamp.nanosec)


def _topic_messages(reader: Reader, path: Path, topic: str, msgtype: str, *, required: bool):
    """Deserialized messages of ``topic`` in bag order, with checks of type and definition."""
    connections = [connection for connection in reader.connections if connection.topic == topic]
    if not connections:
        if not required:
            return None
        topics = sorted({connection.topic for connection in reader.connections})
        raise BagFormatError(f"{path}: no topic {topic!r} (topics in the bag: {topics})")
    for connection in connections:
        if connection.msgtype != msgtype:
            raise BagFormatError(f"{path}: topic {topic!r} has type {connection.msgtype!r}, expected {msgtype!r}")
        if msgtype == STATE_MSGTYPE and connection.digest != raven_state_md5():
            raise BagFormatError(
                f"{path}: topic {topic!r} has a raven_state definition with MD5 {connection.digest}, "
                f"expected {raven_state_md5()} (msg/raven_state.msg of the RAVEN-II controller)"
            )
    typestore = raven_typestore()
    messages = []
    try:
        for _, _, raw in reader.messages(connections=connections):
            messages.append(typestore.deserialize_ros1(raw, msgtype))
    except ReaderError as error:
        raise BagFormatError(f"{path}: topic {topic!r}: unreadable data after sample {len(messages) - 1} "
                             f"({error})") from error
    except Exception as error:  # a damaged message makes the deserializer fail in many ways
        raise BagFormatError(f"{path}: topic {topic!r}: sample {len(messages)} cannot be decoded "
                             f"as {msgtype} ({type(error).__name__}: {error})") from error
    if not messages:
        raise BagFormatError(f"{path}: topic {topic!r} holds no messages")
    return messages


def _checked_stamps(messages, stamp_of, path: Path, topic: str) -> np.ndarray:
    stamps = np.array([_stamp_nanoseconds(stamp_of(message)) for message in messages], dtype=np.int64)
    steps = np.diff(stamps)
    if np.any(steps <= 0):
        sample = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise BagFormatError(
            f"{path}: topic {topic!r}: time goes backwards or repeats at sample {sample} "
            f"({stamps[sample - 1] / _NANOSECONDS:.9f} s then {stamps[sample] / _NANOSECONDS:.9f} s)"
        )
    return stamps


def _check_finite(values: np.ndarray, path: Path, topic: str, what: str) -> None:
    finite = np.isfinite(values)
    if not np.all(finite):
        sample = int(np.flatnonzero(~finite.reshape(len(values), -1).all(axis=1))[0])
        raise BagFormatError(f"{path}: topic {topic!r}: {what} is not finite at sample {sample}")


def _state_from_messages(messages, path: Path, topic: str) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Stamps (ns) and SI fields; values are checked against the limits afterwards."""
    stamps = _checked_stamps(messages, lambda message: message.hdr.stamp, path, topic)
    published = {}
    for spec in RAVENSTATE_FIELDS:
        if spec.ros_element == "duration":
            values = np.array([_stamp_nanoseconds(getattr(message, spec.name)) for message in messages],
                              dtype=np.int64)
        else:
            values = np.array([getattr(message, spec.name) for message in messages])
        published[spec.name] = values
    with np.errstate(over="ignore", invalid="ignore"):
        return stamps, si_fields(published)


def _truth_from_messages(messages, path: Path, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and joints (M, 3); values are checked against the limits afterwards."""
    stamps = _checked_stamps(messages, lambda message: message.header.stamp, path, topic)
    for sample, message in enumerate(messages):
        if len(message.position) != 3:
            raise BagFormatError(f"{path}: topic {topic!r}: sample {sample} has {len(message.position)} "
                                 "positions, expected 3 (shoulder rad, elbow rad, insertion m)")
    joints = np.array([message.position for message in messages], dtype=np.float64)
    return stamps / _NANOSECONDS, joints


def _labels_from_messages(messages, state_stamps: np.ndarray, path: Path, topic: str) -> dict[str, np.ndarray]:
    if len(messages) != state_stamps.size:
        raise BagFormatError(f"{path}: topic {topic!r} has {len(messages)} messages, "
                             f"one per robot-state sample ({state_stamps.size}) expected")
    names = list(messages[0].name)
    for sample, message in enumerate(messages):
        if list(message.name) != names or len(message.position) != len(names):
            raise BagFormatError(f"{path}: topic {topic!r}: sample {sample} has labels {list(message.name)}, "
                                 f"sample 0 has {names}")
        if _stamp_nanoseconds(message.header.stamp) != state_stamps[sample]:
            raise BagFormatError(f"{path}: topic {topic!r}: sample {sample} is not stamped like robot-state "
                                 f"sample {sample}")
    values = np.array([message.position for message in messages], dtype=np.float64).reshape(len(messages), -1)
    _check_finite(values, path, topic, "position")
    labels = {}
    for column, name in enumerate(names):
        match = _LABEL_NAME.match(name)
        if match is None:
            raise BagFormatError(f"{path}: topic {topic!r}: label name {name!r} is not '<label>[<dtype>]'")
        try:
            dtype = np.dtype(match["dtype"])
        except TypeError as error:
            raise BagFormatError(f"{path}: topic {topic!r}: label {name!r} names an unknown dtype") from error
        column_values = values[:, column]
        if np.issubdtype(dtype, np.integer) or dtype == np.bool_:
            whole = (column_values == np.round(column_values)) & (np.abs(column_values) <= _MAX_EXACT_LABEL)
            if dtype == np.bool_:
                whole &= (column_values == 0) | (column_values == 1)
            if not np.all(whole):
                raise BagFormatError(f"{path}: topic {topic!r}: label {name!r} at sample "
                                     f"{int(np.flatnonzero(~whole)[0])} is not a {dtype.name} "
                                     f"({column_values[~whole][0]!r})")
        labels[match["key"]] = column_values.astype(dtype)
    return labels


_BAG_MAGIC = b"#ROSBAG V2.0\n"
_OP_MESSAGE, _OP_CHUNK, _OP_CONNECTION = 0x02, 0x05, 0x07


def _record_fields(header: bytes) -> dict[str, bytes] | None:
    """The ``name=value`` fields of a ROS1 bag record header, or None if it is damaged."""
    fields, offset = {}, 0
    while offset + 4 <= len(header):
        (size,) = struct.unpack_from("<I", header, offset)
        entry = header[offset + 4: offset + 4 + size]
        if len(entry) != size or b"=" not in entry:
            return None
        name, value = entry.split(b"=", 1)
        fields[name.decode("latin-1")] = value
        offset += 4 + size
    return fields if offset == len(header) else None


def _records(data: bytes, offset: int = 0):
    """Complete records ``(op, header fields, payload)`` from ``offset`` on, then for a record cut
    short ``(op, fields, partial payload)`` once with ``op`` negated; stops at damage."""
    while offset + 4 <= len(data):
        (header_size,) = struct.unpack_from("<I", data, offset)
        if offset + 8 + header_size > len(data):
            return
        fields = _record_fields(data[offset + 4: offset + 4 + header_size])
        if fields is None or len(fields.get("op", b"")) != 1:
            return
        (payload_size,) = struct.unpack_from("<I", data, offset + 4 + header_size)
        start = offset + 8 + header_size
        payload = data[start: start + payload_size]
        op = fields["op"][0]
        if len(payload) < payload_size:
            yield -op, fields, payload
            return
        yield op, fields, payload
        offset = start + payload_size


def _chunk_content(fields: dict[str, bytes], payload: bytes) -> bytes:
    """The records of a (possibly cut) chunk; an unknown compression reads as empty."""
    compression = fields.get("compression", b"none")
    if compression == b"none":
        return payload
    if compression == b"bz2":
        try:
            return bz2.BZ2Decompressor().decompress(payload)
        except (OSError, ValueError, EOFError):
            return b""
    return b""


def _readable_extent(path: Path) -> str:
    """Where an unindexed (truncated) bag stops: topic, sample and time of the last whole message."""
    data = path.read_bytes()
    if not data.startswith(_BAG_MAGIC):
        return "it does not start as a ROS1 bag (version 2.0)"
    topics: dict[bytes, str] = {}
    counts: dict[str, int] = {}
    last = None
    for op, fields, payload in _records(data, len(_BAG_MAGIC)):
        if abs(op) != _OP_CHUNK:
            continue
        for inner_op, inner_fields, _ in _records(_chunk_content(fields, payload)):
            if inner_op == _OP_CONNECTION and "conn" in inner_fields:
                topics[inner_fields["conn"]] = inner_fields.get("topic", b"?").decode("latin-1", "replace")
            elif inner_op == _OP_MESSAGE and "conn" in inner_fields and len(inner_fields.get("time", b"")) == 8:
                topic = topics.get(inner_fields["conn"], "?")
                counts[topic] = counts.get(topic, 0) + 1
                seconds, nanoseconds = struct.unpack("<II", inner_fields["time"])
                last = (topic, counts[topic] - 1, seconds + nanoseconds / _NANOSECONDS)
    if last is None:
        return "no whole message is readable"
    whole = ", ".join(f"{topic!r} {count}" for topic, count in sorted(counts.items()))
    return (f"it breaks off after sample {last[1]} of topic {last[0]!r} (t = {last[2]:.6f} s); "
            f"whole messages per topic: {whole}")


def read_bag(path: str | os.PathLike, arm: str = "left", *, state_topic: str = STATE_TOPIC,
             truth_topic: str = TRUTH_TOPIC, scenario_topic: str = SCENARIO_TOPIC,
             on_invalid: str = "flag", limits: RecordingLimits | None = None
             ) -> tuple[RavenStateLog, GroundTruthLog]:
    """Read a RAVEN-II recording (this project's or a real robot's) into SI logs.

    Parameters
    ----------
    path : path-like
        The ``.bag`` file.
    arm : {"left", "right"}
        The arm whose state is the calibration input (the bag holds both).
    state_topic, truth_topic, scenario_topic : str
        Topic names, e.g. ``"/ravenstate_100hz"`` for a bag recorded from a throttled topic.
        The scenario topic is optional in the bag.
    on_invalid : {"flag", "drop", "raise"}
        What to do with samples holding values the robot cannot produce (outside the limits of
        ``simulation.recordings.limits``, non-finite included): keep them with ``valid`` False
        (default), remove them, or raise. "flag" and "drop" warn once
        (``ImpossibleValueWarning``) naming the bag, the counts per topic and the first value.
    limits : RecordingLimits, optional
        Default: ``RecordingLimits.for_arm(arm)``.

    Returns
    -------
    state_log : RavenStateLog
        Time = header stamps, s; labels from the scenario topic, or none; ``valid`` per sample.
    truth_log : GroundTruthLog
        ``valid`` per sample.

    Raises
    ------
    FileNotFoundError
        No such file.
    BagFormatError
        The bag is truncated or damaged, a topic is missing or of another type, time does not
        increase, or the labels do not match the robot-state samples; the message names the
        file, the topic and the sample (for a bag cut short, the last whole message of the
        readable part: its topic, sample index and time).
    ImpossibleValueError
        ``on_invalid="raise"`` and a sample holds an impossible value (naming the file, the
        topic, the column, the sample, its time, value and limit).
    """
    check_arm(arm)
    check_on_invalid(on_invalid)
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no bag file {path}")
    try:
        with Reader(path) as reader:
            state_messages = _topic_messages(reader, path, state_topic, STATE_MSGTYPE, required=True)
            truth_messages = _topic_messages(reader, path, truth_topic, JOINT_STATE_MSGTYPE, required=True)
            scenario_messages = _topic_messages(reader, path, scenario_topic, JOINT_STATE_MSGTYPE, required=False)
    except (BagFormatError, PermissionError, IsADirectoryError):
        raise
    except Exception as error:  # a damaged index makes rosbags fail in many ways, ReaderError or not
        try:
            extent = _readable_extent(path)
        except (OSError, MemoryError, ValueError, struct.error):
            extent = "its content cannot be scanned"
        detail = str(error) if isinstance(error, ReaderError) else f"{type(error).__name__}: {error}"
        raise BagFormatError(f"{path}: not a readable ROS1 bag ({detail}); {extent}. A bag cut short by a "
                             "crash may be repaired with 'rosbag reindex'") from error
    stamps, fields = _state_from_messages(state_messages, path, state_topic)
    labels = {} if scenario_messages is None else _labels_from_messages(scenario_messages, stamps, path, scenario_topic)
    truth_time, joints = _truth_from_messages(truth_messages, path, truth_topic)
    state_time = stamps / _NANOSECONDS

    state_found = find_invalid(state_time, state_columns(fields, arm), arm, limits)
    truth_columns = {f"truth.{joint}": joints[:, j] for j, joint in enumerate(GROUND_TRUTH_JOINTS)}
    truth_found = find_invalid(truth_time, truth_columns, arm, limits)
    resolve_invalid(path, [(f"topic {state_topic!r}", state_found), (f"topic {truth_topic!r}", truth_found)],
                    on_invalid)
    state_valid, truth_valid = ~state_found.mask, ~truth_found.mask
    if on_invalid == "drop":
        fields = {name: values[state_valid] for name, values in fields.items()}
        labels = {name: values[state_valid] for name, values in labels.items()}
        state_time, truth_time, joints = state_time[state_valid], truth_time[truth_valid], joints[truth_valid]
        state_valid, truth_valid = state_valid[state_valid], truth_valid[truth_valid]
    try:
        state_log = RavenStateLog(state_time, fields, labels, arm, state_valid)
    except ValueError as error:
        raise BagFormatError(f"{path}: topic {state_topic!r}: {error}") from error
    try:
        truth_log = GroundTruthLog(truth_time, joints, truth_valid)
    except ValueError as error:
        raise BagFormatError(f"{path}: topic {truth_topic!r}: {error}") from error
    return state_log, truth_log


def read_bag_folder(folder: str | os.PathLike, arm: str = "left", *, pattern: str = "*.bag",
                    **topics: str) -> list[tuple[Path, RavenStateLog, GroundTruthLog]]:
    """Read every bag of a folder, in file-name order.

    Parameters
    ----------
    folder : path-like
    arm : {"left", "right"}
    pattern : str
        Glob of the bag files in ``folder``.
    **topics
        ``state_topic``, ``truth_topic``, ``scenario_topic``, ``on_invalid``, ``limits`` as in
        ``read_bag``.

    Returns
    -------
    list of (Path, RavenStateLog, GroundTruthLog)
        One entry per bag. Recordings usually restart their clocks, so they are returned apart;
        ``CalibrationDataset.concat`` joins their synchronized datasets.

    Raises
    ------
    FileNotFoundError
        The folder does not exist or holds no matching bag.
    BagFormatError
        From the first bag that cannot be read (naming it).
    """
    folder = Path(folder)
    check_on_invalid(topics.get("on_invalid", "flag"))
    if not folder.is_dir():
        raise FileNotFoundError(f"no folder {folder}")
    paths = sorted(folder.glob(pattern))
    if not paths:
        raise FileNotFoundError(f"no bag matching {pattern!r} in {folder}")
    return [(bag, *read_bag(bag, arm, **topics)) for bag in paths]
