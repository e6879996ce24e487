"""The hysteresis amplitude study: what it reads from a report, its rank correlations, its refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest

from studies.discrepancy_hysteresis_amplitude import hysteretic_amplitude, main, rank_correlations, read_run

TRUE_HYSTERESIS = {"stiffness": [12.0, 4.0, 200.0], "width": [1 / 340, 1 / 250, 1 / 12000],
                   "shape": [140 / 340, 100 / 250, 4700 / 12000]}
TRUE_CABLE = [38.7, 14.3, 2095.0]


def _report(elbow_scale=1.0, shrink=0.8, plant_bound=0.87, scored_by="plant replay", seed=1):
    """A --hidden-effect hysteresis report: the fitted hysteresis the generator's with the elbow's
    stiffness times ``elbow_scale``, the base's cable stiffness 1 % over the generator's."""
    fitted = {k: list(v) for k, v in TRUE_HYSTERESIS.items()}
    fitted["stiffness"][1] *= elbow_scale
    return {"seed": seed, "joints": ["shoulder", "elbow", "z_ins"], "shrink": shrink, "scored_by": scored_by,
            "plant_floor_bound": plant_bound, "floor_bound": 0.79, "hidden_effect": ["hysteresis"],
            "named_effects": ["hysteresis"], "fitted_parameters": {"hysteresis": fitted},
            "true_parameters": {"hysteresis": TRUE_HYSTERESIS},
            "starting_parameters": {"final": {"cable_stretch": {"stiffness": [1.01 * k for k in TRUE_CABLE]}}},
            "true_starting_parameters": {"cable_stretch": {"stiffness": TRUE_CABLE}}}


def _write(folder, report):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "report.json").write_text(json.dumps(report))
    return folder


def test_the_amplitude_is_where_an_integrated_bouc_wen_loop_saturates():
    # dz = ds - beta |ds| z - gamma ds |z| driven by a stretch swinging ten yield widths each way
    stiffness, width, shape = 4.0, 0.004, 0.4
    beta, gamma = 1 / width, shape / width
    stretch = 10 * width * np.sin(np.linspace(0, 6 * np.pi, 600_001))
    z, largest = 0.0, 0.0
    for ds in np.diff(stretch):
        z += ds - beta * abs(ds) * z - gamma * ds * abs(z)
        largest = max(largest, abs(z))
    amplitude = hysteretic_amplitude({"stiffness": [stiffness], "width": [width], "shape": [shape]})
    assert stiffness * largest == pytest.approx(amplitude[0], rel=1e-3)
    assert amplitude[0] == pytest.approx(stiffness / (beta + gamma))


def test_a_report_gives_its_shortfall_in_points_and_each_error_as_a_fraction(tmp_path):
    run = read_run(_write(tmp_path / "run", _report(elbow_scale=1.25, shrink=0.80, plant_bound=0.87)))
    assert run.shortfall == pytest.approx(7.0)
    assert run.joints == ("shoulder", "elbow", "z_ins") and run.seed == 1
    # the amplitude is linear in the stiffness: 25 % more on the elbow, the others exact
    np.testing.assert_allclose(run.errors["amplitude"], [0.0, 0.25, 0.0], atol=1e-12)
    np.testing.assert_allclose(run.errors["stiffness"], [0.0, 0.25, 0.0], atol=1e-12)
    np.testing.assert_allclose(run.errors["cable_stiffness"], [0.01] * 3, atol=1e-12)
    # a run scored quasi-statically is held to the quasi-static floor's bound
    quasi_static = read_run(_write(tmp_path / "qs", _report(shrink=0.75, scored_by="quasi-static replay")))
    assert quasi_static.shortfall == pytest.approx(4.0)


def test_the_shortfall_ranks_with_the_error_that_grows_with_it_and_against_the_one_that_falls(tmp_path):
    runs = [read_run(_write(tmp_path / f"run{k}", _report(elbow_scale=1 + 0.1 * k, shrink=0.85 - 0.02 * k)))
            for k in range(4)]
    ranks = rank_correlations(runs)
    assert ranks["amplitude"][1] == pytest.approx(1.0) and ranks["stiffness"][1] == pytest.approx(1.0)
    reversed_runs = [read_run(_write(tmp_path / f"rev{k}",
                                     _report(elbow_scale=1 + 0.1 * k, shrink=0.75 + 0.02 * k))) for k in range(4)]
    assert rank_correlations(reversed_runs)["amplitude"][1] == pytest.approx(-1.0)
    assert rank_correlations(runs[:2]) is None
    # an error that is the same on every run (the shoulder's, the cable's) has no rank to compare
    assert ranks["amplitude"][0] is None and ranks["cable_stiffness"] == [None, None, None]


def test_the_command_prints_every_run_and_writes_the_correlations(tmp_path, capsys):
    folders = [_write(tmp_path / f"run{k}", _report(elbow_scale=1 + 0.1 * k, shrink=0.85 - 0.02 * k, seed=k))
               for k in range(3)]
    out = main([*map(str, folders), "--out", str(tmp_path / "amplitude.json")])
    text = capsys.readouterr().out
    assert "| 0 | 2.0 |" in text and "| 2 | 6.0 |" in text and "Spearman with the shortfall" in text
    written = json.loads((tmp_path / "amplitude.json").read_text())
    assert written["spearman"]["amplitude"][1] == pytest.approx(1.0) == out["spearman"]["amplitude"][1]
    assert [r["seed"] for r in written["runs"]] == [0, 1, 2]
    assert written["spearman"]["amplitude"][0] is None and "| - |" in text


def _blind(report):
    return {k: v for k, v in report.items() if k not in ("true_parameters", "hidden_effect")}


@pytest.mark.parametrize("edit, message", [
    (_blind, "is a blind report: it holds no generator values"),
    (lambda r: {**r, "true_parameters": {"backlash": {}}, "hidden_effect": ["backlash"]},
     "no hysteresis was hidden (hidden: backlash)"),
    (lambda r: {**r, "fitted_parameters": {}, "named_effects": []}, "the analysis named no hysteresis (named: nothing)"),
    (lambda r: {**r, "plant_floor_bound": None}, "holds no floor bound for the replay that scored it"),
    (lambda r: {k: v for k, v in r.items() if k != "shrink"}, "is not a discrepancy run's report (no 'shrink')"),
    (lambda r: {k: v for k, v in r.items() if k != "starting_parameters"},
     "is not a complete --hidden-effect report (KeyError: 'starting_parameters')"),
    (lambda r: {**r, "true_starting_parameters": {"cable_stretch": {"stiffness": [1.0, 0.0, 1.0]}}},
     "the cable stiffness is not finite or the generator's is 0"),
])
def test_a_report_that_holds_no_named_generated_hysteresis_is_refused_in_one_line(tmp_path, capsys, edit, message):
    folder = _write(tmp_path / "run", edit(_report()))
    with pytest.raises(SystemExit) as exit_info:
        main([str(folder)])
    lines = capsys.readouterr().err.strip().splitlines()
    assert exit_info.value.code == 2 and len(lines) == 1 and message in lines[0], lines


def test_a_missing_corrupt_or_empty_input_is_refused_in_one_line(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "corrupt.json").write_text("{not json")
    for argument, message in ((tmp_path / "missing", "no file or folder"), (tmp_path / "empty", "holds no report.json"),
                              (tmp_path / "corrupt.json", "is not a readable report (JSONDecodeError)")):
        with pytest.raises(SystemExit) as exit_info:
            main([str(argument)])
        lines = capsys.readouterr().err.strip().splitlines()
        assert exit_info.value.code == 2 and len(lines) == 1 and message in lines[0], lines
