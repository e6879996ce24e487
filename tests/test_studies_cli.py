"""The study scripts' command line fails fast and cleanly: one line, status 2, nothing written.

A user's mistake (an argument out of range, an unknown name, a path that is missing or of the wrong
kind, an input file that cannot be read) must be reported in one line naming it, with exit status
2 (argparse's convention), before any simulation or training starts, and must leave the output
folder as it was. A run that succeeds replaces the previous results as a whole.
"""

from __future__ import annotations

import importlib
import importlib.util
import json
import os
import runpy
import subprocess
import sys
from pathlib import Path

import pytest

from studies.common import runner

ROOT = Path(__file__).resolve().parents[1]


def _tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): (p.read_bytes() if p.is_file() else b"")
            for p in sorted(folder.rglob("*"))}


def _run_script(script: str, *arguments: str, cwd: Path) -> subprocess.CompletedProcess:
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
                   "PYTHONWARNINGS": "ignore"}
    return subprocess.run([sys.executable, str(ROOT / "studies" / f"{script}.py"), *arguments], cwd=cwd,
                          env=environment, capture_output=True, text=True, timeout=600)


@pytest.fixture
def workspace(tmp_path):
    """A folder with an earlier result, a file, an empty folder and corrupt data files."""
    (tmp_path / "previous").mkdir()
    (tmp_path / "previous" / "results.json").write_text('{"old": true}\n')
    (tmp_path / "a_file.txt").write_text("not a folder\n")
    (tmp_path / "empty").mkdir()
    (tmp_path / "corrupt.parquet").write_bytes(b"PAR1 this is not a parquet file")
    (tmp_path / "corrupt.bag").write_bytes(b"#ROSBAG V2.0\n\x00\x01 truncated")
    (tmp_path / "robot_unknown.json").write_text('{"effects": {"cable_stretch": {"stiffnes": [1, 2, 3]}}}\n')
    (tmp_path / "robot_corrupt.json").write_text('{"arm": "left", \n')
    return tmp_path


# one mistake per script, each script run as a program (its ``__main__`` block) in this process:
# a new process per script would pay the imports each time; two of them run as real processes below
SCRIPT_MISTAKES = [
    ("compare_sota", ["--data", "{tmp}/empty"], "holds no .bag or .parquet"),
    ("compare_sota", ["--data", "{tmp}/corrupt.parquet"], "corrupt.parquet"),
    ("compare_sota", ["--robot-params", "{tmp}/missing.json"], "missing.json does not exist"),
    ("compare_sota", ["--robot-params", "{tmp}/robot_unknown.json"], "unknown field 'stiffnes'"),
    ("compare_sota", ["--robot-params", "{tmp}/robot_corrupt.json"], "not a valid JSON"),
    ("compare_sota", ["--robot-params", "{tmp}/robot_corrupt.json", "--data", "{tmp}/empty"], "robot_corrupt.json"),
    ("directions", ["--jobs", "0"], "--jobs"),
    ("model_mismatch", ["--lams", "0,-1"], "--lams"),
    ("model_mismatch", ["--robot-params", "{tmp}/robot_unknown.json"], "unknown field 'stiffnes'"),
    ("discrepancy", ["--sweep", "--seeds", "0"], "--seeds"),
    ("discrepancy", ["--measured", "{tmp}/corrupt.bag"], "corrupt.bag"),
    ("discrepancy_convergence", ["--effect", "coupling"], "is in the starting structure"),
    ("discrepancy_unmodelled", ["--amplitude", "-0.01"], "--amplitude"),
    ("discrepancy_homing", ["--duration", "1e9"], "at most 21600 s (six hours)"),
    ("discrepancy_hysteresis_shape", ["--pin-shape", "1.5"], "the candidate's range"),
    ("discrepancy_hysteresis_shape", ["--response-time", "nan"], "--response-time"),
    ("discrepancy_hysteresis_shape", ["--scorer-lag", "-0.1"], "--scorer-lag"),
    ("discrepancy_hysteresis_shape", ["--backfit-patience", "-1"], "--backfit-patience"),
    ("discrepancy_hysteresis_shape", ["--scorer-lag", "0.1", "--fit-scorer-lag"],
     "argument --fit-scorer-lag: not allowed with argument --scorer-lag"),
    ("discrepancy_hysteresis_shape", ["--fit-replay-lag", "--scorer-lag", "0.1"],
     "--fit-replay-lag gives the scorer the fitted lags: leave out --scorer-lag"),
    ("discrepancy", ["--sweep", "--inertial-loads", "motors"],
     "--inertial-loads applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--ablate", "coupling", "--inertial-loads", "joints"], "--inertial-loads applies to"),
    ("discrepancy", ["--hidden-effect", "drift", "--inertial-loads", "links"],
     "argument --inertial-loads: invalid choice: 'links'"),
    ("homing", ["--out", "{tmp}/a_file.txt"], "is a file"),
    ("input_features", ["--hours", "-1"], "--hours"),
    ("long_operation", ["--kinds", "idle,sleeping"], "sleeping"),
    ("long_operation", ["--hours", "1e9"], "hours must be at most 24 (one day of operation)"),
    ("sparsity", ["--out", "{tmp}/a_file.txt/results"], "is not a folder"),
    ("speed", ["--methods", "linear,magic"], "magic"),
    ("train_on_error", ["--dnn-seeds", "0"], "--dnn-seeds"),
]


