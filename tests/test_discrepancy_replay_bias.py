"""The replay-bias study: the factor it finds on records the replay itself made, its refusals."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from studies.discrepancy_replay_bias import (FACTOR_TOLERANCE, base_weights, beside_blind_runs, effect_loop_height,
                                             generated, main, stiffness_factor)


def _replayed_record(record, stiffness_scale, rounds=6):
    """``record``'s signals with its joints and torques the quasi-static replay's own, of the generator's
    parameters with the hysteresis stiffness times ``stiffness_scale``: the replay is run again on its
    own joints (the links' derivatives held at the record's, so that only the poses change) until it
    reproduces them."""
    from simulation.discrepancy.replay import RavenModel

    true = record.generator.effect("hysteresis")
    model = RavenModel(record.generator.with_effect(true.replace(stiffness=true.stiffness * stiffness_scale)),
                       np.zeros(3))
    velocity, acceleration = record.signals.velocity, record.signals.acceleration
    signals = record.signals.with_derivatives(velocity=velocity, acceleration=acceleration)
    for _ in range(rounds):
        state = model.replay(signals, record.robot)
        signals = dataclasses.replace(signals, truth=state.joints, torque=state.torque, travel=None,
                                      loaded_travel=None).with_derivatives(velocity=velocity, acceleration=acceleration)
    state = model.replay(signals, record.robot)
    assert np.max(np.abs(state.joints - signals.truth)) < 1e-6  # the replay reproduces its own record
    return signals


def test_on_records_the_replay_made_itself_the_factor_is_the_one_they_were_made_with():
    record = generated(0, 30.0, None)
    signals = _replayed_record(record, np.ones(3))
    weights = base_weights(record.generator, signals, record.split, record.robot)
    factors = [stiffness_factor(record.generator, signals, record.split, record.robot, weights, j) for j in range(3)]
    np.testing.assert_allclose(factors, 1.0, atol=5 * FACTOR_TOLERANCE)
    # one joint's loop made 30 % higher (or 20 % lower), every other value the generator's
    for joint, scale in ((1, 1.3), (2, 0.8)):
        signals = _replayed_record(record, np.where(np.arange(3) == joint, scale, 1.0))
        weights = base_weights(record.generator, signals, record.split, record.robot)
        factor = stiffness_factor(record.generator, signals, record.split, record.robot, weights, joint)
        assert factor == pytest.approx(scale, abs=5 * FACTOR_TOLERANCE)


def test_the_loop_height_is_the_candidates_stiffness_times_width_over_one_plus_shape():
    from simulation.model.effects import Hysteresis

    stiffness, width, shape = np.array([12.0, 4.0, 200.0]), np.array([3e-3, 4e-3, 8e-5]), np.array([0.4, 0.9, 0.0])
    loops = Hysteresis(stiffness=stiffness, beta=1 / width, gamma=shape / width)
    np.testing.assert_allclose(effect_loop_height(loops), stiffness * width / (1 + shape))
    np.testing.assert_allclose(effect_loop_height(loops), loops.stiffness / (loops.beta + loops.gamma))


def _report(seed, elbow_scale, shrink):
    true = {"stiffness": [12.0, 4.0, 200.0], "width": [3e-3, 4e-3, 8e-5], "shape": [0.4, 0.4, 0.4]}
    fitted = {**true, "stiffness": [12.0, 4.0 * elbow_scale, 200.0]}
    report = {"joints": ["shoulder", "elbow", "z_ins"], "shrink": shrink, "scored_by": "plant replay",
              "plant_floor_bound": 0.87, "hidden_effect": ["hysteresis"], "named_effects": ["hysteresis"],
              "fitted_parameters": {"hysteresis": fitted}, "true_parameters": {"hysteresis": true},
              "starting_parameters": {"final": {"cable_stretch": {"stiffness": [38.0, 14.0, 2000.0]}}},
              "true_starting_parameters": {"cable_stretch": {"stiffness": [38.0, 14.0, 2000.0]}},
              "record_s": 1201.8}
    return report if seed is None else {**report, "seed": seed}


def _write(folder, report):
    folder.mkdir(parents=True)
    (folder / "report.json").write_text(json.dumps(report))
    return str(folder)


def test_the_factor_is_put_beside_the_blind_run_of_its_seed_and_ranked_with_it(tmp_path):
    from studies.discrepancy_replay_bias import blind_runs

    runs = blind_runs([_write(tmp_path / f"run{s}", _report(s, 1.1 + 0.05 * s, 0.85 - 0.01 * s)) for s in range(4)],
                      1200.0)
    beside = beside_blind_runs({0: 1.10, 1: 1.12, 2: 1.15, 3: 1.16, 9: 1.5}, runs)
    assert [row["seed"] for row in beside["rows"]] == [0, 1, 2, 3]  # seed 9 has no report
    assert beside["rows"][2]["blind_loop_error"] == pytest.approx(0.2)
    assert beside["rows"][2]["shortfall_points"] == pytest.approx(4.0)
    assert beside["spearman"] == {"blind_loop_error": pytest.approx(1.0), "shortfall_points": pytest.approx(1.0)}
    assert beside_blind_runs({0: 1.1, 1: 1.2}, runs)["spearman"] is None


def test_the_starting_base_is_the_blind_starting_model_weighed_by_its_own_residual():
    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.replay import RavenModel
    from studies.common.discrepancy_runs import STARTING_STRUCTURE
    from studies.discrepancy_replay_bias import fitted_candidate

    record = generated(3, 30.0, None, starting=True)
    model, weights = record.starting
    assert set(model.enabled_effects) == set(STARTING_STRUCTURE) and "hysteresis" not in model.enabled_effects
    joints = record.signals.truth[record.split.fit] - model.replay(record.signals, record.robot).joints[record.split.fit]
    # the fit part's offsets are in the model (to what the first state's shift with them leaves), and
    # each joint weighs by its residual's spread (floor 0.001 deg, mm)
    assert np.all(np.abs(joints.mean(axis=0)) < 0.01 * joints.std(axis=0))
    floor = np.array([np.radians(1e-3), np.radians(1e-3), 1e-6])
    np.testing.assert_allclose(weights.joints, np.maximum(joints.std(axis=0), floor), rtol=1e-9)
    fit = fitted_candidate(record, 3, "fitted", "starting")
    values = {k: np.asarray(v) for k, v in fit["values"].items()}
    assert set(values) == {"stiffness", "width", "shape", "response_time"}
    from simulation.model.effects import Hysteresis

    rebuilt = dataclasses.replace(model.with_effect(Hysteresis(
        stiffness=values["stiffness"], beta=1.0 / values["width"], gamma=values["shape"] / values["width"],
        response_time=values["response_time"])), follows_hysteresis_lag=True)
    assert isinstance(rebuilt, RavenModel)
    # the reported sum of squares is the fitted model's, offsets fitted on the fit part
    assert fit["chi_square"] == pytest.approx(residual(rebuilt, record.signals, record.robot,
                                                       mask=record.split.fit).chi_square(weights), rel=1e-9)
    without = generated(3, 30.0, None)
    with pytest.raises(ValueError, match="holds no starting model"):
        fitted_candidate(without, 3, "none", "starting")


@pytest.mark.parametrize("argv, message", [
    (["--response-times", "default,0,0"], "a response time is given twice in 'default,0,0'"),
    (["--response-times", "2"], "'2' is not 'default' or a response time: must be between 0 and 1 s, got 2"),
    (["--seeds", "0"], "--seeds"),
    (["--fit-iterations", "0"], "--fit-iterations"),
    (["--fit-lag"], "--fit-lag goes with --fit"),
    (["--on-starting-base"], "--on-starting-base goes with --fit"),
])
def test_bad_options_are_refused_in_one_line(argv, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(argv)
    error = capsys.readouterr().err.strip().splitlines()
    assert exit_info.value.code == 2 and len(error) <= 2 and message in error[-1], error


def test_reports_that_do_not_fit_the_runs_option_are_refused_in_one_line(tmp_path, capsys):
    cases = [
        ([_write(tmp_path / "a", _report(None, 1.2, 0.8))], "does not say its seed"),
        ([_write(tmp_path / "b", _report(3, 1.2, 0.8)), _write(tmp_path / "c", _report(3, 1.1, 0.8))],
         "two reports of seed 3"),
        ([_write(tmp_path / "d", _report(4, 1.2, 0.8)), "--seed", "4"], "--runs measures the seeds of its reports"),
        ([_write(tmp_path / "e", {**_report(5, 1.2, 0.8), "record_s": 240.4})],
         "is of a 240.4 s record, not of the 1200 s this study generates (--duration)"),
        ([str(tmp_path / "missing")], "missing"),
    ]
    for runs, message in cases:
        with pytest.raises(SystemExit) as exit_info:
            main(["--runs", *runs])
        error = capsys.readouterr().err.strip().splitlines()
        assert exit_info.value.code == 2 and message in error[-1], error
