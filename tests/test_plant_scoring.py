"""The blind analysis's last step: its models scored with the plant replay, when and how."""

from __future__ import annotations

import json
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from kinematics import RavenII
from simulation.discrepancy.replay import RavenModel
from simulation.discrepancy.signals import RAVEN_JOINTS, RAVEN_UNITS, MeasuredSignals
from simulation.discrepancy.workflow import Split
from simulation.identification import nominal_parameters
from simulation.model.laws import coupling_matrix
from studies.common.discrepancy_report import (SCORED_BY_PLANT, SCORED_BY_QUASI_STATIC, plant_refit_section,
                                               report_document)
from studies.common.discrepancy_runs import LIBRARY, generate_measured
from studies.common.plant_scoring import (PLANT_REFIT_EFFECTS, PLANT_SCORED_EFFECTS, PlantRefit, PlantScore,
                                          plant_floor_gap, plant_held_out_gap, plant_joints, plant_score_reason,
                                          pooled_gap, refit_with_plant, score_with_plant, with_plant_friction)

from raven_signals import near_still_signals as _signals


def test_the_plant_scores_the_library_effects_it_integrates_and_no_other():
    assert PLANT_SCORED_EFFECTS == ("backlash", "hysteresis", "drift", "homing_offset", "registration_offset",
                                    "transmission_error", "capstan_friction")
    assert set(PLANT_SCORED_EFFECTS) < set(LIBRARY)


@pytest.mark.parametrize("named, homings, payload, reason", [
    ((), 1, None, "nothing was named"),
    (("backlash", "motor_friction"), 1, None, "motor_friction acts outside what the plant replay integrates"),
    (("payload", "motor_friction"), 1, None, "payload, motor_friction act outside"),
    (("homing_offset", "gravity_model_error"), 2, None, "gravity_model_error acts outside"),
    (("drift",), 1, np.r_[np.zeros(100), np.full(100, 0.5)], "the declared payload changes"),
])
def test_the_plant_scores_nothing_it_cannot_replay_and_says_why(named, homings, payload, reason):
    result = SimpleNamespace(named_effects=named)
    said = plant_score_reason(result, _signals(homings=homings, payload=payload))
    assert said is not None and said.startswith(reason), said
    score = score_with_plant(result, _signals(homings=homings, payload=payload), split=None)
    assert not score.applies and score.reason == said and score.replays == 0
    assert score.gap_before is None and score.shrink is None


def test_a_named_effect_the_plant_integrates_is_scored_on_one_homing_or_more():
    assert plant_score_reason(SimpleNamespace(named_effects=("backlash", "capstan_friction")), _signals()) is None
    assert plant_score_reason(SimpleNamespace(named_effects=("registration_offset",)), _signals(homings=2)) is None


def test_the_plant_replay_recovers_dry_friction_forces_set_a_third_off():
    # the generator's own parameters with its Coulomb forces 30 % high, 30 % low and 20 % high:
    # refitted with the plant replay on the first half of a 20 s record, each comes back to within
    # 3 % (0.1 %, 0.1 % and 0.6 % when measured)
    dataset, generator = generate_measured((), seed=0, duration=20.0)
    signals = MeasuredSignals.from_dataset(dataset)
    friction = generator.effect("coulomb_friction")
    true = np.asarray(friction.force, dtype=float)
    wrong = generator.with_effect(friction.replace(force=np.r_[true[:3] * [1.3, 0.7, 1.2], true[3:]]))
    refined, factors, replays = with_plant_friction(RavenModel(wrong, np.zeros(3)), signals, Split.by_time(signals),
                                                    RavenII(signals.arm, check_limits=False))
    assert replays <= 200 + 12
    np.testing.assert_allclose(refined.params.effect("coulomb_friction").force[:3], true[:3], rtol=0.03)
    np.testing.assert_allclose(factors, 1 / np.array([1.3, 0.7, 1.2]), rtol=0.03)
    np.testing.assert_array_equal(refined.params.effect("coulomb_friction").force[3:], true[3:])


