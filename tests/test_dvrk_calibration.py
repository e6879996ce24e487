"""Calibrators on real dVRK data (Hwang et al. 2020): train on random motion, test on peg transfer.

Inputs are the commanded joint positions ``q_des`` (6 features; the window calibrators see the
last 5 of them), targets the measured ``q_act``, in error mode. The per-joint table (RMSE in
degrees for rotational joints, millimetres for insertion, every joint of every calibrator, with
the change against the fixed offset) is printed; run with ``-s`` to see it:

    python -m pytest tests/test_dvrk_calibration.py -s -q

The networks use the paper's settings on one thread, except that the two-phase network trains
100 epochs, its forest has 50 trees, and the LSTM has 32 units and 20 epochs, to keep the file
within its time budget.
"""

from __future__ import annotations

import numpy as np
import pytest

from estimators import DNNCalibrator, FixedOffsetCalibrator, GPRCalibrator, LinearCalibrator
from estimators import PolynomialCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator
from estimators import pooled_rmse, rmse_per_joint
from simulation.recordings import load_dvrk, locate_dvrk_data
from simulation.recordings.dvrk import JOINT_NAMES, PRISMATIC_JOINTS, WRIST_JOINTS

pytestmark = pytest.mark.xdist_group("dvrk_calibration")
"""One worker runs this module, so the calibrators are fitted once (a module fixture)."""

RAW = list(range(6))
REQUIRED_WRIST_REDUCTION = 0.25


def calibrators():
    return {
        "fixed offset": FixedOffsetCalibrator(raw_columns=RAW),
        "linear": LinearCalibrator(raw_columns=RAW),
        "polynomial (2nd order)": PolynomialCalibrator(raw_columns=RAW),
        "DNN 100-100 (paper)": DNNCalibrator(raw_columns=RAW, random_state=0, n_threads=1),
        "GPR (Mahler 2014)": GPRCalibrator(raw_columns=RAW, random_state=0, n_threads=1),
        "two-phase (Seita 2018)": TwoPhaseCalibrator(
            raw_columns=RAW, n_estimators=50, random_state=0,
            dnn=DNNCalibrator(max_epochs=100, n_threads=1)),
        "window linear, 5 (Hwang 2020)": WindowLinearCalibrator(raw_columns=RAW, window=5),
        "window LSTM, 5 (Hwang 2020)": WindowLSTMCalibrator(
            raw_columns=RAW, window=5, hidden_size=32, max_epochs=20, batch_size=128,
            random_state=0, n_threads=1),
    }


@pytest.fixture(scope="module")
def results():
    try:
        root = locate_dvrk_data()
    except FileNotFoundError as error:
        pytest.skip(f"real dVRK data not available: {error}")
    train = load_dvrk(root, split="random_unfiltered")
    test = load_dvrk(root, split="peg_transfer")
    predictions = {"raw (q_des)": np.asarray(test.X[:, RAW])}
    for name, calibrator in calibrators().items():
        predictions[name] = calibrator.fit(train.X, train.y).predict(test.X)
    return test.y, predictions


def per_joint_table(truth, predictions) -> str:
    """RMSE per joint in deg / mm, the pooled wrist RMSE, and the change against the fixed
    offset; a joint made worse than by the fixed offset is marked with '+'."""
    to_report = np.where(PRISMATIC_JOINTS, 1e3, np.degrees(1.0))
    baseline = rmse_per_joint(truth, predictions["fixed offset"])
    baseline_wrist = pooled_rmse(truth, predictions["fixed offset"], WRIST_JOINTS)
    units = ["mm" if prismatic else "deg" for prismatic in PRISMATIC_JOINTS]
    header = " | ".join(f"{i + 1} {name} ({unit})" for i, (name, unit) in
                        enumerate(zip(JOINT_NAMES, units)))
    lines = [f"| calibrator | {header} | wrist 4-6 pooled (deg) | wrist vs fixed offset |",
             "|---" * 9 + "|"]
    for name, prediction in predictions.items():
        errors = rmse_per_joint(truth, prediction)
        cells = []
        for error, base, scale in zip(errors, baseline, to_report):
            worse = name != "raw (q_des)" and error > base * 1.0005
            cells.append(f"{error * scale:.3f}{' +' if worse else ''}")
        wrist = pooled_rmse(truth, prediction, WRIST_JOINTS)
        change = 100.0 * (wrist / baseline_wrist - 1.0)
        lines.append(f"| {name} | " + " | ".join(cells)
                     + f" | {np.degrees(wrist):.3f} | {change:+.1f} % |")
    return "\n".join(lines)