def _arguments(arguments: list[str], workspace: Path) -> list[str]:
    arguments = [a.replace("{tmp}", str(workspace)) for a in arguments]
    return arguments if "--out" in arguments else arguments + ["--out", str(workspace / "previous")]


def _assert_one_line_error(script: str, status, stdout: str, stderr: str, named: str) -> None:
    lines = stderr.strip().splitlines()
    assert status == 2, stderr
    assert len(lines) == 1 and lines[0].startswith(f"python studies/{script}.py: error: "), stderr
    assert named in lines[0]
    assert "Traceback" not in stderr and stdout == ""


@pytest.mark.parametrize("script, arguments, named", SCRIPT_MISTAKES,
                         ids=[f"{s}{' '.join(a).replace('{tmp}', '')}" for s, a, _ in SCRIPT_MISTAKES])
def test_a_mistake_gets_one_line_and_status_2_and_nothing_is_written(workspace, capsys, monkeypatch,
                                                                     script, arguments, named):
    path = ROOT / "studies" / f"{script}.py"
    monkeypatch.setattr(sys, "argv", [str(path), *_arguments(arguments, workspace)])
    monkeypatch.chdir(workspace)
    before = _tree(workspace)
    with pytest.raises(SystemExit) as exit_info:
        runpy.run_path(str(path), run_name="__main__")
    captured = capsys.readouterr()
    _assert_one_line_error(script, exit_info.value.code, captured.out, captured.err, named)
    assert _tree(workspace) == before


# run as the user runs it: a new process, its exit status and its stderr
PROCESS_MISTAKES = [SCRIPT_MISTAKES[0], SCRIPT_MISTAKES[4]]


@pytest.mark.parametrize("script, arguments, named", PROCESS_MISTAKES,
                         ids=[f"{s}{' '.join(a).replace('{tmp}', '')}" for s, a, _ in PROCESS_MISTAKES])
def test_a_mistake_in_a_new_process_exits_with_status_2(workspace, script, arguments, named):
    before = _tree(workspace)
    result = _run_script(script, *_arguments(arguments, workspace), cwd=workspace)
    _assert_one_line_error(script, result.returncode, result.stdout, result.stderr, named)
    assert _tree(workspace) == before


