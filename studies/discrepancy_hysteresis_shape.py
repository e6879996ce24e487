"""What sets the fitted Bouc-Wen shape of a hidden hysteresis, and whether the shape holds the shrink short.

A diagnostic, never part of an analysis: it knows the generator. It runs what ``python
studies/discrepancy.py --hidden-effect hysteresis --seed S --fixed-plant-lag --out DIR`` runs
(twenty minutes of random motion with the hysteresis hidden, written to ``DIR/measured.parquet``, the
blind analysis of that file scored with the plant, a fitted hysteresis lagging by the candidate's
constant, then the oracle and both floors: the command as its tables here were measured, before it
fitted the lag by default, except that the candidate's constant is now a round 0.1 s and was then
0.05 s, the generator's; ``--scorer-lag 0.05`` runs it as then) with up to four changes:

``--response-time T``
    The generator's hysteresis follows the cable's stretch over T seconds (its
    ``Hysteresis.response_time``, a first-order lag; 0.05 s by default, 0 at every plant
    sub-step). The quasi-static replay's Bouc-Wen follows the logged stretch sample by sample
    whatever T is. The plant replay that scores the final models gives a fitted hysteresis the
    same T, so that the scorer's plant is the generator's (as the command's ``--fixed-plant-lag``
    was at the default T while the candidate's constant was 0.05 s).
``--scorer-lag L``
    The plant replay gives a fitted hysteresis the lag L seconds instead (the candidate's
    ``candidates.HYSTERESIS_RESPONSE_TIME``, or T above), while the generator keeps its own: how much
    the plant's scores owe to the scorer sharing the generator's lag. The quasi-static analysis, and
    so what is named and fitted, does not read it.
``--fit-scorer-lag``
    The plant replay fits the lag of a fitted hysteresis on the fit part, as the command does by
    default (within 0 to 0.5 s, from 0.1 s), instead of taking one: whether a
    scorer that shares no lag with the generator finds the generator's, and what it closes with it.
``--pin-shape X``
    The library's hysteresis candidate holds its shape ``gamma / beta`` at X (0 to 1) instead of
    fitting it, in the blind analysis and in the oracle; its stiffness and width are fitted as
    usual (the report's ``at_bound`` then lists the shape, held at both ends of its range).
``--fit-replay-lag``
    The library's hysteresis candidate fits a response time per joint with its other parameters
    (from a round 0.1 s, within 0 to 0.5 s), and the quasi-static replay's Bouc-Wen state follows
    the stretch over it (``RavenModel.follows_hysteresis_lag``), in the blind analysis and in the
    oracle: whether a workflow that fits the lag it replays closes more of the gap. The plant
    replay that scores the final models takes those lags, or fits its own with ``--fit-scorer-lag``
    (not with ``--scorer-lag``).
``--motor-side-loads``
    The quasi-static replay takes the links' inertial loads from the motors' acceleration through
    the nominal coupling (the command's ``--inertial-loads motors``, causal too) instead of from the
    measured joints, in the blind analysis, the oracle and the quasi-static floor: whether a
    replay with that lower floor, whose fits the plant then scores, closes more. The plant replay
    takes no acceleration, so its floor is the same (its bound moves only through the starting
    model's offsets, which the replay fits).

``--backfit-patience N`` passes the command's option of that name to the blind analysis (and so
to the oracle). None of these changes the analysis's code path: the record reaches it as a file.
With none of them the run is the command's with ``--fixed-plant-lag`` (the scorer's lag the
candidate's 0.1 s, the generator's 0.05 s); with ``--fit-scorer-lag`` alone, the command's. Run::

    python studies/discrepancy_hysteresis_shape.py --seed 97 --response-time 0 --out DIR
    python studies/discrepancy_hysteresis_shape.py --seed 97 --scorer-lag 0.2 --out DIR
    python studies/discrepancy_hysteresis_shape.py --seed 97 --response-time 0.2 --fit-scorer-lag --out DIR
    python studies/discrepancy_hysteresis_shape.py --seed 97 --pin-shape 0.4 --out DIR
    python studies/discrepancy_hysteresis_shape.py --seed 124 --fit-replay-lag --fit-scorer-lag --out DIR
    python studies/discrepancy_hysteresis_shape.py --seed 124 --motor-side-loads --fit-scorer-lag --out DIR

It prints the named effects, the fitted shape, stiffness and width beside the generator's, the
first iteration's fit-part gap and BIC, and the shrink (plant and quasi-static) beside the plant
floor's bound; ``DIR/report.json`` is the command's report with ``response_time_s``,
``scorer_lag_s`` (the fitted lag with ``--fit-scorer-lag``, the replay's per joint with
``--fit-replay-lag`` alone), ``scorer_lag_fitted``, ``replay_lag_fitted``, ``motor_side_loads`` and
``pinned_shape`` added.
"""

from __future__ import annotations

import json
import sys
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path

from simulation.discrepancy.candidates import ParameterBlock
from studies.common.discrepancy_runs import DEFAULT_RECORD_S, record_length
from studies.common.runner import StudyRun, non_negative_int, number_between, script_parser, say