def test_fixed_offset_removes_the_wrist_bias(results):
    truth, predictions = results
    assert (pooled_rmse(truth, predictions["fixed offset"], WRIST_JOINTS)
            < 0.8 * pooled_rmse(truth, predictions["raw (q_des)"], WRIST_JOINTS))


def test_a_calibrator_cuts_the_wrist_error_of_the_fixed_offset_by_a_quarter(results):
    truth, predictions = results
    table = per_joint_table(truth, predictions)
    print("\n" + table)
    baseline = pooled_rmse(truth, predictions["fixed offset"], WRIST_JOINTS)
    reductions = {name: 1.0 - pooled_rmse(truth, prediction, WRIST_JOINTS) / baseline
                  for name, prediction in predictions.items()}
    best = max(reductions, key=reductions.get)
    assert reductions[best] >= REQUIRED_WRIST_REDUCTION, (
        f"best wrist reduction {reductions[best]:.1%} ({best}) < 25 %\n{table}")


def test_table_reports_every_joint_of_every_calibrator(results):
    truth, predictions = results
    rows = per_joint_table(truth, predictions).splitlines()[2:]
    assert len(rows) == len(predictions) == len(calibrators()) + 1
    for row in rows:
        assert len(row.strip("|").split("|")) == 1 + len(JOINT_NAMES) + 2


def test_the_discrepancy_workflow_closes_half_the_wrist_gap_and_beats_every_calibrator(results):
    # fitted and chosen on the random motion, scored on the peg transfer, like the calibrators
    from studies.common.discrepancy_runs import run_on_dvrk

    truth, predictions = results
    result, _, split = run_on_dvrk(locate_dvrk_data(), joints=WRIST_JOINTS)
    assert split.held_out.sum() == len(truth)
    assert result.named_effects[:1] == ("coupled_hysteresis",), result.named_effects
    assert result.shrink >= 0.5, result.shrink
    named = np.sqrt(np.mean(np.square(result.residual_after.joints)))  # rad, all three wrist joints
    for name, prediction in predictions.items():
        assert named < pooled_rmse(truth, prediction, WRIST_JOINTS), name


def test_every_split_holds_out_other_samples_than_it_learns_from_and_the_reverse_swaps_them():
    from studies.common.dvrk_splits import SPLITS, split_parts

    try:
        root = locate_dvrk_data()
    except FileNotFoundError as error:
        pytest.skip(f"real dVRK data not available: {error}")
    random, peg = (load_dvrk(root, split=name) for name in ("random_unfiltered", "peg_transfer"))
    parts = {split: split_parts(split, root) for split in SPLITS}
    (_, x_random, _), (_, x_peg, y_peg) = parts["random -> peg"]
    assert np.array_equal(x_random, random.X) and np.array_equal(x_peg, peg.X) and np.array_equal(y_peg, peg.y)
    reverse = parts["peg -> random"]
    assert all(np.array_equal(a, b) for a, b in zip(reverse[0], parts["random -> peg"][1]))
    assert all(np.array_equal(a, b) for a, b in zip(reverse[1], parts["random -> peg"][0]))
    for split, record in (("random, 1st half -> 2nd half", random), ("peg, 1st half -> 2nd half", peg)):
        (t0, x0, y0), (t1, x1, y1) = parts[split]
        assert t0[-1] < t1[0] and len(t0) + len(t1) == len(record.t) and abs(len(t0) - len(t1)) <= 1
        assert np.array_equal(np.concatenate([x0, x1]), record.X) and np.array_equal(np.concatenate([y0, y1]), record.y)
    with pytest.raises(ValueError, match="unknown split 'random -> random'; choose from random -> peg, "):
        split_parts("random -> random", root)
    from studies.common.dvrk_splits import run_split

    for joints in ((6,), (3, 3), (), (-1, 4), (3.0,)):
        with pytest.raises(ValueError, match=r"joints must be distinct joint indices 0-5 of the dVRK arm, got "):
            run_split("random -> peg", root, joints)
