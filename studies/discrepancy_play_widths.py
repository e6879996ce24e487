"""How the dVRK wrist analysis depends on the play widths of ``coupled_hysteresis``.

The candidate is a weighted sum of play operators of each wrist joint's commanded motion, at
half-widths that are fixed fractions of each joint's range (a geometric grid). The grid is a
choice, so this study runs the whole analysis (``python studies/discrepancy.py --measured
../shared/data/dvrk_hwang2020``: fit on the first two thirds of the random motion, choose on its
last third, report on the peg transfer) once per grid and lists, for each, what was named, the
pooled gap on the validation part (random motion) after the named effects, and the held-out
shrink (peg transfer). The library's grid is the one with the smallest validation gap: chosen on
the random motion, never on the peg transfer. ``--split`` runs the grids on another split of
``studies/discrepancy_dvrk_splits.py`` (e.g. "peg -> random": fit and choose on the peg transfer,
report on the random motion). ``--drivers own`` drives each joint's play operators by its own
motion alone (one weight per joint and width instead of one per joint, moving joint and width).

Run: ``python studies/discrepancy_play_widths.py [--grids 2-7,3-8,1-8,2-5,3-6,4-9] [--split "random -> peg"]
[--drivers every|own]``
(each grid is ``a-b``: half-widths 1/2^a to 1/2^b of each joint's range).
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass

import numpy as np

from simulation.discrepancy.candidates import PLAY_DRIVERS, check_play_drivers
from studies.common import reporting
from studies.common.dvrk_splits import SPLITS, check_split, run_split
from studies.common.runner import StudyRun, say, study_parser
from studies.common.sweeps import run_tasks

STUDY = "discrepancy_play_widths"
DEFAULT_GRIDS = ((2, 7), (3, 8), (1, 8), (2, 5), (3, 6), (4, 9))


@dataclass(frozen=True)
class GridConfig:
    """Grids of play half-widths, each ``(a, b)``: fractions 1/2^a down to 1/2^b of a joint's range,
    run on one ``split`` (a name of :data:`~studies.common.dvrk_splits.SPLITS`), each joint driven by
    the motion of the joints ``drivers`` says (:data:`~simulation.discrepancy.candidates.PLAY_DRIVERS`)."""

    grids: tuple[tuple[int, int], ...] = DEFAULT_GRIDS
    split: str = SPLITS[0]
    drivers: str = "every"

    def __post_init__(self) -> None:
        if not self.grids or any(not (1 <= a <= b <= 16) for a, b in self.grids):
            raise ValueError(f"each grid needs 1 <= a <= b <= 16, got {self.grids}")
        check_split(self.split)
        check_play_drivers(self.drivers)


def _grids(text: str) -> tuple[tuple[int, int], ...]:
    grids = []
    for part in text.split(","):
        try:
            a, b = (int(v) for v in part.split("-"))
        except ValueError:
            raise argparse.ArgumentTypeError(f"{part!r} is not a grid a-b (two integers)") from None
        grids.append((a, b))
    return tuple(grids)


def fractions_of(grid: tuple[int, int]) -> tuple[float, ...]:
    return tuple(2.0 ** -k for k in range(grid[0], grid[1] + 1))


def _pooled_deg(per_joint_rad) -> float:
    return float(np.sqrt(np.mean(np.square(np.degrees(per_joint_rad)))))


def analyse(grid: tuple[int, int], split: str = SPLITS[0], drivers: str = "every") -> dict:
    """The dVRK wrist analysis of one split with one grid of play half-widths and their drivers."""
    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.signals import pooled_rmse

    (result, signals, parts), _ = run_split(split, play_fractions=fractions_of(grid), play_drivers=drivers)
    validation = residual(result.model_after, signals, offsets=np.zeros(signals.n_joints), mask=parts.validation)
    return {"grid": list(grid), "named": list(result.named_effects),
            "validation_gap": pooled_rmse(validation.joints, result.units), "shrink": result.shrink,
            "held_out_gap": _pooled_deg(result.gap_after), "held_out_gap_before": _pooled_deg(result.gap_before),
            "held_out_gap_alone": alone_gaps(result, signals, parts)}


def alone_gaps(result, signals, parts) -> dict:
    """Pooled held-out gap (deg) of each named effect alone, as fitted in the final model, with its
    offsets fitted on the fit part and carried to the held-out part as the workflow carries them:
    which of the named effects closes the gap and which widens it."""
    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.generic import NominalModel
    from simulation.discrepancy.signals import pooled_rmse

    gaps = {}
    for name in result.named_effects:
        alone = NominalModel(offsets=np.zeros(signals.n_joints), effects={name: result.model_after.effects[name]})
        offsets = residual(alone, signals, mask=parts.fit).joint_offsets
        gaps[name] = pooled_rmse(residual(alone, signals, offsets=offsets, mask=parts.held_out).joints, result.units)
    return gaps


def run(config: GridConfig, n_jobs: int = -1, backend: str = "loky", scheduler=None, progress: bool = True) -> dict:
    runs = run_tasks(analyse, [(grid, config.split, config.drivers) for grid in config.grids], n_jobs=n_jobs,
                     backend=backend, scheduler=scheduler, progress=progress, description="grids")
    return {"split": config.split, "drivers": config.drivers, "runs": runs}


def _parts_named(split: str) -> tuple[str, str]:
    """What the validation and held-out parts of ``split`` are, in words."""
    names = {"random": "random motion", "peg": "peg transfer"}
    learning, held_out = split.split(" -> ")
    if "half" in split:
        record = names[learning.split(",")[0]]
        return f"{record}, 1st half", f"{record}, 2nd half"
    return names[learning], names[held_out]


def _label(grid) -> str:
    return f"1/{2 ** grid[0]} to 1/{2 ** grid[1]}"


def _drivers_named(results: dict) -> str:
    """What drives each joint's play operators, in words, after the split's name ("" for the library's form)."""
    return "; each joint driven by its own motion alone" if results.get("drivers", "every") == "own" else ""


def tables(results: dict) -> list[str]:
    split = results.get("split", SPLITS[0])
    learning, held_out = _parts_named(split)
    rows = [[_label(r["grid"]), ", ".join(r["named"]) or "none", f"{r['validation_gap']:.3f}",
             f"{r['held_out_gap']:.3f}", f"{100 * r['shrink']:.1f}",
             ", ".join(f"{name} {gap:.3f}" for name, gap in r.get("held_out_gap_alone", {}).items()) or "-"]
            for r in results["runs"]]
    return [f"## The dVRK wrist analysis per grid of play half-widths (fit -> held out: {split}{_drivers_named(results)})",
            "",
            reporting.markdown_table(["half-widths (of each joint's range)", "named",
                                      f"validation gap after (deg, {learning})", f"held-out gap after (deg, {held_out})",
                                      "held-out shrink %", "held-out gap, each named effect alone (deg)"], rows),
            "",
            "Gaps: pooled RMSE over the three wrist joints after the named effects (fitted on the first two "
            "thirds of the learning part, chosen on its last third); the starting model's held-out gap is "
            f"{results['runs'][0]['held_out_gap_before']:.3f} deg."]


def finding(results: dict) -> str:
    best = min(results["runs"], key=lambda r: r["validation_gap"])
    shrinks = [100 * r["shrink"] for r in results["runs"]]
    return (f"Fit -> held out: {results.get('split', SPLITS[0])}{_drivers_named(results)}. "
            f"The grid with the smallest validation gap is {_label(best['grid'])} ({best['validation_gap']:.3f} deg); "
            f"with it {100 * best['shrink']:.1f} % of the held-out gap closes. Over the {len(shrinks)} grids the "
            f"held-out shrink ranges from {min(shrinks):.1f} % to {max(shrinks):.1f} %.")


def configure(args) -> GridConfig:
    return GridConfig(grids=args.grids[:2] if args.quick else args.grids, split=args.split, drivers=args.drivers)


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--grids", type=_grids, default=DEFAULT_GRIDS,
                        help="comma-separated grids a-b: play half-widths 1/2^a to 1/2^b of each joint's range")
    parser.add_argument("--split", choices=SPLITS, default=SPLITS[0],
                        help="fit -> held-out part, as in studies/discrepancy_dvrk_splits.py")
    parser.add_argument("--drivers", choices=PLAY_DRIVERS, default="every",
                        help="which joints' motion drives each joint's play operators: every joint's or its own")
    with StudyRun(parser, argv, configure) as study:
        say(f"dVRK wrist analysis ({study.config.split}) with {len(study.config.grids)} grids of play half-widths")
        results = run(study.config, **study.parallel)
        return study.conclude(results, title="Discrepancy workflow: the play widths of coupled hysteresis",
                              finding=finding, tables=tables, figures=lambda results, out: [])


if __name__ == "__main__":
    main()