def test_a_perfect_analysis_of_hidden_backlash_scored_by_the_plant_closes_most_of_the_gap():
    # the blind analysis stands in here by a result whose final model is the generator's own (what
    # a perfect analysis would give) and whose starting model lacks the hidden backlash
    dataset, generator = generate_measured(("backlash",), seed=0, duration=20.0, size_factor=3.0)
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    result = SimpleNamespace(named_effects=("backlash",), model_before=RavenModel(generator.without("backlash"),
                                                                                  np.zeros(3)),
                             model_after=RavenModel(generator, np.zeros(3)))
    score = score_with_plant(result, signals, split, max_evaluations=10)
    assert score.applies and score.reason is None
    assert score.gap_before.shape == score.gap_after.shape == (3,)
    assert score.shrink == pytest.approx(1 - pooled_gap(score.gap_after) / pooled_gap(score.gap_before))
    # the generator's own model leaves about the encoders' error; without its backlash, several times it
    assert score.shrink > 0.5
    assert score.replays <= 2 * (10 + 12) and set(score.friction_factors) == {"before", "after"}
    assert json.loads(json.dumps(score.document()))["gap_after"] == list(score.gap_after)


def test_a_plant_replay_that_does_not_stay_finite_scores_nothing(monkeypatch):
    import studies.common.plant_scoring as scoring

    dataset, generator = generate_measured(("backlash",), seed=0, duration=5.0)
    signals = MeasuredSignals.from_dataset(dataset)
    model = RavenModel(generator, np.zeros(3))
    result = SimpleNamespace(named_effects=("backlash",), model_before=model, model_after=model)
    monkeypatch.setattr(scoring, "replay_links", lambda *args, **kwargs: np.full((len(args[2]), 3), np.nan))
    score = score_with_plant(result, signals, Split.by_time(signals), max_evaluations=3)
    assert not score.applies and score.reason == "the plant replay of the starting model did not stay finite"
    assert score.shrink is None and score.gap_before is None


def _stand_in_result():
    return SimpleNamespace(named_effects=("backlash",), unexplained=False, gap_before=np.array([2e-4, 1e-4, 3e-6]),
                           gap_after=np.array([1.5e-4, 1e-4, 3e-6]), shrink=0.2, library=LIBRARY, units=RAVEN_UNITS,
                           joint_names=RAVEN_JOINTS, torque_gap_before=None, torque_gap_after=None, equivalent={},
                           rivals={}, signature=(), residual_structure=None, backfit_rounds=6, backfit_patience=0,
                           named_backfit_patience=2, backfit_capped=(),
                           max_effects=4, search_capped=False,
                           controller=None, fitted_parameters={}, parameter_units={}, parameter_bounds={},
                           iterations=(), model_before=None)


def test_the_report_gives_the_plant_replays_gaps_where_it_applies_and_keeps_the_quasi_static_ones():
    result = _stand_in_result()
    plant = PlantScore(applies=True, gap_before=np.array([2.2e-4, 0.9e-4, 3e-6]),
                       gap_after=np.array([0.8e-4, 0.8e-4, 3e-6]), shrink=0.55,
                       friction_factors={"before": np.ones(3), "after": np.ones(3)}, replays=120)
    document = report_document(result, {"kind": "raven"}, 1.0, plant=plant)
    assert document["scored_by"] == SCORED_BY_PLANT
    assert document["shrink"] == 0.55 and document["gap_after"] == [0.8e-4, 0.8e-4, 3e-6]
    assert document["gap_before_report_units"][0] == pytest.approx(np.degrees(2.2e-4))
    assert document["quasi_static"] == {"gap_before": [2e-4, 1e-4, 3e-6], "gap_after": [1.5e-4, 1e-4, 3e-6],
                                        "shrink": 0.2}
    assert document["plant_replay"]["applies"] is True and document["plant_replay"]["replays"] == 120
    # where it does not apply, the quasi-static replay's figures are the report's, and the reason is kept
    skipped = PlantScore(applies=False, reason="motor_friction acts outside what the plant replay integrates")
    document = report_document(result, {"kind": "raven"}, 1.0, plant=skipped)
    assert document["scored_by"] == SCORED_BY_QUASI_STATIC and document["shrink"] == 0.2
    assert document["gap_after"] == document["quasi_static"]["gap_after"]
    assert document["plant_replay"]["reason"] == "motor_friction acts outside what the plant replay integrates"
    assert report_document(result, {"kind": "dvrk"}, 1.0)["plant_replay"] is None


