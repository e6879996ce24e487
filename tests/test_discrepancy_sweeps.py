"""Sweeps of the discrepancy workflow run in parts and summarised as one (``--merge-sweeps``).

The runs are written by hand (a sweep's runs take hours): what is checked is the bookkeeping, that
parts merge into exactly the table one sweep over the same runs gives, and that parts which cannot
be compared are refused with a line naming the file and what differs.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from studies.common.discrepancy_runs import LIBRARY, STARTING_STRUCTURE
from studies.common.discrepancy_sweep import summarise_sweep
from studies.discrepancy import main


def _run(hidden: str, seed: int, named=(), shrink=0.0, oracle=0.0) -> dict:
    first = named[0] if named else "none"
    return {"hidden": hidden, "seed": seed, "named_first": first, "named": list(named), "equivalent": {},
            "rivals": {}, "unexplained": False, "gap_before": 0.004 + 0.001 * seed, "shrink": shrink,
            "oracle_shrink": oracle, "residual_structure": [0.1, 0.05, 0.02],
            "oracle_residual_structure": [0.1, 0.05, 0.02], "signature": [], "command_shrink": None}


RUNS = [_run("none", 0), _run("none", 1),
        _run("backlash", 0, ("backlash",), 0.40, 0.40), _run("backlash", 1, (), 0.0, 0.35),
        _run("hysteresis", 2, ("hysteresis",), 0.70, 0.70)]


def _part(folder, runs, duration=1200.0, **changes):
    document = summarise_sweep(runs, duration, folder)
    document.update(changes)
    (folder / "confusion.json").write_text(json.dumps(document))
    return folder


def _summary_table(text: str) -> str:
    return text.split("## Per hidden effect")[1].split("## Confusion matrix")[0]


def test_parts_merge_into_the_table_of_one_sweep_over_the_same_runs(tmp_path):
    whole = summarise_sweep(RUNS, 1200.0, tmp_path / "whole")
    first = _part(tmp_path / "a", [RUNS[3], RUNS[0]])
    second = _part(tmp_path / "b", [RUNS[4], RUNS[2], RUNS[1]])
    assert main(["--merge-sweeps", str(first), str(second / "confusion.json"), "--out", str(tmp_path / "m")]) == 0
    merged = json.loads((tmp_path / "m" / "confusion.json").read_text())
    assert merged["matrix"] == whole["matrix"] and merged["runs"] == whole["runs"]
    assert merged["seeds"] == [0, 1, 2] and merged["duration_s"] == 1200.0
    assert merged["merged_from"] == [str(first / "confusion.json"), str(second / "confusion.json")]
    table = _summary_table((tmp_path / "m" / "confusion.md").read_text())
    assert table == _summary_table((tmp_path / "whole" / "confusion.md").read_text())
    # backlash named on one seed of two, hysteresis on its one: the goal is counted per effect, and
    # a miss says which part: seed 0 closes its oracle's 40 %, seed 1 none of its oracle's 35 %
    assert _cells(table, "backlash")[1] == "1 of 2" and _cells(table, "hysteresis")[1] == "1 of 1"
    assert _cells(table, "backlash")[6] == "no: named first on 1 of 2; seed 1 closes 0.0 % (oracle 35.0 %)"
    assert _cells(table, "hysteresis")[6] == "yes"


def test_runs_whose_backfit_the_cap_cut_are_counted_and_runs_recorded_before_the_count_are_not(tmp_path):
    capped = dict(_run("hysteresis", 3, ("hysteresis",), 0.72, 0.72), backfit_capped=["hysteresis"])
    kept = dict(_run("hysteresis", 4, ("hysteresis",), 0.74, 0.74), backfit_capped=[])
    summarise_sweep(RUNS + [capped, kept], 1200.0, tmp_path)
    table = _summary_table((tmp_path / "confusion.md").read_text())
    assert "| hysteresis | 3 of 3 (the backfit cut by its cap in 1) |" in table
    assert "| backlash | 1 of 2 |" in table  # no run of it says how its backfit ended


def _refused_in_one_line(first, other, named: str, tmp_path, capsys) -> None:
    """``--merge-sweeps first other`` exits with status 2, one line that contains ``named``, and no output."""
    with pytest.raises(SystemExit) as exit_info:
        main(["--merge-sweeps", str(first), str(other), "--out", str(tmp_path / "m")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert exit_info.value.code == 2
    assert len(lines) == 1 and named in lines[0], lines
    assert not (tmp_path / "m").exists()


@pytest.mark.parametrize("second, changes, named", [
    ([RUNS[2]], {}, "backlash with seed 0 is in both"),
    ([RUNS[4]], {"duration_s": 240.0}, "differs from the sweeps before it in record length or effect size"),
    ([RUNS[4]], {"size_factor": 3.0}, "size factors [1.0, 3.0]"),
    ([RUNS[4]], {"library": list(LIBRARY[:-1])}, "was swept with another library"),
    # a run without the key was swept before the lag was fitted, with the candidate's constant
    ([dict(RUNS[4], seed=5, plant_lag_fitted=True)], {}, "in how the plant scored a named hysteresis's lag"),
    ([RUNS[4]], {"starting_structure": list(STARTING_STRUCTURE) + ["drift"]}, "another starting structure"),
])
def test_parts_that_cannot_be_compared_are_refused_in_one_line(tmp_path, capsys, second, changes, named):
    first = _part(tmp_path / "a", RUNS[:3])
    other = _part(tmp_path / "b", second, **changes)
    _refused_in_one_line(first, other, named, tmp_path, capsys)


def _cells(table: str, first: str) -> list[str]:
    line = next(row for row in table.splitlines() if row.startswith(f"| {first} |"))
    return [cell.strip() for cell in line.strip("|").split("|")]


def test_the_floor_bound_is_what_the_same_seeds_none_run_leaves_of_each_gap(tmp_path):
    runs = [dict(_run("none", 0), gap_before=0.003), dict(_run("none", 1), gap_before=0.004),
            dict(_run("backlash", 0, ("backlash",), 0.45, 0.45), gap_before=0.006),
            dict(_run("backlash", 1, ("backlash",), 0.55, 0.55), gap_before=0.010, quasi_static_shrink=0.42),
            dict(_run("hysteresis", 2, ("hysteresis",), 0.70, 0.70), gap_before=0.010),
            dict(_run("hysteresis", 3, ("hysteresis",), 0.70, 0.70), gap_before=0.010, floor=0.002),
            dict(_run("drift", 0, ("drift",), 0.0, 0.0), gap_before=0.002)]
    summarise_sweep(runs, 1200.0, tmp_path)
    text = (tmp_path / "confusion.md").read_text()
    table = _summary_table(text)
    # 1 - 0.003 / 0.006 and 1 - 0.004 / 0.010; never below 0; a run that measured its floor uses it,
    # and a run recorded without one and without its seed's none run has no bound
    assert _cells(table, "backlash")[5] == "55.0 [50.0, 60.0]"
    assert _cells(table, "hysteresis")[5] == "-" and _cells(table, "none")[5] == "-"
    hysteresis_rows = [row for row in text.split("## Runs")[1].splitlines() if row.startswith("| hysteresis |")]
    assert [row.strip("|").split("|")[9].strip() for row in hysteresis_rows] == ["-", "80.0"]
    assert _cells(table, "drift")[5] == "0.0 [0.0, 0.0]"
    runs_table = text.split("## Runs")[1]
    backlash_rows = [row for row in runs_table.splitlines() if row.startswith("| backlash |")]
    assert [row.strip("|").split("|")[9].strip() for row in backlash_rows] == ["50.0", "60.0"]
    # the quasi-static shrink beside the reported one; a run recorded before the plant scored any
    # was scored quasi-statically, so its shrink is that one
    assert [row.strip("|").split("|")[8].strip() for row in backlash_rows] == ["45.0000", "42.0000"]



def test_a_run_the_plant_scored_reads_its_bound_against_the_floor_the_plant_scored(tmp_path):
    runs = [dict(_run("none", 0), gap_before=0.003, plant_floor=0.002), dict(_run("none", 1), gap_before=0.004),
            # scored by the plant: 1 - 0.002 / 0.005, where the quasi-static floor would give 1 - 0.003 / 0.006
            dict(_run("backlash", 0, ("backlash",), 0.65, 0.65), gap_before=0.006, plant_gap_before=0.005),
            # its seed's none run was recorded before the plant floor was measured: no bound, never the quasi one
            dict(_run("backlash", 1, ("backlash",), 0.60, 0.60), gap_before=0.010, plant_gap_before=0.008),
            # floors the run measured itself (a sweep without none runs)
            dict(_run("hysteresis", 2, ("hysteresis",), 0.70, 0.70), gap_before=0.010, plant_gap_before=0.008,
                 floor=0.004, plant_floor=0.002),
            # not scored by the plant: the quasi-static floor, as before
            dict(_run("payload", 0, ("payload",), 0.90, 0.90), gap_before=0.030, plant_gap_before=None)]
    summarise_sweep(runs, 1200.0, tmp_path)
    text = (tmp_path / "confusion.md").read_text()
    rows = {(cells[0], cells[1]): cells for cells in
            ([c.strip() for c in row.strip("|").split("|")] for row in text.split("## Runs")[1].splitlines()
             if row.startswith("| ") and not row.startswith("| hidden"))}
    assert rows[("backlash", "0")][9] == "60.0"
    assert rows[("backlash", "1")][9] == "-"
    assert rows[("hysteresis", "2")][9] == "75.0"
    assert rows[("payload", "0")][9] == "90.0"
    # the summary has no bound for backlash, one of whose runs has none
    assert _cells(_summary_table(text), "backlash")[5] == "-"


def _report(hidden=("backlash",), seed=0, named=("backlash",), plant=True, **changes) -> dict:
    """A ``--hidden-effect`` run's report.json, with the keys a row of the table reads (SI gaps)."""
    gap = [1e-4, 2e-4, 3e-6]
    document = {
        "analysis": "blind", "starting_structure": list(STARTING_STRUCTURE), "library": list(LIBRARY),
        "named_effects": list(named), "unexplained": False, "equivalent": {}, "rivals": {}, "signature": [],
        "shrink": 0.6, "scored_by": "plant replay" if plant else "quasi-static replay",
        "quasi_static": {"gap_before": gap, "gap_after": [5e-5, 1e-4, 2e-6], "shrink": 0.5},
        "plant_replay": {"applies": plant, "gap_before": [8e-5, 1.5e-4, 2e-6], "fits_lag": True,
                         "hysteresis_lag_s": None},
        "residual_structure": [0.1, 0.05, 0.0], "oracle_residual_structure": [0.1, 0.05, 0.0],
        "backfit_capped": [], "oracle_backfit_capped": [],
        "controller": {"command_gap_before": [3.0, 4.0, 0.0], "command_gap_after": [3.0, 4.0, 0.0]},
        "hidden_effect": list(hidden), "seed": seed, "duration_s": 1200.0, "size_factor": 1.0,
        "oracle_shrink": 0.6, "oracle_quasi_static": {"shrink": 0.5},
        "floor_gap": [5e-5, 1e-4, 1e-6], "plant_floor_gap": [4e-5, 5e-5, 1e-6] if plant else None}
    document.update(changes)
    return document


