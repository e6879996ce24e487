"""Six hours of idle, unloaded and loaded operation after calibration (the paper's Fig. 6).

For each configuration a fresh session of the virtual RAVEN-II records the J2-J3 zig-zags at
sparsities 1/6, 1/4, 1/3 (one recording each), then operates for 6 hours: holding its pose
(idle), random motion (unloaded), or random motion with 500 g at the tool tip (loaded; the
payload hangs during the calibration too, as in the paper's loaded experiment). Models are
trained on every combination of the zig-zags (7 training sets, 194 s to 1002 s) and scored hour
by hour. As in the paper, the summary is the average over the 3 longest training sets.

The operation is scored on every ``eval_stride``-th log sample (10 by default: 3 Hz, 3600
samples per hour), which keeps 6 hours of the full robot state out of memory. The sessions are
:func:`studies.common.sessions.operation_session` (calibration, then the simulator's
``long_operation`` scenario).

Run: ``python studies/long_operation.py [--quick] [--hours H] [--out DIR] [--jobs N]``
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.evaluation import JOINT_HEADERS
from studies.common.methods import MODEL_LABELS, MethodSettings, dnn, regression
from studies.common.runner import StudyRun, names, positive_float, positive_int, say, study_parser
from studies.common.sessions import (
    KINDS,
    OperationSessionConfig,
    all_combinations,
    kind_seed,
    longest_sets,
    operation_session,
    training_sets,
)
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "long_operation"
MODELS = ("fixed_offset", "dnn", "linear", "polynomial")


@dataclass(frozen=True)
class LongOperationConfig:
    """Configurations, session, training budgets of the study."""

    session: OperationSessionConfig = field(default_factory=OperationSessionConfig)
    kinds: tuple[str, ...] = KINDS
    settings: MethodSettings = field(default_factory=MethodSettings)

    def __post_init__(self) -> None:
        unknown = [k for k in self.kinds if k not in KINDS]
        if unknown or not self.kinds:
            raise ValueError(f"kinds must be among {KINDS}, got {self.kinds}")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "LongOperationConfig":
        """Two sparsities (1/2, 1/3), 18 minutes of operation scored in 6-minute blocks, one DNN seed."""
        session = OperationSessionConfig.quick(seed)
        return cls(**{"session": session, "settings": MethodSettings.quick(), **changes})


def run(config: LongOperationConfig, *, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
        progress: bool = True) -> dict:
    """Simulate the sessions, train on every combination of zig-zags, score per hour."""
    s = config.session
    seeds = {kind: kind_seed(s.seed, kind) for kind in config.kinds}
    sessions = run_tasks(operation_session, [(kind, seeds[kind], s) for kind in config.kinds], n_jobs=n_jobs,
                         backend=backend, scheduler=scheduler, progress=progress, description="sessions")
    methods = {"dnn": dnn(config.settings), **{m: regression(m) for m in MODELS if m != "dnn"}}
    combos = all_combinations(s.sparsities)
    cells, longest, hour_names, durations = [], {}, {}, {}
    for kind, (parts, hours) in zip(config.kinds, sessions):
        sets = training_sets(parts["selected"], combos)
        longest[kind] = longest_sets(sets)
        hour_names[kind] = list(hours["selected"])
        durations[kind] = {label: round(train.duration, 1) for label, train in sets.items()}
        cells += [GridCell((kind, label, m), methods[m], train, hours["selected"])
                  for label, train in sets.items() for m in MODELS]
    outcomes = fit_grid(cells, seed=s.seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler,
                        progress=progress)
    per_set = {kind: {label: {m: {h: mean_joint_rmse(outcomes[(kind, label, m)], h).tolist()
                                  for h in hour_names[kind]} for m in MODELS}
                      for label in durations[kind]} for kind in config.kinds}
    summary = {kind: {m: {h: np.nanmean([per_set[kind][label][m][h] for label in longest[kind]], axis=0).tolist()
                          for h in hour_names[kind]} for m in MODELS} for kind in config.kinds}
    spread = {kind: {m: {h: np.nanstd([per_set[kind][label][m][h] for label in durations[kind]], axis=0).tolist()
                         for h in hour_names[kind]} for m in MODELS} for kind in config.kinds}
    return {"hours": hour_names, "longest_training_sets": longest, "training_set_durations_s": durations,
            "rmse_3_longest": summary, "rmse_std_over_training_sets": spread, "rmse_per_training_set": per_set,
            "session_seeds": seeds, "failures": failures(outcomes)}


def decay(results: dict) -> dict:
    """Per configuration and model: RMSE of the last hour minus the first (deg, deg, mm), 3 longest sets."""
    out = {}
    for kind, models in results["rmse_3_longest"].items():
        first, last = results["hours"][kind][0], results["hours"][kind][-1]
        out[kind] = {m: (np.asarray(v[last]) - np.asarray(v[first])).tolist() for m, v in models.items()}
    return out


def relative_decay(results: dict, model: str) -> dict:
    """Mean over joints of (last hour / first hour - 1), per configuration, for one model."""
    out = {}
    for kind, models in results["rmse_3_longest"].items():
        first, last = results["hours"][kind][0], results["hours"][kind][-1]
        out[kind] = float(np.mean(np.asarray(models[model][last]) / np.asarray(models[model][first]) - 1.0))
    return out


def finding(results: dict) -> str:
    lines, ordered = [], True
    for model in ("dnn", "linear"):
        rel = relative_decay(results, model)
        lines.append(f"{MODEL_LABELS[model]} " + ", ".join(f"{k} {100 * v:+.0f}%" for k, v in rel.items()))
        present = [k for k in KINDS if k in rel]
        ordered &= all(rel[a] < rel[b] for a, b in zip(present, present[1:]))
    simulated = ("change of RMSE from the first to the last hour (mean over joints, 3 longest training sets): "
                 + "; ".join(lines) + ".")
    complete = all(k in results["rmse_3_longest"] for k in KINDS)
    return reporting.agreement_line(ordered and complete, simulated, paper.FINDINGS["long_operation"],
                                    paper.FINDING_KIND["long_operation"])


def tables(results: dict) -> list[str]:
    sections = []
    for kind, models in results["rmse_3_longest"].items():
        for j, joint in enumerate(JOINT_HEADERS):
            rows = [[hour, *[models[m][hour][j] for m in MODELS]] for hour in results["hours"][kind]]
            d = decay(results)[kind]
            rows.append(["last - first", *[d[m][j] for m in MODELS]])
            sections += [f"## {kind}: {joint}", "",
                         reporting.markdown_table(["Hour", *[MODEL_LABELS[m] for m in MODELS]], rows), ""]
    longest = next(iter(results["longest_training_sets"].values()))
    sections.append(f"Each entry: RMSE averaged over the {len(longest)} longest training sets "
                    f"({', '.join(longest)}) and the network seeds. "
                    "The paper gives this experiment as a figure (Fig. 6); its numbers are not available here.")
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    paths = []
    for kind, models in results["rmse_3_longest"].items():
        hours = results["hours"][kind]
        x = [float(h.split()[-1]) for h in hours]
        series = {MODEL_LABELS[m]: (np.array([models[m][h] for h in hours]),
                                    np.array([results["rmse_std_over_training_sets"][kind][m][h] for h in hours]))
                  for m in MODELS}
        paths.append(plots.lines_with_spread(x, series, JOINT_HEADERS, out / f"long_operation_{kind}.png",
                                             f"{kind} operation: RMSE per hour (longest training sets; "
                                             "bars: std over all training sets)", "hour of operation",
                                             log_scale=True))
    return paths


def configure(args) -> LongOperationConfig:
    config = LongOperationConfig.quick(args.seed) if args.quick else \
        LongOperationConfig(session=OperationSessionConfig(seed=args.seed))
    config = replace(config, kinds=args.kinds)
    if args.hours is not None:
        config = replace(config, session=replace(config.session, hours=args.hours))
    if args.dnn_seeds is not None:
        config = replace(config, settings=config.settings.with_(dnn_seeds=args.dnn_seeds))
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--hours", type=positive_float, default=None, help="hours of operation")
    parser.add_argument("--kinds", type=names(KINDS, "kind of operation"), default=",".join(KINDS),
                        help="comma-separated: idle, unloaded, loaded")
    parser.add_argument("--dnn-seeds", type=positive_int, default=None, help="network training seeds to average")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"{', '.join(config.kinds)}: calibration then {config.session.hours:g} h of operation each")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Idle, unloaded and loaded operation (Fig. 6)", finding=finding,
                              tables=tables, figures=figures,
                              extra={"decay_last_minus_first_hour": decay(results)})


if __name__ == "__main__":
    main()