@pytest.mark.parametrize("named, score, reason", [
    (("backlash",), PlantScore(applies=False, reason="nothing was named"),
     "the plant replay does not score the analysis: nothing was named"),
    (("transmission_error", "homing_offset"), PlantScore(applies=True, gap_before=np.ones(3), gap_after=np.ones(3),
                                                        shrink=0.0),
     "no named effect is one the plant refit refits (backlash, hysteresis, drift)"),
])
def test_the_plant_refit_refits_nothing_where_it_cannot_and_says_why(named, score, reason):
    assert set(PLANT_REFIT_EFFECTS) < set(PLANT_SCORED_EFFECTS)
    refit = refit_with_plant(SimpleNamespace(named_effects=named), _signals(), None, score)
    assert not refit.applies and refit.reason == reason and refit.replays == 0
    assert refit.shrink is None and refit.gap_after is None
    assert report_document(_stand_in_result(), {"kind": "raven"}, 1.0, plant=score,
                           plant_refit=refit)["plant_refit"]["reason"] == reason
    assert plant_refit_section(refit, _stand_in_result()) == [
        "## Named effects refitted with the plant replay", "", f"Not refitted: {reason}.", ""]


def test_the_report_gives_the_plant_refit_beside_the_workflows_figures_in_report_units():
    result = _stand_in_result()
    result.parameter_units = {"backlash": {"half_width": ["rad", "rad", "m"]}}
    plant = PlantScore(applies=True, gap_before=np.array([2.2e-4, 0.9e-4, 3e-6]),
                       gap_after=np.array([0.8e-4, 0.8e-4, 3e-6]), shrink=0.55, replays=120)
    refit = PlantRefit(applies=True, effects=("backlash",), gap_after=np.array([0.6e-4, 0.7e-4, 2e-6]), shrink=0.65,
                       fitted={"backlash": {"half_width": [1e-3, 2e-3, 1e-5]}},
                       refitted={"backlash": {"half_width": [1.5e-3, 1e-3, 2e-5]}},
                       friction_factors=np.array([0.9, 1.1, 1.0]), replays=600)
    document = report_document(result, {"kind": "raven"}, 1.0, plant=plant, plant_refit=refit)
    # the headline stays the workflow's models', the refit beside it in SI
    assert document["shrink"] == 0.55 and document["gap_after"] == [0.8e-4, 0.8e-4, 3e-6]
    assert document["plant_refit"] == {"applies": True, "reason": None, "effects": ["backlash"],
                                       "gap_after": [0.6e-4, 0.7e-4, 2e-6], "shrink": 0.65,
                                       "fitted": refit.fitted, "refitted": refit.refitted,
                                       "friction_factors": [0.9, 1.1, 1.0], "replays": 600,
                                       "hysteresis_lag_s": None}
    assert json.loads(json.dumps(document["plant_refit"])) == document["plant_refit"]
    text = "\n".join(plant_refit_section(refit, result))
    assert "shrink 65.0 % over the same starting gap" in text and "600 replays" in text
    assert "factors 0.900, 1.100, 1.000" in text
    rows = [line for line in text.splitlines() if line.startswith("| backlash")]
    # each value fitted, then refitted, in degrees and millimetres
    np.testing.assert_allclose([[float(c) for c in row.split("|")[4:6]] for row in rows],
                               [[np.degrees(1e-3), np.degrees(1.5e-3)], [np.degrees(2e-3), np.degrees(1e-3)],
                                [1e-2, 2e-2]], rtol=1e-3)
    assert [row.split("|")[6].strip() for row in rows] == ["deg", "deg", "mm"]
    assert report_document(result, {"kind": "raven"}, 1.0, plant=plant)["plant_refit"] is None


