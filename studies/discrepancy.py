"""The model-discrepancy workflow from the command line: report, tables and plots.

    python studies/discrepancy.py --hidden-effect backlash --seed 0 --out results/discrepancy
    python studies/discrepancy.py --measured results/discrepancy/measured.parquet --out results/again
    python studies/discrepancy.py --hidden-effect none
    python studies/discrepancy.py --hidden-effect hysteresis --plant-refit   # named effects refitted with the plant
    python studies/discrepancy.py --hidden-effect hysteresis --fixed-plant-lag  # the scoring's lag fixed at 0.1 s
    python studies/discrepancy.py --measured LOG.parquet --inertial-loads motors  # links' loads from the motors
    python studies/discrepancy.py --ablate coupling                 # the model lacks a term the data have
    python studies/discrepancy.py --measured ../shared/data/dvrk_hwang2020
    python studies/discrepancy.py --sweep --seeds 5 --duration 240  # hidden vs named, with the oracle
    python studies/discrepancy.py --merge-sweeps PART1 PART2        # one table from sweeps run apart
    python studies/discrepancy.py --merge-sweeps RUN1 RUN2 ...      # the same table from --hidden-effect runs

``--measured PATH`` is the blind analysis. On RAVEN-II data (a dataset file ``.parquet``/``.csv``,
ROS bags, or a folder of either) it always starts from the same structure, the cable model of
``STARTING_STRUCTURE`` identified on the first half of the record, and screens the same library
``LIBRARY`` (:mod:`studies.common.discrepancy_runs`); it takes no seed and knows nothing of how the
data were made (``--seed``, ``--duration`` or ``--size-factor`` given with it is refused, as is any
option given with an input it does nothing for). ``--max-rate HZ`` keeps every k-th row of a
faster RAVEN-II log first (its thresholds were set on 30 Hz logs, and its cost grows with the
rows). ``--backfit-rounds N`` allows N rounds
of re-identifying the starting structure around a candidate instead of thirty (``report.json``'s
``backfit_capped`` names the fits the cap cut short; with ``--hidden-effect`` the oracle gets the
same cap). ``--max-effects N`` stops the search once it has named N effects instead of four, without
the last iteration that checks for more (``report.json``'s ``search_capped``): on data known to hold
at most N effects it names and fits the same at less cost. ``--inertial-loads motors`` has the
replay take the links' inertial loads from the motors' acceleration through the arm's nominal
coupling instead of from a causal second derivative of the measured joints (``joints``, the
default); with ``--hidden-effect`` the oracle and the floors are replayed alike, and
``report.json``'s ``inertial_loads`` says which. The identification reads the record alike either
way, and the plant replay takes no acceleration. On the dVRK folder format the start is
the dVRK's own nominal model (measured joints = reported joints plus offsets; wrist joints 4-6 by
default) with the generic library.

``--hidden-effect NAME`` generates data with the virtual RAVEN-II (twenty minutes of random motion
unless ``--duration`` says otherwise): the starting structure plus NAME and nothing else (``none``:
nothing; several names separated by commas; NAME from the library, or ``capstan_runout``, which the
library lacks), logged at the robot's 30 Hz unless ``--log-rate`` says otherwise. It writes them as
``DIR/measured.parquet`` and runs
exactly the ``--measured`` analysis on that file. Only then, knowing the generator, it adds to the
report the true parameters beside the fitted ones and the oracle: the generator's true structure
fitted to the same fit part, whose held-out gap is what a model of the right structure closes, and
the floor: the gap the starting model leaves on the same seed's record with nothing hidden, and the
share of this record's gap above it (``floor_gap``, ``floor_bound``, both the quasi-static replay's;
where the plant scores the analysis, ``plant_floor_gap`` and ``plant_floor_bound`` as well, the
same floor scored with the plant as the analysis's starting model is). An
effect of the starting structure cannot be hidden (the data would not change): ``--ablate NAME``
instead generates with the full structure and analyses from the structure without NAME, with NAME
among the candidates; that is an ablation, and its report says so.

On RAVEN-II data the analysis ends by scoring its starting and final models with the plant replay,
which follows the links' swing on their cables (:mod:`studies.common.plant_scoring`): where that
applies the report's gaps and shrink are the plant's (``scored_by``), the workflow's quasi-static
ones kept in ``quasi_static``, and the oracle is scored the same way. ``--plant-refit`` then refits
a named backlash, hysteresis or drift with the plant replay on the fit part, from the workflow's
own values (:func:`studies.common.plant_scoring.refit_with_plant`; about ten more minutes on a
twenty-minute record), and reports it beside those figures (``plant_refit``), which stay the
workflow's models'. A fitted hysteresis lags the stretch in the plant (the quasi-static replay has
no such lag): the score fits that lag to the plant on the fit part, with each model's Coulomb
forces, from a round 0.1 s (``plant_replay.hysteresis_lag_s``; the oracle and ``--plant-refit`` fit
theirs too), so that nothing it scores with is a value the generator shares.
``--fixed-plant-lag`` takes the candidate's constant instead, a round 0.1 s; until 2026-12-06 that
constant was 0.05 s, the simulator's default, and the plant-scored hysteresis figures measured
before the lag was fitted by default were scored with it (``--fit-plant-lag``, the default, is kept
so that earlier commands still run).

Every run writes ``DIR/report.json``, ``DIR/report.md`` and PNG plots, and exits 0 whenever the
workflow ran, whatever it found; a mistake in the arguments or an unreadable input file gets one
line and exit status 2, before any work and with nothing written.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from simulation.discrepancy import WorkflowSettings
from simulation.discrepancy.candidates import HYSTERESIS_RESPONSE_TIME
from simulation.discrepancy.signals import pooled_rmse
from simulation.identification import NotIdentifiableError
from simulation.engine.robot import LOG_RATE, TRUTH_RATE
from studies.common.data_sources import is_dvrk_folder
from studies.common.discrepancy_report import (
    SCORED_BY_QUASI_STATIC,
    add_generator_knowledge,
    add_learned_comparison,
    file_digest,
    in_report_units,
    report_unit_names,
    scored_gaps,
    write_report,
)
from studies.common.discrepancy_runs import (
    ABLATION_CHOICES,
    DEFAULT_RECORD_S,
    HIDDEN_CHOICES,
    INERTIAL_LOADS,
    STARTING_STRUCTURE,
    analyse_measured,
    analysed_rows,
    analysis_settings,
    check_analysable,
    drift_record_note,
    generate_measured,
    hidden_effects,
    inertial_loads_from,
    learned_calibrators_on_dvrk,
    log_rate_options,
    read_flagged,
    read_measured,
    record_length,
    run_ablation,
    run_on_dvrk,
    run_on_raven_dataset,
    short_record_note,
    write_measured,
)
from studies.common.plant_scoring import (HYSTERESIS_LAG_RANGE, PLANT_REFIT_EFFECTS, PLANT_REFIT_EVALUATIONS,
                                         refit_with_plant, score_with_plant)
from studies.common.discrepancy_sweep import SWEEP_EFFECTS, read_sweeps, summarise_sweep, sweep
from studies.common.runner import (
    StudyRun,
    UsageError,
    existing_path,
    non_negative_int,
    one_line,
    positive_float,
    positive_int,
    refuse_options_that_do_not_apply,
    say,
    script_parser,
)

STUDY = "discrepancy"


def parse_effect_list(text: str) -> tuple[str, ...]:
    """``"none,backlash"`` -> ("none", "backlash"): the hidden effects of a sweep, each a valid choice."""
    names = tuple(n.strip() for n in text.split(",") if n.strip())
    for name in names:
        if name != "none":
            hidden_effects(name)
    if not names:
        raise argparse.ArgumentTypeError(f"expected effect names separated by commas, got {text!r}")
    return names


def parse_ablated(text: str) -> str:
    if text not in ABLATION_CHOICES:
        raise argparse.ArgumentTypeError(f"cannot ablate {text!r}; choose from {', '.join(ABLATION_CHOICES)}")
    return text


def joint_numbers(text: str) -> tuple[int, ...]:
    """``"4,5,6"`` -> (4, 5, 6): dVRK joints, numbered 1 to 6."""
    try:
        joints = tuple(int(j) for j in text.split(",") if j.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected joint numbers 1-6 separated by commas, got {text!r}") from None
    if not joints or any(not 1 <= j <= 6 for j in joints) or len(set(joints)) != len(joints):
        raise argparse.ArgumentTypeError(f"expected distinct joint numbers 1-6 separated by commas, got {text!r}")
    return joints



def analyse(path: Path, out: Path, runtime_s=None, shown_path: Path | None = None, arm: str = "left",
            progress: bool = False, max_rate: float | None = None, backfit_rounds: int | None = None,
            max_effects: int | None = None, plant_refit: bool = False, backfit_patience: int | None = None,
            fit_plant_lag: bool = True, inertial_loads: str = "joints", named_backfit_patience: int | None = None):
    """The blind ``--measured`` analysis of RAVEN-II data at ``path``, reported in ``out``.

    The analysis's last step scores its starting and final models with the plant replay where that
    applies (:func:`~studies.common.plant_scoring.score_with_plant`; the report's gaps and shrink are
    then the plant's, the workflow's quasi-static ones kept beside them). With ``plant_refit`` its
    named backlash, hysteresis or drift is then refitted with the plant replay
    (:func:`~studies.common.plant_scoring.refit_with_plant`), reported beside those figures. The
    plant score fits the lag of a named hysteresis; with ``fit_plant_lag`` False it takes the
    candidate's constant (``candidates.HYSTERESIS_RESPONSE_TIME``, a round 0.1 s).

    Returns the result, signals, split, plant score and plant refit (None unless asked for).
    ``shown_path`` is the input's name in the report (where the file will be once published);
    ``arm`` is for bags and CSV files (a Parquet dataset file records its own); ``max_rate`` (Hz)
    thins a faster log first; ``backfit_rounds`` caps the backfit's rounds, ``max_effects`` the
    effects named and ``backfit_patience`` (``named_backfit_patience``, once a candidate is named)
    the backfit's rounds in a row that may fail to lower the residual, instead of the workflow's
    defaults; ``inertial_loads`` (one of
    :data:`~studies.common.discrepancy_runs.INERTIAL_LOADS`) is where the replay takes the links'
    inertial loads from. The analysis reads ``path`` and nothing else
    (:func:`~studies.common.discrepancy_runs.analyse_measured`); the report's source counts the rows
    it left out for holding impossible values.
    """
    import time

    with inertial_loads_from(inertial_loads):
        clock = time.perf_counter()
        say("identifying the starting model and screening the library...")
        if arm == "left":
            result, signals, split = analyse_measured(path, progress=progress, max_rate=max_rate,
                                                      backfit_rounds=backfit_rounds, max_effects=max_effects,
                                                      backfit_patience=backfit_patience,
                                                      named_backfit_patience=named_backfit_patience)
        else:
            result, signals, split = run_on_raven_dataset(read_measured(path, arm, max_rate), progress=progress,
                                                          settings=analysis_settings(backfit_rounds, max_effects,
                                                                                     backfit_patience,
                                                                                     named_backfit_patience))
        source = {"kind": "raven", "path": str(shown_path or path), "sha256": file_digest(path),
                  "description": f"RAVEN-II data {Path(shown_path or path).name}"}
        if max_rate is not None:
            source["max_rate_hz"] = float(max_rate)
            source["description"] += f", thinned to at most {max_rate:g} Hz"
        dropped_rows = read_flagged(path, arm).n_invalid
        if dropped_rows:
            source["rows_dropped_invalid"] = int(dropped_rows)
            source["description"] += (f", {dropped_rows} row{'s' if dropped_rows != 1 else ''} with impossible "
                                      "values left out")
        if result.named_effects:
            say("scoring the starting and final models with the plant replay...")
        plant = score_with_plant(result, signals, split, fit_lag=fit_plant_lag)
        refit = None
        if plant_refit:
            if plant.applies and any(name in PLANT_REFIT_EFFECTS for name in result.named_effects):
                say("refitting the named effects with the plant replay...")
            refit = refit_with_plant(result, signals, split, plant)
        runtime = time.perf_counter() - clock if runtime_s is None else runtime_s
        write_report(result, signals, split, source, out, runtime, plant=plant, plant_refit=refit,
                     inertial_loads=inertial_loads)
        return result, signals, split, plant, refit


OPTION_DEFAULTS = {"seed": 0, "seeds": 3, "duration": DEFAULT_RECORD_S, "size_factor": 1.0,
                   "joints": (4, 5, 6), "arm": "left", "log_rate": LOG_RATE, "plant_refit": False,
                   "fit_plant_lag": False, "fixed_plant_lag": False, "inertial_loads": "joints"}
"""Values of the options that apply to some inputs only, when not given (their parser default is
None, so that a given option can be told from an absent one)."""


def options_that_apply(args) -> dict[str, tuple[bool, str]]:
    """Which of the input-dependent options apply to this run's input, and where each applies."""
    generated = args.hidden_effect is not None or args.ablate is not None or args.sweep
    dvrk = args.measured is not None and is_dvrk_folder(args.measured)
    raven_measured = args.measured is not None and not dvrk
    analysed_blind = (args.hidden_effect is not None or raven_measured,
                      "--measured RAVEN-II data and --hidden-effect only")
    plant_scored = (analysed_blind[0] or args.sweep, "--measured RAVEN-II data, --hidden-effect and --sweep only")
    return {
        "log_rate": (args.hidden_effect is not None,
                     "--hidden-effect only: it is the rate of the data that option generates"),
        "max_rate": (raven_measured, "--measured RAVEN-II data only"),
        "backfit_rounds": analysed_blind,
        "max_effects": analysed_blind,
        "plant_refit": analysed_blind,
        "fit_plant_lag": plant_scored,
        "fixed_plant_lag": plant_scored,
        "backfit_patience": analysed_blind,
        "named_backfit_patience": analysed_blind,
        "inertial_loads": analysed_blind,
        "seed": (generated, "generated data (--hidden-effect, --ablate, --sweep): measured data carry no seed"),
        "seeds": (args.sweep, "--sweep only"),
        "duration": (generated, "generated data (--hidden-effect, --ablate, --sweep) only"),
        "size_factor": (args.hidden_effect is not None or args.sweep, "--hidden-effect and --sweep only"),
        "effects": (args.sweep, "--sweep only"),
        "joints": (dvrk, "--measured dVRK data only"),
        "arm": (raven_measured, "--measured RAVEN-II data only"),
    }


