"""Recordings checked against the arm's physical limits: flagged, dropped or refused."""

import contextlib
import re
import warnings

import numpy as np
import pytest

from kinematics import RavenII
from kinematics.joint_limits import CONTROLLER_JOINT_LIMITS
from simulation.engine.robot import VirtualRaven
from simulation.engine.scenarios import record_random_test
from simulation.model.constants import RavenConstants
from simulation.recordings import (
    VALID_COLUMN,
    BagFormatError,
    ImpossibleValueError,
    ImpossibleValueWarning,
    RecordingLimits,
    find_invalid,
    read_bag,
    write_bag,
)
from simulation.recordings.dataset import CalibrationDataset, synchronize
from simulation.recordings.limits import (
    RE30_NO_LOAD_SPEED,
    RE40_NO_LOAD_SPEED,
    WORKSPACE_RADIUS,
    state_columns,
)
from simulation.recordings.ravenstate import GROUND_TRUTH_JOINTS, GroundTruthLog, RavenStateLog
from simulation.recordings.recording import Recording

LIMITS = RecordingLimits.for_arm("left")


@pytest.fixture(scope="module")
def logs():
    """Homing from power-on, then 3 s of the random test motion (30 Hz state, 100 Hz truth)."""
    robot = VirtualRaven(seed=11)
    homing = robot.home()
    robot.start_operating_clock()
    test = record_random_test(robot, duration=3.0, seed=4)
    return Recording.concatenate([homing, test]).to_logs(robot.robot)


@pytest.fixture(scope="module")
def dataset(logs):
    return synchronize(*logs)


def truth_columns(truth):
    return {f"truth.{joint}": truth.joints[:, j] for j, joint in enumerate(GROUND_TRUTH_JOINTS)}


@contextlib.contextmanager
def no_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error", ImpossibleValueWarning)
        yield


# ---------------------------------------------------------------------------------------------
# The limits themselves


def test_limits_follow_from_the_hardware_constants():
    c = RavenConstants(arm="left")
    # the datasheets' no-load speeds, 10 % margin, per motor
    np.testing.assert_allclose(LIMITS.motor_speed[[0, 1, 2]], 1.1 * 7580 * 2 * np.pi / 60)
    np.testing.assert_allclose(LIMITS.motor_speed[[4, 5, 6, 7]], 1.1 * 8170 * 2 * np.pi / 60)
    assert RE40_NO_LOAD_SPEED < RE30_NO_LOAD_SPEED
    np.testing.assert_array_equal(LIMITS.dac_max[[0, 1, 2, 4, 5, 6, 7]], c.dac_max)
    # stall torque = torque constant x stall current; at the gearbox output as tau is published
    np.testing.assert_allclose(LIMITS.torque_max[0], 2.50 * c.gearbox[0])
    # the homed joint range holds the controller's limits and the hard stops
    for slot, joint in ((0, 0), (1, 1), (2, 2), (4, 3), (5, 4)):
        assert LIMITS.joint_lower[slot] < CONTROLLER_JOINT_LIMITS.lower[joint]
        assert LIMITS.joint_upper[slot] > CONTROLLER_JOINT_LIMITS.upper[joint]
    assert np.all(LIMITS.joint_upper[:3] > c.hard_stop)
    # motor range = joint range through the inverse coupling: corners of the joint box inside
    corners = np.array(np.meshgrid(*[(LIMITS.joint_lower[j], LIMITS.joint_upper[j]) for j in range(3)]))
    corners = corners.reshape(3, -1).T
    motors = (np.linalg.solve(c.nominal_coupling(), corners.T).T) * c.transmission_ratio[:3]
    assert np.all(motors >= LIMITS.motor_lower[:3] - 1e-9) and np.all(motors <= LIMITS.motor_upper[:3] + 1e-9)


