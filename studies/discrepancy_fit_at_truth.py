"""Whether a hidden effect's candidate fit or its law falls short: the workflow with that fit pinned
at the generator's values.

A diagnostic, never part of an analysis: it knows the generator. It generates the data of
``python studies/discrepancy.py --hidden-effect NAME --seed S --duration D`` (D = 240 s unless
``--duration`` says otherwise) and runs the same workflow twice on
them, once as the blind analysis does and once with the candidate called ``NAME`` fitted to the
generator's values (:func:`studies.common.discrepancy_runs.true_values`) wherever the workflow fits
it. If the pinned run closes the gap and names nothing after it while the blind run does not, the
replay's law can represent the effect and the blind fit stops short of it.

Run: ``python studies/discrepancy_fit_at_truth.py --hidden-effect hysteresis --seed 0`` (two
analyses of a 240 s record, a few minutes on one core). It first showed why a wrong name followed
motor friction (its search stopped short; the identification now fits motor friction together
with the starting structure, so it is no longer pinnable here).
"""

from __future__ import annotations

import json
import sys
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from studies.common.discrepancy_runs import record_length
from studies.common.runner import non_negative_int, script_parser

STUDY = "discrepancy_fit_at_truth"


@contextmanager
def pinned_fit(name: str, theta: np.ndarray):
    """Within the block, the workflow fits candidate ``name`` to ``theta`` (the generator's values)."""
    from simulation.discrepancy import workflow
    from simulation.discrepancy.fitting import residual

    fit = workflow.fit_candidate

    def at_truth(candidate, model, signals, weights, robot=None, mask=None, **options):
        if candidate.name != name:
            return fit(candidate, model, signals, weights, robot, mask, **options)
        trial = candidate.apply(model, theta)
        return theta.copy(), trial, residual(trial, signals, robot, mask=mask).chi_square(weights)

    workflow.fit_candidate = at_truth
    try:
        yield
    finally:
        workflow.fit_candidate = fit


def summary(result) -> dict:
    return {"named_effects": list(result.named_effects), "shrink": result.shrink,
            "validation_gaps": [it.gap_before for it in result.iterations],
            "fitted_parameters": result.fitted_parameters, "unexplained": result.unexplained,
            "residual_structure": None if result.residual_structure is None else list(result.residual_structure)}


def pinnable() -> tuple[str, ...]:
    """The library's effects the workflow fits by its candidate search: not the per-homing offsets
    (drawn anew at each homing), the payload (fitted by a profile over re-identifications), the
    controller's gravity-model error (fitted by the controller replay) or an effect the
    identification fits together with the starting structure (motor friction, the transmission
    error)."""
    from simulation.identification import IDENTIFIABLE_EFFECTS
    from studies.common.discrepancy_runs import LIBRARY, PER_HOMING_EFFECTS

    return tuple(n for n in LIBRARY
                 if n not in PER_HOMING_EFFECTS + ("payload", "gravity_model_error") + IDENTIFIABLE_EFFECTS)


def main(argv: list[str] | None = None) -> dict:
    from studies.common.discrepancy_runs import generate_measured, raven_library, run_on_raven_dataset, true_values
    from simulation.discrepancy.signals import MeasuredSignals

    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--hidden-effect", required=True, choices=pinnable(), help="the effect hidden and pinned")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of the generated data (>= 0)")
    parser.add_argument("--duration", type=record_length, default=240.0, help="record length (s, at most six hours)")
    parser.add_argument("--out", type=Path, default=None, help="write the two summaries to this JSON file")
    args = parser.parse_args(argv)

    dataset, generator = generate_measured((args.hidden_effect,), args.seed, args.duration)
    values = true_values(generator, args.hidden_effect)
    (candidate,) = raven_library(MeasuredSignals.from_dataset(dataset), (args.hidden_effect,))
    theta = np.concatenate([np.asarray(values[b.name], dtype=float).ravel() for b in candidate.blocks])

    blind, *_ = run_on_raven_dataset(dataset)
    with pinned_fit(args.hidden_effect, theta):
        pinned, *_ = run_on_raven_dataset(dataset)
    out = {"hidden_effect": args.hidden_effect, "seed": args.seed, "duration_s": args.duration,
           "generator_values": values, "blind": summary(blind), "pinned": summary(pinned)}
    for label in ("blind", "pinned"):
        s = out[label]
        structure = s["residual_structure"]
        repeats = "not checked" if structure is None else ", ".join(f"{v:.2f}" for v in structure)
        print(f"{label:7s} named {', '.join(s['named_effects']) or 'nothing'}; shrink {100 * s['shrink']:.1f} %; "
              f"validation gap per iteration {', '.join(f'{g:.4g}' for g in s['validation_gaps'])}; "
              f"unexplained {'yes' if s['unexplained'] else 'no'} (repeating share per joint {repeats})")
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(out, indent=1, default=lambda v: np.asarray(v).tolist()))
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
