"""Robot parameter sets as dictionaries and JSON files: exact round trips, clear refusals, defaults."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from simulation import default_fit
from simulation.model.constants import RavenConstants
from simulation.model.effects import EFFECT_NAMES, EFFECT_TYPES
from simulation.model.parameters import RavenParameters

SEEDS = range(12)


def _random_like(default, rng: np.random.Generator):
    """A random value of the same kind and size as a field's default (positive numbers, many magnitudes)."""
    if isinstance(default, bool):
        return bool(rng.integers(2))
    if isinstance(default, str):
        return default
    if isinstance(default, (np.ndarray, tuple)):
        values = 10.0 ** rng.uniform(-9, 4, size=np.size(default)) * rng.uniform(1, 2, size=np.size(default))
        return tuple(values) if isinstance(default, tuple) else values
    return float(10.0 ** rng.uniform(-6, 4) * rng.uniform(1, 2))


def _randomized(obj, rng: np.random.Generator):
    changes = {f.name: _random_like(getattr(obj, f.name), rng) for f in dataclasses.fields(obj) if f.init}
    return dataclasses.replace(obj, **changes)


def random_parameters(seed: int) -> RavenParameters:
    """Every effect switched on or off at random, every array and scalar random, either arm."""
    rng = np.random.default_rng(seed)
    arm = ("left", "right")[seed % 2]
    effects = tuple(_randomized(t(), rng) for t in EFFECT_TYPES)
    gravity = None if seed % 3 == 0 else tuple(rng.normal(0.0, 5.0, size=3))
    return RavenParameters(arm=arm, constants=_randomized(RavenConstants(arm=arm), rng), effects=effects,
                           gravity=gravity)


def _walk(value):
    if isinstance(value, dict):
        for v in value.values():
            yield from _walk(v)
    elif isinstance(value, list):
        for v in value:
            yield from _walk(v)
    else:
        yield value


# --- round trips ---------------------------------------------------------------------------------


@pytest.mark.parametrize("arm", ["left", "right"])
def test_default_round_trip(arm):
    params = RavenParameters(arm=arm)
    data = params.to_dict()
    assert data["arm"] == arm and data["constants"]["arm"] == arm
    assert list(data["effects"]) == list(EFFECT_NAMES)
    assert data["effects"]["cable_stretch"]["enabled"] is True
    assert data["effects"]["cable_stretch"]["stiffness"] == params.effect("cable_stretch").stiffness.tolist()
    assert data["gravity"] is None
    assert RavenParameters.from_dict(data) == params


def test_to_dict_is_plain_json():
    data = random_parameters(1).to_dict()
    for leaf in _walk(data):
        assert leaf is None or type(leaf) in (bool, str, float), type(leaf)
    json.dumps(data, allow_nan=False)


@pytest.mark.parametrize("seed", SEEDS)
def test_randomized_round_trip(seed):
    params = random_parameters(seed)
    back = RavenParameters.from_dict(params.to_dict())
    assert back == params
    assert hash(back) == hash(params)
    for name in EFFECT_NAMES:
        assert back.is_enabled(name) == params.is_enabled(name)
        for field, value in params.effect(name).parameters().items():
            assert np.array_equal(getattr(back.effect(name), field), value)
    for f in dataclasses.fields(RavenConstants):
        assert np.array_equal(getattr(back.constants, f.name), getattr(params.constants, f.name))
    assert back.gravity == params.gravity


@pytest.mark.parametrize("seed", SEEDS)
def test_json_text_round_trip_is_exact(seed):
    params = random_parameters(seed)
    assert RavenParameters.from_dict(json.loads(json.dumps(params.to_dict()))) == params


def test_awkward_floats_survive_json_text():
    values = np.array([0.1 + 0.2, 1.0 / 3.0, np.nextafter(1.0, 2.0)])
    tiny = np.array([5e-324, np.nextafter(0.0, 1.0) * 3, 1.7976931348623157e308 / 1e300])
    params = RavenParameters().with_effect(
        RavenParameters().effect("cable_stretch").replace(stiffness=values, hardening=tiny))
    back = RavenParameters.from_dict(json.loads(json.dumps(params.to_dict())))
    assert back.effect("cable_stretch").stiffness.tobytes() == values.tobytes()
    assert back.effect("cable_stretch").hardening.tobytes() == tiny.tobytes()


@pytest.mark.parametrize("seed", range(4))
def test_json_file_round_trip(tmp_path, seed):
    params = random_parameters(seed)
    path = tmp_path / "robot.json"
    assert params.to_json(path) == path
    assert RavenParameters.from_json(path) == params
    assert RavenParameters.from_json(str(path)) == params
    RavenParameters().to_json(path)  # replaces the earlier file
    assert RavenParameters.from_json(path) == RavenParameters()
    assert [p.name for p in tmp_path.iterdir()] == ["robot.json"]