# more mistakes, checked in this process (the parsing and checks are the same code)
IN_PROCESS_MISTAKES = [
    ("compare_sota", ["--seed", "-1"], "--seed"),
    ("compare_sota", ["--data", "{tmp}/missing_folder"], "no file or folder"),
    ("compare_sota", ["--methods", "raw,magic"], "unknown method 'magic'"),
    ("compare_sota", ["--methods", ","], "no method given"),
    ("compare_sota", ["--jobs", "-2"], "--jobs"),
    ("compare_sota", ["--dnn-seeds", "zero"], "not an integer"),
    ("compare_sota", ["--test-fraction", "1.5"], "--test-fraction"),
    ("compare_sota", ["--test-data", "{tmp}/corrupt.parquet"], "--test-data needs --data"),
    ("compare_sota", ["--data", "{tmp}/a_file.txt"], "unknown data file type"),
    ("compare_sota", ["--backend", "cluster"], "--backend"),
    ("homing", ["--scheduler", "tcp://localhost:8786"], "--scheduler needs --backend dask or --backend ray"),
    ("discrepancy", ["--hidden-effect", "backlash", "--seed", "-3"], "--seed"),
    ("discrepancy", ["--hidden-effect", "backlash", "--duration", "nan"], "--duration"),
    ("discrepancy", ["--measured", "{tmp}/missing"], "no file or folder"),
    ("discrepancy", ["--hidden-effect", "none", "--log-rate", "0"], "argument --log-rate: must be > 0, got 0"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--log-rate", "100"], "--log-rate applies to --hidden-effect only"),
    ("discrepancy", ["--sweep", "--log-rate", "100"], "--log-rate applies to --hidden-effect only"),
    # refused even at the robot's own rate: what matters is that it was given
    ("discrepancy", ["--measured", "{tmp}/empty", "--log-rate", "30"], "--log-rate applies to --hidden-effect only"),
    ("discrepancy", ["--hidden-effect", "none", "--max-rate", "30"], "--max-rate applies to --measured RAVEN-II data"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--max-rate", "-30"], "argument --max-rate: must be > 0"),
    ("discrepancy", ["--hidden-effect", "none", "--backfit-rounds", "-1"], "argument --backfit-rounds"),
    ("discrepancy", ["--sweep", "--backfit-rounds", "30"],
     "--backfit-rounds applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--ablate", "coupling", "--backfit-rounds", "30"],
     "--backfit-rounds applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--hidden-effect", "none", "--max-effects", "0"], "argument --max-effects"),
    ("discrepancy", ["--hidden-effect", "none", "--backfit-patience", "-1"], "argument --backfit-patience"),
    ("discrepancy", ["--sweep", "--backfit-patience", "2"],
     "--backfit-patience applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--hidden-effect", "none", "--named-backfit-patience", "1.5"],
     "argument --named-backfit-patience"),
    ("discrepancy", ["--ablate", "coupling", "--named-backfit-patience", "0"],
     "--named-backfit-patience applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--sweep", "--max-effects", "2"],
     "--max-effects applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--sweep", "--plant-refit"],
     "--plant-refit applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--ablate", "coupling", "--plant-refit"],
     "--plant-refit applies to --measured RAVEN-II data and --hidden-effect only"),
    ("discrepancy", ["--ablate", "coupling", "--fixed-plant-lag"],
     "--fixed-plant-lag applies to --measured RAVEN-II data, --hidden-effect and --sweep only"),
    ("discrepancy", ["--ablate", "coupling", "--fit-plant-lag"],
     "--fit-plant-lag applies to --measured RAVEN-II data, --hidden-effect and --sweep only"),
    ("discrepancy", ["--hidden-effect", "none", "--fit-plant-lag", "--fixed-plant-lag"],
     "argument --fixed-plant-lag: not allowed with argument --fit-plant-lag"),
    ("discrepancy", ["--measured", "{tmp}/empty"], "holds no .bag or .parquet"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--seed", "3"],
     "--seed applies to generated data (--hidden-effect, --ablate, --sweep): measured data carry no seed"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--seed", "0"], "--seed applies to generated data"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--duration", "60"], "--duration applies to generated data"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--size-factor", "3"],
     "--size-factor applies to --hidden-effect and --sweep only"),
    ("discrepancy", ["--ablate", "coupling", "--size-factor", "3"],
     "--size-factor applies to --hidden-effect and --sweep only"),
    ("discrepancy", ["--hidden-effect", "backlash", "--seeds", "5"], "--seeds applies to --sweep only"),
    ("discrepancy", ["--hidden-effect", "backlash", "--effects", "drift"], "--effects applies to --sweep only"),
    ("discrepancy", ["--merge-sweeps", "{tmp}/empty", "--seed", "2"], "--seed applies to generated data"),
    ("discrepancy", ["--hidden-effect", "backlash", "--joints", "5"], "--joints applies to --measured dVRK data only"),
    ("discrepancy", ["--hidden-effect", "backlash", "--arm", "right"],
     "--arm applies to --measured RAVEN-II data only"),
    ("discrepancy", ["--measured", "{tmp}/empty", "--joints", "0,7"], "--joints"),
    ("discrepancy", ["--merge-sweeps", "{tmp}/missing"], "no file or folder"),
    ("discrepancy", ["--merge-sweeps", "{tmp}/empty"], "confusion.json is not a sweep's confusion.json"),
    ("discrepancy", ["--merge-sweeps", "{tmp}/robot_corrupt.json"], "robot_corrupt.json is not a sweep's"),
    ("discrepancy", ["--merge-sweeps", "{tmp}/robot_unknown.json"],
     "is not a sweep's confusion.json or a run's report.json (no 'runs'"),
    ("discrepancy_rounding", ["--measured", "{tmp}/empty", "--seed", "2"],
     "--seed applies to --hidden-effect only: a record carries no seed, length or size factor"),
    ("discrepancy_rounding", ["--measured", "{tmp}/empty", "--duration", "60"], "--duration applies to --hidden-effect"),
    ("discrepancy_convergence", ["--iterations", "30,0"], "--iterations"),
    ("discrepancy_homing", ["--sizes", "1,0"], "--sizes"),
    ("discrepancy_homing", ["--sizes", "1,nan"], "--sizes"),
    ("discrepancy_play_widths", ["--grids", "3-1"], "each grid needs 1 <= a <= b <= 16"),
    ("discrepancy_play_widths", ["--grids", "2-x"], "'2-x' is not a grid a-b"),
    ("discrepancy_play_widths", ["--split", "peg -> peg"], "argument --split: invalid choice: 'peg -> peg'"),
    ("discrepancy_fit_at_truth", ["--hidden-effect", "payload"], "invalid choice: 'payload'"),
    ("discrepancy_fit_at_truth", ["--hidden-effect", "motor_friction"], "invalid choice: 'motor_friction'"),
    ("discrepancy_fit_at_truth", ["--hidden-effect", "backlash", "--duration", "0"],
     "argument --duration: the record length must be at least 5 s"),
    ("discrepancy_backfit", ["--hidden-effect", "magic"], "invalid choice: 'magic'"),
    ("discrepancy_backfit", ["--hidden-effect", "backlash", "--rounds", "6,x"], "--rounds"),
    ("discrepancy_backfit", ["--hidden-effect", "backlash", "--rounds", "6,-1"], "--rounds"),
    ("discrepancy_backfit", ["--hidden-effect", "backlash", "--patience", "-1"], "argument --patience: must be >= 0"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "magic"], "invalid choice: 'magic'"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "none", "--extra-coulomb", "0,0"],
     "argument --extra-coulomb: must be three finite numbers >= 0 separated by commas, got '0,0'"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "none", "--extra-coulomb", "0,x,1"],
     "argument --extra-coulomb: must be three numbers separated by commas, got '0,x,1'"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "none", "--extra-coulomb", "0,-1,0"], "--extra-coulomb"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "none", "--log-rate", "0"], "--log-rate"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "none", "--substeps", "0"], "--substeps"),
    ("discrepancy_replay_fidelity", ["--hidden-effect", "none", "--replay-friction-scale", "-1"],
     "--replay-friction-scale"),
    ("discrepancy_floor", ["--effects", "backlash,magic"], "unknown hidden effect 'magic'"),
    ("discrepancy_floor", ["--effects", "coupling"], "coupling"),
    ("discrepancy_floor", ["--seeds", "0"], "--seeds"),
    ("discrepancy_floor", ["--duration", "nan"], "--duration"),
    ("discrepancy_convergence", ["--effect", "none"], "hides nothing"),
    ("discrepancy_convergence", ["--effect", "magic"], "unknown hidden effect 'magic'"),
    ("directions", ["--directions", "J2-J3,J4"], "unknown direction 'J4'"),
    ("sparsity", ["--repeats", "0"], "--repeats"),
    ("input_features", ["--large-dnn-seeds", "-1"], "--large-dnn-seeds"),
]