def test_workspace_radius_bounds_the_forward_kinematics_over_the_joint_box():
    rng = np.random.default_rng(0)
    lower = np.r_[LIMITS.joint_lower[[0, 1, 2, 4, 5]], -np.pi / 2]
    upper = np.r_[LIMITS.joint_upper[[0, 1, 2, 4, 5]], np.pi / 2]
    q = rng.uniform(lower, upper, (2000, 6))
    position = RavenII(arm="left").forward_kinematics(q, check_limits=False)[:, :3, 3]
    assert np.abs(position).max() < WORKSPACE_RADIUS


def test_clean_simulated_recording_has_no_flag_through_every_reader(logs, dataset, tmp_path):
    state, truth = logs
    assert set(state.fields["runlevel"]) == {1, 3}  # homing and operating samples both checked
    assert find_invalid(state.time, state_columns(state.fields, "left"), "left").count == 0
    assert find_invalid(truth.time, truth_columns(truth), "left").count == 0
    with no_warning():
        bag = write_bag(tmp_path / "clean.bag", state, truth)
        state_back, truth_back = read_bag(bag)
        assert state_back.valid.all() and truth_back.valid.all()
        for reader in (lambda: CalibrationDataset.read_parquet(dataset.to_parquet(tmp_path / "clean.parquet")),
                       lambda: CalibrationDataset.read_csv(dataset.to_csv(tmp_path / "clean.csv"))):
            back = reader()
            assert back.n_invalid == 0 and back.valid_mask().all() and len(back) == len(dataset)


# ---------------------------------------------------------------------------------------------
# Tables: each kind of impossible value, in each mode


def _edit(dataset, column, row, value):
    table = dataset.table.copy()
    table.loc[row, column] = value(table.loc[row, column]) if callable(value) else value
    return table


def _operating_row(dataset, offset=10):
    return int(np.flatnonzero(dataset.table["runlevel"].to_numpy() == 3)[offset])


KINDS = [
    # column, edit, expected limit text in the message
    ("mpos.shoulder", lambda v: v + 60.0, r"\|jump\| <= .* rad/s x elapsed time"),
    ("encVals.elbow", lambda v: v + 2**24, r"\|jump\| <= .* count/s"),
    ("jpos.z_ins", lambda v: v + 0.004, r"cable coupling of mpos"),
    ("mpos.wrist", lambda v: v + 0.5, r"moves with encVals\.wrist within 2 counts"),
    ("tau.elbow", 1.0e6, r"\[-30\.625, 30\.625\] N m \(stall torque\)"),
    ("dac_val.wrist", 4000, r"\[-3000, 3000\] count \(DAC clip\)"),
    ("mvel.grasp1", 2000.0, r"rad/s \(no-load speed\)"),
    ("tau.tool_rot", np.nan, r"finite"),
    ("truth.elbow", 3.5, r"rad \(joint range\)"),
    ("pos.y", 4.0, r"m \(workspace\)"),
    ("ori.R01", 1.2, r"rotation matrix entry"),
    ("type", 22, r"serial in \(49,\) \(left arm\)"),
]


@pytest.mark.parametrize("column, value, limit", KINDS, ids=[kind[0] for kind in KINDS])
def test_each_impossible_value_in_a_table_is_flagged_dropped_or_refused(dataset, tmp_path, column, value, limit):
    row = _operating_row(dataset)
    table = _edit(dataset, column, row, value)
    # the dataset refuses a non-finite value in a row marked valid, so the file marks it
    path = CalibrationDataset(table.assign(**{VALID_COLUMN: table.notna().all(axis=1)}), "left").to_parquet(
        tmp_path / "edited.parquet")
    time = dataset.time[row]
    expected = (rf"edited\.parquet: impossible values in 1 of {len(dataset)} samples{{action}}; first: "
                rf"column '{re.escape(column)}', sample {row}, t = {time:.6f} s, value .*, limit .*{limit}")

    with pytest.warns(ImpossibleValueWarning, match=expected.format(action=r", flagged \(valid = False\)")) as caught:
        flagged = CalibrationDataset.read_parquet(path)
    assert len([w for w in caught if issubclass(w.category, ImpossibleValueWarning)]) == 1
    assert np.flatnonzero(~flagged.valid_mask()).tolist() == [row] and flagged.n_invalid == 1
    assert len(flagged) == len(dataset)

    with pytest.warns(ImpossibleValueWarning, match=expected.format(action=", dropped")):
        dropped = CalibrationDataset.read_parquet(path, on_invalid="drop")
    assert len(dropped) == len(dataset) - 1 and dropped.valid_mask().all()
    assert row not in np.flatnonzero(np.isin(dataset.time, dropped.time))

    with pytest.raises(ImpossibleValueError, match=expected.format(action="")):
        CalibrationDataset.read_parquet(path, on_invalid="raise")