STUDY = "discrepancy_hysteresis_shape"


response_time = number_between(0.0, 1.0, " s")
"""A response time in seconds, from 0 to one second."""

shape_value = number_between(0.0, 1.0, note=" (the candidate's range)")
"""A Bouc-Wen shape ``gamma / beta`` from 0 to 1, the candidate's range."""


REPLAY_LAG = ParameterBlock("response_time", 3, 0.0, 0.5, 0.1, 0.1, "s")
"""The response time per joint that ``--fit-replay-lag`` fits with the hysteresis candidate: from a
round 0.1 s (the candidate's constant), within 0 to 0.5 s, as ``studies/discrepancy_replay_bias.py
--fit-lag`` fits it on the generator's base."""


def fitting_its_lag(candidate):
    """The hysteresis ``candidate`` with a response time per joint fitted with it (:data:`REPLAY_LAG`),
    building models whose quasi-static replay follows that lag
    (:attr:`~simulation.discrepancy.replay.RavenModel.follows_hysteresis_lag`)."""
    own = candidate.build

    def build(model, values):
        built = own(model, values)
        effect = built.params.effect("hysteresis").replace(response_time=values["response_time"])
        return replace(built.with_effect(effect), follows_hysteresis_lag=True)

    return replace(candidate, blocks=candidate.blocks + (REPLAY_LAG,), build=build)


@contextmanager
def hysteresis_candidate(shape: float | None, lag: float | None, fit_lag: bool = False):
    """Within the block, the library's hysteresis candidate holds its shape at ``shape`` (None:
    fitted) and builds a hysteresis of response time ``lag`` seconds (None: the candidate's own,
    ``candidates.HYSTERESIS_RESPONSE_TIME``); with ``fit_lag`` it fits a response time per joint
    instead, which the quasi-static replay follows (``lag`` must then be None)."""
    from simulation.discrepancy import candidates

    if fit_lag and lag is not None:
        raise ValueError("a fitted replay lag leaves no constant lag to the candidate")
    library, own_lag = candidates.raven_candidates, candidates.HYSTERESIS_RESPONSE_TIME

    def pinned(signals):
        out = []
        for candidate in library(signals):
            if candidate.name == "hysteresis" and shape is not None:
                blocks = tuple(replace(b, lower=shape, upper=shape, initial=shape) if b.name == "shape" else b
                               for b in candidate.blocks)
                candidate = replace(candidate, blocks=blocks)
            if candidate.name == "hysteresis" and fit_lag:
                candidate = fitting_its_lag(candidate)
            out.append(candidate)
        return out

    candidates.raven_candidates = pinned
    if lag is not None:
        candidates.HYSTERESIS_RESPONSE_TIME = lag
    try:
        yield
    finally:
        candidates.raven_candidates, candidates.HYSTERESIS_RESPONSE_TIME = library, own_lag


def generator_with(lag: float | None):
    """The virtual RAVEN-II's parameters, its hysteresis of response time ``lag`` (None: default)."""
    from simulation.model.parameters import RavenParameters

    params = RavenParameters()
    if lag is None:
        return params
    return params.with_effect(replace(params.effect("hysteresis"), response_time=lag))


def summary(report: dict) -> dict:
    """The figures this study prints, from the command's ``report.json``."""
    first = next(c for c in report["iterations"][0]["candidates"] if c["name"] == "hysteresis")
    quasi = report.get("quasi_static") or {}
    return {"named_effects": report["named_effects"], "shrink": report["shrink"],
            "quasi_static_shrink": quasi.get("shrink", report["shrink"]),
            "plant_floor_bound": report.get("plant_floor_bound"), "floor_bound": report.get("floor_bound"),
            "first_fit_gap": first["fit_gap"], "first_bic": first["bic"],
            "fitted": report["fitted_parameters"].get("hysteresis"), "true": report["true_parameters"]["hysteresis"]}


def _check_lags(args) -> None:
    if args.fit_replay_lag and args.scorer_lag is not None:
        raise ValueError("--fit-replay-lag gives the scorer the fitted lags: leave out --scorer-lag")


def _values(values) -> str:
    return ", ".join(f"{v:.3g}" for v in values)