def _write_report(folder, document):
    folder.mkdir(parents=True)
    (folder / "report.json").write_text(json.dumps(document))
    return folder


def test_single_runs_are_rows_whose_bound_is_read_against_their_own_floor(tmp_path):
    first = _write_report(tmp_path / "a", _report(seed=0))
    second = _write_report(tmp_path / "b", _report(seed=1, plant=False, shrink=0.45, oracle_shrink=0.45))
    nothing = _write_report(tmp_path / "c", _report(hidden=(), named=(), seed=0, shrink=0.0, oracle_shrink=0.0,
                                                    plant=False))
    assert main(["--merge-sweeps", str(first), str(second / "report.json"), str(nothing),
                 "--out", str(tmp_path / "m")]) == 0
    merged = json.loads((tmp_path / "m" / "confusion.json").read_text())
    assert [(r["hidden"], r["seed"], r["named_first"]) for r in merged["runs"]] == [
        ("none", 0, "none"), ("backlash", 0, "backlash"), ("backlash", 1, "backlash")]
    assert merged["runs"][1]["command_shrink"] == 0.0 and merged["runs"][1]["plant_lag_fitted"] is True
    # pooled in degrees and millimetres, by hand: seed 0 was scored by the plant and reads its plant
    # floor, seed 1 was not and reads its quasi-static floor
    deg = 180.0 / np.pi

    def pooled(rad_rad_m):
        return np.sqrt(np.mean(np.square([rad_rad_m[0] * deg, rad_rad_m[1] * deg, rad_rad_m[2] * 1e3])))

    plant_bound = 1.0 - pooled([4e-5, 5e-5, 1e-6]) / pooled([8e-5, 1.5e-4, 2e-6])
    quasi_bound = 1.0 - pooled([5e-5, 1e-4, 1e-6]) / pooled([1e-4, 2e-4, 3e-6])
    runs_table = (tmp_path / "m" / "confusion.md").read_text().split("## Runs")[1]
    backlash_rows = [row.strip("|").split("|") for row in runs_table.splitlines() if row.startswith("| backlash |")]
    assert [row[9].strip() for row in backlash_rows] == [f"{100 * plant_bound:.1f}", f"{100 * quasi_bound:.1f}"]
    table = _summary_table((tmp_path / "m" / "confusion.md").read_text())
    # 60 % and 45 %, each its oracle's: the goal's second term holds where the first does not
    assert _cells(table, "backlash")[1:4] == ["2 of 2", f"{pooled([1e-4, 2e-4, 3e-6]):.4f}",
                                              "52.5 [45.0, 60.0]"]
    assert _cells(table, "backlash")[6] == "yes"


