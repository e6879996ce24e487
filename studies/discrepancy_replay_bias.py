"""Where the quasi-static replay puts a hidden hysteresis when every other value is the generator's.

A diagnostic that knows the generator, never part of an analysis. The blind analysis fits a named
hysteresis with the quasi-static replay (``simulation.discrepancy.replay``), whose Bouc-Wen state
follows the logged stretch sample by sample and whose links take their inertial loads from causal
estimates of their accelerations. The generator's hysteresis follows the stretch of the simulated
plant over its response time (a first-order lag, 0.05 s by default), on links that swing on their
cables. This study measures what that difference alone does to the fitted size of the loop.

For each seed it generates the record of ``python studies/discrepancy.py --hidden-effect hysteresis
--seed S`` (twenty minutes of random motion by default), reads it as the analysis reads its file,
and replays the fit part (the record's first half) with the generator's own parameters, the
hysteresis included, changing one thing: one joint's hysteresis stiffness, scaled by a factor
between :data:`FACTOR_RANGE`'s ends. Its width and shape stay the generator's, so the factor scales
the loop's height (``stiffness / (beta + gamma)``). It reports, per joint, the factor at the fit
part's smallest weighted sum of squares (joints and motor torques, the offsets fitted on the fit
part, each channel weighed by the residual the generator's parameters leave without the hysteresis,
as the workflow weighs by its starting model's). A replay that followed the plant exactly would put
it at 1. Three replays:

- **the workflow's**: the replay as the analysis runs it;
- **without the links' inertial loads**: the links' accelerations set to zero, which removes what the
  causal acceleration estimate brings to the loads;
- **following the generator's lag**: the workflow's, but its Bouc-Wen state follows the stretch
  over the generator's response time, as the simulator's does (``RavenModel.follows_hysteresis_lag``;
  only where the generator's hysteresis lags).

and two generators (``--response-times``): the hysteresis at its default response time, and one that
follows the stretch of every plant sub-step (0), as the replay's does.

With ``--fit``, the library's hysteresis candidate is also fitted (as the workflow's candidate fits
run, from its typical values, at most ``--fit-iterations`` IPOPT iterations) on the generator's
base, its parameters without the hysteresis: the loop height per joint over the generator's and the
fitted shape; where the generator's hysteresis lags, fitted also with the replay following that lag,
and with ``--fit-lag`` also with the replay following a lag per joint fitted with the candidate (0 to
0.5 s, from a round 0.1 s): whether the quasi-static replay can find the lag itself. With
``--on-starting-base`` these fits are made on the blind analysis's starting model instead (the
starting structure identified on the fit part, weighed as the workflow weighs it): the base the
analysis's first iteration fits its candidates on, before any backfit.
With ``--runs``, the reports of ``--hidden-effect hysteresis`` runs (as
``studies/discrepancy_hysteresis_amplitude.py`` reads them): the seeds measured are theirs, and
beside the replay's elbow factor of each seed are its blind fit's elbow loop-height error and its
shortfall from the bound, with the Spearman rank correlation of the factor with each over the
seeds. Run::

    python studies/discrepancy_replay_bias.py --seed 124 --seeds 5 --out bias.json
    python studies/discrepancy_replay_bias.py --fit --runs results/hysteresis-124 results/hysteresis-125 ...
    python studies/discrepancy_replay_bias.py --seed 124 --seeds 5 --fit --fit-lag --on-starting-base
"""

from __future__ import annotations

import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from studies.common.discrepancy_runs import DEFAULT_RECORD_S, record_length
from studies.common.reporting import write_json
from studies.common.runner import (UsageError, existing_path, fail, non_negative_int, number_between, positive_int,
                                   say, script_parser)

STUDY = "discrepancy_replay_bias"

FACTOR_RANGE = (0.5, 2.0)
"""The factors of the generator's hysteresis stiffness searched (a bounded scalar search)."""

FACTOR_TOLERANCE = 1e-3
"""Absolute tolerance of the searched factor."""

REPLAYS = ("the workflow's replay", "without the links' inertial loads", "following the generator's lag")
"""The replays of :func:`stiffness_factors` (see the module's text)."""

JOINTS = ("shoulder", "elbow", "z_ins")

FIT_LAGS = ("none", "generator's", "fitted")
"""What the replay's Bouc-Wen state follows in :func:`fitted_candidate`."""

BASES = ("generator's", "starting")
"""What :func:`fitted_candidate` fits the candidate on: the generator's parameters without the
hysteresis, or the blind analysis's starting model (:func:`starting_base`)."""