def test_a_glitch_is_flagged_and_not_its_neighbours(dataset):
    row = _operating_row(dataset, 20)
    table = dataset.table.copy()
    for column in ("mpos.z_ins", "encVals.z_ins"):
        # +20 rad on the insertion motor and its encoder alike: within the motor's range and
        # reachable in one 30 Hz tick, but jpos was computed from the true motor position
        step = 20.0 if column == "mpos.z_ins" else round(20.0 * LIMITS.counts_per_rad)
        table.loc[row:row + 3, column] += step
    with pytest.warns(ImpossibleValueWarning, match=r"column 'jpos\.z_ins', sample %d" % row):
        checked = CalibrationDataset(table, "left").check()
    assert np.flatnonzero(~checked.valid_mask()).tolist() == list(range(row, row + 4))


def test_time_in_other_units_or_faster_than_the_servo_loop_is_flagged(dataset):
    table = dataset.table.copy()
    table["time"] = table["time"] / 1000.0  # kiloseconds
    with pytest.warns(ImpossibleValueWarning, match=r"column 'time', sample 1, .*half a servo tick"):
        checked = CalibrationDataset(table, "left").check()
    assert checked.n_invalid == len(dataset) - 1
    table = dataset.table.copy()
    table["time"] = table["time"] * 1000.0  # milliseconds
    with pytest.warns(ImpossibleValueWarning, match=r"time not in seconds"):
        assert CalibrationDataset(table, "left").check().n_invalid == len(dataset)


def test_a_log_of_the_other_arm_is_flagged_throughout(dataset):
    with pytest.warns(ImpossibleValueWarning, match=r"column 'type', sample 0, .*value 49, limit serial in \(22,\)"):
        checked = CalibrationDataset(dataset.table, "right").check()
    assert checked.n_invalid == len(dataset)


def test_flags_survive_files_and_select(dataset, tmp_path):
    row = _operating_row(dataset)
    table = _edit(dataset, "tau.shoulder", row, 100.0)
    with pytest.warns(ImpossibleValueWarning):
        flagged = CalibrationDataset(table, "left").check()
    with pytest.warns(ImpossibleValueWarning, match="1 of"):
        back = CalibrationDataset.read_csv(flagged.to_csv(tmp_path / "flagged.csv"))
    assert back.valid_mask().tolist() == flagged.valid_mask().tolist()
    # a row marked invalid in the file stays invalid even if its values look fine (no new warning)
    marked = dataset.table.assign(**{VALID_COLUMN: np.arange(len(dataset)) != 5})
    CalibrationDataset(marked, "left").to_parquet(tmp_path / "marked.parquet")
    with no_warning():
        back = CalibrationDataset.read_parquet(tmp_path / "marked.parquet")
    assert np.flatnonzero(~back.valid_mask()).tolist() == [5]
    assert len(back.select(back.valid_mask())) == len(dataset) - 1


def test_bad_mode_and_broken_files_are_errors(dataset, tmp_path):
    with pytest.raises(ValueError, match="on_invalid must be one of"):
        dataset.check("ignore")
    garbage = tmp_path / "garbage.csv"
    garbage.write_bytes(b"\x00\xff\x00" * 10)
    with pytest.raises(ValueError):
        CalibrationDataset.read_csv(garbage)


# ---------------------------------------------------------------------------------------------
# Bags


def _with_fields(state, valid=None, **edits):
    fields = {name: values.copy() for name, values in state.fields.items()}
    for name, (index, value) in edits.items():
        fields[name][index] = value
    return RavenStateLog(state.time, fields, state.labels, state.arm, valid)