def test_to_json_missing_folder_names_the_file(tmp_path):
    with pytest.raises(FileNotFoundError, match="robot.json"):
        RavenParameters().to_json(tmp_path / "absent" / "robot.json")


# --- equality ------------------------------------------------------------------------------------


def test_equality_compares_arrays_exactly():
    params = RavenParameters()
    stiffness = params.effect("cable_stretch").stiffness.copy()
    stiffness[1] = np.nextafter(stiffness[1], np.inf)
    other = params.with_effect(params.effect("cable_stretch").replace(stiffness=stiffness))
    assert RavenParameters() == params
    assert other != params
    assert params.without("noise") != params
    assert RavenParameters(arm="right") != params
    assert RavenParameters(gravity=(0.0, 0.0, -9.81)) != params
    assert params != params.to_dict()


def test_missing_effect_equals_switched_off_default():
    params = RavenParameters(effects=tuple(t() for t in EFFECT_TYPES if t.name != "backlash"))
    assert params == RavenParameters().without("backlash")
    assert RavenParameters.from_dict(params.to_dict()) == params


# --- partial dictionaries --------------------------------------------------------------------------


def test_empty_dict_is_the_virtual_raven():
    assert RavenParameters.from_dict({}) == RavenParameters()
    assert RavenParameters.from_dict({"arm": "right"}) == RavenParameters(arm="right")


def test_partial_dict_takes_defaults():
    params = RavenParameters.from_dict({
        "effects": {"cable_stretch": {"stiffness": [10.0, 20.0, 300.0]}, "noise": {"enabled": False}},
        "constants": {"kp": [0.2, 0.2, 0.1, 0.09, 0.05, 0.05, 0.05]},
    })
    default = RavenParameters()
    law = params.effect("cable_stretch")
    assert law.enabled and np.array_equal(law.stiffness, [10.0, 20.0, 300.0])
    assert np.array_equal(law.hardening, default.effect("cable_stretch").hardening)
    assert not params.is_enabled("noise")
    assert np.array_equal(params.effect("noise").current_noise, default.effect("noise").current_noise)
    assert np.array_equal(params.constants.kp, [0.2, 0.2, 0.1, 0.09, 0.05, 0.05, 0.05])
    assert np.array_equal(params.constants.kd, default.constants.kd)
    expected = default.with_effect(law).without("noise")
    expected = dataclasses.replace(expected, constants=params.constants)
    assert params == expected


def test_integers_are_numbers():
    params = RavenParameters.from_dict({"effects": {"cable_stretch": {"damping": [1, 2, 3]}}})
    assert params.effect("cable_stretch").damping.dtype == float
    assert np.array_equal(params.effect("cable_stretch").damping, [1.0, 2.0, 3.0])


# --- refusals ------------------------------------------------------------------------------------


def _with(path: tuple, value) -> dict:
    data = RavenParameters().to_dict()
    target = data
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return data


