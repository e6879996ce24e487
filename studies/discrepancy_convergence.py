"""How the discrepancy workflow's answer depends on how far its candidate fits are run.

Each candidate is fitted with one start and at most ``fit_iterations`` IPOPT iterations
(:class:`simulation.discrepancy.WorkflowSettings`, 30 by default). The fit minimises the weighted
residual of the joints *and* the motor torques, while the workflow is judged by the held-out
joint gap. This study hides one effect in generated data (as ``studies/discrepancy.py
--hidden-effect`` does), writes the data to a file once per seed, and analyses that same file with
several iteration budgets: the named effects, the shrink of the held-out joint gap (pooled, deg
and mm), the gap per joint, and the named candidate's BIC (validation weighted residual plus
penalty, lower is better) show whether a longer fit lowers its objective and whether the joint gap
follows.

Run: ``python studies/discrepancy_convergence.py [--effect hysteresis] [--seeds 5]
[--iterations 30,60,100] [--duration 240] [--out DIR] [--jobs N]``
"""

from __future__ import annotations

import argparse
import tempfile
from dataclasses import dataclass

import numpy as np

from studies.common import reporting
from studies.common.discrepancy_runs import record_length
from studies.common.runner import StudyRun, positive_float, positive_int, say, study_parser
from studies.common.sweeps import run_tasks

STUDY = "discrepancy_convergence"


@dataclass(frozen=True)
class ConvergenceConfig:
    """Hidden effect, seeds, record length (s) and the iteration budgets compared."""

    effect: str = "hysteresis"
    seeds: tuple[int, ...] = (0, 1, 2, 3, 4)
    duration: float = 240.0
    iterations: tuple[int, ...] = (30, 60, 100)
    size_factor: float = 1.0

    def __post_init__(self) -> None:
        from studies.common.discrepancy_runs import check_hidden

        if self.effect == "none":
            raise ValueError("--effect none hides nothing: give an effect of the library")
        check_hidden((self.effect,))
        if not self.iterations or any(int(n) != n or n < 1 for n in self.iterations):
            raise ValueError(f"iterations must be positive integers, got {self.iterations}")


def _budgets(text: str) -> tuple[int, ...]:
    try:
        values = tuple(positive_int(part) for part in text.split(","))
    except argparse.ArgumentTypeError as error:
        raise argparse.ArgumentTypeError(f"{text!r}: {error}") from None
    return tuple(sorted(set(values)))


def analyse_seed(effect: str, seed: int, duration: float, size_factor: float, iterations: tuple[int, ...]) -> dict:
    """One seed: generate, write, then analyse the file once per iteration budget."""
    from simulation.discrepancy import WorkflowSettings
    from simulation.discrepancy.signals import report_scale
    from studies.common.discrepancy_runs import generate_measured, read_measured, run_on_raven_dataset, write_measured

    dataset, _ = generate_measured((effect,), seed, duration, size_factor=size_factor)
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        path = write_measured(dataset, folder)
        for budget in iterations:
            result, signals, _ = run_on_raven_dataset(read_measured(path),
                                                      settings=WorkflowSettings(fit_iterations=budget))
            first = result.iterations[0]
            named_score = next((s for s in first.scores if s.name == first.named), None)
            scale = report_scale(signals.units)
            rows.append({
                "fit_iterations": budget,
                "named_effects": list(result.named_effects),
                "shrink": float(result.shrink),
                "gap_before": (np.asarray(result.gap_before) * scale).tolist(),
                "gap_after": (np.asarray(result.gap_after) * scale).tolist(),
                "first_named": first.named,
                "first_named_bic": None if named_score is None else float(named_score.bic),
                "bic_before": float(first.bic_before),
            })
    return {"seed": seed, "runs": rows}


