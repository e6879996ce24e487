"""Synchronization with ground truth, feature groups and dataset files."""

import bisect
import json

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest

import simulation.recordings.dataset as dataset_module
from simulation.recordings import VALID_COLUMN
from simulation.recordings.dataset import (
    ALL,
    FEATURE_COLUMNS,
    SELECTED,
    CalibrationDataset,
    FeatureGroup,
    FeatureGroupRegistry,
    register_feature_group,
    synchronize,
)
from simulation.recordings.tables import METADATA_KEY, TableFormatError
from simulation.recordings.ravenstate import RAVENSTATE_FIELDS, GroundTruthLog, RavenStateLog


def random_state(time, seed=0, arm="left"):
    """A valid log whose entries are all different random numbers (counts as integers)."""
    rng = np.random.default_rng(seed)
    n = time.size
    fields = {}
    for spec in RAVENSTATE_FIELDS:
        shape = (n, spec.width) if spec.is_array else (n,)
        fields[spec.name] = rng.integers(-1000, 1000, shape) if spec.is_count else rng.normal(size=shape)
    labels = {"payload_kg": rng.uniform(0, 1, n), "segment": rng.integers(0, 4, n)}
    return RavenStateLog(time, fields, labels, arm)


def smooth_truth(time):
    return GroundTruthLog(time, np.column_stack([np.sin(time), np.cos(2 * time), 0.35 + 0.01 * time]))


def interpolate_by_hand(t, truth):
    """Piecewise-linear interpolation written out sample by sample."""
    k = min(bisect.bisect_right(truth.time.tolist(), t) - 1, len(truth) - 2)
    t0, t1 = truth.time[k], truth.time[k + 1]
    weight = (t - t0) / (t1 - t0)
    return (1 - weight) * truth.joints[k] + weight * truth.joints[k + 1]


@pytest.fixture(scope="module")
def paired():
    state = random_state(np.arange(0.0, 10.0, 1 / 30))  # 300 samples at 30 Hz
    truth = smooth_truth(np.arange(2.0, 8.0 + 1e-9, 0.01))  # 100 Hz over [2, 8] s
    return state, truth


def test_interpolated_truth_equals_a_hand_computation(paired):
    state, truth = paired
    dataset = synchronize(state, truth)
    expected = np.array([interpolate_by_hand(t, truth) for t in dataset.time])
    np.testing.assert_allclose(dataset.targets, expected, rtol=0, atol=1e-12)
    linear = GroundTruthLog(truth.time, np.column_stack([truth.time, -2 * truth.time, 1e-3 * truth.time]))
    on_line = synchronize(state, linear)
    np.testing.assert_allclose(on_line.targets, np.column_stack([on_line.time, -2 * on_line.time,
                                                                 1e-3 * on_line.time]), atol=1e-12)


def test_samples_outside_the_truth_span_are_dropped_and_counted(paired):
    state, truth = paired
    dataset = synchronize(state, truth)
    outside = (state.time < truth.time[0]) | (state.time > truth.time[-1])
    assert dataset.n_dropped_outside == int(outside.sum()) > 100
    assert dataset.n_dropped_in_gaps == 0
    np.testing.assert_array_equal(dataset.time, state.time[~outside])
    np.testing.assert_array_equal(dataset.labels["segment"], state.labels["segment"][~outside])


def test_samples_in_a_truth_gap_are_dropped_unless_the_gap_is_allowed(paired):
    state, truth = paired
    hole = (truth.time > 4.0 + 1e-9) & (truth.time < 4.5 - 1e-9)
    gappy = truth.select(~hole)
    left_edge, right_edge = truth.time[np.flatnonzero(hole)[0] - 1], truth.time[np.flatnonzero(hole)[-1] + 1]
    in_hole = (state.time > left_edge) & (state.time < right_edge)
    dataset = synchronize(state, gappy, max_gap=0.05)
    assert dataset.n_dropped_in_gaps == int(in_hole.sum()) >= 14
    assert not np.any((dataset.time > left_edge) & (dataset.time < right_edge))
    relaxed = synchronize(state, gappy, max_gap=0.6)
    assert relaxed.n_dropped_in_gaps == 0 and len(relaxed) == len(dataset) + int(in_hole.sum())


