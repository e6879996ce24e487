"""The numerical core of the studies: samples, scores, methods, sweeps, reports, paper numbers."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

from kinematics import RavenII
from studies.common import paper_numbers as paper
from studies.common.evaluation import (
    cartesian_rmse_report,
    joint_rmse_report,
    mean_scores,
    percentage_of,
    score,
    to_report_units,
)
from studies.common.methods import (
    CalibratorOnSamples,
    Method,
    MethodSettings,
    UKFOnSamples,
    dnn,
    method_catalogue,
    raw,
    regression,
    seeds_for,
)
from studies.common.reporting import agreement_line, format_value, markdown_table, to_jsonable, write_json
from studies.common.samples import Samples
from studies.common.sweeps import run_tasks
from studies.common.training import fit_and_score, run_methods
from estimators import LinearCalibrator, WindowLinearCalibrator


def synthetic_samples(n=400, seed=0, recordings=1, tool=True):
    """Joints in the calibration workspace; raw = truth + a torque-dependent stretch + offset."""
    rng = np.random.default_rng(seed)
    truth = np.column_stack([rng.uniform(0.35, 1.05, n), rng.uniform(0.96, 1.92, n), rng.uniform(0.33, 0.42, n)])
    torque = rng.normal(size=(n, 3))
    raw_joints = truth + 0.01 * torque + np.array([0.02, -0.03, 0.004])
    X = np.hstack([raw_joints, torque])
    tool_joints = rng.uniform(-0.5, 0.5, (n, 3)) if tool else None
    recording = np.repeat(np.arange(recordings), int(np.ceil(n / recordings)))[:n]
    return Samples(X=X, feature_names=("r1", "r2", "r3", "t1", "t2", "t3"), raw_columns=(0, 1, 2), targets=truth,
                   time=np.arange(n) / 30.0, recording=recording, tool_joints=tool_joints)


# --- samples -----------------------------------------------------------------------------------


def test_samples_reject_bad_shapes_and_values():
    good = synthetic_samples(20)
    with pytest.raises(ValueError, match="targets"):
        Samples(X=good.X, feature_names=good.feature_names, raw_columns=(0, 1, 2), targets=good.targets[:5],
                time=good.time, recording=good.recording)
    bad = good.X.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match=r"X contains NaN or infinity \(first at row 3, column 'r2'\)"):
        Samples(X=bad, feature_names=good.feature_names, raw_columns=(0, 1, 2), targets=good.targets,
                time=good.time, recording=good.recording)
    truth = good.targets.copy()
    truth[5, 2] = np.inf
    with pytest.raises(ValueError, match=r"targets contains NaN or infinity \(first at row 5, column 'joint 3'\)"):
        Samples(X=good.X, feature_names=good.feature_names, raw_columns=(0, 1, 2), targets=truth,
                time=good.time, recording=good.recording)
    with pytest.raises(ValueError, match="raw_columns"):
        Samples(X=good.X, feature_names=good.feature_names, raw_columns=(0, 1, 9), targets=good.targets,
                time=good.time, recording=good.recording)
    interleaved = np.array([0, 1] * 10)
    with pytest.raises(ValueError, match="consecutive"):
        Samples(X=good.X, feature_names=good.feature_names, raw_columns=(0, 1, 2), targets=good.targets,
                time=good.time, recording=interleaved)
    # time runs per recording: it may start again in the next one, never go back (or stall) within one
    two = np.repeat([0, 1], 10)
    restarted = np.concatenate([good.time[:10], good.time[:10]])
    assert len(Samples(X=good.X, feature_names=good.feature_names, raw_columns=(0, 1, 2), targets=good.targets,
                       time=restarted, recording=two)) == 20
    for row, earlier in ((7, 3), (7, 6)):
        back = good.time.copy()
        back[row] = good.time[earlier]
        with pytest.raises(ValueError, match=f"time must increase strictly within a recording; it does not at row {row} "):
            Samples(X=good.X, feature_names=good.feature_names, raw_columns=(0, 1, 2), targets=good.targets,
                    time=back, recording=good.recording)


def test_samples_concat_renumbers_recordings_and_select_marks_thinning():
    a, b = synthetic_samples(30, recordings=2), synthetic_samples(20, seed=1)
    joined = Samples.concat([a, b])
    assert [rows.size for rows in joined.recordings()] == [15, 15, 20]
    assert np.array_equal(joined.X[30:], b.X)
    assert joined.select(np.arange(10, 40)).stride == 1
    assert joined.select(np.arange(0, 50, 5)).stride > 1
    # the first rows of each recording are still consecutive log samples of their recording
    assert joined.select(np.r_[0:5, 15:20, 30:35]).stride == 1
    assert joined.select(np.r_[0:5, 7:12]).stride > 1
    with pytest.raises(ValueError, match="increasing"):
        joined.select(np.array([3, 1]))


# --- scores ------------------------------------------------------------------------------------


def test_report_units_are_degrees_and_millimetres():
    assert np.allclose(to_report_units([np.pi, np.pi / 180, 0.001]), [180.0, 1.0, 1.0])
    truth = np.zeros((4, 3))
    estimate = np.tile([np.radians(2.0), 0.0, 0.003], (4, 1))
    assert np.allclose(joint_rmse_report(truth, estimate), [2.0, 0.0, 3.0])


def test_cartesian_rmse_equals_pinocchio_forward_kinematics():
    samples = synthetic_samples(60)
    estimate = samples.targets + np.array([0.002, -0.004, 0.0015])
    robot = RavenII("left", check_limits=False)
    reported = cartesian_rmse_report(robot, samples.targets, estimate, samples.tool_joints)
    # independent computation: Pinocchio's FK, one configuration at a time
    errors = []
    for q3_true, q3_est, tool in zip(samples.targets, estimate, samples.tool_joints):
        p_true = robot.forward_kinematics(np.r_[q3_true, tool], backend="pinocchio")[:3, 3]
        p_est = robot.forward_kinematics(np.r_[q3_est, tool], backend="pinocchio")[:3, 3]
        errors.append(p_est - p_true)
    errors = np.array(errors) * 1e3
    expected = np.r_[np.sqrt(np.mean(errors**2, axis=0)), np.sqrt(np.mean(np.sum(errors**2, axis=1)))]
    assert np.allclose(reported, expected, rtol=1e-9, atol=1e-9)
    # an insertion error moves the tool tip by about as much (the RCM is the base origin)
    only_insertion = samples.targets + np.array([0.0, 0.0, 0.001])
    assert cartesian_rmse_report(robot, samples.targets, only_insertion, samples.tool_joints)[3] == \
        pytest.approx(1.0, rel=0.02)


def test_score_without_tool_joints_has_no_cartesian_part_and_checks_shape():
    samples = synthetic_samples(50, tool=False)
    result = score(samples.raw_joints, samples)
    assert result.cartesian is None and result.joint.shape == (3,)
    with pytest.raises(ValueError, match="shape"):
        score(samples.raw_joints[:10], samples)


def test_mean_scores_and_percentages():
    samples = synthetic_samples(50)
    a, b = score(samples.raw_joints, samples), score(samples.targets + 1e-4, samples)
    assert np.allclose(mean_scores([a, b]).joint, (a.joint + b.joint) / 2)
    assert np.allclose(percentage_of([0.104, 0.120], [0.859, 1.095]), [12.1, 10.96], atol=0.01)
    with pytest.raises(ValueError):
        percentage_of([1.0], [0.0])


# --- methods -----------------------------------------------------------------------------------


def test_fixed_offset_and_linear_correct_a_biased_stretched_encoder():
    train, test = synthetic_samples(600), synthetic_samples(300, seed=5)
    rmse = {}
    for method in (raw(), regression("fixed_offset"), regression("linear")):
        outcome = fit_and_score(method, 0, train, {"test": test})
        assert outcome.error is None
        rmse[method.key] = outcome.scores["test"].joint
    assert np.all(rmse["linear"] < 1e-6)  # the synthetic error is exactly linear in X
    assert np.all(rmse["fixed_offset"] < rmse["raw"])


def test_end_to_end_and_on_error_linear_models_predict_the_same():
    train, test = synthetic_samples(500), synthetic_samples(100, seed=3)
    on_error = CalibratorOnSamples(LinearCalibrator()).fit(train).predict(test)
    end_to_end = CalibratorOnSamples(LinearCalibrator(), train_on_error=False).fit(train).predict(test)
    assert np.allclose(on_error, end_to_end, atol=1e-10)


def test_window_model_refuses_thinned_samples_and_predicts_each_recording_from_its_start():
    train = synthetic_samples(300, recordings=3)
    model = CalibratorOnSamples(WindowLinearCalibrator(window=4), temporal=True).fit(train)
    whole = model.predict(train)
    second = train.select(train.recording == 1)
    assert np.allclose(whole[train.recording == 1], model.predict(second))
    with pytest.raises(ValueError, match="every"):
        model.predict(train.select(np.arange(0, 300, 3)))


class _Exploding:
    def fit(self, samples):
        raise RuntimeError("boom")


def _explode(seed):
    return _Exploding()


def test_a_failing_method_is_reported_not_raised_and_unrunnable_ones_say_why():
    samples = synthetic_samples(100)
    method = Method("boom", "Boom", "-", "test", _explode)
    assert fit_and_score(method, 0, samples, {"test": samples}).error == "RuntimeError: boom"
    runs = run_methods([method, method_catalogue(MethodSettings.quick())["ukf"]], samples, {"test": samples},
                       n_jobs=1, backend="sequential", progress=False)
    assert runs["boom"].status == "failed" and "boom" in runs["boom"].note
    # the UKF cannot run on samples without the robot state
    assert runs["ukf"].status == "skipped" and "robot state" in runs["ukf"].note


class _Noisy:
    def fit(self, samples):
        for _ in range(10):
            warnings.warn("identification did not converge", RuntimeWarning)
        return self

    def predict(self, samples):
        return samples.raw_joints


def _noisy(seed):
    return _Noisy()


def test_warnings_of_a_method_are_collected_once_each():
    samples = synthetic_samples(30)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # nothing may escape to the caller
        outcome = fit_and_score(Method("noisy", "Noisy", "-", "test", _noisy), 0, samples, {"test": samples})
    assert outcome.warnings == ("RuntimeWarning: identification did not converge",)
    assert outcome.error is None


def test_ukf_needs_the_full_robot_state():
    samples = synthetic_samples(50)
    with pytest.raises(ValueError, match="robot state"):
        UKFOnSamples().fit(samples)


def test_network_seeds_are_independent_but_reproducible():
    method = dnn(MethodSettings(dnn_seeds=3, dnn_epochs=2))
    assert seeds_for(method, 7) == seeds_for(method, 7)
    assert len(set(seeds_for(method, 7))) == 3
    assert seeds_for(method, 7) != seeds_for(method, 8)


def test_method_settings_reject_nonsense():
    with pytest.raises(ValueError, match="dnn_seeds"):
        MethodSettings(dnn_seeds=0)
    with pytest.raises(ValueError, match="two_phase_max_samples"):
        MethodSettings(two_phase_max_samples=-3)
    with pytest.raises(ValueError, match="ukf_scales must be one of"):
        MethodSettings(ukf_scales="fixed")


def test_nominal_ukf_scales_reach_the_filter_and_chosen_ones_leave_its_defaults():
    from studies.common.methods import method_catalogue

    for key in ("ukf", "ukf_disturbance", "ukf_hybrid"):
        nominal = method_catalogue(MethodSettings(ukf_scales="nominal"))[key].make(0)
        chosen = method_catalogue(MethodSettings())[key].make(0)
        assert nominal.options["velocity_scale_factors"] == (1.0,) and nominal.options["coast_noise_scale"] == 1.0
        assert "velocity_scale_factors" not in chosen.options and "coast_noise_scale" not in chosen.options


# --- sweeps ------------------------------------------------------------------------------------


def _square_after(delay_rank: int, value: int) -> int:
    import time
    time.sleep(0.01 * delay_rank)
    return value * value


def test_sweep_results_come_back_in_task_order():
    tasks = [(3 - k, k) for k in range(4)]
    assert run_tasks(_square_after, tasks, n_jobs=2, backend="threading", progress=False) == [0, 1, 4, 9]
    with pytest.raises(ValueError, match="backend"):
        run_tasks(_square_after, tasks, backend="mpi", progress=False)


# --- reporting ---------------------------------------------------------------------------------


def test_tables_and_json_are_plain(tmp_path):
    table = markdown_table(["a", "b"], [["x", 1.23456], ["y", None], ["z", (0.1, 0.25)]])
    assert "| x | 1.235 |" in table and "| y | - |" in table and "0.100-0.250" in table
    with pytest.raises(ValueError, match="cells"):
        markdown_table(["a", "b"], [["only one"]])
    assert format_value(float("nan")) == "-"
    path = write_json(tmp_path / "r.json", {"v": np.array([1.0, np.nan]), "n": np.int64(3)})
    assert json.loads(path.read_text()) == {"v": [1.0, None], "n": 3}
    assert to_jsonable(MethodSettings())["dnn_seeds"] == 5
    assert agreement_line(False, "a", "b").startswith("**Finding (test): DOES NOT AGREE")
    # on recorded data the evidence is measured, whatever the simulator was tuned to
    assert agreement_line(True, "a", "b", "built in", measured=True) == \
        "**Finding (test on recorded data): AGREES with the paper.** Measured: a Paper: b"
    assert "AGREE" not in agreement_line(True, "a", "b", "built in")
    with pytest.raises(ValueError, match="kind must be one of"):
        agreement_line(True, "a", "b", "tuned")


def test_the_machine_description_names_the_releases_and_the_processor_the_kernels_are_compiled_for():
    import casadi
    import llvmlite.binding
    import scipy

    from studies.common.reporting import RESULT_PACKAGES, machine_description, package_versions

    machine = machine_description()
    assert set(machine["packages"]) == set(RESULT_PACKAGES)
    # the installed releases, as the packages themselves report them
    assert machine["packages"]["numpy"] == np.__version__ and machine["packages"]["scipy"] == scipy.__version__
    assert machine["packages"]["casadi"] == casadi.__version__
    assert machine["compiled_for"] == llvmlite.binding.get_host_cpu_name()
    assert package_versions(("numpy", "no-such-package-here")) == {"numpy": np.__version__,
                                                                    "no-such-package-here": None}
    json.dumps(machine)  # plain JSON


def test_every_study_says_whether_its_finding_is_built_in():
    from studies.common.paper_numbers import FINDING_KIND, FINDINGS

    assert set(FINDINGS) | {"compare_sota"} == set(FINDING_KIND)
    assert set(FINDING_KIND.values()) <= {"test", "built in"}


# --- paper numbers -----------------------------------------------------------------------------


def test_paper_table_i_reproduces_its_printed_percentages():
    # percentages printed in Table I (of fixed offset): J2-J3 DNN 12.1/10.9/24.0, J1 poly joint 3 83.5
    j2j3 = paper.TABLE_I["J2-J3"]
    assert np.allclose(percentage_of(j2j3["dnn"], j2j3["fixed_offset"]), [12.1, 10.9, 24.0], atol=0.06)
    assert math.isclose(100 * paper.TABLE_I["J1"]["polynomial"][2] / paper.TABLE_I["J1"]["fixed_offset"][2],
                        83.5, abs_tol=0.06)
    assert paper.HEADLINE["dnn_joint_rmse"] == j2j3["dnn"]
    assert set(paper.TABLE_I) == set(paper.TABLE_I_DIRECTIONS)


def test_held_out_rows_are_within_the_learned_range_only_when_every_joint_is():
    from studies.discrepancy_dvrk_splits import within_learned_range

    learned = np.array([[0.0, -1.0], [2.0, 1.0], [1.0, 0.0]])
    held_out = np.array([[1.0, 0.5],    # inside both ranges
                         [2.0, -1.0],   # on both edges: inside
                         [2.1, 0.0],    # first joint beyond its range
                         [1.0, -1.5],   # second joint beyond its range
                         [-0.1, 2.0]])  # both beyond
    np.testing.assert_array_equal(within_learned_range(learned, held_out), [True, True, False, False, False])
    with pytest.raises(ValueError, match=r"same columns.*\(3, 2\) and \(2, 3\)"):
        within_learned_range(learned, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="learned row"):
        within_learned_range(np.zeros((0, 2)), held_out)
    with pytest.raises(ValueError, match="NaN"):
        within_learned_range(learned, np.array([[1.0, np.nan]]))


def _split_part(before, after, learned):
    """One part of a split's held-out data as the splits study reports it: pooled RMSE (deg) of the
    starting model, of the named effects and of every calibrator (all ``learned``)."""
    from studies.discrepancy_dvrk_splits import CALIBRATORS

    return {"before": before, "after": after, "learned": {name: learned for name in CALIBRATORS}}


def test_play_leverage_is_the_hat_matrix_diagonal_scaled_to_average_one_and_infinite_off_the_span():
    from studies.discrepancy_dvrk_splits import play_leverage

    rng = np.random.default_rng(3)
    learned = rng.normal(size=(400, 4)) * [1.0, 0.1, 2.0, 0.5]
    learned[:, 3] = learned[:, 0] - learned[:, 2]  # rank 3 of 4 columns: one combination never excited
    held_out = np.vstack([learned[:5], 3.0 * learned[5:8], [[0.0, 1.0, 0.0, 0.0]], [[1.0, 0.0, 0.0, 0.0]]])
    leverage = play_leverage(learned, held_out)
    # an independent computation: the diagonal of the hat matrix with a constant column, times rows over rank
    x = np.column_stack([learned, np.ones(len(learned))])
    h = np.column_stack([held_out, np.ones(len(held_out))])
    hat = np.einsum("ij,jk,ik->i", h, np.linalg.pinv(x.T @ x), h) * len(x) / np.linalg.matrix_rank(x)
    np.testing.assert_allclose(leverage[:9], hat[:9], rtol=1e-9)
    assert play_leverage(learned, learned).mean() == pytest.approx(1.0, abs=1e-12)
    # one unit along a column whose learned spread is 0.1 lies ten spreads out: a leverage of about
    # 10 ** 2 over the rank (4 with the constant), far above the learned rows' 1; off the span, unbounded
    assert 15 < leverage[8] < 35
    assert np.isinf(leverage[9]) and np.all(np.isfinite(leverage[:9]))
    with pytest.raises(ValueError, match=r"same columns.*\(400, 4\) and \(2, 3\)"):
        play_leverage(learned, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="NaN"):
        play_leverage(learned, np.array([[np.nan, 0.0, 0.0, 0.0]]))


def test_leverage_quarters_are_equal_shares_by_rank_with_the_unbounded_on_top():
    from studies.discrepancy_dvrk_splits import leverage_quarters

    leverage = np.array([5.0, np.inf, 0.5, 2.0, 2.0, 9.0, 1.0, np.inf])
    np.testing.assert_array_equal(leverage_quarters(leverage), [2, 3, 0, 1, 1, 2, 0, 3])
    with pytest.raises(ValueError, match="at least 4 leverages and no NaN"):
        leverage_quarters(np.array([1.0, np.nan, 2.0, 3.0]))
    with pytest.raises(ValueError, match="at least 4"):
        leverage_quarters(np.ones(3))


def test_the_splits_leverage_table_lists_every_quarter_and_the_finding_its_ends():
    from studies.discrepancy_dvrk_splits import CALIBRATORS, finding, tables

    quarters = [dict(_split_part(8.0, 4.0, 5.0), low=0.5, high=2.0, leverage_median=1.2),
                dict(_split_part(8.0, 6.0, 5.0), low=2.0, high=4.0, leverage_median=3.0),
                dict(_split_part(9.0, 8.1, 5.0), low=4.0, high=9.0, leverage_median=6.0),
                dict(_split_part(10.0, 10.5, 7.0), low=9.0, high=40.0, leverage_median=14.0)]
    runs = [{"split": "peg -> random", "named": ["coupled_hysteresis"], "shrink": 0.2, "before": 9.0, "after": 7.0,
             "learned": {name: 6.0 for name in CALIBRATORS}, "inside_share": 1.0,
             "by_range": {"inside": _split_part(9.0, 7.0, 6.0), "outside": _split_part(*[float("nan")] * 3)},
             "leverage_median": 4.1, "by_leverage": quarters}]
    lines = "\n".join(tables({"runs": runs})).splitlines()
    rows = [line for line in lines if line.startswith("| peg -> random | ") and "quarter" not in line
            and ("lowest" in line or "| 2nd |" in line or "| 3rd |" in line or "highest" in line)]
    assert rows == ["| peg -> random | 1st (lowest) | 0.5 to 2.0 | 1.2 | 50.0 | 8.000 | 4.000 | 5.000 |",
                    "| peg -> random | 2nd | 2.0 to 4.0 | 3.0 | 25.0 | 8.000 | 6.000 | 5.000 |",
                    "| peg -> random | 3rd | 4.0 to 9.0 | 6.0 | 10.0 | 9.000 | 8.100 | 5.000 |",
                    "| peg -> random | 4th (highest) | 9.0 to 40.0 | 14.0 | -5.0 | 10.000 | 10.500 | 7.000 |"]
    assert ("median play-feature leverage 4.1: 50.0 % closed on the held-out quarter of lowest leverage, "
            "-5.0 % on the highest") in finding({"runs": runs})


def test_the_splits_table_gives_each_range_its_share_and_shrink_and_skips_an_empty_one():
    from studies.discrepancy_dvrk_splits import CALIBRATORS, finding, tables

    nan = float("nan")
    runs = [{"split": "random -> peg", "named": ["coupled_hysteresis"], "shrink": 0.5, "before": 8.0, "after": 4.0,
             "learned": {name: 5.0 for name in CALIBRATORS}, "inside_share": 1.0,
             "by_range": {"inside": _split_part(8.0, 4.0, 5.0), "outside": _split_part(nan, nan, nan)}},
            {"split": "peg -> random", "named": [], "shrink": 0.2, "before": 10.0, "after": 8.0,
             "learned": {name: 7.0 for name in CALIBRATORS}, "inside_share": 0.75,
             "by_range": {"inside": _split_part(8.0, 6.0, 6.5), "outside": _split_part(12.0, 10.8, 9.0)}}]
    lines = "\n".join(tables({"runs": runs})).splitlines()
    range_rows = [line for line in lines if "| within |" in line or "| beyond |" in line]
    assert range_rows == ["| random -> peg | within | 100.0 | - | 50.0 | 8.000 | 4.000 | 5.000 |",
                          "| peg -> random | within | 75.0 | - | 25.0 | 8.000 | 6.000 | 6.500 |",
                          "| peg -> random | beyond | 25.0 | - | 10.0 | 12.000 | 10.800 | 9.000 |"]
    text = finding({"runs": runs})
    assert "25 % of the held-out samples beyond the learned wrist ranges: 25.0 % closed within them, 10.0 % beyond" \
        in text and text.count("beyond the learned") == 1


@pytest.mark.parametrize("split, learning, held_out", [
    ("random -> peg", "random motion", "peg transfer"), ("peg -> random", "peg transfer", "random motion"),
    ("peg, 1st half -> 2nd half", "peg transfer, 1st half", "peg transfer, 2nd half")])
def test_the_play_widths_table_names_the_parts_of_its_split(split, learning, held_out):
    from studies.discrepancy_play_widths import GridConfig, finding, tables

    runs = [{"grid": [1, 8], "named": ["coupled_hysteresis"], "validation_gap": 2.0, "held_out_gap": 5.0,
             "held_out_gap_before": 8.0, "shrink": 0.375},
            {"grid": [3, 8], "named": ["coupled_hysteresis"], "validation_gap": 1.5, "held_out_gap": 5.5,
             "held_out_gap_before": 8.0, "shrink": 0.3125}]
    text = "\n".join(tables({"split": split, "runs": runs}))
    assert f"(fit -> held out: {split})" in text
    assert f"| validation gap after (deg, {learning}) | held-out gap after (deg, {held_out}) |" in text
    assert "| 1/8 to 1/256 | coupled_hysteresis | 1.500 | 5.500 | 31.2 |" in text
    assert "the starting model's held-out gap is 8.000 deg" in text
    # the grid is chosen on the validation part, whatever the held-out part says
    assert finding({"split": split, "runs": runs}).startswith(
        f"Fit -> held out: {split}. The grid with the smallest validation gap is 1/8 to 1/256 (1.500 deg)")
    from studies.common.dvrk_splits import run_split

    for refuse in (lambda: GridConfig(split="peg -> peg"), lambda: run_split("peg -> peg")):
        with pytest.raises(ValueError, match="unknown split 'peg -> peg'; choose from random -> peg, "):
            refuse()


def test_the_play_widths_study_says_when_each_joint_is_driven_by_its_own_motion_and_refuses_other_drivers():
    from studies.discrepancy_play_widths import GridConfig, finding, main, tables

    runs = [{"grid": [1, 8], "named": ["hysteresis", "coupling"], "validation_gap": 4.8, "held_out_gap": 5.0,
             "held_out_gap_before": 7.3, "shrink": 0.313,
             "held_out_gap_alone": {"hysteresis": 5.5, "coupling": 7.25}}]
    for drivers, said in (("own", True), ("every", False)):
        results = {"split": "random -> peg", "drivers": drivers, "runs": runs}
        text = "\n".join(tables(results)) + finding(results)
        assert ("each joint driven by its own motion alone" in text) is said
        assert text.count("each joint driven by its own motion alone") == 2 * said
        assert "| 1/2 to 1/256 | hysteresis, coupling | 4.800 | 5.000 | 31.3 | hysteresis 5.500, coupling 7.250 |" in text
    with pytest.raises(ValueError, match="unknown play drivers 'others'; choose from every, own"):
        GridConfig(drivers="others")
    with pytest.raises(SystemExit):
        main(["--drivers", "others", "--out", "unused"])


def test_the_weights_of_either_form_of_coupled_hysteresis_are_labelled_by_joint_driver_and_width():
    from simulation.discrepancy.generic import HYSTERESIS_WIDTH_FRACTIONS
    from studies.common.discrepancy_report import value_labels

    joints, widths = ("roll", "pitch", "yaw"), len(HYSTERESIS_WIDTH_FRACTIONS)
    every = value_labels(9 * widths, joints, "weight")
    assert every[0] == "roll from roll, play of 1/2 of its range"
    assert every[widths] == "roll from pitch, play of 1/2 of its range"
    assert every[-1] == "yaw from yaw, play of 1/256 of its range"
    own = value_labels(3 * widths, joints, "weight")
    assert own[widths - 1] == "roll from its own motion, play of 1/256 of its range"
    assert own[widths] == "pitch from its own motion, play of 1/2 of its range"
    assert value_labels(3, joints, "weight") == list(joints)
