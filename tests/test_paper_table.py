"""The paper-beside-simulator table: which numbers are fit targets, ratios, goals, bad inputs."""

from __future__ import annotations

import json

import pytest

from studies import paper_table
from studies.common import paper_numbers as paper


def _write(folder, document):
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "results.json").write_text(json.dumps(document))
    return folder


@pytest.fixture()
def inputs(tmp_path):
    """Results of the three studies, with the paper's own numbers doubled or halved where noted."""
    rmse = {d: {m: list(paper.TABLE_I[d][m]) for m in paper.TABLE_I_MODELS} for d in ("J2-J3", "J1-J2")}
    rmse["J1-J2"]["dnn"] = [2.5 * v for v in paper.TABLE_I["J1-J2"]["dnn"]]      # a prediction 2.5x off
    hours = [f"hour {h}" for h in range(6)]
    summary = {m: {h: [0.2, 0.3, 0.15] for h in hours} for m in ("linear", "dnn")}
    folders = {
        "directions": _write(tmp_path / "d", {"study": "directions", "command": "studies/directions.py",
                                               "rmse": rmse}),
        "long_operation": _write(tmp_path / "l", {"study": "long_operation", "command": "x",
                                                   "hours": {"unloaded": hours},
                                                   "rmse_3_longest": {"unloaded": summary}}),
        "compare_sota": _write(tmp_path / "c", {"study": "compare_sota", "command": "x",
                                                 "unloaded": {"joint_rmse": {"ukf": [0.1, 0.1, 0.1]}}}),
    }
    return folders


def _args(folders, out):
    return ["--directions", str(folders["directions"]), "--long-operation", str(folders["long_operation"]),
            "--compare-sota", str(folders["compare_sota"]), "--out", str(out), "--skip-fit"]


def test_only_j2_j3_raw_and_fixed_offset_are_marked_fitted(inputs, tmp_path, capsys):
    document = paper_table.main(_args(inputs, tmp_path / "out"))
    kinds = {row["quantity"]: row["kind"] for row in document["rows"]}
    assert {q for q, k in kinds.items() if k == "fitted"} == {"Table I J2-J3, raw", "Table I J2-J3, fixed_offset"}
    rows = {row["quantity"]: row for row in document["rows"]}
    assert rows["Table I J1-J2, dnn"]["ratio"] == pytest.approx((2.5, 2.5, 2.5))
    assert rows["Table I J1-J2, dnn"]["meets_goal"] == (False, False, False)
    assert all(rows["Table I J1-J2, linear"]["meets_goal"])
    ukf = rows["Table III UKF (Haghighipanah et al.), unloaded test"]
    assert ukf["ratio"] == pytest.approx([0.1 / v for v in (1.195, 1.242, 0.927)])
    assert ukf["meets_goal"] == (False, False, False)          # ten times better than published
    assert (tmp_path / "out" / "table.md").read_text().count("| predicted |") == len(document["rows"]) - 2


def test_a_fitted_number_must_be_within_ten_percent():
    row = paper_table.Row("x", "fitted", (1.0, 1.0, 1.0), (1.05, 0.89, 1.09))
    assert row.meets_goal == (True, False, True)
    prediction = paper_table.Row("x", "predicted", (1.0, 1.0, 1.0), (1.9, 0.49, 1.99))
    assert prediction.meets_goal == (True, False, True)


def test_a_missing_study_names_the_command_that_writes_it(inputs, tmp_path, capsys):
    (inputs["long_operation"] / "results.json").unlink()
    with pytest.raises(SystemExit) as exit_info:
        paper_table.main(_args(inputs, tmp_path / "out"))
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip().splitlines()
    assert len(error) == 1 and "python studies/long_operation.py" in error[0]


def test_results_of_another_study_are_refused(inputs, tmp_path, capsys):
    _write(inputs["compare_sota"], {"study": "directions", "rmse": {}})
    with pytest.raises(SystemExit):
        paper_table.main(_args(inputs, tmp_path / "out"))
    assert "not of 'compare_sota'" in capsys.readouterr().err
