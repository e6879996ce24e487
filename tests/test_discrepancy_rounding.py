"""The rounding study: copies of a record changed by one ulp, and the verdict on their analyses."""

from __future__ import annotations

import json

import numpy as np
import pytest

from studies.discrepancy_rounding import PERTURBED_PREFIXES, main, rounding_copy, verdict


@pytest.fixture(scope="module")
def five_seconds():
    from studies.common.discrepancy_runs import generate_measured

    dataset, _ = generate_measured((), seed=3, duration=5.0)
    return dataset


def _perturbed(column: str) -> bool:
    return column.startswith(PERTURBED_PREFIXES) and column.split(".", 1)[1] in ("shoulder", "elbow", "z_ins")


def test_a_rounding_copy_moves_each_measured_value_by_a_unit_in_the_last_place_and_nothing_else(five_seconds):
    copy = rounding_copy(five_seconds, seed=1)
    original, changed = five_seconds.table, copy.table
    assert list(changed.columns) == list(original.columns) and len(changed) == len(original)
    perturbed = [c for c in original.columns if _perturbed(c)]
    assert len(perturbed) == 9  # motor positions, motor torques and ground truth of the three joints
    moved = 0
    for column in original.columns:
        a, b = original[column].to_numpy(), changed[column].to_numpy()
        if column in perturbed:
            a, b = a.astype(float), b.astype(float)
            # a unit or two in the last place (2^-52 of the value, then rounded); two thirds of the values move
            assert np.all(np.abs(b - a) <= 2 * np.spacing(np.abs(a))), column
            moved += int(np.count_nonzero(b != a))
        else:
            assert np.array_equal(a, b) or (a.dtype.kind == "f" and np.array_equal(a, b, equal_nan=True)), column
    total = len(original) * len(perturbed)
    assert 0.5 * total < moved < 0.8 * total
    # the same seed makes the same copy, another seed another one
    again, other = rounding_copy(five_seconds, seed=1).table, rounding_copy(five_seconds, seed=2).table
    assert all(np.array_equal(again[c], changed[c]) for c in perturbed)
    assert any(not np.array_equal(other[c], changed[c]) for c in perturbed)


@pytest.mark.parametrize("runs, stable", [
    ([(["hysteresis"], 0.60, False), (["hysteresis"], 0.61, False), (["hysteresis"], 0.595, False)], True),
    ([(["hysteresis"], 0.60, False), (["hysteresis", "drift"], 0.60, False)], False),  # another name
    ([(["hysteresis", "payload"], 0.60, False), (["payload", "hysteresis"], 0.60, False)], False),  # another order
    ([(["hysteresis"], 0.60, False), (["hysteresis"], 0.45, False)], False),  # the shrink moves by 15 points
    ([([], 0.0, True), ([], 0.0, False)], False),  # flagged unexplained once only
])
def test_the_verdict_is_stable_only_when_every_analysis_agrees(runs, stable):
    runs = [{"named_effects": n, "shrink": s, "unexplained": u} for n, s, u in runs]
    result = verdict(runs, tolerance=0.02)
    assert result["tolerance"] == 0.02
    assert result["stable"] is stable
    shrinks = [r["shrink"] for r in runs]
    assert result["shrink_spread"] == pytest.approx(max(shrinks) - min(shrinks))


def test_the_command_analyses_the_record_and_its_copies_blind_and_writes_the_verdict(tmp_path, capsys):
    out = tmp_path / "rounding.json"
    result = main(["--hidden-effect", "none", "--seed", "3", "--duration", "5", "--copies", "1", "--jobs", "1",
                   "--backfit-rounds", "0", "--out", str(out)])
    printed = capsys.readouterr().out
    assert len(result["runs"]) == 2 and result["stable"] is True
    assert all(run["named_effects"] == [] for run in result["runs"])
    assert "record: named nothing" in printed and "copy 1: named nothing" in printed and "stable" in printed
    assert json.loads(out.read_text())["stable"] is True


@pytest.mark.parametrize("argv, message", [
    (["--measured", "/no/such/record.parquet"], "argument --measured: no file or folder"),
    (["--hidden-effect", "none", "--copies", "0"], "argument --copies: must be >= 1"),
    (["--hidden-effect", "none", "--tolerance", "2"], "argument --tolerance: must be between 0 and 1"),
    (["--hidden-effect", "hidden"], "argument --hidden-effect: unknown hidden effect 'hidden'"),
    (["--hidden-effect", "cable_stretch"], "cable_stretch is in the starting structure"),
])
def test_bad_arguments_are_one_line_errors(argv, message, capsys):
    with pytest.raises(SystemExit) as stopped:
        main(argv)
    error = capsys.readouterr().err.strip()
    assert stopped.value.code == 2 and message in error and "\n" not in error


def test_a_file_that_is_not_a_record_is_one_line_error(tmp_path, capsys):
    broken = tmp_path / "broken.parquet"
    broken.write_bytes(b"not parquet")
    with pytest.raises(SystemExit) as stopped:
        main(["--measured", str(broken)])
    error = capsys.readouterr().err.strip()
    assert stopped.value.code == 2 and "cannot be analysed" in error and "\n" not in error