DEFAULT_SEED = 124
"""The seed measured without ``--seed`` or ``--runs``: the one whose blind fit overshoots most."""


@dataclass(frozen=True)
class Record:
    """One generated record, read as the analysis reads it, with what only a diagnostic may know."""

    signals: object
    split: object
    robot: object
    generator: object
    weights: object
    starting: tuple | None = None
    """The starting model the blind analysis identifies and the workflow's weights of its residual
    (:func:`starting_base`), when asked for."""


def generated(seed: int, duration: float, response_time: float | None, starting: bool = False) -> Record:
    """Seed ``seed``'s record of ``duration`` s with the hysteresis hidden (its response time
    ``response_time`` s; None: the effect's default), written and read as the analysis reads its
    file; the channel weights of the generator's parameters without the hysteresis on the fit part;
    with ``starting``, also the blind analysis's starting model (:func:`starting_base`)."""
    from kinematics import RavenII
    from simulation.discrepancy.signals import MeasuredSignals
    from simulation.discrepancy.workflow import Split
    from studies.common.discrepancy_runs import generate_measured, read_measured, write_measured
    from studies.discrepancy_hysteresis_shape import generator_with

    data, generator = generate_measured(("hysteresis",), seed, duration, params=generator_with(response_time))
    with tempfile.TemporaryDirectory() as folder:
        dataset = read_measured(write_measured(data, folder))
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    robot = RavenII(signals.arm, check_limits=False)
    return Record(signals, split, robot, generator, base_weights(generator, signals, split, robot),
                  starting_base(dataset, signals, split, robot) if starting else None)


def starting_base(dataset, signals, split, robot) -> tuple:
    """The model the blind analysis's first iteration fits its candidates on: the starting structure
    identified on the fit part from the uninformed start, with the fit part's offsets; and the
    channel weights the workflow gives its residual there (as ``run_workflow`` weighs: offsets not
    fitted again, a floor of 0.001 deg and mm)."""
    from simulation.discrepancy.fitting import ChannelWeights, residual
    from simulation.discrepancy.signals import report_scale
    from studies.common.discrepancy_runs import STARTING_STRUCTURE, raven_base_identifier

    model = raven_base_identifier(dataset, split.fit, STARTING_STRUCTURE).identify(tuple(STARTING_STRUCTURE), None)
    model = _with_fit_offsets(model, signals, split, robot)
    fit = residual(model, signals, robot, offsets=np.zeros(signals.n_joints), mask=split.fit)
    return model, ChannelWeights.from_residual(fit.joints, fit.torque, 1e-3 / report_scale(signals.units))


def _with_fit_offsets(model, signals, split, robot):
    from simulation.discrepancy.fitting import residual

    return model.with_offsets(model.offsets + residual(model, signals, robot, mask=split.fit).joint_offsets)


def base_weights(generator, signals, split, robot):
    """The workflow's channel weights (:class:`~simulation.discrepancy.fitting.ChannelWeights`, with
    its floor of 0.001 deg and mm) of the residual the generator's parameters leave on the fit part
    without the hysteresis."""
    from simulation.discrepancy.fitting import ChannelWeights, residual
    from simulation.discrepancy.replay import RavenModel
    from simulation.discrepancy.signals import report_scale

    base = _with_fit_offsets(RavenModel(generator.without("hysteresis"), np.zeros(3)), signals, split, robot)
    fit = residual(base, signals, robot, mask=split.fit)
    return ChannelWeights.from_residual(fit.joints, fit.torque, 1e-3 / report_scale(signals.units))


def stiffness_factor(generator, signals, split, robot, weights, joint: int, follows_lag: bool = False) -> float:
    """The factor of joint ``joint``'s hysteresis stiffness (the generator's otherwise) at the fit
    part's smallest weighted sum of squares of the quasi-static replay, within :data:`FACTOR_RANGE`;
    with ``follows_lag`` the replay's Bouc-Wen state follows the stretch over the generator's
    response time (``RavenModel.follows_hysteresis_lag``)."""
    from scipy.optimize import minimize_scalar

    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.replay import RavenModel

    true = generator.effect("hysteresis")
    model = RavenModel(generator, np.zeros(3), follows_hysteresis_lag=follows_lag)

    def chi_square(factor):
        stiffness = np.array(true.stiffness, dtype=float)
        stiffness[joint] *= factor
        scaled = _with_fit_offsets(model.with_effect(true.replace(stiffness=stiffness)), signals, split, robot)
        return residual(scaled, signals, robot, mask=split.fit).chi_square(weights)

    best = minimize_scalar(chi_square, bounds=FACTOR_RANGE, method="bounded", options={"xatol": FACTOR_TOLERANCE})
    return float(best.x)