@pytest.mark.parametrize(
    "data, message",
    [
        ({"effects": {"cable_strech": {"enabled": True}}},
         r"unknown effect 'cable_strech'.*known effects: cable_stretch"),
        ({"effects": {"cable_stretch": {"stifness": [1.0, 2.0, 3.0]}}},
         r"effects\.cable_stretch: unknown field 'stifness'; known fields: enabled, stiffness"),
        (_with(("effects", "cable_stretch", "stiffness"), [1.0, 2.0]),
         r"effects\.cable_stretch\.stiffness must be a list of 3 numbers, got 2"),
        (_with(("effects", "coulomb_friction", "force"), 0.2),
         r"effects\.coulomb_friction\.force must be a list of 3 numbers, got float"),
        (_with(("effects", "viscous_friction", "coefficient"), [0.5, float("nan"), 8.0]),
         r"effects\.viscous_friction\.coefficient\[1\] must be finite, got nan"),
        (_with(("effects", "drift", "time_scale"), float("inf")), r"effects\.drift\.time_scale must be finite"),
        (_with(("effects", "backlash", "half_width"), [4e-4, "5e-4", 2e-5]),
         r"effects\.backlash\.half_width\[1\] must be a number, got str"),
        (_with(("effects", "quantization", "motor_counts_per_rev"), "4000"),
         r"effects\.quantization\.motor_counts_per_rev must be a number, got str"),
        (_with(("effects", "noise", "truth_noise"), [True, 2e-5, 2e-6]),
         r"effects\.noise\.truth_noise\[0\] must be a number, got bool"),
        (_with(("effects", "noise", "enabled"), 1), r"effects\.noise\.enabled must be true or false, got int"),
        (_with(("effects", "noise", "enabled"), "false"), r"effects\.noise\.enabled must be true or false, got str"),
        (_with(("effects", "cable_stretch", "stiffness"), [0.0, 2.0, 3.0]),
         r"effects\.cable_stretch: cable stiffness and hardening stretch must be positive"),
        (_with(("effects", "hysteresis"), [1.0]), r"effects\.hysteresis must be an object of fields, got list"),
        (_with(("effects", "hysteresis", "response_time"), [0.05, -0.01, 0.05]),
         r"effects\.hysteresis: response_time must be non-negative"),
        (_with(("constants", "kp"), [0.3] * 6), r"constants\.kp must be a list of 7 numbers, got 6"),
        (_with(("constants", "cable_coupling"), [0.1, float("nan"), 0.0]),
         r"constants\.cable_coupling\[1\] must be finite"),
        (_with(("constants", "servo_period"), None), r"constants\.servo_period must be a number, got NoneType"),
        (_with(("constants", "bogus"), 1.0), r"constants: unknown field 'bogus'"),
        (_with(("constants", "arm"), "right"), r"constants are for the right arm, parameters for the left arm"),
        ({"arm": "right", "constants": {"arm": "left"}},
         r"constants are for the left arm, parameters for the right arm"),
        (_with(("arm",), "centre"), r"arm must be 'left' or 'right', got 'centre'"),
        (_with(("gravity",), [0.0, -9.81]), r"gravity must be a list of 3 numbers, got 2"),
        (_with(("gravity",), [0.0, 0.0, float("-inf")]), r"gravity\[2\] must be finite"),
        (_with(("payload",), 0.5),
         r"unknown robot parameter key 'payload'; known keys: arm, constants, effects, gravity"),
        (_with(("effects",), ["cable_stretch"]), r"effects must be an object keyed by effect name, got list"),
        ([1, 2, 3], r"robot parameters must be an object, got list"),
    ],
)
def test_from_dict_refuses_with_one_line(data, message):
    with pytest.raises(ValueError, match=message) as caught:
        RavenParameters.from_dict(data)
    assert "\n" not in str(caught.value)


def test_from_json_names_the_file(tmp_path):
    missing = tmp_path / "nowhere.json"
    with pytest.raises(FileNotFoundError, match="nowhere.json"):
        RavenParameters.from_json(missing)
    broken = tmp_path / "broken.json"
    broken.write_text('{"arm": "left",')
    with pytest.raises(ValueError, match=r"broken\.json: not a valid JSON parameter file"):
        RavenParameters.from_json(broken)
    twice = tmp_path / "twice.json"
    twice.write_text('{"arm": "left", "arm": "right"}')
    with pytest.raises(ValueError, match=r"twice\.json: .*'arm' appears twice"):
        RavenParameters.from_json(twice)
    nan = tmp_path / "nan.json"
    nan.write_text('{"effects": {"cable_stretch": {"damping": [1.0, NaN, 60.0]}}}')
    with pytest.raises(ValueError, match=r"nan\.json: effects\.cable_stretch\.damping\[1\] must be finite"):
        RavenParameters.from_json(nan)


# --- default_fit --out ---------------------------------------------------------------------------


def test_write_fit_writes_a_readable_parameter_set(tmp_path):
    params = random_parameters(3)
    path = default_fit.write_fit(params, tmp_path / "fitted.json")
    assert RavenParameters.from_json(path) == params


def test_out_is_checked_before_the_fit(tmp_path, monkeypatch, capsys):
    def no_fit(*args, **kwargs):
        raise AssertionError("the fit started before --out was checked")

    monkeypatch.setattr(default_fit, "fit_cable_stretch", no_fit)
    with pytest.raises(SystemExit) as caught:
        default_fit.main(["--out", str(tmp_path / "absent" / "fitted.json")])
    assert caught.value.code == 2
    assert "folder" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        default_fit.main(["--out", str(tmp_path)])
    assert "is a folder" in capsys.readouterr().err
    with pytest.raises(ValueError, match="does not exist"):
        default_fit.check_output_path(tmp_path / "absent" / "fitted.json")


def test_main_writes_what_it_fits(tmp_path, monkeypatch):
    fitted = RavenParameters().with_effect(RavenParameters().effect("cable_stretch").replace(stiffness=[1.0, 2.0, 3.0]))
    errors = default_fit.ProtocolErrors(raw=default_fit.PUBLISHED_RAW, fixed_offset=default_fit.PUBLISHED_FIXED_OFFSET,
                                        calibration=None, test=None, homing_stretch=np.zeros(3))
    monkeypatch.setattr(default_fit, "fit_cable_stretch", lambda params, seed: (fitted, errors))
    default_fit.main(["--skip-drift", "--out", str(tmp_path / "fitted.json")])
    assert RavenParameters.from_json(tmp_path / "fitted.json") == fitted


def test_help_lists_out(capsys):
    with pytest.raises(SystemExit):
        default_fit.main(["--help"])
    assert "--out FILE.json" in capsys.readouterr().out
