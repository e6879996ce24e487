"""The ravenstate field specification and the log containers' validation."""

import numpy as np
import pytest
from rosbags.typesys import get_types_from_msg

from simulation.recordings.bags import RAVEN_STATE_MSG, STATE_MSGTYPE
from simulation.recordings.ravenstate import (
    ARM_SLOTS,
    DOF_NAMES,
    FIELD_SPECS,
    RAVENSTATE_FIELDS,
    GroundTruthLog,
    RavenStateLog,
)


def zero_fields(n):
    return {spec.name: np.zeros((n, spec.width) if spec.is_array else n) for spec in RAVENSTATE_FIELDS}


def ramp_log(n=20, start=0.0, labels=None, arm="left"):
    """A valid log whose every entry differs (sample index + entry offset)."""
    fields = {}
    for spec in RAVENSTATE_FIELDS:
        base = np.arange(n, dtype=float)
        fields[spec.name] = base[:, None] + np.arange(spec.width) * 100 if spec.is_array else base
    return RavenStateLog(start + 0.01 * np.arange(n), fields, labels or {}, arm)


def test_spec_matches_the_robot_message_definition_in_order():
    parsed = get_types_from_msg(RAVEN_STATE_MSG, STATE_MSGTYPE)[STATE_MSGTYPE][1]
    assert parsed[0][0] == "hdr"
    message_fields = parsed[1:]
    assert [name for name, _ in message_fields] == [spec.name for spec in RAVENSTATE_FIELDS]
    for (name, (kind, detail)), spec in zip(message_fields, RAVENSTATE_FIELDS):
        if spec.is_array:
            (_, (element, _)), width = detail
            assert (element, width) == (spec.ros_element, spec.width), name
        elif spec.ros_element == "duration":
            assert detail == "builtin_interfaces/msg/Duration"
        else:
            assert detail[0] == spec.ros_element and spec.width == 1, name


def test_spec_widths_split_evenly_between_the_two_arms():
    for spec in RAVENSTATE_FIELDS:
        assert len(spec.entry_names) == len(spec.si_units) == max(spec.per_arm, 1)
        if spec.per_arm:
            assert 2 * spec.per_arm == spec.width, spec.name
    assert FIELD_SPECS["jpos"].arm_slice("right") == ARM_SLOTS["right"]
    assert FIELD_SPECS["pos"].arm_slice("right") == slice(3, 6)
    assert FIELD_SPECS["ori_d"].arm_slice("right") == slice(9, 18)
    assert FIELD_SPECS["runlevel"].arm_slice("right") == slice(0, 1)


def test_published_scales_follow_publish_ravenstate_ros():
    degrees = {"mpos", "jpos", "mvel", "jvel", "mpos_d", "jpos_d"}
    for spec in RAVENSTATE_FIELDS:
        expected = 180.0 / np.pi if spec.name in degrees else 1.0e6 if spec.name in ("pos", "pos_d") else 1.0
        assert spec.published_scale == pytest.approx(expected), spec.name
        assert spec.source.startswith("src/raven/local_io.cpp:"), spec.name
    jpos = FIELD_SPECS["jpos"]
    assert jpos.si_units[DOF_NAMES.index("z_ins")] == "m"
    assert jpos.si_units[DOF_NAMES.index("shoulder")] == "rad"
    assert {spec.name for spec in RAVENSTATE_FIELDS if spec.is_count} == {
        "runlevel", "sublevel", "last_seq", "type", "encVals", "dac_val"}


def test_log_stores_counts_as_integers_and_the_rest_as_read_only_floats():
    log = ramp_log()
    assert log.fields["encVals"].dtype == np.int64
    assert log.fields["pos"].dtype == np.float64
    with pytest.raises(ValueError):
        log.fields["jpos"][0, 0] = 1.0
    assert len(log) == 20


def test_missing_and_unknown_fields_are_named():
    fields = zero_fields(5)
    del fields["tau"]
    fields["torque"] = np.zeros((5, 16))
    with pytest.raises(ValueError, match=r"missing \['tau'\].*unknown \['torque'\]"):
        RavenStateLog(np.arange(5.0), fields)


def test_wrong_width_is_named():
    fields = zero_fields(5)
    fields["jac_vel"] = np.zeros((5, 6))
    with pytest.raises(ValueError, match=r"'jac_vel' has shape \(5, 6\), expected \(5, 12\)"):
        RavenStateLog(np.arange(5.0), fields)


