"""Training on the error vs end-to-end (the paper's Table II).

On the session of the 6-hour unloaded operation (as in the paper, II-J), the DNN, linear and
2nd-order polynomial regression are trained either on the error (they output ``truth - raw``,
added to the raw joints) or end-to-end (they output the joints), on every combination of the
J2-J3 zig-zags at sparsities 1/6, 1/4, 1/3. Each entry is the RMSE averaged over all training
sets and the hours of operation, as in the paper's table, whose numbers are printed beside.

Run: ``python studies/train_on_error.py [--quick] [--hours H] [--out DIR] [--jobs N]``
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.evaluation import JOINT_HEADERS
from studies.common.methods import MODEL_LABELS as PAPER_MODEL_LABELS
from studies.common.methods import Method, MethodSettings, dnn, regression
from studies.common.runner import StudyRun, positive_float, positive_int, say, study_parser
from studies.common.sessions import (
    OperationSessionConfig,
    all_combinations,
    kind_seed,
    operation_session,
    training_sets,
)
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "train_on_error"
MODELS = ("dnn", "linear", "polynomial")
MODEL_LABELS = {**PAPER_MODEL_LABELS, "polynomial": "Poly Reg"}
"""The paper's model names; its Table II calls the polynomial "Poly Reg"."""
MODES = ("error", "end_to_end")


@dataclass(frozen=True)
class TrainOnErrorConfig:
    """Session (unloaded operation) and budgets of the study."""

    session: OperationSessionConfig = field(default_factory=OperationSessionConfig)
    settings: MethodSettings = field(default_factory=MethodSettings)

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "TrainOnErrorConfig":
        """Two sparsities, 18 minutes of operation in 6-minute blocks, one DNN seed."""
        session = OperationSessionConfig.quick(seed)
        return cls(**{"session": session, "settings": MethodSettings.quick(), **changes})


def methods(settings: MethodSettings) -> dict[tuple[str, str], Method]:
    """Each model trained on the error and end-to-end."""
    out = {}
    for mode in MODES:
        on_error = mode == "error"
        out[("dnn", mode)] = dnn(settings, train_on_error=on_error, key=f"dnn_{mode}")
        for model in ("linear", "polynomial"):
            out[(model, mode)] = regression(model, train_on_error=on_error, key=f"{model}_{mode}")
    return out


def run(config: TrainOnErrorConfig, *, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
        progress: bool = True) -> dict:
    """Simulate the unloaded session; train each model both ways on every training set; average."""
    s = config.session
    seed = kind_seed(s.seed, "unloaded")
    (parts, hours), = run_tasks(operation_session, [("unloaded", seed, s)], n_jobs=1, backend=backend,
                                scheduler=scheduler, progress=progress, description="session")
    sets = training_sets(parts["selected"], all_combinations(s.sparsities))
    tests = hours["selected"]
    recipes = methods(config.settings)
    cells = [GridCell((model, mode, label), recipes[(model, mode)], train, tests)
             for (model, mode) in recipes for label, train in sets.items()]
    outcomes = fit_grid(cells, seed=s.seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress)
    rmse = {model: {mode: np.nanmean([mean_joint_rmse(outcomes[(model, mode, label)], h)
                                      for label in sets for h in tests], axis=0).tolist()
                    for mode in MODES} for model in MODELS}
    return {"training_sets": list(sets), "hours": list(tests), "rmse": rmse, "session_seed": seed,
            "failures": failures(outcomes)}


def finding(results: dict) -> str:
    r = results["rmse"]
    dnn_worse = [e2e / err for err, e2e in zip(r["dnn"]["error"], r["dnn"]["end_to_end"])]
    linear_same = [abs(e2e / err - 1.0) for err, e2e in zip(r["linear"]["error"], r["linear"]["end_to_end"])]
    agrees = all(v > 1.0 for v in dnn_worse) and all(v < 0.01 for v in linear_same)
    simulated = ("end-to-end / on-error RMSE, joints 1/2/3: DNN " + "/".join(f"{v:.2f}" for v in dnn_worse)
                 + "; linear " + "/".join(f"{1 + d:.3f}" for d in linear_same) + "; polynomial "
                 + "/".join(f"{e2e / err:.3f}" for err, e2e in zip(r["polynomial"]["error"], r["polynomial"]["end_to_end"]))
                 + ".")
    return reporting.agreement_line(agrees, simulated, paper.FINDINGS["train_on_error"],
                                    paper.FINDING_KIND["train_on_error"])


def tables(results: dict) -> list[str]:
    headers = ["Model", "Data"]
    for joint in JOINT_HEADERS:
        headers += [f"{joint} Err", f"{joint} E-to-E"]
    rows = []
    for model in MODELS:
        for source, values in (("simulated here", results["rmse"][model]), ("published", paper.TABLE_II[model])):
            row = [MODEL_LABELS[model], source]
            for j in range(3):
                row += [values["error"][j], values["end_to_end"][j]]
            rows.append(row)
    sections = ["## Trained on error (Err) vs end-to-end (E-to-E), Table II layout", "",
                reporting.markdown_table(headers, rows), "",
                f"Each simulated entry is the RMSE averaged over {len(results['training_sets'])} training sets "
                f"({', '.join(results['training_sets'])}) and {len(results['hours'])} blocks of unloaded operation."]
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    groups = [MODEL_LABELS[m] for m in MODELS]
    series = {f"{mode.replace('_', '-')} (simulated)": np.array([results["rmse"][m][mode] for m in MODELS])
              for mode in MODES}
    series.update({f"{mode.replace('_', '-')} (paper)": np.array([paper.TABLE_II[m][mode] for m in MODELS])
                   for mode in MODES})
    return [plots.grouped_bars(groups, series, JOINT_HEADERS, out / "train_on_error.png",
                               "Trained on error vs end-to-end (Table II)")]


def configure(args) -> TrainOnErrorConfig:
    config = TrainOnErrorConfig.quick(args.seed) if args.quick else \
        TrainOnErrorConfig(session=OperationSessionConfig(seed=args.seed))
    if args.hours is not None:
        config = replace(config, session=replace(config.session, hours=args.hours))
    if args.dnn_seeds is not None:
        config = replace(config, settings=config.settings.with_(dnn_seeds=args.dnn_seeds))
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--hours", type=positive_float, default=None, help="hours of unloaded operation")
    parser.add_argument("--dnn-seeds", type=positive_int, default=None, help="network training seeds to average")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"unloaded session: calibration then {config.session.hours:g} h; "
            "models trained on error and end-to-end")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Training on error vs end-to-end (Table II)", finding=finding,
                              tables=tables, figures=figures, extra={"published": {"table_ii": paper.TABLE_II}})


if __name__ == "__main__":
    main()