def test_the_plant_replay_of_a_model_registers_its_offsets_on_the_motor_side_and_carries_its_payload():
    # the constant and per-homing offsets move the motor coordinates, as RAVEN-II's registration at
    # the hard stops does: the same as a model without offsets along motor coordinates shifted by
    # the coupling's inverse (from the arm's constants) times the offsets of each sample
    signals = _signals(homings=2)
    homing, n = signals.homing, len(signals)
    robot = RavenII("left", check_limits=False)
    extra = np.array([2e-3, -1e-3, 5e-4])
    offsets = np.array([1e-3, 0.0, 0.0])
    params = nominal_parameters("left")
    model = RavenModel(params, offsets, homing_offsets={1: extra})
    per_sample = offsets + np.where(homing[:, None] == 1, extra, 0.0)
    coupling = coupling_matrix(*params.constants.cable_coupling)
    shifted = replace(signals, drive=signals.drive + np.linalg.solve(coupling, per_sample.T).T, travel=None,
                      loaded_travel=None)
    expected = plant_joints(RavenModel(params, np.zeros(3)), shifted, robot)
    np.testing.assert_allclose(plant_joints(model, signals, robot), expected, rtol=0, atol=1e-12)
    # each homing starts from the measured joints, whatever the offsets
    starts = np.flatnonzero(signals.restarts)
    np.testing.assert_array_equal(plant_joints(model, signals, robot)[starts], signals.truth[starts])
    plain = RavenModel(params, offsets)
    # an undeclared payload loads the links as a declared one does
    declared = replace(signals, payload_kg=np.full(n, 0.5), travel=None, loaded_travel=None)
    np.testing.assert_array_equal(plant_joints(plain.with_payload(0.5), signals, robot),
                                  plant_joints(plain, declared, robot))
    assert not np.allclose(plant_joints(plain.with_payload(0.5), signals, robot), plant_joints(plain, signals, robot))


def test_the_plant_replay_refuses_a_record_whose_declared_payload_changes():
    signals = _signals(payload=np.r_[np.zeros(100), np.full(100, 0.5)])
    with pytest.raises(ValueError, match="declared payload changes from 0 kg to 0.5 kg"):
        plant_joints(RavenModel(nominal_parameters("left"), np.zeros(3)), signals, RavenII("left", check_limits=False))


def test_the_plant_floor_is_the_held_out_gap_of_the_starting_model_with_its_friction_refitted():
    # a record with nothing hidden whose "starting model" is the generator's own with its Coulomb
    # forces a third off: the floor scores it as the analysis scores a starting model, so it comes
    # back to the held-out gap of the generator's own forces, not to that of the forces as given
    # (measured: 0.00171 against 0.00166, pooled deg and mm; 0.129 as given)
    dataset, generator = generate_measured((), seed=1, duration=20.0)
    signals = MeasuredSignals.from_dataset(dataset)
    split, robot = Split.by_time(signals), RavenII(signals.arm, check_limits=False)
    friction = generator.effect("coulomb_friction")
    true = np.asarray(friction.force, dtype=float)
    wrong = RavenModel(generator.with_effect(friction.replace(force=np.r_[true[:3] * [1.3, 0.7, 1.2], true[3:]])),
                       np.zeros(3))
    floor = plant_floor_gap((signals, split, robot, wrong))
    exact = plant_held_out_gap(RavenModel(generator, np.zeros(3)), signals, split, robot)
    as_given = plant_held_out_gap(wrong, signals, split, robot)
    assert floor.shape == (3,) and np.all(np.isfinite(floor))
    assert pooled_gap(floor) == pytest.approx(pooled_gap(exact), rel=0.05)
    assert pooled_gap(as_given) > 10 * pooled_gap(exact)


def _hysteresis_record(lag, seed, duration=60.0):
    """A record of the generator with its hysteresis lagging the stretch by ``lag`` s, and the
    generator's own model with the lag set to the candidate's 0.05 s instead."""
    from simulation.model.parameters import RavenParameters
    from studies.common.plant_scoring import with_lag

    params = RavenParameters()
    params = params.with_effect(replace(params.effect("hysteresis"), response_time=lag))
    dataset, generator = generate_measured(("hysteresis",), seed=seed, duration=duration, params=params)
    signals = MeasuredSignals.from_dataset(dataset)
    return signals, with_lag(RavenModel(generator, np.zeros(3)), 0.05)


@pytest.mark.parametrize("true_lag, seed", [(0.3, 1), (0.02, 3)])
def test_the_plant_fits_a_hysteresis_lag_from_its_start_toward_the_generators_on_either_side(true_lag, seed):
    # from its start of 0.1 s the lag moves toward the generator's: above 0.2 s for 0.3 s, under
    # 0.05 s for 0.02 s (measured: 0.339 s and 0.008 s; the plant's residual
    # hardly changes below about 0.05 s, which bounds how close a small lag comes)
    from studies.common.plant_scoring import HYSTERESIS_LAG_START, with_plant_friction_and_lag

    signals, model = _hysteresis_record(true_lag, seed)
    split, robot = Split.by_time(signals), RavenII(signals.arm, check_limits=False)
    assert HYSTERESIS_LAG_START == 0.1
    fitted, factors, lag, replays = with_plant_friction_and_lag(model, signals, split, robot, 60)
    assert (lag > 0.2) if true_lag > 0.1 else (lag < 0.05)
    assert replays <= 60 + 16
    np.testing.assert_array_equal(fitted.params.effect("hysteresis").response_time, lag)
    # the model's Coulomb forces are its generator's, and stay so within 3 %
    np.testing.assert_allclose(factors, 1.0, atol=0.03)
    assert pooled_gap(plant_held_out_gap(fitted, signals, split, robot)) < \
        pooled_gap(plant_held_out_gap(model, signals, split, robot))