def stiffness_factors(record: Record) -> dict[str, list[float]]:
    """:func:`stiffness_factor` of every joint, for each replay of :data:`REPLAYS` (the last only
    where the generator's hysteresis lags: otherwise it is the first)."""
    signals = record.signals
    replays = {REPLAYS[0]: (signals, False),
               REPLAYS[1]: (signals.with_derivatives(acceleration=np.zeros_like(signals.truth)), False)}
    if np.any(record.generator.effect("hysteresis").response_time > 0):
        replays[REPLAYS[2]] = (signals, True)
    return {name: [stiffness_factor(record.generator, s, record.split, record.robot, record.weights, j, lagged)
                   for j in range(len(JOINTS))] for name, (s, lagged) in replays.items()}


def effect_loop_height(hysteresis) -> np.ndarray:
    """The loop height of a :class:`~simulation.model.effects.Hysteresis` (its largest hysteretic load
    per joint, ``stiffness / (beta + gamma)``, N m, N m, N), through
    :func:`~studies.discrepancy_hysteresis_amplitude.hysteretic_amplitude` in the candidate's terms
    (``width = 1 / beta``, ``shape = gamma / beta``)."""
    from studies.discrepancy_hysteresis_amplitude import hysteretic_amplitude

    beta = np.asarray(hysteresis.beta, dtype=float)
    return hysteretic_amplitude({"stiffness": hysteresis.stiffness, "width": 1.0 / beta,
                                 "shape": np.asarray(hysteresis.gamma, dtype=float) / beta})


def fitted_candidate(record: Record, max_iter: int, lag: str = "none", base: str = "generator's") -> dict:
    """The library's hysteresis candidate fitted with the quasi-static replay on the fit part, on the
    generator's parameters without the hysteresis (``base`` ``"generator's"``, weighed as
    :func:`base_weights`) or on the blind analysis's starting model (``"starting"``, weighed as the
    workflow weighs it; the record must hold it): its values, its loop height over the generator's
    minus 1 per joint, and the fitted values at an end of their search range (as the workflow's
    reports mark them). ``lag`` (one of :data:`FIT_LAGS`) is what the replay's Bouc-Wen state
    follows: ``"none"`` the stretch itself (the workflow's replay), ``"generator's"`` the stretch
    over the generator's response time, ``"fitted"`` the stretch over a response time per joint
    fitted with the candidate (from a round 0.1 s, within 0 to 0.5 s). The candidate's own round
    lag, which only a plant replay reads, is replaced in the last two."""
    from dataclasses import replace

    from simulation.discrepancy.fitting import fit_candidate
    from simulation.discrepancy.replay import RavenModel
    from simulation.discrepancy.workflow import values_at_bounds
    from studies.common.discrepancy_runs import raven_library
    from studies.discrepancy_hysteresis_amplitude import hysteretic_amplitude
    from studies.discrepancy_hysteresis_shape import fitting_its_lag

    if lag not in FIT_LAGS:
        raise ValueError(f"lag must be one of {', '.join(FIT_LAGS)}, got {lag!r}")
    if base not in BASES:
        raise ValueError(f"base must be one of {', '.join(BASES)}, got {base!r}")
    if base == "starting" and record.starting is None:
        raise ValueError("the record holds no starting model: generate it with starting=True")
    (candidate,) = raven_library(record.signals, ("hysteresis",))
    if lag == "fitted":
        candidate = fitting_its_lag(candidate)
    elif lag == "generator's":
        own, generators = candidate.build, record.generator.effect("hysteresis").response_time

        def with_lag(model, values):
            built = own(model, values)
            return built.with_effect(built.params.effect("hysteresis").replace(response_time=generators))

        candidate = replace(candidate, build=with_lag)
    follows_lag = lag != "none"
    if base == "starting":
        model, weights = record.starting
        model = replace(model, follows_hysteresis_lag=follows_lag)
    else:
        model, weights = _with_fit_offsets(RavenModel(record.generator.without("hysteresis"), np.zeros(3),
                                                      follows_hysteresis_lag=follows_lag),
                                           record.signals, record.split, record.robot), record.weights
    theta, _, chi_square = fit_candidate(candidate, model, record.signals, weights, record.robot,
                                         mask=record.split.fit, starts=1, max_iter=max_iter)
    values = candidate.unpack(theta)
    true = record.generator.effect("hysteresis")
    fitted = hysteretic_amplitude(values)
    lower, upper, _, _ = candidate.bounds()
    names = [f"{block.name}[{JOINTS[j]}]" for block in candidate.blocks for j in range(block.size)]
    at_end = [name for name, end in zip(names, values_at_bounds(theta, lower, upper)) if end]
    return {"values": {name: np.asarray(v, dtype=float).tolist() for name, v in values.items()},
            "loop_error": (fitted / effect_loop_height(true) - 1.0).tolist(),
            "at_range_end": at_end, "chi_square": float(chi_square)}


