"""Scaling the physics outside the filter's model class, and the model-mismatch study's arithmetic."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simulation.model.effects import EFFECT_NAMES
from simulation.model.mismatch import (
    FILTER_CLASS,
    MAGNITUDE_FIELDS,
    SENSOR_EFFECTS,
    out_of_class_effects,
    scale_out_of_class,
)
from simulation.model.parameters import RavenParameters
from studies.model_mismatch import crossover, interval95


@pytest.fixture(scope="module")
def everything_on():
    return RavenParameters().switched(EFFECT_NAMES, True)


def test_every_effect_is_in_the_filter_class_a_sensor_or_scaled():
    assert set(FILTER_CLASS) | set(SENSOR_EFFECTS) | set(MAGNITUDE_FIELDS) == set(EFFECT_NAMES)
    assert not set(FILTER_CLASS) & set(MAGNITUDE_FIELDS)


def test_lam_one_is_the_given_robot(everything_on):
    assert scale_out_of_class(everything_on, 1.0) == everything_on
    assert scale_out_of_class(RavenParameters(), 1) == RavenParameters()


def test_lam_zero_leaves_only_the_filter_class_and_the_sensors(everything_on):
    bare = scale_out_of_class(everything_on, 0.0)
    assert set(bare.enabled_effects) == set(FILTER_CLASS) | set(SENSOR_EFFECTS)
    for name in (*FILTER_CLASS, *SENSOR_EFFECTS):
        assert bare.effect(name) == everything_on.effect(name)


@pytest.mark.parametrize("lam", [0.25, 0.5, 2.0])
def test_magnitudes_scale_linearly_and_shapes_stay(everything_on, lam):
    scaled = scale_out_of_class(everything_on, lam)
    for name in out_of_class_effects(everything_on):
        before, after = everything_on.effect(name), scaled.effect(name)
        assert after.enabled
        for f in dataclasses.fields(before):
            if f.name in ("enabled",):
                continue
            old, new = np.asarray(getattr(before, f.name), float), np.asarray(getattr(after, f.name), float)
            expected = old * lam if f.name in MAGNITUDE_FIELDS[name] else old
            np.testing.assert_allclose(new, expected, rtol=1e-12, err_msg=f"{name}.{f.name}")
    for name in FILTER_CLASS:
        assert scaled.effect(name) == everything_on.effect(name)


def test_switched_off_effects_stay_off():
    robot = RavenParameters().switched(["backlash"], False)
    assert not scale_out_of_class(robot, 2.0).is_enabled("backlash")


@pytest.mark.parametrize("lam, message", [(-0.5, "lam must be finite and >= 0"), (float("nan"), "lam must be finite"),
                                          (float("inf"), "lam must be finite"), ("1", "lam must be a number"),
                                          (True, "lam must be a number")])
def test_bad_lam_is_refused(lam, message):
    with pytest.raises(ValueError, match=message):
        scale_out_of_class(RavenParameters(), lam)


def test_a_lam_that_leaves_the_gearbox_transmitting_nothing_is_refused(everything_on):
    loss = float(np.max(everything_on.effect("motor_friction").gearbox_loss))
    with pytest.raises(ValueError, match="gearbox loss reach 1"):
        scale_out_of_class(everything_on, 1.0 / loss)


def test_crossover_interpolates_where_the_learned_error_meets_the_filters():
    lams = np.array([0.0, 1.0, 2.0])
    assert crossover(lams, [0.3, 0.3, 0.3], [0.1, 0.2, 0.4]) == pytest.approx(1.5)
    assert crossover(lams, [0.3, 0.3, 0.3], [0.1, 0.2, 0.25]) is None
    assert crossover(lams, [0.1, 0.3, 0.3], [0.2, 0.2, 0.2]) is None
    assert crossover(lams, [0.1, 0.1, 0.1], [0.2, 0.2, 0.2]) == 0.0
    assert crossover(lams, [0.3, np.nan, 0.3], [0.1, 0.2, 0.4]) is None
    # a filter that is worse at one lam only does not count as overtaken before it is for good
    four = np.array([0.0, 0.5, 1.0, 2.0])
    assert crossover(four, [0.3, 0.3, 0.3, 0.3], [0.1, 0.9, 0.2, 0.5]) == pytest.approx(1.0 + 1.0 / 3.0)


def test_interval_is_the_student_t_interval():
    from scipy import stats

    rows = np.array([[1.0, 2.0], [1.2, 2.6], [0.9, 2.2], [1.1, 2.4]])
    got = interval95(rows)
    for j in range(2):
        expected = stats.t.interval(0.95, 3, loc=rows[:, j].mean(), scale=stats.sem(rows[:, j]))
        np.testing.assert_allclose(got[j], expected, rtol=1e-12)
