"""Whether the workflow's backfit stops short: the same record analysed with more backfit rounds.

A candidate the identification cannot fit is backfitted: fitted on top of the starting model, the
starting structure re-identified with the candidate's share removed, the candidate fitted again,
for at most ``WorkflowSettings.backfit_rounds`` rounds (thirty; six until the README's
thirty-round sweep), each kept only if it lowers the fit part's weighted residual. Where the
candidate and the base share a direction (capstan friction and the identified Coulomb force: both
bound the joint's friction) each round moves them only a little along it, and six rounds can stop
far from where the rounds converge.

This study generates the data of ``python studies/discrepancy.py --hidden-effect NAME --seed S``
(twenty minutes unless ``--duration`` says otherwise), writes it to a file and analyses that file
as the blind analysis does, once per cap of ``--rounds``, printing for each the effects named, the
shrink, whether the residual left was flagged unexplained (its largest repeating share per joint),
the named effects' fitted values beside the generator's, which backfits were still lowering the
residual at the cap (``DiscrepancyResult.backfit_capped``) and the analysis's CPU time, then the
floor bound of the record (``studies/discrepancy_floor.py``). With
``--oracle`` it fits the generator's structure with each cap too (``oracle``). With ``--patience N``
the backfit goes on past up to N rounds in a row that do not lower the residual, from where each
ended, and keeps the best (``WorkflowSettings.backfit_patience``; the workflow's default is 0). It
knows the generator only to print its values; every analysis runs on the file.

Run: ``python studies/discrepancy_backfit.py --hidden-effect capstan_friction --seed 34`` (two
twenty-minute analyses, about ten minutes on one core).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from studies.common.discrepancy_runs import DEFAULT_RECORD_S, HIDDEN_CHOICES, record_length
from studies.common.reporting import write_json
from studies.common.runner import non_negative_int, positive_float, script_parser

STUDY = "discrepancy_backfit"


def round_caps(text: str) -> tuple[int, ...]:
    """Backfit caps separated by commas: integers of at least 0, each analysed once, in order."""
    try:
        return tuple(sorted({non_negative_int(part) for part in text.split(",")}))
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}") from None


def summary(result, cpu_s: float) -> dict:
    return {"named_effects": list(result.named_effects), "shrink": result.shrink,
            "unexplained": result.unexplained, "backfit_capped": list(result.backfit_capped),
            "residual_structure": None if result.residual_structure is None else list(result.residual_structure),
            "fitted_parameters": result.fitted_parameters, "cpu_s": cpu_s}


def _line(label: str, s: dict) -> str:
    structure = s["residual_structure"]
    repeats = "not checked" if structure is None else ", ".join(f"{v:.2f}" for v in structure)
    return (f"{label}: named {', '.join(s['named_effects']) or 'nothing'}; shrink {100 * s['shrink']:.1f} %; "
            f"unexplained {'yes' if s['unexplained'] else 'no'} (largest repeating share per joint {repeats}); "
            f"backfit cut by the cap: {', '.join(s['backfit_capped']) or 'none'}; {s['cpu_s']:.0f} s of CPU")


def _values(s: dict, truth: dict) -> list[str]:
    lines = []
    for name, values in s["fitted_parameters"].items():
        for parameter, fitted in values.items():
            true = (truth.get(name) or {}).get(parameter)
            text = ", ".join(f"{v:.4g}" for v in np.ravel(fitted))
            lines.append(f"    {name}.{parameter}: {text}"
                         + ("" if true is None else f" (generator: {', '.join(f'{v:.4g}' for v in np.ravel(true))})"))
    return lines


def main(argv: list[str] | None = None) -> dict:
    from simulation.discrepancy import WorkflowSettings
    from studies.common.discrepancy_runs import (
        HIDDEN_PAYLOAD_KG, floor_bound, floor_gap, generate_measured, oracle, read_measured, run_on_raven_dataset,
        true_values, write_measured)

    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--hidden-effect", required=True, choices=HIDDEN_CHOICES, help="the effect hidden")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of the generated data (>= 0)")
    parser.add_argument("--duration", type=record_length, default=DEFAULT_RECORD_S,
                        help="record length (s, at most six hours)")
    parser.add_argument("--size-factor", type=positive_float, default=1.0, help="the hidden effect's size (x default)")
    parser.add_argument("--rounds", type=round_caps, default=round_caps(f"6,{WorkflowSettings().backfit_rounds}"),
                        help="backfit caps to compare, separated by commas (default: 6, the workflow's cap until "
                             f"the thirty-round sweep, and the workflow's {WorkflowSettings().backfit_rounds})")
    parser.add_argument("--oracle", action="store_true", help="fit the generator's structure with each cap too")
    parser.add_argument("--accelerate", action="store_true",
                        help="with WorkflowSettings.backfit_acceleration (a round from where the rounds head)")
    parser.add_argument("--patience", type=non_negative_int, default=0,
                        help="with WorkflowSettings.backfit_patience: rounds in a row that may fail to lower the "
                             "residual before the backfit stops (0: the workflow's default, the first ends it)")
    parser.add_argument("--out", type=Path, default=None, help="write the summaries to this JSON file")
    args = parser.parse_args(argv)

    hidden = () if args.hidden_effect == "none" else (args.hidden_effect,)
    dataset, generator = generate_measured(hidden, args.seed, args.duration, size_factor=args.size_factor)
    payload = HIDDEN_PAYLOAD_KG * args.size_factor if "payload" in hidden else 0.0
    truth = {name: true_values(generator, name, payload) for name in hidden}
    out = {"hidden_effect": list(hidden), "seed": args.seed, "duration_s": args.duration, "accelerate": args.accelerate,
           "patience": args.patience,
           "size_factor": args.size_factor, "generator_values": truth, "runs": {}}
    with tempfile.TemporaryDirectory() as folder:
        path = write_measured(dataset, folder)
        for cap in args.rounds:
            start = time.process_time()
            settings = WorkflowSettings(backfit_rounds=cap, backfit_acceleration=args.accelerate,
                                        backfit_patience=args.patience)
            result, *_ = run_on_raven_dataset(read_measured(path), settings=settings)
            runs = {"workflow": summary(result, time.process_time() - start)}
            if args.oracle:
                start = time.process_time()
                runs["oracle"] = summary(oracle(path, hidden, backfit_rounds=cap, backfit_acceleration=args.accelerate,
                                                backfit_patience=args.patience),
                                         time.process_time() - start)
            out["runs"][cap] = runs
            for label, s in runs.items():
                print(_line(f"{label}, at most {cap} backfit rounds", s), flush=True)
                print("\n".join(_values(s, truth)), flush=True)
    # the starting model's gaps do not depend on the cap
    floor = result.gap_before if not hidden else floor_gap(args.seed, args.duration)
    out["floor_bound"] = bound = floor_bound(floor, result.gap_before, result.units)
    print(f"floor bound: {100 * bound:.1f} % (1 - the held-out gap the starting model leaves on the same seed's "
          "record with nothing hidden / this record's, pooled: about the most a model replayed this way closes)",
          flush=True)
    if args.out is not None:
        write_json(args.out, out)
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