def blind_runs(paths, duration: float) -> dict[int, object]:
    """The ``--hidden-effect hysteresis`` reports at ``paths`` by seed (read as
    ``studies/discrepancy_hysteresis_amplitude.py`` reads them); a report without a seed, two of one
    seed, or one of a record whose length is not within 5 % of ``duration`` s (the records this study
    generates) is refused."""
    from studies.discrepancy_hysteresis_amplitude import read_run

    runs = {}
    for path in paths:
        run = read_run(path)
        if run.seed is None:
            raise UsageError(f"{run.source} does not say its seed")
        if run.record_s is None or abs(run.record_s - duration) > 0.05 * duration:
            raise UsageError(f"{run.source} is of a {run.record_s} s record, not of the {duration:g} s this study "
                             "generates (--duration)")
        if run.seed in runs:
            raise UsageError(f"two reports of seed {run.seed}: {runs[run.seed].source} and {run.source}")
        runs[run.seed] = run
    return runs


def beside_blind_runs(factors: dict[int, float], runs: dict) -> dict:
    """The replay's elbow factor beside each blind run of the same seed (its elbow loop-height error
    and its shortfall in points) and, over three seeds or more, the Spearman rank correlation of the
    factor with each."""
    from scipy.stats import spearmanr

    seeds = [s for s in factors if s in runs]
    rows = [{"seed": s, "factor": factors[s], "blind_loop_error": float(runs[s].errors["amplitude"][1]),
             "shortfall_points": runs[s].shortfall} for s in seeds]
    ranks = None
    if len(rows) >= 3:
        factor = [r["factor"] for r in rows]
        ranks = {key: (None if np.ptp([r[key] for r in rows]) == 0 or np.ptp(factor) == 0
                       else float(spearmanr(factor, [r[key] for r in rows]).statistic))
                 for key in ("blind_loop_error", "shortfall_points")}
    return {"rows": rows, "spearman": ranks}


response_time = number_between(0.0, 1.0, " s")


def response_times(text: str) -> tuple[float | None, ...]:
    """``default`` (None) or seconds from 0 to 1, separated by commas, each once."""
    import argparse

    out = []
    for part in text.split(","):
        part = part.strip()
        try:
            out.append(None if part == "default" else response_time(part))
        except argparse.ArgumentTypeError as error:
            raise argparse.ArgumentTypeError(f"{part!r} is not 'default' or a response time: {error}") from None
    if len(set(out)) != len(out):
        raise argparse.ArgumentTypeError(f"a response time is given twice in {text!r}")
    return tuple(out)


def _factor(value: float) -> str:
    """A factor, marked where it sits at an end of :data:`FACTOR_RANGE` (the smallest sum of squares
    may then lie beyond it)."""
    at_end = min(abs(value - end) for end in FACTOR_RANGE) <= 2 * FACTOR_TOLERANCE
    return f"{value:.3f}" + (" (at the searched range's end)" if at_end else "")


def _label(lag: float | None) -> str:
    return "default response time" if lag is None else f"response time {lag:g} s"


