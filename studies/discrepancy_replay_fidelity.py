"""How closely the discrepancy replay reproduces the simulator: the generator's own parameters replayed.

A diagnostic, never part of an analysis: it knows the generator. It generates the data of
``python studies/discrepancy.py --hidden-effect NAME --seed S`` (four minutes unless ``--duration``
says otherwise), replays the generator's own parameters on them (offsets fitted on the first half,
as the workflow fits them) and prints the RMS residual per joint (deg, deg, mm) and its largest
repeating share (:func:`~simulation.discrepancy.signature.residual_structure` on the fit and
validation parts, as the workflow's unexplained check computes it), beside the same for the same
seed with nothing hidden. A replay that were the simulator's equal would leave the same residual
with the effect as without. What it leaves more is where the two differ: in form, which no fit can
remove and which the unexplained check may flag after the right name, or in the scale the
simulator's integration gives a parameter, which a fit takes (the options below tell them apart).

``--extra-coulomb`` adds to the generator's Coulomb friction (N m, N m, N) in the second record
(not in the one with nothing hidden), to tell an effect's own law from a larger dry friction:
capstan friction on the insertion axis bounds the friction by about 0.23 N more (0.126 times a
tension of about 1.9 N), and the same 0.23 N added to the Coulomb force with nothing hidden leaves
about as much more residual.
``--replay-friction-scale`` replays every dry friction (the Coulomb forces, the capstan friction
coefficients) that many times the generator's values, in both records: the simulator's dry
friction, integrated in 0.5 ms steps, acts as about 1 % to 1.5 % more than its parameters in the
replay's continuous quasi-static terms, and 1.015 leaves the same insertion residual with capstan
friction hidden as without.
``--log-rate`` records at another rate than the 30 Hz of the robot's log; ``--substeps`` integrates
the plant in that many steps per 1 ms servo tick instead of two (the friction's excess is the
simulator's time step: with eight sub-steps the best scale is about 1.005).

Run: ``python studies/discrepancy_replay_fidelity.py --hidden-effect capstan_friction --seed 30``
(two four-minute records, about a minute on one core), ``--hidden-effect none --extra-coulomb
0,0,0.234`` for the Coulomb force alone.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from studies.common.discrepancy_runs import record_length
from studies.common.runner import non_negative_int, positive_float, positive_int, script_parser

STUDY = "discrepancy_replay_fidelity"


def coulomb_increase(text: str) -> np.ndarray:
    """Three finite non-negative numbers separated by commas (N m, N m, N)."""
    try:
        values = np.array([float(v) for v in text.split(",")])
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be three numbers separated by commas, got {text!r}") from None
    if values.shape != (3,) or not np.all(np.isfinite(values)) or np.any(values < 0):
        raise argparse.ArgumentTypeError(f"must be three finite numbers >= 0 separated by commas, got {text!r}")
    return values


def replay_residual(hidden: tuple[str, ...], seed: int, duration: float, extra_coulomb: np.ndarray,
                    log_rate: float, params=None, friction_scale: float = 1.0, substeps: int = 2) -> dict:
    """RMS residual per joint (SI) and largest repeating share per joint of the generator's own
    parameters replayed on the generated record of ``hidden`` (the generator built from ``params``,
    the simulator's defaults unless given, integrated in ``substeps`` per servo tick), with its dry
    friction times ``friction_scale``."""
    from kinematics import RavenII
    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.replay import RavenModel
    from simulation.discrepancy.signals import MeasuredSignals
    from simulation.discrepancy.signature import residual_structure
    from simulation.discrepancy.workflow import Split
    from simulation.model.parameters import RavenParameters
    from studies.common.discrepancy_runs import generate_measured, log_rate_options

    params = params or RavenParameters()
    if np.any(extra_coulomb > 0):
        friction = params.effect("coulomb_friction")
        params = params.with_effect(friction.replace(force=friction.force + extra_coulomb))
    rates = {**log_rate_options(log_rate), "substeps": substeps}
    dataset, generator = generate_measured(hidden, seed, duration, params=params, robot_options=rates)
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    robot = RavenII(signals.arm, check_limits=False)
    replayed = generator
    if friction_scale != 1.0:
        for name, field in (("coulomb_friction", "force"), ("capstan_friction", "mu")):
            if not replayed.is_enabled(name):
                continue
            effect = replayed.effect(name)
            replayed = replayed.with_effect(effect.replace(**{field: getattr(effect, field) * friction_scale}))
    model = RavenModel(replayed, np.zeros(3))
    model = model.with_offsets(residual(model, signals, robot, mask=split.fit).joint_offsets)
    joints = residual(model, signals, robot, offsets=np.zeros(3)).joints
    part = split.fit | split.validation
    check = residual_structure(signals.select(part), joints[part])
    return {"rms": np.sqrt(np.mean(joints ** 2, axis=0)).tolist(), "repeating_share": list(check.explained),
            "samples": len(signals)}


def main(argv: list[str] | None = None) -> dict:
    from studies.common.discrepancy_runs import HIDDEN_CHOICES, check_hidden

    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--hidden-effect", required=True, choices=HIDDEN_CHOICES, help="the effect hidden")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of the generated data (>= 0)")
    parser.add_argument("--duration", type=record_length, default=240.0, help="record length (s, at most six hours)")
    parser.add_argument("--extra-coulomb", type=coulomb_increase, default=np.zeros(3),
                        help="added to the Coulomb friction in both records (N m,N m,N)")
    parser.add_argument("--replay-friction-scale", type=positive_float, default=1.0,
                        help="replay every dry friction this many times the generator's values")
    parser.add_argument("--substeps", type=positive_int, default=2,
                        help="plant integration steps per 1 ms servo tick (the robot's default: 2)")
    parser.add_argument("--log-rate", type=positive_float, default=30.0, help="rate of the robot's log (Hz)")
    parser.add_argument("--out", type=Path, default=None, help="write both replays to this JSON file")
    args = parser.parse_args(argv)

    hidden = check_hidden(args.hidden_effect)
    scale = args.replay_friction_scale
    runs = {"nothing hidden": replay_residual((), args.seed, args.duration, np.zeros(3), args.log_rate,
                                              friction_scale=scale, substeps=args.substeps)}
    if hidden or np.any(args.extra_coulomb > 0):
        label = ", ".join(hidden) or "nothing hidden"
        if np.any(args.extra_coulomb > 0):
            label += f", Coulomb + {','.join(f'{v:g}' for v in args.extra_coulomb)}"
        runs[label] = replay_residual(hidden, args.seed, args.duration, args.extra_coulomb, args.log_rate,
                                      friction_scale=scale, substeps=args.substeps)
    units = np.array([np.degrees(1.0), np.degrees(1.0), 1e3])
    baseline = np.asarray(runs["nothing hidden"]["rms"])
    print(f"generator's own parameters replayed (dry friction x {scale:g}), seed {args.seed}, "
          f"{args.duration:g} s at {args.log_rate:g} Hz, {args.substeps} plant steps per servo tick")
    for label, run in runs.items():
        rms = np.asarray(run["rms"])
        print(f"{label}: RMS {', '.join(f'{v:.5f}' for v in rms * units)} (deg, deg, mm), "
              f"{', '.join(f'{r:.2f}' for r in rms / baseline)} x nothing hidden; largest repeating share "
              f"{', '.join(f'{s:.2f}' for s in run['repeating_share'])}")
    out = {"hidden_effect": list(hidden), "seed": args.seed, "duration_s": args.duration,
           "extra_coulomb": args.extra_coulomb.tolist(), "replay_friction_scale": scale, "substeps": args.substeps,
           "log_rate_hz": args.log_rate,
           "replays": runs}
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(out, indent=1))
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
