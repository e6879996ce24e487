"""The suite's timing script reads pytest's output right and refuses bad arguments in one line."""

from __future__ import annotations

import importlib.util
import shutil
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_SPEC = importlib.util.spec_from_file_location("bench_suite", ROOT / "benchmarks" / "bench_suite.py")
bench_suite = importlib.util.module_from_spec(_SPEC)
sys.modules.setdefault("bench_suite", bench_suite)  # its dataclasses look their module up there
_SPEC.loader.exec_module(bench_suite)

OUTPUT = """\
........x.s.. [ 99%]
============================= slowest durations ==============================
36.44s call     tests/test_discrepancy.py::test_two_hidden_effects@discrepancy_discrepancy-two-effects
8.67s setup    tests/test_compare_sota.py::test_results_have_the_documented_layout@compare_sota
4.67s call     tests/test_ukf_faults.py::test_friction[0.002 N m]@ukf_faults
0.50s teardown tests/test_discrepancy.py::test_nothing_hidden_names_nothing@discrepancy

(1200 durations < 0.005s hidden.  Use -vv to show these durations.)
=========================== short test summary info ============================
XFAIL tests/test_calibrators_contract.py::test_sklearn_contract[x] - a reason with 1.5s in it
2 failed, 1877 passed, 8 skipped, 4 xfailed, 14 warnings in 238.54s (0:03:58)
"""


def test_the_durations_are_read_with_phase_node_and_module():
    rows = bench_suite.parse_durations(OUTPUT)
    assert [(r.seconds, r.phase) for r in rows] == [(36.44, "call"), (8.67, "setup"), (4.67, "call"), (0.5, "teardown")]
    # a parametrized id with spaces stays whole; the xdist group suffix stays in the node id
    assert rows[2].node == "tests/test_ukf_faults.py::test_friction[0.002 N m]@ukf_faults"
    assert [r.module for r in rows] == ["tests/test_discrepancy.py", "tests/test_compare_sota.py",
                                        "tests/test_ukf_faults.py", "tests/test_discrepancy.py"]


def test_the_summary_gives_every_count_and_the_test_time():
    counts, seconds = bench_suite.parse_summary(OUTPUT)
    assert counts == {"failed": 2, "passed": 1877, "skipped": 8, "xfailed": 4, "warnings": 14}
    assert seconds == 238.54
    # pytest's decorated summary line, without -q
    assert bench_suite.parse_summary("==== 5 passed in 1.20s ====\n") == ({"passed": 5}, 1.2)


def test_an_output_without_a_summary_is_refused():
    with pytest.raises(ValueError, match="no summary line"):
        bench_suite.parse_summary(OUTPUT.rsplit("\n", 2)[0])


def test_modules_are_summed_largest_first_and_busy_is_cpu_over_the_cores_time():
    rows = tuple(bench_suite.parse_durations(OUTPUT))
    run = bench_suite.SuiteRun("HEAD", "0" * 40, test_s=238.54, wall_s=240.0, cpu_s=432.0, workers=2, durations=rows)
    assert run.by_module() == [("tests/test_discrepancy.py", pytest.approx(36.94)),
                               ("tests/test_compare_sota.py", 8.67), ("tests/test_ukf_faults.py", 4.67)]
    assert run.busy == pytest.approx(0.9)
    text = bench_suite.report(run, top=2)
    assert "1.33 of the 180 s budget" in text and "busy 90 %" in text
    assert "tests/test_ukf_faults.py" not in text.split("slowest:")[0]  # only the top two modules


@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(), reason="needs git and a clone")
def test_a_commit_that_does_not_exist_or_one_commit_twice_is_refused_in_one_line(capsys):
    with pytest.raises(SystemExit) as exit_info:
        bench_suite.main(["--ref", "no-such-commit-anywhere"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "'no-such-commit-anywhere' is not a commit" in error
    # two names of one commit are no comparison
    with pytest.raises(SystemExit) as exit_info:
        bench_suite.main(["--ref", "HEAD", "--against", "HEAD"])
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "is the same commit as --ref HEAD" in error


@pytest.mark.parametrize("arguments, message", [(["--workers", "0"], "workers must be 'auto' or a positive number"),
                                                (["--rounds", "0"], "--rounds")])
def test_bad_counts_are_refused_in_one_line(arguments, message, capsys):
    with pytest.raises(SystemExit) as exit_info:
        bench_suite.main(arguments)
    assert exit_info.value.code == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and message in error
