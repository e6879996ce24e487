"""The model-discrepancy workflow: hidden effects are found, nothing is invented, gaps shrink.

Each hidden-effect test generates "measured" data with the virtual RAVEN-II, starts from the
nominal structure without the hidden effect, identified from the data itself, and checks what the
workflow names and how much of the held-out gap it closes. Short records (120 s) keep the suite
fast; ``python studies/discrepancy.py --sweep`` runs the seeds sweep.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from simulation.discrepancy import (
    LIBRARY_NAMES,
    MeasuredSignals,
    NominalModel,
    Split,
    localize,
    strongest_dependence,
)
from simulation.discrepancy.signals import pooled_rmse
from studies.common.discrepancy_runs import run_hidden_effect, run_on_generic

DURATION = 120.0


@pytest.fixture(scope="module")
def results():
    """Memoised workflow runs on generated data, keyed by the hidden effects."""
    cache = {}

    def run(*hidden):
        if hidden not in cache:
            result, signals, split, generator = run_hidden_effect(hidden, seed=0, duration=DURATION)
            cache[hidden] = (result, signals, split, generator)
        return cache[hidden]

    return run


@pytest.mark.parametrize("effect", ["coulomb_friction", "viscous_friction", "gravity_stretch", "coupling", "drift"])
def test_a_hidden_effect_is_named_and_closes_at_least_half_the_held_out_gap(results, effect):
    result, *_ = results(effect)
    assert result.named_effects[:1] == (effect,), result.named_effects
    assert result.shrink >= 0.5, result.shrink
    assert not result.unexplained
    # the reported shrink is the pooled held-out RMSE with rad in degrees and m in millimetres
    before = pooled_rmse(result.residual_before.joints, result.units)
    after = pooled_rmse(result.residual_after.joints, result.units)
    assert result.shrink == pytest.approx(1.0 - after / before)
    assert np.sqrt(np.mean(result.residual_before.joints ** 2, axis=0)) == pytest.approx(result.gap_before)


@pytest.mark.parametrize("effect", ["backlash", "hysteresis"])
def test_look_alike_effects_are_told_apart_by_name(results, effect):
    # backlash and hysteresis both lag the joint behind reversals; the identified starting model
    # absorbs part of them into its friction, so the shrink is smaller, but the name must be right
    result, *_ = results(effect)
    assert result.named_effects[:1] == (effect,), result.named_effects
    assert result.shrink > 0.2, result.shrink


def test_nothing_hidden_names_nothing(results):
    result, *_ = results()
    assert result.named_effects == ()
    assert not result.unexplained
    assert result.shrink == pytest.approx(0.0)
    # the identified nominal model already reproduces the data to the encoders' resolution
    assert np.all(result.gap_before < np.array([2e-4, 2e-4, 1e-5])), result.gap_before


def test_two_hidden_effects_are_named_in_two_iterations(results):
    result, *_ = results("backlash", "coulomb_friction")
    assert set(result.named_effects) == {"backlash", "coulomb_friction"}, result.named_effects
    named_per_iteration = [it.named for it in result.iterations if it.named is not None]
    assert len(named_per_iteration) == 2
    assert result.shrink >= 0.5


def test_an_effect_missing_from_the_library_is_reported_unexplained(results):
    assert "capstan_runout" not in LIBRARY_NAMES
    result, *_ = results("capstan_runout")
    assert result.unexplained
    assert result.named_effects == () or result.shrink < 0.5, result.named_effects


def test_the_report_of_a_run_has_the_documented_keys(tmp_path, results):
    from studies.discrepancy import write_report

    result, signals, split, _ = results("coupling")
    paths = write_report(result, signals, split, {"description": "test"}, tmp_path, runtime_s=1.0)
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["named_effects"] == ["coupling"]
    assert report["unexplained"] is False
    assert len(report["gap_before"]) == 3 and len(report["gap_after"]) == 3
    np.testing.assert_allclose(report["gap_before"], result.gap_before)
    assert report["shrink"] == pytest.approx(result.shrink)
    assert "coupling" in report["fitted_parameters"]
    assert (tmp_path / "report.md").read_text().startswith("# Model discrepancy")
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)
    assert {p.suffix for p in paths} >= {".json", ".md", ".png"}


def _generic_record(seed=0, n=3000):
    rng = np.random.default_rng(seed)
    time = np.arange(n) * 0.01
    phases = rng.uniform(0, 2 * np.pi, size=2)
    reported = np.column_stack([0.3 * np.sin(0.7 * time + phases[0]) + 0.1 * np.sin(2.3 * time),
                                0.2 * np.sin(0.5 * time + phases[1]) + 0.05 * np.sin(3.1 * time)])
    return time, reported, rng


def test_generic_data_with_a_dead_band_names_backlash():
    # a robot known only by reported and measured joints: the measured joint trails the reported
    # one by a play of 0.5 deg that reverses with the motion (plus encoder noise)
    from simulation.discrepancy.replay import play_series

    time, reported, rng = _generic_record()
    half = np.deg2rad([0.5, 0.3])
    truth = np.column_stack([play_series(np.ascontiguousarray(reported[:, j]), half[j]) for j in range(2)])
    truth = truth + 0.01 + rng.normal(0, 1e-4, truth.shape)
    result, _, _ = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    assert result.named_effects[:1] == ("backlash",), result.named_effects
    assert result.shrink >= 0.8
    np.testing.assert_allclose(result.fitted_parameters["backlash"]["half_width"], half, rtol=0.1)


def test_localization_finds_a_residual_that_flips_with_direction():
    time, reported, rng = _generic_record(seed=1)
    signals = MeasuredSignals.generic(time, reported, reported, ("a", "b"), ("rad", "rad"))
    residual = np.column_stack([np.deg2rad(0.2) * np.sign(signals.velocity[:, 0]), rng.normal(0, 1e-5, len(time))])
    table = localize(signals, residual)
    spread = strongest_dependence(table).set_index(["joint", "variable"])["spread of bin means"]
    assert spread["a", "direction"] == pytest.approx(0.4, rel=0.05)  # degrees, -0.2 to +0.2
    assert spread["a", "direction"] > 5 * spread["a", "position"]
    assert spread["b", "direction"] < 0.01
    means = table[(table.joint == "a") & (table.variable == "direction")].set_index("bin")["mean"]
    assert means["moving up"] == pytest.approx(0.2, rel=0.05)
    assert means["moving down"] == pytest.approx(-0.2, rel=0.05)


def test_the_nominal_generic_model_replays_reported_plus_offsets():
    time, reported, _ = _generic_record()
    signals = MeasuredSignals.generic(time, reported, reported + 0.1, ("a", "b"), ("rad", "m"))
    model = NominalModel(offsets=np.array([0.1, 0.1]))
    np.testing.assert_allclose(model.replay(signals).joints, signals.truth)


@pytest.mark.parametrize("change, message", [
    (lambda t, r, y: (t, r[:, :1], y), "reported must have shape"),
    (lambda t, r, y: (t, r, np.where(np.arange(len(t))[:, None] == 7, np.nan, y)), "truth is not finite at sample 7"),
    (lambda t, r, y: (t[::-1].copy(), r, y), "time must increase strictly"),
    (lambda t, r, y: (t[:5], r[:5], y[:5]), "at least 20 samples"),
])
def test_bad_generic_input_is_refused_with_the_problem_named(change, message):
    time, reported, _ = _generic_record(n=200)
    t, r, y = change(time, reported, reported.copy())
    with pytest.raises(ValueError, match=message):
        MeasuredSignals.generic(t, r, y, ("a", "b"), ("rad", "rad"))


def test_overlapping_split_parts_are_refused():
    n = 100
    first = np.arange(n) < 60
    with pytest.raises(ValueError, match="must not overlap"):
        Split(fit=first, validation=np.arange(n) >= 50, held_out=np.zeros(n, dtype=bool))


def test_the_command_line_refuses_an_unknown_effect_and_a_missing_path(tmp_path, capsys):
    from studies.discrepancy import main

    with pytest.raises(SystemExit):
        main(["--hidden-effect", "cable_wobble", "--out", str(tmp_path)])
    assert "unknown hidden effect 'cable_wobble'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        main(["--measured", str(tmp_path / "absent"), "--out", str(tmp_path)])
    assert exit_info.value.code == 2 and "no file or folder" in capsys.readouterr().err