def main(argv=None) -> int:
    parser = script_parser(STUDY, __doc__)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--hidden-effect", type=hidden_effects, metavar="NAME",
                        help=f"'none' or effects to hide, comma-separated: {', '.join(HIDDEN_CHOICES[1:])}")
    source.add_argument("--measured", type=existing_path, metavar="PATH",
                        help="recorded data: a dataset file, bag(s), or the dVRK folder format (blind analysis)")
    source.add_argument("--ablate", type=parse_ablated, metavar="NAME",
                        help=f"ablation: the model lacks one of {', '.join(ABLATION_CHOICES)}")
    source.add_argument("--sweep", action="store_true", help="confusion matrix of hidden vs named effects")
    source.add_argument("--merge-sweeps", type=existing_path, nargs="+", metavar="DIR",
                        help="one confusion matrix from sweeps run apart and single --hidden-effect runs "
                             "(their --out folders, confusion.json or report.json)")
    parser.add_argument("--seed", type=non_negative_int, default=None,
                        help="seed of generated data (default 0; --sweep: its first seed)")
    parser.add_argument("--seeds", type=positive_int, default=None, help="seeds per effect for --sweep (default 3)")
    parser.add_argument("--duration", type=record_length, default=None,
                        help="seconds of generated random motion (default: twenty minutes, the paper's random tests "
                             "and the shortest record on which drift at its published size was named; 240 for a "
                             "quicker look that cannot show drift; at least 5 s, at most six hours)")
    parser.add_argument("--size-factor", type=positive_float, default=None,
                        help="--hidden-effect and --sweep only: generate the hidden effect at this multiple of its "
                             "default size (default 1: the size its source gives)")
    parser.add_argument("--log-rate", type=positive_float, default=None, metavar="HZ",
                        help="--hidden-effect only: log the generated robot state (and the ground truth, at least "
                             f"at its {TRUTH_RATE:g} Hz) at this rate instead of the robot's {LOG_RATE:g} Hz")
    parser.add_argument("--max-rate", type=positive_float, default=None, metavar="HZ",
                        help="--measured RAVEN-II data only: keep every k-th row so that the log's rate is at most "
                             "HZ (the workflow's cost grows with the rows, and its thresholds were set at 30 Hz)")
    parser.add_argument("--backfit-rounds", type=non_negative_int, default=None, metavar="N",
                        help="--measured RAVEN-II data and --hidden-effect only: at most N backfit rounds instead of "
                             f"the workflow's {WorkflowSettings().backfit_rounds} (report.json's backfit_capped names "
                             "fits the cap cut short)")
    parser.add_argument("--backfit-patience", type=non_negative_int, default=None, metavar="N",
                        help="--measured RAVEN-II data and --hidden-effect only: let the backfit go on past up to N "
                             "rounds in a row that do not lower the fit part's residual, from where each ended, "
                             f"keeping the best (the workflow's default: {WorkflowSettings().backfit_patience}, the "
                             "first such round ends it; with --hidden-effect the oracle gets the same)")
    parser.add_argument("--named-backfit-patience", type=non_negative_int, default=None, metavar="N",
                        help="--measured RAVEN-II data and --hidden-effect only: once a candidate is named, let its "
                             "backfit go on past up to N rounds in a row that do not lower the fit part's residual "
                             "(the workflow's default: "
                             f"{WorkflowSettings().named_backfit_patience}; 0: it ends where the candidate was "
                             "chosen; with --hidden-effect the oracle gets the same)")
    parser.add_argument("--max-effects", type=positive_int, default=None, metavar="N",
                        help="--measured RAVEN-II data and --hidden-effect only: name at most N effects instead of "
                             f"{WorkflowSettings().max_iterations}, and stop there without checking for more "
                             "(report.json's search_capped says whether it stopped at N)")
    parser.add_argument("--plant-refit", action="store_true", default=None,
                        help="--measured RAVEN-II data and --hidden-effect only: refit a named backlash, hysteresis or "
                             "drift with the plant replay where it scores the analysis, from the workflow's values (up "
                             f"to {PLANT_REFIT_EVALUATIONS} replays of the fit part, about ten minutes on twenty), "
                             "reported beside the workflow's own figures")
    lag = parser.add_mutually_exclusive_group()
    lag.add_argument("--fixed-plant-lag", action="store_true", default=None,
                     help="--measured RAVEN-II data, --hidden-effect and --sweep only: where the plant replay scores a "
                          f"named hysteresis, give it the candidate's lag of {HYSTERESIS_RESPONSE_TIME:g} s behind the "
                          "stretch (a round value; the plant-scored hysteresis figures of the days before the lag "
                          "was fitted used 0.05 s, the simulator's default) "
                          "instead of fitting the lag to the plant on the fit part "
                          f"(0 to {HYSTERESIS_LAG_RANGE[1]:g} s)")
    lag.add_argument("--fit-plant-lag", action="store_true", default=None,
                     help="the default, kept so that earlier commands run: fit the lag of a named hysteresis to the "
                          "plant")
    parser.add_argument("--inertial-loads", choices=INERTIAL_LOADS, default=None,
                        help="--measured RAVEN-II data and --hidden-effect only: where the replay takes the links' "
                             "inertial loads from: 'joints' (the default), a causal second derivative of the measured "
                             "joints; 'motors', the motors' acceleration through the arm's nominal coupling (with "
                             "--hidden-effect the oracle and the floor get the same)")
    parser.add_argument("--effects", type=parse_effect_list, default=None, metavar="NAMES",
                        help="--sweep only these hidden effects (comma-separated; default: every choice)")
    parser.add_argument("--joints", type=joint_numbers, default=None,
                        help="dVRK joints (1-6) to study (default 4,5,6: the wrist)")
    parser.add_argument("--arm", default=None, choices=("left", "right"),
                        help="arm of --measured bags or CSV files (default left; Parquet dataset files record theirs)")
    parser.add_argument("--out", type=Path, default=Path("results") / "discrepancy")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress bars (nor, when stderr is not a terminal, a line per finished sweep run)")
    with StudyRun(parser, argv) as study:
        args = study.args
        refuse_options_that_do_not_apply(parser, args, options_that_apply(args), OPTION_DEFAULTS)
        progress = not args.no_progress and sys.stderr.isatty()
        if args.merge_sweeps:
            runs, duration, size_factor, files = read_sweeps(args.merge_sweeps)
            summarise_sweep(runs, duration, study.folder, size_factor, extra={"merged_from": files})
            study.publish()
            study.done()
            return 0
        if args.sweep:
            sweep(args.effects or SWEEP_EFFECTS, range(args.seed, args.seed + args.seeds), args.duration, study.folder,
                  progress, args.size_factor, lines=not args.no_progress and not progress,
                  fit_plant_lag=not args.fixed_plant_lag)
            study.publish()
            study.done()
            return 0
        plant = refit = None
        if args.hidden_effect is not None:
            say(f"generating {args.duration:.0f} s of motion with {', '.join(args.hidden_effect) or 'nothing'} hidden...")
            dataset, generator = generate_measured(args.hidden_effect, seed=args.seed, duration=args.duration,
                                                   size_factor=args.size_factor,
                                                   robot_options=log_rate_options(args.log_rate))
            path = write_measured(dataset, study.folder)
            del dataset
            result, signals, split, plant, refit = analyse(path, study.folder, shown_path=study.final(path),
                                                           progress=progress, backfit_rounds=args.backfit_rounds,
                                                           max_effects=args.max_effects, plant_refit=args.plant_refit,
                                                           backfit_patience=args.backfit_patience,
                                                           named_backfit_patience=args.named_backfit_patience,
                                                           fit_plant_lag=not args.fixed_plant_lag,
                                                           inertial_loads=args.inertial_loads)
            add_generator_knowledge(study.folder, args.hidden_effect, args.seed, args.duration, generator, path,
                                    result, args.size_factor, args.log_rate, plant, signals, split)
        elif args.ablate is not None:
            result, signals, split, generator = run_ablation(args.ablate, seed=args.seed, duration=args.duration,
                                                             folder=study.folder)
            source = {"kind": "simulated", "ablated": args.ablate, "seed": args.seed, "duration_s": args.duration,
                      "description": f"ablation of {args.ablate} on the virtual RAVEN-II"}
            structure = tuple(e for e in STARTING_STRUCTURE if e != args.ablate)
            write_report(result, signals, split, source, study.folder, study.stop_clock(), structure, "ablation",
                         inertial_loads="joints")
        elif is_dvrk_folder(args.measured):
            joints = tuple(j - 1 for j in args.joints)
            root = args.measured.parent if (args.measured / "q_des.npy").exists() else args.measured
            with study.reading(args.measured):
                result, signals, split = run_on_dvrk(root, joints)
            text = ",".join(str(j) for j in args.joints)
            source = {"kind": "dvrk", "path": str(args.measured), "joints": [j + 1 for j in joints],
                      "description": f"dVRK data of Hwang et al. 2020, joints {text} "
                                     "(fit on random motion, held out: peg transfer)"}
            write_report(result, signals, split, source, study.folder, study.stop_clock(), (), "blind")
            say("training the learned calibrators on the same split...")
            add_learned_comparison(study.folder, result, learned_calibrators_on_dvrk(root, joints))
        else:
            # an unreadable input, or one the workflow cannot analyse, is a one-line usage error before any work
            with study.reading(args.measured):
                flagged = read_flagged(args.measured, args.arm)
            try:
                check_analysable(analysed_rows(flagged, args.max_rate))
            except ValueError as error:
                dropped = flagged.n_invalid
                left_out = f" ({dropped} of {len(flagged)} rows left out for impossible values)" if dropped else ""
                raise UsageError(f"{args.measured} cannot be analysed{left_out}: {one_line(error)}") from error
            del flagged
            try:
                result, signals, split, plant, refit = analyse(args.measured, study.folder, arm=args.arm,
                                                               progress=progress, max_rate=args.max_rate,
                                                               backfit_rounds=args.backfit_rounds,
                                                               max_effects=args.max_effects,
                                                               plant_refit=args.plant_refit,
                                                               backfit_patience=args.backfit_patience,
                                                               named_backfit_patience=args.named_backfit_patience,
                                                               fit_plant_lag=not args.fixed_plant_lag,
                                                               inertial_loads=args.inertial_loads)
            except NotIdentifiableError as error:
                raise UsageError(f"{args.measured} cannot be analysed: {one_line(error)}") from error
        study.publish()
    units = report_unit_names(result.units)
    note = short_record_note(signals)
    if note is not None:
        print(f"warning: {note}", file=sys.stderr)
    drift_note = drift_record_note(signals)
    if drift_note is not None:
        print(f"note: {drift_note}", file=sys.stderr)
    gap_before, gap_after, shrink, scored_by = scored_gaps(result, plant)
    print(f"named effects: {', '.join(result.named_effects) or 'none'}; unexplained: {result.unexplained}")
    for name, b, a, u in zip(result.joint_names, in_report_units(gap_before, result.units),
                             in_report_units(gap_after, result.units), units):
        print(f"  {name:12s} held-out gap {b:9.4f} -> {a:9.4f} {u}")
    print(f"shrink (pooled, deg and mm; {scored_by}): {100 * shrink:.1f} %   "
          f"[{pooled_rmse(gap_before[None, :], result.units):.4f} -> {pooled_rmse(gap_after[None, :], result.units):.4f}]")
    if scored_by != SCORED_BY_QUASI_STATIC:
        print(f"  the workflow's quasi-static replay: {100 * result.shrink:.1f} %")
    if plant is not None and plant.applies and plant.hysteresis_lag is not None:
        print(f"  the hysteresis's lag fitted to the plant: {plant.hysteresis_lag:.3f} s")
    if refit is not None:
        print(f"  {', '.join(refit.effects)} refitted with the plant replay ({refit.replays} replays): "
              f"{100 * refit.shrink:.1f} %" if refit.applies else f"  not refitted with the plant replay: {refit.reason}")
    for sentence in result.signature:
        print(f"  unexplained: {sentence}")
    study.done()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