@pytest.mark.parametrize("changes, named", [
    ({"analysis": "blind", "hidden_effect": None}, "is not the report of a --hidden-effect run"),
    ({"analysis": "ablation"}, "is not the report of a --hidden-effect run (analysis 'ablation'"),
    ({"hidden_effect": ["hysteresis", "payload"]}, "hides 2 effects (hysteresis, payload); a row of the table is one"),
    ({"plant_replay": None}, "is not a complete --hidden-effect report (TypeError"),
    ({"size_factor": 3.0}, "size factors [1.0, 3.0]"),
])
def test_reports_that_cannot_be_rows_are_refused_in_one_line(tmp_path, capsys, changes, named):
    first = _write_report(tmp_path / "a", _report(seed=0))
    other = _write_report(tmp_path / "b", _report(seed=1, **changes))
    _refused_in_one_line(first, other, named, tmp_path, capsys)


def test_shrinks_that_are_zero_to_rounding_meet_the_goal_of_an_oracle_that_closes_nothing(tmp_path):
    # the gravity model's error changes the controller's commands, not the joints' gap: the named
    # model and the oracle both leave the gap as it was, 1 - after / before a rounding off zero
    runs = [_run("gravity_model_error", 0, ("gravity_model_error",), 0.0, 1.1102230246251565e-16),
            _run("gravity_model_error", 1, ("gravity_model_error",), -2.220446049250313e-16, 0.0),
            _run("none", 0, (), 0.0, -2.220446049250313e-16)]
    summarise_sweep(runs, 1200.0, tmp_path)
    text = (tmp_path / "confusion.md").read_text()
    table = _summary_table(text)
    assert _cells(table, "gravity_model_error")[3:5] == ["0.0 [0.0, 0.0]", "0.0 [0.0, 0.0]"]
    assert _cells(table, "gravity_model_error")[6] == "yes"
    # nor in the runs' table
    assert "-0.0" not in table and "-0.0" not in text
    # a shrink short of the oracle's by more than rounding still misses it
    summarise_sweep([_run("backlash", 0, ("backlash",), 0.30, 0.40)], 1200.0, tmp_path / "short")
    assert _cells(_summary_table((tmp_path / "short" / "confusion.md").read_text()), "backlash")[6] == \
        "no: seed 0 closes 30.0 % (oracle 40.0 %)"
