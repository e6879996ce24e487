"""The virtual RAVEN-II as a whole: determinism, recorded state, files, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import RavenII
from simulation.recordings.dataset import synchronize
from simulation.recordings.bags import read_bag, write_bag
from simulation.model.parameters import RavenParameters
from simulation.recordings.ravenstate import RAVENSTATE_FIELDS
from simulation.recordings.recording import Recording, recording_to_dataset
from simulation.engine.robot import Motion, VirtualRaven
from simulation.engine.scenarios import powered_on, record_random_test
from simulation.trajectories import random_sinusoidal


@pytest.fixture(scope="module")
def short_run() -> Recording:
    robot = powered_on(seed=3)
    return record_random_test(robot, duration=20.0, seed=4)


def test_same_seed_same_data_and_different_seed_different_data():
    def run(seed):
        robot = powered_on(seed=seed)
        return record_random_test(robot, duration=5.0, seed=1)

    a, b, c = run(11), run(11), run(12)
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.truth, b.truth)
    assert not np.array_equal(a.values, c.values)


def test_a_concatenated_recording_keeps_the_label_order_so_its_files_are_the_same_in_every_process(short_run):
    # the labels become the dataset file's last columns: their order must not follow the process's
    # string hashing (PYTHONHASHSEED), or one seed's record is written to different bytes each run
    names = ("zeta", "segment", "alpha", "mu", "payload_kg", "beta")
    index, half = np.arange(len(short_run)), len(short_run) // 2
    first, second = short_run.select(index < half - 5), short_run.select(index > half + 5)
    labelled = [Recording(**{**vars(r), "labels": {n: np.full(len(r), k, dtype=np.int64) if n == "segment"
                                                  else np.full(len(r), float(k)) for k, n in enumerate(names)}})
                for r in (first, second)]
    joined = Recording.concatenate(labelled)
    assert tuple(joined.labels) == names
    columns = [c for c in recording_to_dataset(joined, RavenII(joined.arm)).table.columns if c.startswith("label.")]
    assert columns == [f"label.{n}" for n in names]


def test_recording_rates_match_the_papers_30_hz_state_and_100_hz_truth(short_run):
    assert np.median(np.diff(short_run.time)) == pytest.approx(1 / 30, abs=1.5e-3)
    np.testing.assert_allclose(np.diff(short_run.truth_time), 0.01, atol=1e-9)
    assert set(short_run.labels) == {"payload_kg", "operating_hours", "homing_count", "segment"}
    assert np.all(short_run.labels["homing_count"] == 2)


def test_every_ravenstate_field_of_the_arm_carries_simulated_values(short_run):
    robot = RavenII("left", check_limits=False)
    fields = short_run.ravenstate_fields(robot)
    assert set(fields) == {spec.name for spec in RAVENSTATE_FIELDS}
    arm_slots = np.array([0, 1, 2, 4, 5, 6, 7])
    for name in ("encVals", "dac_val", "tau", "mpos", "jpos", "mvel", "mpos_d", "encoffsets"):
        assert np.all(np.any(fields[name][:, arm_slots] != 0, axis=0)), name
        assert np.all(fields[name][:, 8:] == 0), f"{name}: the other arm is not connected"
    for name in ("pos", "ori", "ori_d", "pos_d", "jac_vel", "jac_f"):
        width = fields[name].shape[1] // 2
        assert np.all(np.any(fields[name][:, :width] != 0, axis=0)), name
    # the desired tool pose is the home pose (roll and wrist at zero); the positioning joints move
    assert np.all(fields["jpos_d"][:, :3].std(axis=0) > 0)
    # joint velocities move with the arm: the positioning joints are not constant
    assert np.all(fields["jvel"][:, :3].std(axis=0) > 0)
    # the tool pose follows the forward kinematics of the reported joints
    q = fields["jpos"][:, [0, 1, 2, 4, 5]]
    q6 = np.column_stack([q, 0.5 * (fields["jpos"][:, 7] - fields["jpos"][:, 6])])
    np.testing.assert_allclose(fields["pos"][:, :3], robot.tool_position(q6), atol=1e-12)


def test_the_controller_couples_the_motors_as_fwd_cable_coupling(short_run):
    c = RavenParameters().constants
    mpos = short_run.channel("mpos")
    th1 = mpos[:, 0] / c.transmission_ratio[0]
    th2 = mpos[:, 1] / c.transmission_ratio[1] - c.cable_coupling[0] * th1
    d3 = mpos[:, 2] / c.transmission_ratio[2] - c.cable_coupling[1] * th1 - c.cable_coupling[2] * th2
    np.testing.assert_allclose(short_run.channel("jpos")[:, :3], np.column_stack([th1, th2, d3]), atol=1e-12)
    tool_rot = (mpos[:, 3] - mpos[:, 2] / c.tool_gb_ratio) / c.transmission_ratio[3]
    np.testing.assert_allclose(short_run.channel("jpos")[:, 3], tool_rot, atol=1e-12)


def test_bag_round_trip_of_a_simulated_run_preserves_every_field(short_run, tmp_path):
    robot = RavenII("left", check_limits=False)
    state, truth = short_run.to_logs(robot)
    path = write_bag(tmp_path / "run.bag", state, truth)
    state2, truth2 = read_bag(path)
    for spec in RAVENSTATE_FIELDS:
        a, b = np.asarray(state.fields[spec.name], float), np.asarray(state2.fields[spec.name], float)
        # float32 in the robot's published units
        np.testing.assert_allclose(b, a, rtol=2e-7, atol=2e-6, err_msg=spec.name)
    np.testing.assert_allclose(truth2.joints, truth.joints, atol=1e-7)
    for key in state.labels:
        np.testing.assert_array_equal(state2.labels[key], state.labels[key])


def test_dataset_targets_are_the_interpolated_ground_truth(short_run):
    robot = RavenII("left", check_limits=False)
    dataset = recording_to_dataset(short_run, robot)
    expected = np.column_stack([np.interp(dataset.time, short_run.truth_time, short_run.truth[:, i]) for i in range(3)])
    np.testing.assert_allclose(dataset.targets, expected, atol=1e-12)
    x, names = dataset.features("selected")
    assert x.shape[1] == 16 and names[0] == "jpos.shoulder"
    state, truth = short_run.to_logs(robot)
    direct = synchronize(state, truth)
    np.testing.assert_allclose(direct.features("all")[0], dataset.features("all")[0])


def test_payload_is_carried_by_the_insertion_cable():
    pose = np.array([np.deg2rad(40.0), np.deg2rad(80.0), 0.38, 0.0, 0.0, np.pi / 4, np.pi / 4])
    errors = []
    for payload in (0.0, 0.5):
        robot = powered_on(seed=1)
        robot.set_payload(payload)
        robot.move_to(pose, 2.0)
        rec = robot.hold(1.0)
        errors.append(rec.channel("jpos")[-1, :3] - rec.channel("true_joints")[-1])
    # with the payload the insertion cable stretches more: the joint sits lower than reported
    assert errors[1][2] - errors[0][2] > 1e-3


@pytest.mark.parametrize(
    "motion, message",
    [
        (Motion(q=np.zeros((10, 6)), qd=np.zeros((10, 6)), rate=100.0), "shape"),
        (Motion(q=np.full((10, 7), np.nan), qd=np.zeros((10, 7)), rate=100.0), "non-finite"),
        (Motion(q=np.zeros((10, 7)), qd=np.zeros((9, 7)), rate=100.0), "shape"),
        (Motion(q=np.zeros((10, 7)), qd=np.zeros((10, 7)), rate=0.0), "rate"),
    ],
)
def test_bad_motions_are_refused_with_a_clear_error(motion, message):
    robot = VirtualRaven(seed=0)
    with pytest.raises(ValueError, match=message):
        robot.run(motion)


def test_bad_construction_arguments_are_refused():
    with pytest.raises(ValueError, match="payload_kg"):
        VirtualRaven(payload_kg=-1.0)
    with pytest.raises(ValueError, match="log_rate"):
        VirtualRaven(log_rate=0.0)
    with pytest.raises(ValueError, match="unknown effect"):
        RavenParameters().without("stiction")
    with pytest.raises(ValueError, match="arm"):
        RavenParameters(arm="middle")


def test_right_arm_runs_and_mirrors_the_controller_signs():
    robot = powered_on(RavenParameters(arm="right"), seed=2)
    rec = record_random_test(robot, duration=5.0, seed=2)
    fields = rec.ravenstate_fields(RavenII("right", check_limits=False))
    assert np.all(fields["type"][:, 1] == 22) and np.all(fields["jpos"][:, :8] == 0)
    err = rec.channel("jpos")[:, :3] - rec.channel("true_joints")
    assert np.all(np.abs(err[:, :2]) < np.deg2rad(15)) and np.all(np.abs(err[:, 2]) < 0.03)


def test_random_motion_stays_in_the_workspace_and_the_robot_tracks_it():
    robot = powered_on(seed=5)
    motion = random_sinusoidal(30.0, seed=9)
    robot.move_to(motion.q[0])
    rec = robot.run(motion)
    tracking = rec.channel("jpos")[:, :3] - rec.channel("jpos_d")[:, :3]
    assert np.all(np.abs(tracking[:, :2]) < np.deg2rad(0.5))
    assert np.all(np.abs(tracking[:, 2]) < 1e-3)