def test_a_lag_fitting_score_fits_only_a_model_with_a_hysteresis_and_scores_the_rest_as_without(monkeypatch):
    import studies.common.plant_scoring as scoring

    dataset, generator = generate_measured(("backlash",), seed=0, duration=10.0)
    signals = MeasuredSignals.from_dataset(dataset)
    split, robot = Split.by_time(signals), RavenII(signals.arm, check_limits=False)
    plain = RavenModel(generator, np.zeros(3))
    with pytest.raises(ValueError, match="the model has no hysteresis whose lag could be fitted"):
        scoring.with_plant_friction_and_lag(plain, signals, split, robot, 5)
    result = SimpleNamespace(named_effects=("backlash",), model_before=RavenModel(generator.without("backlash"),
                                                                                  np.zeros(3)), model_after=plain)
    fitting, fixed = (score_with_plant(result, signals, split, max_evaluations=5, fit_lag=f) for f in (True, False))
    assert fitting.fits_lag and not fixed.fits_lag and fitting.hysteresis_lag is None
    assert fitting.shrink == fixed.shrink and fitting.replays == fixed.replays
    assert fitting.document()["fits_lag"] and fitting.document()["hysteresis_lag_s"] is None
    # a final model with a hysteresis gets its lag fitted, beside the friction, and the score says which
    lagged = RavenModel(generator.with_effect(replace(generator.effect("hysteresis"), enabled=True)), np.zeros(3))
    seen = []

    def lag_fit(model, signals, split, robot, max_evaluations):
        seen.append(max_evaluations)
        return model, np.ones(3), 0.123, 7

    monkeypatch.setattr(scoring, "with_plant_friction_and_lag", lag_fit)
    # fitting the lag is the default
    score = score_with_plant(replace_result(result, model_after=lagged), signals, split, max_evaluations=6)
    assert score.hysteresis_lag == 0.123 and seen == [9]
    assert score.document()["hysteresis_lag_s"] == 0.123
    # the oracle is scored as the blind analysis was: with its lag fitted where the blind score fitted one
    seen.clear()
    scoring.score_oracle_with_plant(SimpleNamespace(model_after=lagged), score, signals, split, max_evaluations=4)
    assert seen == [6]
    scoring.score_oracle_with_plant(SimpleNamespace(model_after=lagged), fixed, signals, split, max_evaluations=4)
    assert seen == [6]


def replace_result(result, **changes):
    return SimpleNamespace(**{**vars(result), **changes})


def test_a_refit_with_a_fitted_lag_carries_it_to_the_model_it_scored():
    from simulation.discrepancy import candidates
    from studies.common.plant_scoring import with_refit

    signals = _signals()
    model = RavenModel(nominal_parameters("left"), np.zeros(3))
    refitted = {"hysteresis": {"stiffness": [10.0, 4.0, 200.0], "width": [3e-3, 4e-3, 1e-4], "shape": [0.3] * 3}}
    common = dict(applies=True, effects=("hysteresis",), gap_after=np.ones(3), shrink=0.5, fitted=refitted,
                  refitted=refitted, friction_factors=np.array([1.0, 1.1, 0.9]), replays=10)
    lagged = with_refit(model, PlantRefit(hysteresis_lag=0.2, **common), signals)
    np.testing.assert_array_equal(lagged.params.effect("hysteresis").response_time, 0.2)
    as_candidate = with_refit(model, PlantRefit(**common), signals)
    np.testing.assert_array_equal(as_candidate.params.effect("hysteresis").response_time,
                                  candidates.HYSTERESIS_RESPONSE_TIME)
    assert candidates.HYSTERESIS_RESPONSE_TIME == 0.1  # round, and not the simulator's 0.05 s
    np.testing.assert_allclose(lagged.params.effect("hysteresis").stiffness, [10.0, 4.0, 200.0])
    assert PlantRefit(hysteresis_lag=0.2, **common).document()["hysteresis_lag_s"] == 0.2