@pytest.mark.parametrize("script, arguments, named", IN_PROCESS_MISTAKES,
                         ids=[f"{s}{' '.join(a).replace('{tmp}', '')}" for s, a, _ in IN_PROCESS_MISTAKES])
def test_more_mistakes_in_process(workspace, capsys, script, arguments, named):
    main = importlib.import_module(f"studies.{script}").main
    arguments = [a.replace("{tmp}", str(workspace)) for a in arguments] + ["--out", str(workspace / "previous")]
    before = _tree(workspace)
    with pytest.raises(SystemExit) as exit_info:
        main(arguments)
    lines = capsys.readouterr().err.strip().splitlines()
    assert exit_info.value.code == 2
    assert len(lines) == 1 and named in lines[0], lines
    assert _tree(workspace) == before


def test_help_shows_a_default_only_where_there_is_one():
    parser = runner.script_parser("example", "An example study.")
    parser.add_argument("--seed", type=int, default=None, help="seed of generated data (default 0)")
    parser.add_argument("--seeds", type=int, default=3, help="seeds per effect")
    text = " ".join(parser.format_help().split())
    assert "seed of generated data (default 0)" in text and "None" not in text
    assert "seeds per effect (default: 3)" in text


def test_an_option_given_where_it_does_nothing_is_refused_and_an_absent_one_gets_its_default(capsys):
    parser = runner.script_parser("example", "An example study.")
    parser.add_argument("--measured")
    parser.add_argument("--seed", type=int, default=None)
    applies = {"seed": (False, "generated data only")}
    args = parser.parse_args(["--measured", "log.parquet"])
    runner.refuse_options_that_do_not_apply(parser, args, applies, {"seed": 0})
    assert args.seed == 0
    args = parser.parse_args(["--measured", "log.parquet", "--seed", "0"])
    with pytest.raises(SystemExit) as exit_info:
        runner.refuse_options_that_do_not_apply(parser, args, applies, {"seed": 0})
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1] == (
        "python studies/example.py: error: --seed applies to generated data only")
    args = parser.parse_args(["--seed", "7"])
    runner.refuse_options_that_do_not_apply(parser, args, {"seed": (True, "generated data only")}, {"seed": 0})
    assert args.seed == 7