def run(config: ConvergenceConfig, n_jobs: int = -1, backend: str = "loky", scheduler=None,
        progress: bool = True) -> dict:
    tasks = [(config.effect, seed, config.duration, config.size_factor, config.iterations) for seed in config.seeds]
    seeds = run_tasks(analyse_seed, tasks, n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress,
                      description="seeds")
    summary = {}
    for budget in config.iterations:
        runs = [next(r for r in s["runs"] if r["fit_iterations"] == budget) for s in seeds]
        shrink = np.array([r["shrink"] for r in runs])
        summary[str(budget)] = {
            "named_first": sum(bool(r["named_effects"]) and r["named_effects"][0] == config.effect for r in runs),
            "shrink_mean": float(shrink.mean()), "shrink_min": float(shrink.min()),
            "shrink_max": float(shrink.max()),
        }
    return {"effect": config.effect, "duration_s": config.duration, "size_factor": config.size_factor,
            "iterations": list(config.iterations), "seeds": seeds, "summary": summary}


def tables(results: dict) -> list[str]:
    n = len(results["seeds"])
    headers = ["fit iterations", f"named first (of {n})", "shrink % mean [min, max]"]
    rows = [[str(b), str(s["named_first"]), f"{100 * s['shrink_mean']:.1f} [{100 * s['shrink_min']:.1f}, "
                                  f"{100 * s['shrink_max']:.1f}]"] for b, s in results["summary"].items()]
    per_seed = []
    for s in results["seeds"]:
        for r in s["runs"]:
            per_seed.append([str(s["seed"]), str(r["fit_iterations"]), ", ".join(r["named_effects"]) or "nothing",
                             f"{100 * r['shrink']:.1f}", *[f"{b:.4f} -> {a:.4f}" for b, a in
                                                           zip(r["gap_before"], r["gap_after"])],
                             "-" if r["first_named_bic"] is None else f"{r['first_named_bic']:.1f}",
                             f"{r['bic_before']:.1f}"])
    return [f"## Hidden {results['effect']}, {results['duration_s']:.0f} s records, x{results['size_factor']:g} size",
            "", reporting.markdown_table(headers, rows), "",
            "## Per seed", "",
            reporting.markdown_table(["seed", "fit iterations", "named", "shrink %", "shoulder deg",
                                      "elbow deg", "z_ins mm", "BIC of the first named", "BIC before"], per_seed),
            "", "Held-out gap before -> after per joint (RMSE). BIC: the first iteration's validation weighted "
                "residual of the model with the named candidate, plus its penalty (lower is better); "
                "'BIC before' is the starting model's."]


def finding(results: dict) -> str:
    summary = results["summary"]
    parts = [f"{b} iterations: {100 * s['shrink_mean']:.1f} % mean shrink, named first on {s['named_first']} "
             f"of {len(results['seeds'])}" for b, s in summary.items()]
    return f"Hidden {results['effect']}: " + "; ".join(parts) + "."


def configure(args) -> ConvergenceConfig:
    if args.quick:
        return ConvergenceConfig(effect=args.effect, seeds=(args.seed,), duration=120.0, iterations=(30, 60),
                                 size_factor=args.size_factor)
    return ConvergenceConfig(effect=args.effect, seeds=tuple(range(args.seed, args.seed + args.seeds)),
                             duration=args.duration, iterations=args.iterations, size_factor=args.size_factor)


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--effect", default="hysteresis", help="the effect hidden (a library candidate)")
    parser.add_argument("--seeds", type=positive_int, default=5, help="how many seeds, from --seed on")
    parser.add_argument("--duration", type=record_length, default=240.0, help="record length (s, at most six hours)")
    parser.add_argument("--iterations", type=_budgets, default=(30, 60, 100),
                        help="comma-separated IPOPT iteration budgets of each candidate fit")
    parser.add_argument("--size-factor", type=positive_float, default=1.0, help="multiple of the effect's default size")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"hidden {config.effect}: {len(config.seeds)} seeds x {len(config.iterations)} budgets, "
            f"{config.duration:.0f} s records")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Discrepancy workflow: fit budget", finding=finding, tables=tables,
                              figures=lambda results, out: [])


if __name__ == "__main__":
    main()