def main(argv: list[str] | None = None) -> dict:
    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--seed", type=non_negative_int, default=None,
                        help=f"first seed (>= 0; {DEFAULT_SEED} without it)")
    parser.add_argument("--seeds", type=positive_int, default=None, help="number of seeds from --seed (1 without it)")
    parser.add_argument("--duration", type=record_length, default=DEFAULT_RECORD_S,
                        help="record length (s, at most six hours)")
    parser.add_argument("--response-times", type=response_times, default=(None, 0.0), metavar="LIST",
                        help="the generator's hysteresis response times, 'default' or s from 0 to 1, by commas")
    parser.add_argument("--fit", action="store_true",
                        help="also fit the library's hysteresis candidate on the generator's base")
    parser.add_argument("--fit-lag", action="store_true",
                        help="with --fit: also fit the candidate with a lag of the replay's Bouc-Wen state fitted "
                             "with it (0 to 0.5 s per joint, from 0.1 s)")
    parser.add_argument("--on-starting-base", action="store_true",
                        help="with --fit: fit the candidate on the starting model the blind analysis identifies "
                             "(its first iteration's base) instead of the generator's base")
    parser.add_argument("--fit-iterations", type=positive_int, default=150,
                        help="with --fit: most IPOPT iterations of the candidate's fit")
    parser.add_argument("--runs", nargs="+", type=existing_path, default=(), metavar="RUN",
                        help="--hidden-effect hysteresis runs (folders or report.json): measure their seeds and put "
                             "them beside")
    parser.add_argument("--out", type=Path, default=None, help="write the figures to this JSON file")
    args = parser.parse_args(argv)
    if args.fit_lag and not args.fit:
        fail(parser.prog, "--fit-lag goes with --fit")
    if args.on_starting_base and not args.fit:
        fail(parser.prog, "--on-starting-base goes with --fit")
    try:
        runs = blind_runs(args.runs, args.duration)
    except UsageError as error:
        fail(parser.prog, str(error))
    if runs and (args.seed is not None or args.seeds is not None):
        fail(parser.prog, "--runs measures the seeds of its reports: leave out --seed and --seeds")
    lags = args.response_times
    first_seed = DEFAULT_SEED if args.seed is None else args.seed
    seeds = sorted(runs) if runs else list(range(first_seed, first_seed + (args.seeds or 1)))
    out = {"seeds": seeds, "duration_s": args.duration, "factor_range": list(FACTOR_RANGE), "joints": list(JOINTS),
           "runs": {}}
    print("factor of the generator's hysteresis stiffness at the fit part's smallest weighted sum of squares "
          f"of the quasi-static replay (shoulder, elbow, z_ins; {args.duration:g} s records)")
    for seed in seeds:
        out["runs"][seed] = {}
        for lag in lags:
            say(f"seed {seed}: generating {args.duration:g} s with the hysteresis hidden ({_label(lag)})...")
            record = generated(seed, args.duration, lag, starting=args.on_starting_base)
            figures = {"response_time_s": float(record.generator.effect("hysteresis").response_time[0]),
                       "factors": stiffness_factors(record)}
            for name, values in figures["factors"].items():
                print(f"seed {seed}, {_label(lag)}, {name}: " + ", ".join(map(_factor, values)), flush=True)
            if args.fit:
                fits = {"fit": "none"}
                if REPLAYS[2] in figures["factors"]:
                    fits["fit following the generator's lag"] = "generator's"
                if args.fit_lag:
                    fits["fit following a fitted lag"] = "fitted"
                base = "starting" if args.on_starting_base else "generator's"
                for key, fit_lag in fits.items():
                    key = key.replace("fit", "fit on the starting base", 1) if args.on_starting_base else key
                    fit = figures[key] = fitted_candidate(record, args.fit_iterations, fit_lag, base)
                    ends = f" (at its range's end: {', '.join(fit['at_range_end'])})" if fit["at_range_end"] else ""
                    fitted_lag = ("; lag " + ", ".join(f"{v:.3f} s" for v in fit["values"]["response_time"])
                                  if fit_lag == "fitted" else "")
                    print(f"seed {seed}, {_label(lag)}, the candidate fitted on the {base} base"
                          + {"none": "", "generator's": ", the replay following the generator's lag",
                             "fitted": ", the replay following a lag fitted with it"}[fit_lag]
                          + ": loop height " + ", ".join(f"{100 * e:+.1f} %" for e in fit["loop_error"])
                          + "; shape " + ", ".join(f"{v:.2f}" for v in fit["values"]["shape"]) + fitted_lag
                          + f"; weighted sum of squares {fit['chi_square']:.0f}" + ends,
                          flush=True)
            out["runs"][seed][_label(lag)] = figures
    if runs:
        first = _label(lags[0])
        factors = {s: out["runs"][s][first]["factors"][REPLAYS[0]][1] for s in seeds}
        out["beside_blind_runs"] = beside_blind_runs(factors, runs)
        print(f"elbow, {first}, {REPLAYS[0]}, beside the blind runs of the same seeds:")
        for row in out["beside_blind_runs"]["rows"]:
            print(f"  seed {row['seed']}: factor {row['factor']:.3f}, blind loop height "
                  f"{100 * row['blind_loop_error']:+.1f} %, {row['shortfall_points']:.1f} points under the bound")
        ranks = out["beside_blind_runs"]["spearman"]
        if ranks is not None:
            print("  Spearman of the factor with the blind loop-height error "
                  + ", with the shortfall ".join("-" if ranks[k] is None else f"{ranks[k]:+.2f}"
                                                 for k in ("blind_loop_error", "shortfall_points")))
    if args.out is not None:
        write_json(args.out, out)
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