def test_a_bag_glitch_is_flagged_dropped_or_refused_naming_topic_and_sample(logs, tmp_path):
    state, truth = logs
    k = int(np.flatnonzero(state.fields["runlevel"] == 3)[5])
    glitched = _with_fields(state, mpos=((k, 0), state.fields["mpos"][k, 0] + 30.0))
    path = write_bag(tmp_path / "glitch.bag", glitched, truth)
    expected = (rf"glitch\.bag: impossible values in 1 of {len(state)} samples of topic '/ravenstate'"
                rf"{{action}}; first: topic '/ravenstate', column 'mpos\.shoulder', sample {k}, "
                rf"t = {state.time[k]:.6f} s, value [0-9.]+, limit")
    with pytest.warns(ImpossibleValueWarning, match=expected.format(action=r", flagged \(valid = False\)")):
        flagged, truth_back = read_bag(path)
    assert np.flatnonzero(~flagged.valid).tolist() == [k] and truth_back.valid.all()
    with pytest.warns(ImpossibleValueWarning, match=expected.format(action=", dropped")):
        dropped, _ = read_bag(path, on_invalid="drop")
    assert len(dropped) == len(state) - 1 and state.time[k] not in dropped.time
    with pytest.raises(ImpossibleValueError, match=expected.format(action="")):
        read_bag(path, on_invalid="raise")


def test_non_finite_and_other_arm_values_in_a_bag_are_flagged(logs, tmp_path):
    state, truth = logs
    valid = np.ones(len(state), dtype=bool)
    valid[7] = False
    # slot 4 is the left arm's tool_rot, slot 9 the right arm's elbow (an arm not in this log)
    poisoned = _with_fields(state, valid, tau=((7, 4), np.nan), dac_val=((9, 9), 30000))
    joints = truth.joints.copy()
    joints[42, 1] = np.inf
    truth_valid = np.arange(len(truth)) != 42
    path = write_bag(tmp_path / "nan.bag", poisoned, GroundTruthLog(truth.time, joints, truth_valid))
    with pytest.warns(ImpossibleValueWarning, match=r"2 of \d+ samples of topic '/ravenstate', 1 of \d+ samples "
                                                    r"of topic '/ext_jpos'.*column 'tau.tool_rot', sample 7, "
                                                    r".*value nan, limit finite"):
        state_back, truth_back = read_bag(path)
    assert np.flatnonzero(~state_back.valid).tolist() == [7, 9]
    assert np.flatnonzero(~truth_back.valid).tolist() == [42]
    # the dataset carries the flags: the rows of flagged samples and those interpolated across
    # the flagged ground-truth sample
    synced = synchronize(state_back, truth_back)
    invalid_times = synced.time[~synced.valid_mask()]
    assert set(state.time[[7, 9]]) <= set(invalid_times)
    assert all(abs(t - truth.time[42]) < 0.01 for t in invalid_times if t not in state.time[[7, 9]])
    other_arm = write_bag(tmp_path / "other.bag", _with_fields(state, dac_val=((9, 9), 30000)), truth)
    with pytest.raises(ImpossibleValueError, match=r"column 'dac_val\.elbow \(right arm\)', sample 9, "
                                                   r".*value 30000, limit \[-2500, 2500\] count"):
        read_bag(other_arm, on_invalid="raise")