def test_a_sample_on_a_truth_sample_is_kept_beside_a_gap():
    truth = GroundTruthLog(np.array([0.0, 1.0, 5.0, 6.0]), np.arange(12.0).reshape(4, 3))
    state = random_state(np.array([0.5, 1.0, 3.0, 5.0, 5.5]))
    dataset = synchronize(state, truth, max_gap=2.0)
    np.testing.assert_array_equal(dataset.time, [0.5, 1.0, 5.0, 5.5])
    np.testing.assert_array_equal(dataset.targets[1], [3.0, 4.0, 5.0])
    assert dataset.n_dropped_in_gaps == 1


def test_no_overlap_and_bad_parameters_are_errors(paired):
    state, truth = paired
    with pytest.raises(ValueError, match="no robot-state sample is within"):
        synchronize(state, smooth_truth(np.array([20.0, 21.0])))
    with pytest.raises(ValueError, match="max_gap must be a positive"):
        synchronize(state, truth, max_gap=0.0)
    with pytest.raises(ValueError, match="at least 2"):
        synchronize(state, smooth_truth(np.array([3.0])))


def test_feature_groups_have_the_documented_sizes_and_raw_columns(paired):
    state, truth = paired
    dataset = synchronize(state, truth)
    X_selected, names = dataset.features("selected")
    assert X_selected.shape == (len(dataset), 16) and names[:3] == ("jpos.shoulder", "jpos.elbow", "jpos.z_ins")
    assert names[8:] == tuple(f"tau.{dof}" for dof in
                              ("shoulder", "elbow", "z_ins", "no_connection", "tool_rot", "wrist", "grasp1", "grasp2"))
    X_all, all_names = dataset.features("all")
    assert X_all.shape == (len(dataset), 122) and all_names == FEATURE_COLUMNS
    kept = (state.time >= truth.time[0]) & (state.time <= truth.time[-1])
    for group, X in (("selected", X_selected), ("all", X_all)):
        indices = dataset.raw_column_indices(group)
        np.testing.assert_array_equal(X[:, list(indices)], state.fields["jpos"][kept][:, 0:3])
        np.testing.assert_array_equal(X[:, list(indices)], dataset.raw_joints)
    np.testing.assert_array_equal(dataset.features("selected")[0][:, 8:], state.fields["tau"][kept][:, 0:8])
    np.testing.assert_allclose(dataset.raw_errors, dataset.targets - dataset.raw_joints)


def test_right_arm_features_come_from_slots_8_to_15(paired):
    state, truth = paired
    dataset = synchronize(state, truth, arm="right")
    kept = (state.time >= truth.time[0]) & (state.time <= truth.time[-1])
    X, _ = dataset.features("selected")
    np.testing.assert_array_equal(X[:, :8], state.fields["jpos"][kept][:, 8:16])
    np.testing.assert_array_equal(dataset.table["pos.x"], state.fields["pos"][kept][:, 3])
    np.testing.assert_array_equal(dataset.table["type"], state.fields["type"][kept][:, 1])
    np.testing.assert_array_equal(dataset.table["runlevel"], state.fields["runlevel"][kept])
    assert dataset.arm == "right"


def test_all_group_holds_each_arm_entry_once():
    per_arm = sum(max(spec.per_arm, 1) for spec in RAVENSTATE_FIELDS)
    assert len(ALL.columns) == per_arm == 122
    assert len(set(ALL.columns)) == 122
    assert SELECTED.raw_column_indices() == (0, 1, 2)
    assert ALL.raw_column_indices() == tuple(FEATURE_COLUMNS.index(f"jpos.{j}") for j in ("shoulder", "elbow", "z_ins"))


def test_user_groups_register_and_are_checked(paired, monkeypatch):
    monkeypatch.setattr(dataset_module, "FEATURE_GROUPS", FeatureGroupRegistry([SELECTED, ALL]))
    group = register_feature_group("joints_velocities", ["jpos.shoulder", "jpos.elbow", "jpos.z_ins",
                                                         "jvel.shoulder", "label.payload_kg"])
    dataset = synchronize(*paired)
    X, names = dataset.features("joints_velocities")
    assert names == group.columns and X.shape[1] == 5
    np.testing.assert_array_equal(X[:, 4], dataset.labels["payload_kg"])
    with pytest.raises(ValueError, match="exists already"):
        register_feature_group("joints_velocities", ["jpos.shoulder"])
    with pytest.raises(ValueError, match=r"\['truth.shoulder'\] are not feature or label columns"):
        FeatureGroup("leaky", ("jpos.shoulder", "truth.shoulder"))
    with pytest.raises(KeyError, match="no feature group 'nope'"):
        dataset.features("nope")
    with pytest.raises(ValueError, match="lacks the raw joint columns"):
        dataset.raw_column_indices(FeatureGroup("torques", ("tau.shoulder",)))


