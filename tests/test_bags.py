"""ROS1 bag round trip, published units, and clear errors on damaged bags."""

import hashlib

import numpy as np
import pytest
from rosbags.rosbag1 import Reader, Writer
from scipy.spatial.transform import Rotation

from simulation.recordings.dataset import convert_bag
from simulation.recordings.bags import (
    JOINT_STATE_MSGTYPE,
    SCENARIO_TOPIC,
    STATE_MSGTYPE,
    STATE_TOPIC,
    TRUTH_TOPIC,
    BagFormatError,
    raven_typestore,
    read_bag,
    read_bag_folder,
    write_bag,
)
from simulation.recordings.ravenstate import RAVENSTATE_FIELDS, GroundTruthLog, RavenStateLog

STATE_RATE, TRUTH_RATE = 30.0, 100.0


def plausible_logs(seed=7, n=300, start=12.5):
    """Robot state at 30 Hz and ground truth at 100 Hz, every field varying, SI units."""
    rng = np.random.default_rng(seed)
    time = start + np.arange(n) / STATE_RATE + rng.uniform(0, 1e-3, n)

    def rotations():
        return np.hstack([Rotation.random(n, random_state=seed + k).as_matrix().reshape(n, 9) for k in (1, 2)])

    joints = rng.uniform(-1.5, 1.5, (n, 16))
    joints[:, [2, 10]] = rng.uniform(0.33, 0.42, (n, 2))  # insertion, m
    fields = {
        "runlevel": rng.integers(0, 4, n),
        "sublevel": rng.integers(0, 3, n),
        "last_seq": np.cumsum(rng.integers(1, 40, n)),
        "type": np.tile([49, 22], (n, 1)),
        "pos": rng.uniform(-0.15, 0.15, (n, 6)),
        "ori": rotations(),
        "ori_d": rotations(),
        "pos_d": rng.uniform(-0.15, 0.15, (n, 6)),
        "dt": 1e-3 + rng.uniform(-2e-5, 2e-5, n),
        "encVals": rng.integers(-2_000_000, 2_000_000, (n, 16)),
        "dac_val": rng.integers(-5000, 5000, (n, 16)),
        "tau": rng.normal(0.0, 0.05, (n, 16)),
        "mpos": rng.uniform(-200.0, 200.0, (n, 16)),
        "jpos": joints,
        "mvel": rng.normal(0.0, 20.0, (n, 16)),
        "jvel": rng.normal(0.0, 0.2, (n, 16)),
        "mpos_d": rng.uniform(-200.0, 200.0, (n, 16)),
        "jpos_d": joints + rng.normal(0.0, 1e-3, (n, 16)),
        "grasp_d": rng.integers(-1000, 1000, (n, 2)) / 1000.0,
        "encoffsets": rng.integers(-50_000, 50_000, (n, 16)).astype(float),
        "jac_vel": rng.normal(0.0, 0.05, (n, 12)),
        "jac_f": rng.normal(0.0, 2.0, (n, 12)),
    }
    labels = {
        "payload_kg": np.repeat([0.0, 0.5, 1.0], n // 3 + 1)[:n],
        "operating_hours": np.linspace(0.0, 6.0, n),
        "homing_count": np.repeat([1, 2], n // 2 + 1)[:n].astype(np.int64),
        "segment": rng.integers(0, 5, n),
    }
    truth_time = np.arange(start - 0.2, time[-1] + 0.2, 1.0 / TRUTH_RATE)
    truth = np.column_stack([np.sin(truth_time), np.cos(truth_time), 0.35 + 0.05 * np.sin(truth_time)])
    return RavenStateLog(time, fields, labels, "left"), GroundTruthLog(truth_time, truth)


@pytest.fixture(scope="module")
def logs():
    return plausible_logs()


@pytest.fixture(scope="module")
def good_bag(logs, tmp_path_factory):
    return write_bag(tmp_path_factory.mktemp("bags") / "recording.bag", *logs)


def raw_messages(path):
    typestore = raven_typestore()
    with Reader(path) as reader:
        return [(connection.topic, timestamp, typestore.deserialize_ros1(raw, connection.msgtype))
                for connection, timestamp, raw in reader.messages()]


def rewrite(source, target, edit=lambda topic, index, message: message, drop_topics=()):
    """Copy a bag, letting ``edit`` change the index-th message of a topic."""
    typestore = raven_typestore()
    counters = {}
    with Reader(source) as reader, Writer(target) as writer:
        connections = {}
        for connection in reader.connections:
            if connection.topic not in drop_topics:
                connections[connection.topic] = writer.add_connection(
                    connection.topic, connection.msgtype, typestore=typestore)
        for connection, timestamp, raw in reader.messages():
            if connection.topic in drop_topics:
                continue
            index = counters.get(connection.topic, 0)
            counters[connection.topic] = index + 1
            message = edit(connection.topic, index, typestore.deserialize_ros1(raw, connection.msgtype))
            writer.write(connections[connection.topic], timestamp,
                         typestore.serialize_ros1(message, connection.msgtype))
    return target


def test_every_field_round_trips_within_published_precision(logs, good_bag):
    state, truth = logs
    state_back, truth_back = read_bag(good_bag)
    np.testing.assert_allclose(state_back.time, state.time, rtol=0, atol=0.6e-9)
    for spec in RAVENSTATE_FIELDS:
        written, read = state.fields[spec.name], state_back.fields[spec.name]
        assert read.shape == written.shape, spec.name
        if spec.is_count:
            np.testing.assert_array_equal(read, written, err_msg=spec.name)
        elif spec.name in ("pos", "pos_d"):
            np.testing.assert_allclose(read, written, rtol=0, atol=0.5e-6, err_msg=spec.name)
        elif spec.name == "dt":
            np.testing.assert_allclose(read, written, rtol=0, atol=0.6e-9)
        else:
            np.testing.assert_allclose(read, written, rtol=2.0**-23, atol=0, err_msg=spec.name)
        assert not np.array_equal(written, written[:1].repeat(len(written), axis=0)) or spec.name == "type"
    np.testing.assert_allclose(truth_back.time, truth.time, rtol=0, atol=0.6e-9)
    np.testing.assert_array_equal(truth_back.joints, truth.joints)


def test_labels_round_trip_exactly_with_their_dtypes(logs, good_bag):
    state_back, _ = read_bag(good_bag)
    assert set(state_back.labels) == set(logs[0].labels)
    for name, values in logs[0].labels.items():
        assert state_back.labels[name].dtype == values.dtype, name
        np.testing.assert_array_equal(state_back.labels[name], values)


def test_bag_holds_robot_units_topics_and_definition(logs, good_bag):
    state, truth = logs
    messages = raw_messages(good_bag)
    states = [m for topic, _, m in messages if topic == STATE_TOPIC]
    truths = [m for topic, _, m in messages if topic == TRUTH_TOPIC]
    scenarios = [m for topic, _, m in messages if topic == SCENARIO_TOPIC]
    assert len(states) == len(scenarios) == len(state) and len(truths) == len(truth)
    k = 17
    np.testing.assert_array_equal(states[k].jpos, np.float32(np.degrees(state.fields["jpos"][k])))
    np.testing.assert_array_equal(states[k].mvel, np.float32(np.degrees(state.fields["mvel"][k])))
    np.testing.assert_array_equal(states[k].pos, np.rint(state.fields["pos"][k] * 1e6).astype(np.int32))
    np.testing.assert_array_equal(states[k].tau, np.float32(state.fields["tau"][k]))
    assert states[k].hdr.stamp.sec + states[k].hdr.stamp.nanosec * 1e-9 == pytest.approx(state.time[k], abs=1e-9)
    np.testing.assert_array_equal(truths[k].position, truth.joints[k])
    assert list(truths[k].name) == []
    assert "payload_kg[float64]" in scenarios[k].name and "segment[int64]" in scenarios[k].name
    bag_times = [timestamp for _, timestamp, _ in messages]
    assert bag_times == sorted(bag_times)
    # genmsg's MD5 rule: the text of the fields, with Header replaced by its own MD5.
    md5_text = "\n".join(["2176decaecbce78abc3b96ef049fabed hdr"]
                         + [f"{spec.ros_type} {spec.name}" for spec in RAVENSTATE_FIELDS])
    with Reader(good_bag) as reader:
        connection = next(c for c in reader.connections if c.topic == STATE_TOPIC)
        assert connection.msgtype == STATE_MSGTYPE
        assert connection.digest == hashlib.md5(md5_text.encode()).hexdigest()
        assert next(c for c in reader.connections if c.topic == TRUTH_TOPIC).msgtype == JOINT_STATE_MSGTYPE


def test_same_input_gives_byte_identical_bags(logs, tmp_path):
    first = write_bag(tmp_path / "a.bag", *logs)
    second = write_bag(tmp_path / "b.bag", *logs)
    assert first.read_bytes() == second.read_bytes()


def test_log_without_labels_writes_no_scenario_topic(logs, tmp_path):
    state, truth = logs
    bare = RavenStateLog(state.time, state.fields, {}, "left")
    path = write_bag(tmp_path / "bare.bag", bare, truth)
    assert SCENARIO_TOPIC not in {topic for topic, _, _ in raw_messages(path)}
    state_back, _ = read_bag(path, arm="right")
    assert dict(state_back.labels) == {} and state_back.arm == "right"


def test_existing_bag_is_not_overwritten_unless_asked(logs, good_bag):
    before = good_bag.read_bytes()
    with pytest.raises(FileExistsError):
        write_bag(good_bag, *logs)
    write_bag(good_bag, *logs, overwrite=True)
    assert good_bag.read_bytes() == before


def test_failed_write_leaves_no_file(logs, tmp_path):
    state, truth = logs
    fields = dict(state.fields)
    fields["pos"] = state.fields["pos"].copy()
    fields["pos"][40, 2] = 3000.0  # 3e9 micrometres do not fit int32
    with pytest.raises(ValueError, match=r"'pos' at sample 40 does not fit int32"):
        write_bag(tmp_path / "bad.bag", RavenStateLog(state.time, fields, state.labels), truth)
    assert list(tmp_path.iterdir()) == []


def test_truncated_bag_is_a_clear_error_and_converts_to_nothing(good_bag, tmp_path):
    truncated = tmp_path / "truncated.bag"
    data = good_bag.read_bytes()
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(BagFormatError, match=r"truncated\.bag: not a readable ROS1 bag"):
        read_bag(truncated)
    out = tmp_path / "dataset.parquet"
    with pytest.raises(BagFormatError):
        convert_bag(truncated, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["truncated.bag"]


def test_missing_topic_is_named_with_the_topics_present(good_bag, tmp_path):
    path = rewrite(good_bag, tmp_path / "no_truth.bag", drop_topics=(TRUTH_TOPIC,))
    with pytest.raises(BagFormatError, match=r"no_truth\.bag: no topic '/ext_jpos' \(topics in the bag: "
                                             r"\['/ravenstate', '/scenario'\]\)"):
        read_bag(path)


def test_time_going_backwards_names_topic_and_sample(good_bag, tmp_path):
    def swap_stamps(topic, index, message):
        if topic == STATE_TOPIC and index == 11:
            message.hdr.stamp.sec -= 1
        return message

    path = rewrite(good_bag, tmp_path / "backwards.bag", swap_stamps)
    with pytest.raises(BagFormatError, match=r"backwards\.bag: topic '/ravenstate': time goes backwards "
                                             r"or repeats at sample 11"):
        read_bag(path)


def test_labels_out_of_step_with_the_state_are_refused(good_bag, tmp_path):
    path = rewrite(good_bag, tmp_path / "labels.bag",
                   lambda topic, index, message: (setattr(message.header.stamp, "nanosec", 0) or message)
                   if topic == SCENARIO_TOPIC and index == 5 else message)
    with pytest.raises(BagFormatError, match=r"topic '/scenario': sample 5 is not stamped like robot-state"):
        read_bag(path)


def test_folder_reads_every_bag_in_name_order(tmp_path):
    for name, seed in (("b.bag", 2), ("a.bag", 1)):
        write_bag(tmp_path / name, *plausible_logs(seed, n=40))
    recordings = read_bag_folder(tmp_path)
    assert [path.name for path, _, _ in recordings] == ["a.bag", "b.bag"]
    np.testing.assert_allclose(recordings[0][1].fields["tau"], plausible_logs(1, n=40)[0].fields["tau"],
                               rtol=2.0**-23)
    with pytest.raises(FileNotFoundError, match="no bag matching"):
        read_bag_folder(tmp_path, pattern="*.bag2")