@pytest.mark.parametrize("mode", ["flag", "drop", "raise"])
def test_broken_bags_are_errors_in_every_mode(logs, tmp_path, mode):
    state, truth = logs
    good = write_bag(tmp_path / "good.bag", state, truth)
    truncated = tmp_path / "truncated.bag"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    garbage = tmp_path / "garbage.bag"
    garbage.write_bytes(b"#ROSBAG V2.0\n" + bytes(200))
    for path in (truncated, garbage):
        with pytest.raises(BagFormatError, match=re.escape(path.name)):
            read_bag(path, on_invalid=mode)
    # the readable part of the cut bag: the last whole message, its topic, sample and time
    with pytest.raises(BagFormatError) as caught:
        read_bag(truncated, on_invalid=mode)
    where = re.search(r"breaks off after sample (\d+) of topic '(/\w+)' \(t = ([0-9.]+) s\); whole messages per "
                      r"topic: '/ext_jpos' (\d+), '/ravenstate' (\d+), '/scenario' (\d+)", str(caught.value))
    assert where is not None, str(caught.value)
    sample, topic, time = int(where[1]), where[2], float(where[3])
    n_truth, n_state = int(where[4]), int(where[5])
    assert 0 < n_state < len(state) and 0 < n_truth < len(truth)
    expected_time = truth.time[sample] if topic == "/ext_jpos" else state.time[sample]
    assert time == pytest.approx(expected_time, abs=1e-6)
    # messages are written in time order: the readable part is a prefix of both logs
    assert state.time[n_state - 1] <= time + 1e-9 and truth.time[n_truth - 1] <= time + 1e-9


# ---------------------------------------------------------------------------------------------
# Random damage


def _inside_limits(state, truth, limits):
    """Independent check of the values of valid samples: finite and within the key limits."""
    for name, values in state.fields.items():
        assert np.all(np.isfinite(values[state.valid])), name
    assert np.all(np.isfinite(truth.joints[truth.valid]))
    slots = [0, 1, 2, 4, 5, 6, 7]
    arm = slice(0, 8)
    homed = state.valid & np.isin(state.fields["runlevel"], (2, 3))
    for name, low, high in (("mpos", limits.motor_lower, limits.motor_upper),
                            ("jpos", limits.joint_lower, limits.joint_upper)):
        values = state.fields[name][homed][:, arm][:, slots]
        assert np.all(values >= low[slots]) and np.all(values <= high[slots]), name
    for name, top in (("tau", limits.torque_max), ("dac_val", limits.dac_max), ("mvel", limits.motor_speed * 1.01)):
        assert np.all(np.abs(state.fields[name][state.valid][:, arm][:, slots]) <= top[slots]), name
    for name in ("ori", "ori_d"):
        assert np.all(np.abs(state.fields[name][state.valid]) <= 1.001), name
    assert np.all(np.abs(state.fields["pos"][state.valid]) <= WORKSPACE_RADIUS)
    assert np.all(np.diff(state.time) >= 0.5e-3) and np.all(np.diff(truth.time) > 0)
    low, high = limits.joint_lower[:3], limits.joint_upper[:3]
    assert np.all(truth.joints[truth.valid] >= low) and np.all(truth.joints[truth.valid] <= high)
    assert find_invalid(state.time[state.valid], state_columns(
        {k: v[state.valid] for k, v in state.fields.items()}, state.arm), state.arm).count == 0


def test_random_byte_flips_never_read_back_an_impossible_value_unflagged(logs, tmp_path):
    state, truth = logs
    k = int(np.flatnonzero(state.fields["runlevel"] == 3)[0])
    small_state, small_truth = state.select(slice(k, k + 30)), truth.select(
        (truth.time >= state.time[k] - 0.02) & (truth.time <= state.time[k + 29] + 0.02))
    original = write_bag(tmp_path / "small.bag", small_state, small_truth).read_bytes()
    rng = np.random.default_rng(20260)
    outcomes = {"error": 0, "flagged": 0, "unflagged": 0}
    path = tmp_path / "flipped.bag"
    for _ in range(200):
        data = bytearray(original)
        position = int(rng.integers(len(data)))
        data[position] ^= int(rng.integers(1, 256))
        path.write_bytes(bytes(data))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ImpossibleValueWarning)
            try:
                state_back, truth_back = read_bag(path)
            except BagFormatError:
                outcomes["error"] += 1
                continue
        _inside_limits(state_back, truth_back, LIMITS)
        flagged = (~state_back.valid).any() or (~truth_back.valid).any()
        outcomes["flagged" if flagged else "unflagged"] += 1
    assert outcomes["error"] > 0 and outcomes["flagged"] > 0, outcomes