def test_nan_names_field_and_first_bad_sample():
    fields = zero_fields(9)
    fields["mvel"][6, 11] = np.nan
    fields["mvel"][8, 0] = np.inf
    with pytest.raises(ValueError, match=r"'mvel' is not finite at sample 6"):
        RavenStateLog(np.arange(9.0), fields)


def test_fractional_encoder_count_is_refused():
    fields = zero_fields(4)
    fields["encVals"][2, 3] = 0.5
    with pytest.raises(ValueError, match=r"'encVals' holds integer counts but is not integral at sample 2"):
        RavenStateLog(np.arange(4.0), fields)


def test_time_must_strictly_increase():
    with pytest.raises(ValueError, match=r"not strictly increasing at sample 3"):
        RavenStateLog(np.array([0.0, 0.1, 0.2, 0.2, 0.3]), zero_fields(5))
    with pytest.raises(ValueError, match=r"not strictly increasing at sample 2"):
        GroundTruthLog(np.array([0.0, 0.1, 0.05]), np.zeros((3, 3)))


def test_labels_must_match_the_samples():
    with pytest.raises(ValueError, match=r"label 'payload_kg' has shape \(3,\)"):
        RavenStateLog(np.arange(5.0), zero_fields(5), {"payload_kg": np.zeros(3)})
    with pytest.raises(ValueError, match=r"label 'segment' is not finite at sample 1"):
        RavenStateLog(np.arange(3.0), zero_fields(3), {"segment": np.array([0.0, np.nan, 1.0])})


def test_unknown_arm_is_refused():
    with pytest.raises(ValueError, match="arm must be one of"):
        ramp_log(arm="gold")


def test_arm_values_pick_the_arm_block():
    log = ramp_log()
    np.testing.assert_array_equal(log.arm_values("jpos", "right"), log.fields["jpos"][:, 8:16])
    np.testing.assert_array_equal(log.arm_values("ori", "left"), log.fields["ori"][:, 0:9])
    np.testing.assert_array_equal(log.arm_values("type", "right"), log.fields["type"][:, 1])
    np.testing.assert_array_equal(log.arm_values("dt"), log.fields["dt"])


def test_select_by_mask_slice_and_indices_agree():
    log = ramp_log(labels={"segment": np.arange(20) % 3})
    mask = np.zeros(20, dtype=bool)
    mask[5:9] = True
    by_mask, by_slice, by_index = log.select(mask), log.select(slice(5, 9)), log.select(np.arange(5, 9))
    for part in (by_mask, by_slice, by_index):
        np.testing.assert_array_equal(part.time, log.time[5:9])
        np.testing.assert_array_equal(part.fields["tau"], log.fields["tau"][5:9])
        np.testing.assert_array_equal(part.labels["segment"], [2, 0, 1, 2])
    with pytest.raises(ValueError, match="boolean mask has shape"):
        log.select(mask[:-1])


def test_concatenate_joins_in_order_and_refuses_overlap():
    first, second = ramp_log(10, 0.0), ramp_log(10, 1.0)
    joined = RavenStateLog.concatenate([first, second])
    assert len(joined) == 20
    np.testing.assert_array_equal(joined.fields["encVals"][10:], second.fields["encVals"])
    with pytest.raises(ValueError, match="log 1 starts at 0.0 s, not after the end of log 0"):
        RavenStateLog.concatenate([first, ramp_log(10, 0.0)])
    with pytest.raises(ValueError, match="labels"):
        RavenStateLog.concatenate([first, ramp_log(10, 1.0, labels={"segment": np.zeros(10)})])


def test_ground_truth_shape_and_values_are_checked():
    with pytest.raises(ValueError, match=r"joints has shape \(4, 2\), expected \(4, 3\)"):
        GroundTruthLog(np.arange(4.0), np.zeros((4, 2)))
    joints = np.zeros((4, 3))
    joints[3, 2] = np.nan
    with pytest.raises(ValueError, match="not finite at sample 3"):
        GroundTruthLog(np.arange(4.0), joints)
    truth = GroundTruthLog.concatenate([GroundTruthLog(np.arange(4.0), np.ones((4, 3))),
                                        GroundTruthLog(np.arange(4.0) + 4, np.zeros((4, 3)))])
    assert len(truth) == 8 and truth.select(slice(2, 6)).joints.sum() == 6.0
