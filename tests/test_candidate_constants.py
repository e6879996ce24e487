"""No fixed constant of a library candidate is a value the simulator generates with.

A candidate builds a simulator effect from the values it fits; every other field of that effect is
a constant the candidate chooses. Were such a constant the simulator's default, the workflow would
be handed a value of the generator, and its fit of that effect on generated data would be built
in, not measured (issue 13, item 2).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simulation.discrepancy.candidates import HYSTERESIS_RESPONSE_TIME, raven_candidates
from simulation.discrepancy.replay import RavenModel
from simulation.identification import nominal_parameters
from raven_signals import near_still_signals

UNIT_CONVENTIONS = {("drift", "time_scale")}
"""Fields that state a unit, not a property of the robot: a drift candidate's clock runs at the
log's own time (one hour per hour), as the simulator's does unless a test compresses it."""


def _built_effects(candidate, model):
    """The effect ``candidate`` builds at two points of its search range, or None where it builds no
    simulator effect (per-homing offsets, the payload)."""
    lower, upper, _, _ = candidate.bounds()
    built = [candidate.apply(model, lower + share * (upper - lower)).params for share in (0.3, 0.6)]
    if candidate.name not in built[0].enabled_effects:
        return None
    return tuple(params.effect(candidate.name) for params in built)


def _fixed_fields(first, second):
    """The fields of an effect that the candidate's fitted values do not move."""
    return [f.name for f in dataclasses.fields(first)
            if f.name != "enabled" and np.array_equal(getattr(first, f.name), getattr(second, f.name))]


def _effects_of_the_library():
    model = RavenModel(nominal_parameters("left"), np.zeros(3))
    return {c.name: _built_effects(c, model) for c in raven_candidates(near_still_signals(homings=2))}


EFFECTS = _effects_of_the_library()


@pytest.mark.parametrize("name", [name for name, effects in EFFECTS.items() if effects is not None])
def test_no_fixed_constant_of_a_candidate_is_the_simulators_default(name):
    effects = EFFECTS[name]
    default = type(effects[0])()
    shared = [field for field in _fixed_fields(*effects)
              if (name, field) not in UNIT_CONVENTIONS
              and np.any(np.asarray(getattr(effects[0], field)) == np.asarray(getattr(default, field)))]
    assert not shared, f"{name} fixes {shared} at the simulator's default"


def test_the_fixed_fields_found_are_those_the_candidates_choose():
    # the check above reads the candidates' constants where they are: were a constant missed (or a
    # fitted value taken for one), the test would pass while checking nothing
    assert {name for name, effects in EFFECTS.items() if effects is None} == {
        "homing_offset", "registration_offset", "payload"}
    fixed = {name: _fixed_fields(*effects) for name, effects in EFFECTS.items() if effects is not None}
    assert fixed["hysteresis"] == ["response_time"]
    assert fixed["coulomb_friction"] == ["velocity_scale"]
    assert fixed["drift"] == ["payload_gain", "reference_speed", "time_scale"]
    assert fixed["capstan_friction"] == ["wrap_angle"]
    assert fixed["backlash"] == fixed["transmission_error"] == fixed["coupling"] == []
    np.testing.assert_array_equal(EFFECTS["hysteresis"][0].response_time, HYSTERESIS_RESPONSE_TIME)
