"""How far the dVRK wrist analysis carries: the same workflow and calibrators on four splits.

``python studies/discrepancy.py --measured ../shared/data/dvrk_hwang2020`` fits and chooses on the
random motion and reports on the peg transfer. This study runs the same blind workflow (and three
learned calibrators trained on the same part) on that split, on the reverse one (fit on the peg
transfer, report on the random motion) and within each recording (fit and choose on its first
half, report on its second). For each it lists what was named, the held-out shrink, and the pooled
held-out wrist RMSE of the named-effect model beside the calibrators'. A form of effect that only
suits one direction of one split would show here. A second table splits each held-out part into
the samples whose reported wrist joints all lie within the ranges the learning part covered and
the rest, so that what a model does where it interpolates and where it extrapolates can be told
apart. A third splits it into quarters by :func:`play_leverage`: how far each sample's play
features (the inputs of ``coupled_hysteresis``, the form every split names) lie outside the
combinations the fit part excited, which a wrist inside its learned ranges can still reach.

Run: ``python studies/discrepancy_dvrk_splits.py``
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.recordings.dvrk import WRIST_JOINTS
from studies.common import reporting
from studies.common.dvrk_splits import SPLITS, run_split
from studies.common.runner import StudyRun, say, study_parser
from studies.common.sweeps import run_tasks

STUDY = "discrepancy_dvrk_splits"
CALIBRATORS = ("fixed offset", "linear", "window linear, 5 rows")
QUARTER_NAMES = ("1st (lowest)", "2nd", "3rd", "4th (highest)")
LEVERAGE_QUARTERS = 4
"""The held-out part is split into this many equal shares by :func:`play_leverage`."""


@dataclass(frozen=True)
class SplitsConfig:
    """The splits to run (names of :data:`SPLITS`)."""

    splits: tuple[str, ...] = SPLITS

    def __post_init__(self) -> None:
        unknown = [s for s in self.splits if s not in SPLITS]
        if unknown or not self.splits:
            raise ValueError(f"unknown split {unknown[0] if unknown else '(none)'!r}; choose from {', '.join(SPLITS)}")


def _learned_and_held_out(caller: str, learned, held_out, what: str) -> tuple[np.ndarray, np.ndarray]:
    """The two tables as float arrays, or a one-line error naming ``caller`` when they are not two
    tables of the same columns, the learned one with a row, both finite."""
    learned, held_out = np.asarray(learned, dtype=float), np.asarray(held_out, dtype=float)
    if learned.ndim != 2 or held_out.ndim != 2 or learned.shape[1] != held_out.shape[1] or not len(learned):
        raise ValueError(f"{caller} needs two tables with the same columns and a learned row, got shapes "
                         f"{learned.shape} and {held_out.shape}")
    if not (np.all(np.isfinite(learned)) and np.all(np.isfinite(held_out))):
        raise ValueError(f"{caller} needs finite {what}; the learned or held-out table has NaN or inf")
    return learned, held_out


def within_learned_range(learned: np.ndarray, held_out: np.ndarray) -> np.ndarray:
    """Which held-out rows lie, in every column, within the range (min to max) of ``learned``.

    Parameters
    ----------
    learned : (N, J) the reported joints the models learned from.
    held_out : (M, J) the reported joints of the held-out part, in the same units.

    Returns
    -------
    (M,) bool: True where a model of ``learned`` interpolates, False where it extrapolates.
    """
    learned, held_out = _learned_and_held_out("within_learned_range", learned, held_out, "joints")
    return np.all((held_out >= learned.min(axis=0)) & (held_out <= learned.max(axis=0)), axis=1)


def play_leverage(learned: np.ndarray, held_out: np.ndarray) -> np.ndarray:
    """How far each held-out row of features lies outside what the learned rows excite.

    The leverage ``b^T (B^T B)^+ b`` of a held-out row ``b`` in the learned rows ``B`` (both with a
    constant column added, for the offset every model fits), times the number of learned rows over
    the rank of ``B``: the learned rows then average exactly 1. Measured along each direction in units
    of the learned rows' spread along it, a row of leverage ``L`` lies ``sqrt(L)`` times as far out as
    the learned rows do on average, so a row that moves along a direction the learned rows barely
    excite has a large leverage even if every feature is within its learned range. A model linear in
    these features (``coupled_hysteresis`` in the play features) fitted on the learned rows
    extrapolates where ``L`` is well above 1. A held-out row with a part along a direction the learned
    rows do not excite at all (outside their span) has an infinite leverage.

    Parameters
    ----------
    learned : (N, F) the features of the rows the model was fitted on.
    held_out : (M, F) the features of the held-out rows, the same columns.

    Returns
    -------
    (M,) leverages, dimensionless.
    """
    learned, held_out = _learned_and_held_out("play_leverage", learned, held_out, "features")
    learned = np.column_stack([learned, np.ones(len(learned))])
    held_out = np.column_stack([held_out, np.ones(len(held_out))])
    # the learned rows' right singular vectors and values give (B^T B)^+ without forming it
    _, singular, vt = np.linalg.svd(learned, full_matrices=False)
    kept = singular > singular[0] * max(learned.shape) * np.finfo(float).eps
    coordinates = held_out @ vt[kept].T
    leverage = np.sum((coordinates / singular[kept]) ** 2, axis=1) * len(learned) / int(kept.sum())
    outside = np.linalg.norm(held_out - coordinates @ vt[kept], axis=1)
    leverage[outside > np.sqrt(np.finfo(float).eps) * np.linalg.norm(held_out, axis=1)] = np.inf
    return leverage


def _pooled_deg(error: np.ndarray) -> float:
    """Root mean square over every row and column of a joint error (rad), in degrees; NaN when empty."""
    return float(np.degrees(np.sqrt(np.mean(np.square(error))))) if error.size else float("nan")


def _shrink_percent(part: dict) -> float:
    """How much of the starting model's pooled RMSE the named effects close on one part, in %
    (the workflow's own shrink, ``1 - after / before``); NaN on an empty part."""
    return 100 * (1 - part["after"] / part["before"]) if part["before"] > 0 else float("nan")


def analyse(split: str) -> dict:
    """The workflow and the calibrators on one split."""
    from estimators import FixedOffsetCalibrator, LinearCalibrator, WindowLinearCalibrator
    from simulation.discrepancy.generic import play_features, play_widths

    (result, signals, parts), ((t0, x0, y0), (t1, x1, y1)) = run_split(split)
    joints = list(WRIST_JOINTS)
    raw = list(range(6))
    makers = {"fixed offset": lambda: FixedOffsetCalibrator(raw_columns=raw),
              "linear": lambda: LinearCalibrator(raw_columns=raw),
              "window linear, 5 rows": lambda: WindowLinearCalibrator(raw_columns=raw, window=5)}

    errors = {name: y1[:, joints] - makers[name]().fit(x0, y0).predict(x1)[:, joints] for name in CALIBRATORS}
    before, after = result.residual_before.joints, result.residual_after.joints
    if len(before) != len(t1) or len(after) != len(t1):
        raise RuntimeError(f"the workflow's held-out part has {len(after)} rows, the split's {len(t1)}")
    features = play_features(signals, play_widths(signals)).reshape(len(signals), -1)
    leverage = play_leverage(features[parts.fit], features[parts.held_out])

    def summary(mask):
        return {"before": _pooled_deg(before[mask]), "after": _pooled_deg(after[mask]),
                "learned": {name: _pooled_deg(e[mask]) for name, e in errors.items()},
                "leverage_median": float(np.median(leverage[mask])) if mask.any() else float("nan")}

    inside = within_learned_range(x0[:, joints], x1[:, joints])
    by_part = {part: summary(mask) for part, mask in (("inside", inside), ("outside", ~inside))}
    quarter = leverage_quarters(leverage)
    by_leverage = [dict(summary(quarter == k), low=float(leverage[quarter == k].min()),
                        high=float(leverage[quarter == k].max())) for k in range(LEVERAGE_QUARTERS)]
    return {"split": split, "named": list(result.named_effects), "shrink": result.shrink,
            "before": _pooled_deg(before), "after": _pooled_deg(after),
            "learned": {name: _pooled_deg(e) for name, e in errors.items()},
            "inside_share": float(inside.mean()), "by_range": by_part,
            "leverage_median": float(np.median(leverage)), "by_leverage": by_leverage}


def leverage_quarters(leverage: np.ndarray) -> np.ndarray:
    """(M,) which of :data:`LEVERAGE_QUARTERS` equal shares, 0 the lowest, each leverage falls in, by
    rank (ties in the order given), so that infinite leverages share the top one without edges."""
    leverage = np.asarray(leverage, dtype=float)
    if leverage.ndim != 1 or leverage.size < LEVERAGE_QUARTERS or np.any(np.isnan(leverage)):
        raise ValueError(f"leverage_quarters needs at least {LEVERAGE_QUARTERS} leverages and no NaN, got shape "
                         f"{leverage.shape}")
    rank = np.empty(leverage.size, dtype=int)
    rank[np.argsort(leverage, kind="stable")] = np.arange(leverage.size)
    return rank * LEVERAGE_QUARTERS // leverage.size


def run(config: SplitsConfig, n_jobs: int = -1, backend: str = "loky", scheduler=None, progress: bool = True) -> dict:
    runs = run_tasks(analyse, [(s,) for s in config.splits], n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                     progress=progress, description="splits")
    return {"runs": runs}


def tables(results: dict) -> list[str]:
    rows = [[r["split"], ", ".join(r["named"]) or "none", f"{100 * r['shrink']:.1f}", f"{r['before']:.3f}",
             f"{r['after']:.3f}", *[f"{r['learned'][name]:.3f}" for name in CALIBRATORS]] for r in results["runs"]]
    window = CALIBRATORS[-1]

    range_rows = []
    for r in results["runs"]:
        for name, label in (("inside", "within"), ("outside", "beyond")):
            part = r["by_range"][name]
            share = r["inside_share"] if name == "inside" else 1 - r["inside_share"]
            if share == 0:
                continue
            leverage = part.get("leverage_median")
            range_rows.append([r["split"], label, f"{100 * share:.1f}",
                               "-" if leverage is None else f"{leverage:.1f}", f"{_shrink_percent(part):.1f}",
                               f"{part['before']:.3f}", f"{part['after']:.3f}", f"{part['learned'][window]:.3f}"])
    leverage_rows = []
    for r in results["runs"]:
        for k, part in enumerate(r.get("by_leverage", ())):
            leverage_rows.append([r["split"], QUARTER_NAMES[k] if k < len(QUARTER_NAMES) else str(k + 1),
                                  f"{part['low']:.1f} to {part['high']:.1f}", f"{part['leverage_median']:.1f}",
                                  f"{_shrink_percent(part):.1f}", f"{part['before']:.3f}", f"{part['after']:.3f}",
                                  f"{part['learned'][window]:.3f}"])
    return ["## The dVRK wrist analysis on four splits (held-out pooled wrist RMSE, deg)", "",
            reporting.markdown_table(["fit -> held out", "named", "shrink %", "starting model", "named effects",
                                      *CALIBRATORS], rows), "",
            "Named effects: the workflow's model after what it named (fitted on the first two thirds of the "
            "learning part, chosen on its last third); the calibrators learn from the whole learning part.", "",
            "## Held-out samples within and beyond the learning part's wrist ranges (pooled RMSE, deg)", "",
            reporting.markdown_table(["fit -> held out", "reported wrist joints", "share of held out %",
                                      "median leverage", "shrink %",
                                      "starting model", "named effects", window], range_rows), "",
            "Within: every reported wrist joint inside the range (min to max) the learning part covered; "
            "beyond: at least one outside it, where every model extrapolates.", "",
            "## Held-out samples by the leverage of their play features in the fit part's (pooled RMSE, deg)", "",
            reporting.markdown_table(["fit -> held out", "quarter of held out", "leverage", "median leverage",
                                      "shrink %", "starting model", "named effects", window], leverage_rows), "",
            "Leverage: how far a sample's play features (every wrist joint's reported motion through plays of "
            "1/2 to 1/256 of its range, the inputs of coupled_hysteresis) lie outside the combinations the fit "
            "part excited; the fit part's own samples average 1 (play_leverage)."]


def finding(results: dict) -> str:
    parts = []
    for r in results["runs"]:
        best = min(r["learned"], key=r["learned"].get)
        text = (f"{r['split']}: {100 * r['shrink']:.1f} % closed, {r['after']:.2f} deg against "
                f"{r['learned'][best]:.2f} for the best calibrator ({best})")
        if 0 < r["inside_share"] < 1:
            within, beyond = (r["by_range"][p] for p in ("inside", "outside"))
            text += (f" ({100 * (1 - r['inside_share']):.0f} % of the held-out samples beyond the learned wrist "
                     f"ranges: {_shrink_percent(within):.1f} % closed within them, "
                     f"{_shrink_percent(beyond):.1f} % beyond)")
        if r.get("by_leverage"):
            low, high = r["by_leverage"][0], r["by_leverage"][-1]
            text += (f" (median play-feature leverage {r['leverage_median']:.1f}: {_shrink_percent(low):.1f} % closed "
                     f"on the held-out quarter of lowest leverage, {_shrink_percent(high):.1f} % on the highest)")
        parts.append(text)
    return "; ".join(parts) + "."


def configure(args) -> SplitsConfig:
    return SplitsConfig(splits=SPLITS[:1] if args.quick else SPLITS)


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    with StudyRun(parser, argv, configure) as study:
        say(f"dVRK wrist analysis on {len(study.config.splits)} splits")
        results = run(study.config, **study.parallel)
        return study.conclude(results, title="Discrepancy workflow: the dVRK wrist on four splits",
                              finding=finding, tables=tables, figures=lambda results, out: [])


if __name__ == "__main__":
    main()