@pytest.mark.skipif(importlib.util.find_spec("ray") is not None, reason="Ray is installed here")
def test_a_cluster_backend_that_is_not_installed_is_named(workspace, capsys):
    from studies import sparsity

    with pytest.raises(SystemExit) as exit_info:
        sparsity.main(["--backend", "ray", "--out", str(workspace / "previous")])
    assert exit_info.value.code == 2 and "pip install" in capsys.readouterr().err


def _parser() -> runner.StudyParser:
    parser = runner.script_parser("example", "An example study.")
    parser.add_argument("--out", type=Path)
    return parser


def test_a_failed_run_leaves_the_previous_results_whole(workspace, capsys):
    out = workspace / "previous"
    before = _tree(workspace)
    with pytest.raises(SystemExit) as exit_info:
        with runner.StudyRun(_parser(), ["--out", str(out)]) as study:
            (study.folder / "results.json").write_text('{"new": true}\n')
            raise runner.UsageError("the input file is corrupt")
    assert exit_info.value.code == 2
    assert capsys.readouterr().err.strip() == "python studies/example.py: error: the input file is corrupt"
    assert _tree(workspace) == before
    with pytest.raises(RuntimeError, match="a bug"):
        with runner.StudyRun(_parser(), ["--out", str(out)]) as study:
            (study.folder / "results.json").write_text('{"new": true}\n')
            raise RuntimeError("a bug")
    assert _tree(workspace) == before