def main(argv: list[str] | None = None) -> int:
    from simulation.discrepancy import candidates
    from studies.common.discrepancy_report import add_generator_knowledge
    from studies.common.discrepancy_runs import generate_measured, write_measured
    from studies.discrepancy import analyse

    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of the generated data (>= 0)")
    parser.add_argument("--duration", type=record_length, default=DEFAULT_RECORD_S,
                        help="record length (s, at most six hours)")
    parser.add_argument("--response-time", type=response_time, default=None, metavar="T",
                        help="the generator's hysteresis follows the stretch over T s (0 to 1; "
                             "without it, the effect's default)")
    scorer = parser.add_mutually_exclusive_group()
    scorer.add_argument("--scorer-lag", type=response_time, default=None, metavar="L",
                        help="the plant replay's lag of a fitted hysteresis, L s (0 to 1; without it, "
                             "the generator's when --response-time is given, else the candidate's own)")
    scorer.add_argument("--fit-scorer-lag", action="store_true",
                        help="the plant replay fits the lag of a fitted hysteresis on the fit part (as the command "
                             "does by default) instead of taking one")
    parser.add_argument("--pin-shape", type=shape_value, default=None, metavar="X",
                        help="the candidate's shape gamma/beta held at X (0 to 1; without it, fitted)")
    parser.add_argument("--fit-replay-lag", action="store_true",
                        help="the candidate fits a response time per joint (0 to 0.5 s, from 0.1 s) that the "
                             "quasi-static replay's Bouc-Wen state follows, in the blind analysis and the oracle")
    parser.add_argument("--motor-side-loads", action="store_true",
                        help="the quasi-static replay's inertial loads from the motors' acceleration, in the blind "
                             "analysis, the oracle and the quasi-static floor")
    parser.add_argument("--backfit-patience", type=non_negative_int, default=None, metavar="N",
                        help="the command's --backfit-patience (without it, the workflow's default)")
    parser.add_argument("--out", type=Path, default=Path("results") / STUDY)
    with StudyRun(parser, argv, configure=_check_lags) as study:
        args = study.args
        say(f"generating {args.duration:.0f} s of motion with hysteresis hidden"
            + ("" if args.response_time is None else f" (response time {args.response_time:g} s)") + "...")
        dataset, generator = generate_measured(("hysteresis",), seed=args.seed, duration=args.duration,
                                               params=generator_with(args.response_time))
        path = write_measured(dataset, study.folder)
        del dataset
        scorer_lag = (None if args.fit_scorer_lag or args.fit_replay_lag
                      else args.response_time if args.scorer_lag is None else args.scorer_lag)
        loads = "motors" if args.motor_side_loads else "joints"
        with hysteresis_candidate(args.pin_shape, scorer_lag, fit_lag=args.fit_replay_lag):
            result, signals, split, plant, _ = analyse(path, study.folder, shown_path=study.final(path),
                                                       backfit_patience=args.backfit_patience,
                                                       fit_plant_lag=args.fit_scorer_lag, inertial_loads=loads)
            add_generator_knowledge(study.folder, ("hysteresis",), args.seed, args.duration, generator, path,
                                    result, plant=plant, signals=signals, split=split)
        report_path = study.folder / "report.json"
        report = json.loads(report_path.read_text())
        report["response_time_s"] = float(generator.effect("hysteresis").response_time[0])
        if args.fit_scorer_lag:
            report["scorer_lag_s"] = (report["plant_replay"] or {}).get("hysteresis_lag_s")
        elif args.fit_replay_lag:
            # the replay's lags, one per joint, fitted with the named hysteresis (None when none is named)
            report["scorer_lag_s"] = (report["fitted_parameters"].get("hysteresis") or {}).get("response_time")
        else:
            report["scorer_lag_s"] = float(candidates.HYSTERESIS_RESPONSE_TIME if scorer_lag is None else scorer_lag)
        report["scorer_lag_fitted"] = bool(args.fit_scorer_lag)
        report["replay_lag_fitted"] = bool(args.fit_replay_lag)
        report["motor_side_loads"] = bool(args.motor_side_loads)
        report["pinned_shape"] = args.pin_shape
        report_path.write_text(json.dumps(report, indent=1))
        study.publish()
    s = summary(report)
    scorer = report["scorer_lag_s"]
    if scorer is None:
        scorer = "none"
    elif isinstance(scorer, list):
        scorer = f"{_values(scorer)} s, the replay's"
    else:
        scorer = f"{scorer:.3g} s" + (", fitted" if args.fit_scorer_lag else "")
    print(f"response time {report['response_time_s']:g} s (scorer's {scorer}); shape "
          + ("fitted" if args.pin_shape is None else f"pinned at {args.pin_shape:g}")
          + ("; inertial loads from the motors" if args.motor_side_loads else ""))
    print(f"named: {', '.join(s['named_effects']) or 'nothing'}")
    if s["fitted"] is not None:
        for name in ("shape", "stiffness", "width"):
            print(f"  {name:9s} fitted {_values(s['fitted'][name])}   generator {_values(s['true'][name])}")
        if "response_time" in s["fitted"]:
            print(f"  replay lag fitted {_values(s['fitted']['response_time'])} s   generator "
                  f"{report['response_time_s']:g} s")
    print(f"first iteration: fit-part gap {s['first_fit_gap']:.5g}, BIC {s['first_bic']:.0f}")
    bound = s["plant_floor_bound"]
    print(f"shrink {100 * s['shrink']:.1f} % (plant; bound {100 * bound:.1f} %), "
          f"quasi-static {100 * s['quasi_static_shrink']:.1f} % (bound {100 * s['floor_bound']:.1f} %)"
          if bound is not None else f"shrink {100 * s['shrink']:.1f} %")
    study.done()
    return 0


if __name__ == "__main__":
    sys.exit(main())