def test_a_lag_the_bounded_search_steps_a_rounding_error_past_zero_is_held_at_zero(monkeypatch):
    # Powell's bounded search evaluated a lag of -2.8e-18 s at the range's lower end (seed 98),
    # which the hysteresis refuses as negative
    import studies.common.plant_scoring as scoring

    model = RavenModel(nominal_parameters("left"), np.zeros(3))
    model = model.with_effect(replace(model.params.effect("hysteresis"), enabled=True))
    assert scoring.with_lag(model, -2.77555756e-18).params.effect("hysteresis").response_time.tolist() == [0.0] * 3
    assert scoring.with_lag(model, 0.7).params.effect("hysteresis").response_time.tolist() == [0.5] * 3

    weighed_by = []

    def plant_fit(model, build, start, bounds, *args):
        weighed_by.append(model.params.effect("hysteresis").response_time.tolist())
        build(np.r_[-2.77555756e-18 / scoring.HYSTERESIS_LAG_START, start[1:]])
        return np.r_[-2.77555756e-18 / scoring.HYSTERESIS_LAG_START, start[1:]], 1

    monkeypatch.setattr(scoring, "plant_fit", plant_fit)
    _, _, lag, _ = scoring.with_plant_friction_and_lag(scoring.with_lag(model, 0.05), _signals(), None, None, 5)
    assert lag == 0.0
    # the search weighs the joints under its own starting lag, not the model's (the candidate's constant)
    assert weighed_by == [[scoring.HYSTERESIS_LAG_START] * 3]


@pytest.mark.parametrize("fits_lag", [True, False])
def test_the_refit_fits_the_lag_of_a_hysteresis_only_where_its_score_fitted_one(monkeypatch, fits_lag):
    import studies.common.plant_scoring as scoring
    from simulation.discrepancy.candidates import HYSTERESIS_RESPONSE_TIME

    signals = _signals()
    params = nominal_parameters("left")
    params = params.with_effect(replace(params.effect("hysteresis"), enabled=True, stiffness=[10.0, 4.0, 200.0],
                                        response_time=0.07))
    result = SimpleNamespace(named_effects=("hysteresis",), model_after=RavenModel(params, np.zeros(3)))
    score = PlantScore(applies=True, gap_before=np.array([2e-4, 1e-4, 3e-6]), gap_after=np.ones(3), shrink=0.5,
                       fits_lag=fits_lag, hysteresis_lag=0.03 if fits_lag else None)
    seen = {}

    def plant_fit(model, build, start, bounds, *args):
        seen["start"], seen["bounds"] = start, bounds
        seen["weighed at"] = model.params.effect("hysteresis").response_time.tolist()
        x = np.array(start, dtype=float)
        if fits_lag:
            x[-1] = 0.25 / scoring.HYSTERESIS_LAG_START
        seen["built"] = build(x)
        return x, 3

    monkeypatch.setattr(scoring, "plant_fit", plant_fit)
    monkeypatch.setattr(scoring, "plant_held_out_gap", lambda *args: np.full(3, 1e-4))
    refit = refit_with_plant(result, signals, Split.by_time(signals), score)
    # nine hysteresis values and three friction factors, and the lag where the score fitted one
    assert len(seen["start"]) == len(seen["bounds"]) == 9 + 3 + fits_lag
    np.testing.assert_array_equal(seen["start"][9:12], 1.0)
    if fits_lag:
        assert seen["start"][-1] * scoring.HYSTERESIS_LAG_START == pytest.approx(0.03)
        assert seen["bounds"][-1] == (0.0, 5.0)
        assert refit.hysteresis_lag == pytest.approx(0.25)
    else:
        assert refit.hysteresis_lag is None
    # rebuilt through the candidate: the fitted lag, or the candidate's constant where none was fitted
    np.testing.assert_allclose(seen["built"].params.effect("hysteresis").response_time,
                               0.25 if fits_lag else HYSTERESIS_RESPONSE_TIME)
    # weighed under the lag it starts from: the score's fitted one, or the model's own where none was fitted
    np.testing.assert_allclose(seen["weighed at"], 0.03 if fits_lag else 0.07)
    np.testing.assert_array_equal(refit.friction_factors, 1.0)