def test_parquet_round_trip_is_equal_and_carries_metadata(paired, tmp_path):
    dataset = synchronize(*paired)
    path = dataset.to_parquet(tmp_path / "set.parquet")
    back = CalibrationDataset.read_parquet(path)
    # the paired logs are random, so the limit check on reading flags many of their rows: every
    # other column comes back equal, and reading only adds flags, never clears one
    pd.testing.assert_frame_equal(back.table.drop(columns=VALID_COLUMN), dataset.table.drop(columns=VALID_COLUMN))
    assert not np.any(back.valid_mask() & ~dataset.valid_mask())
    assert (back.arm, back.n_dropped_outside, back.n_dropped_in_gaps, back.max_gap) == (
        dataset.arm, dataset.n_dropped_outside, dataset.n_dropped_in_gaps, dataset.max_gap)
    metadata = json.loads(pq.read_schema(path).metadata[METADATA_KEY])
    assert metadata["format_version"] == 1 and metadata["arm"] == "left"
    assert metadata["units"]["jpos.z_ins"] == "m" and metadata["units"]["jpos.shoulder"] == "rad"
    assert metadata["units"]["tau.elbow"] == "N m" and metadata["units"]["label.payload_kg"] == "kg"


def test_other_format_version_or_foreign_parquet_is_refused(paired, tmp_path):
    path = synchronize(*paired).to_parquet(tmp_path / "set.parquet")
    table = pq.read_table(path)
    document = json.loads(table.schema.metadata[METADATA_KEY])
    document["format_version"] = 99
    pq.write_table(table.replace_schema_metadata({METADATA_KEY: json.dumps(document).encode()}),
                   tmp_path / "future.parquet")
    with pytest.raises(TableFormatError, match=r"future\.parquet: dataset format version 99, this reader "
                                               r"supports version 1"):
        CalibrationDataset.read_parquet(tmp_path / "future.parquet")
    pd.DataFrame({"a": [1.0]}).to_parquet(tmp_path / "foreign.parquet")
    with pytest.raises(TableFormatError, match="not a calibration dataset"):
        CalibrationDataset.read_parquet(tmp_path / "foreign.parquet")
    (tmp_path / "garbage.parquet").write_bytes(b"not parquet at all")
    with pytest.raises(TableFormatError, match="not a readable Parquet file"):
        CalibrationDataset.read_parquet(tmp_path / "garbage.parquet")


def test_failed_write_keeps_the_previous_file_intact(paired, tmp_path, monkeypatch):
    dataset = synchronize(*paired)
    path = dataset.to_parquet(tmp_path / "set.parquet")
    before = path.read_bytes()

    def half_write(table, where, **kwargs):
        with open(where, "wb") as handle:
            handle.write(b"PAR1 partial")
        raise OSError("disk full")

    monkeypatch.setattr(pq, "write_table", half_write)
    with pytest.raises(OSError, match="disk full"):
        dataset.select(np.arange(10)).to_parquet(path)
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["set.parquet"]


def test_csv_round_trip_is_exact(paired, tmp_path):
    dataset = synchronize(*paired)
    path = dataset.to_csv(tmp_path / "set.csv")
    back = pd.read_csv(path)
    pd.testing.assert_frame_equal(back, dataset.table)


def test_select_and_concat_keep_rows_labels_and_counts(paired):
    dataset = synchronize(*paired)
    first = dataset.select(dataset.time < 5.0)
    second = dataset.select(dataset.time >= 5.0)
    joined = CalibrationDataset.concat([first, second])
    pd.testing.assert_frame_equal(joined.table, dataset.table)
    assert joined.n_dropped_outside == 2 * dataset.n_dropped_outside
    with pytest.raises(ValueError, match="arm"):
        CalibrationDataset.concat([dataset, synchronize(*paired, arm="right")])


def test_bad_tables_are_refused_by_column(paired):
    table = synchronize(*paired).table.copy()
    table.loc[12, "tau.wrist"] = np.nan
    with pytest.raises(ValueError, match=r"column 'tau.wrist' is not finite at row 12"):
        CalibrationDataset(table)
    with pytest.raises(ValueError, match=r"lacks columns \['truth.elbow'\]"):
        CalibrationDataset(synchronize(*paired).table.drop(columns="truth.elbow"))
    with pytest.raises(ValueError, match="unknown columns"):
        CalibrationDataset(synchronize(*paired).table.assign(extra=1.0))