def test_a_successful_run_replaces_the_previous_results_as_a_whole(workspace):
    out = workspace / "previous"
    (out / "figure_of_an_older_run.png").write_bytes(b"old")
    with runner.StudyRun(_parser(), ["--out", str(out)]) as study:
        (study.folder / "results.json").write_text('{"new": true}\n')
        assert not (out / "results.json").read_text().startswith('{"new"')
    assert sorted(p.name for p in out.iterdir()) == ["results.json"]
    assert json.loads((out / "results.json").read_text()) == {"new": True}
    assert sorted(p.name for p in workspace.iterdir()) == ["a_file.txt", "corrupt.bag", "corrupt.parquet",
                                                            "empty", "previous", "robot_corrupt.json",
                                                            "robot_unknown.json"]


def test_a_folder_holding_other_things_keeps_them(workspace):
    out = workspace / "empty"
    (out / "notes.txt").write_text("mine\n")
    with runner.StudyRun(_parser(), ["--out", str(out / "deeper" / "run")]) as study:
        (study.folder / "report.md").write_text("# new\n")
    assert (out / "deeper" / "run" / "report.md").read_text() == "# new\n"
    with runner.StudyRun(_parser(), ["--out", str(out)]) as study:
        (study.folder / "report.md").write_text("# new\n")
    assert sorted(p.name for p in out.iterdir()) == ["deeper", "notes.txt", "report.md"]


def test_folders_created_for_a_failed_run_are_removed(workspace):
    out = workspace / "new" / "deeper" / "run"
    with pytest.raises(SystemExit):
        with runner.StudyRun(_parser(), ["--out", str(out)]):
            raise runner.UsageError("nothing to read")
    assert not (workspace / "new").exists()


def test_the_run_time_is_measured_once(workspace, capsys):
    with runner.StudyRun(_parser(), ["--out", str(workspace / "timed")]) as study:
        (study.folder / "report.md").write_text("# report\n")
        first = study.stop_clock()
    assert study.stop_clock() == first
    study.done()
    assert capsys.readouterr().err.strip().endswith(f"run time {first:.0f} s")


@pytest.mark.parametrize("parse, text, message", [
    (runner.non_negative_int, "-1", ">= 0"),
    (runner.positive_int, "0", ">= 1"),
    (runner.jobs_count, "0", "-1 for all cores"),
    (runner.positive_float, "inf", "finite"),
    (runner.open_fraction, "0", "between 0 and 1"),
])
def test_argument_types_name_the_mistake(parse, text, message):
    import argparse

    with pytest.raises(argparse.ArgumentTypeError, match=message):
        parse(text)


def test_argument_types_accept_good_values():
    assert runner.jobs_count("-1") == -1 and runner.jobs_count("2") == 2
    assert runner.non_negative_int("0") == 0 and runner.open_fraction("0.3") == 0.3
    assert runner.names(("a", "b", "c"), "letter")(" c, a,c ") == ("c", "a")
