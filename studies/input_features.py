"""Input features: the 16 selected ones vs the whole robot state, small vs large DNN (the paper's Fig. 8).

On the session of the 6-hour unloaded operation (as in the paper, II-H), the models are trained
on the selected features (joint positions and motor torques of the arm, 16 inputs) or on all
features of the robot state (122 here; 138 in the paper's message version), with the paper's
small DNN (2 x 100) and its larger DNN (600-500-400 with regularization) for all features. The
2nd-order polynomial is run on the selected features only: on all features it would have 7,626
monomials per joint. Scores are averaged over the hours of operation and the 3 longest training
sets, as the paper reports them.

Run: ``python studies/input_features.py [--quick] [--hours H] [--out DIR] [--jobs N]``
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from estimators import LARGE_HIDDEN_LAYER_SIZES
from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.evaluation import JOINT_HEADERS
from studies.common.methods import Method, MethodSettings, dnn, regression
from studies.common.runner import StudyRun, positive_float, positive_int, say, study_parser
from studies.common.sessions import (
    OperationSessionConfig,
    all_combinations,
    kind_seed,
    longest_sets,
    operation_session,
    training_sets,
)
from studies.common.sweeps import run_tasks
from studies.common.training import GridCell, failures, fit_grid, mean_joint_rmse

STUDY = "input_features"
VARIANTS = (
    # key, label, feature group, model
    ("dnn_selected", "DNN 2x100, selected", "selected", "dnn"),
    ("dnn_all", "DNN 2x100, all", "all", "dnn"),
    ("dnn_large_all", "DNN 600-500-400, all", "all", "dnn_large"),
    ("linear_selected", "Lin Reg, selected", "selected", "linear"),
    ("linear_all", "Lin Reg, all", "all", "linear"),
    ("polynomial_selected", "2nd Reg, selected", "selected", "polynomial"),
    ("fixed_offset", "Fixed Offset", "selected", "fixed_offset"),
)
PAPER_PARAMETERS = {"dnn_selected": 12103, "dnn_all": 24303, "dnn_large_all": 585503, "linear_selected": 17,
                    "linear_all": 139}
"""Parameter counts the paper gives (its 'all' inputs are 138 features)."""


def parameter_count(variant: str, n_inputs: int, n_outputs: int = 3) -> int:
    """Weights and biases of a variant's model for ``n_inputs`` features (linear: per joint)."""
    model = dict((v[0], v[3]) for v in VARIANTS)[variant]
    if model == "linear":
        return n_inputs + 1
    if model == "fixed_offset":
        return 1
    if model == "polynomial":
        return (n_inputs + 1) * (n_inputs + 2) // 2
    sizes = (n_inputs, *(LARGE_HIDDEN_LAYER_SIZES if model == "dnn_large" else (100, 100)), n_outputs)
    return int(sum(a * b + b for a, b in zip(sizes, sizes[1:])))


@dataclass(frozen=True)
class InputFeaturesConfig:
    """Session (unloaded operation), training sets and budgets of the study."""

    session: OperationSessionConfig = field(default_factory=OperationSessionConfig)
    n_longest: int = 3
    large_dnn_seeds: int = 1
    large_dnn_epochs: int = 200
    settings: MethodSettings = field(default_factory=MethodSettings)

    def __post_init__(self) -> None:
        for name in ("n_longest", "large_dnn_seeds", "large_dnn_epochs"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value}")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "InputFeaturesConfig":
        """Two sparsities, 18 minutes of operation, the 2 longest sets, few large-DNN epochs."""
        session = OperationSessionConfig.quick(seed)
        return cls(**{"session": session, "n_longest": 2, "large_dnn_epochs": 10,
                      "settings": MethodSettings.quick(), **changes})


def _methods(config: InputFeaturesConfig) -> dict[str, Method]:
    large = replace(dnn(config.settings.with_(dnn_seeds=config.large_dnn_seeds,
                                              dnn_epochs=config.large_dnn_epochs), large=True),
                    key="dnn_large", label="DNN 600-500-400", cost=30.0)
    return {"dnn": dnn(config.settings), "dnn_large": large, "linear": regression("linear"),
            "polynomial": regression("polynomial"), "fixed_offset": regression("fixed_offset")}


def run(config: InputFeaturesConfig, *, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
        progress: bool = True) -> dict:
    """Simulate the unloaded session, train every variant on the longest training sets, score per hour."""
    s = config.session
    seed = kind_seed(s.seed, "unloaded")
    (parts, hours), = run_tasks(operation_session, [("unloaded", seed, s, ("selected", "all"))], n_jobs=1,
                                backend=backend, scheduler=scheduler, progress=progress, description="session")
    methods = _methods(config)
    combos = all_combinations(s.sparsities)
    sets = {group: training_sets(parts[group], combos) for group in ("selected", "all")}
    chosen = longest_sets(sets["selected"], config.n_longest)
    cells = [GridCell((key, label), methods[model], sets[group][label], hours[group])
             for key, _, group, model in VARIANTS for label in chosen]
    outcomes = fit_grid(cells, seed=s.seed, n_jobs=n_jobs, backend=backend, scheduler=scheduler, progress=progress)
    hour_names = list(hours["selected"])
    per_hour = {key: {h: np.nanmean([mean_joint_rmse(outcomes[(key, label)], h) for label in chosen], axis=0).tolist()
                      for h in hour_names} for key, *_ in VARIANTS}
    overall = {key: np.mean([per_hour[key][h] for h in hour_names], axis=0).tolist() for key, *_ in VARIANTS}
    inputs = {group: len(parts[group][s.sparsities[0]].feature_names) for group in ("selected", "all")}
    parameters = {key: parameter_count(key, inputs[group]) for key, _, group, _ in VARIANTS}
    return {"training_sets": chosen, "hours": hour_names, "inputs": inputs, "parameters": parameters,
            "rmse_mean_over_hours": overall, "rmse_per_hour": per_hour, "session_seed": seed,
            "failures": failures(outcomes)}


def normalized(results: dict, key: str) -> float:
    """Mean over joints of a variant's RMSE relative to fixed offset's."""
    return float(np.mean(np.asarray(results["rmse_mean_over_hours"][key])
                         / np.asarray(results["rmse_mean_over_hours"]["fixed_offset"])))


def finding(results: dict) -> str:
    n = {key: normalized(results, key) for key, *_ in VARIANTS}
    checks = [n["dnn_all"] > n["dnn_selected"], n["linear_all"] > n["linear_selected"],
              n["dnn_large_all"] < n["dnn_all"], n["dnn_large_all"] > n["dnn_selected"]]
    simulated = ("RMSE relative to fixed offset (mean over joints and hours): "
                 + ", ".join(f"{label} {n[key]:.2f}" for key, label, *_ in VARIANTS if key != "fixed_offset") + ".")
    return reporting.agreement_line(all(checks), simulated, paper.FINDINGS["input_features"],
                                    paper.FINDING_KIND["input_features"])


def tables(results: dict) -> list[str]:
    rows = []
    for key, label, group, _ in VARIANTS:
        rows.append([label, str(results["inputs"][group]), str(results["parameters"][key]),
                     str(PAPER_PARAMETERS.get(key, "-")), *results["rmse_mean_over_hours"][key]])
    headers = ["Model, features", "Inputs", "Parameters", "Paper's parameters", *JOINT_HEADERS]
    sections = ["## RMSE averaged over the hours of unloaded operation", "", reporting.markdown_table(headers, rows), "",
                f"Training sets: {', '.join(results['training_sets'])} (the longest, as the paper averages them). "
                "Parameters of linear regression are per joint. The paper gives this experiment as a figure "
                "(Fig. 8); its RMSE values are not available here."]
    return sections + reporting.failure_lines(results["failures"])


def figures(results: dict, out: Path) -> list[Path]:
    values = {label: results["rmse_mean_over_hours"][key] for key, label, *_ in VARIANTS}
    return [plots.method_bars(values, JOINT_HEADERS, out / "input_features.png",
                            "Selected vs all input features (mean over hours)")]


def configure(args) -> InputFeaturesConfig:
    config = InputFeaturesConfig.quick(args.seed) if args.quick else \
        InputFeaturesConfig(session=OperationSessionConfig(seed=args.seed))
    if args.hours is not None:
        config = replace(config, session=replace(config.session, hours=args.hours))
    if args.dnn_seeds is not None:
        config = replace(config, settings=config.settings.with_(dnn_seeds=args.dnn_seeds))
    if args.large_dnn_seeds is not None:
        config = replace(config, large_dnn_seeds=args.large_dnn_seeds)
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--hours", type=positive_float, default=None, help="hours of unloaded operation")
    parser.add_argument("--dnn-seeds", type=positive_int, default=None,
                        help="small-network training seeds to average")
    parser.add_argument("--large-dnn-seeds", type=positive_int, default=None, help="large-network training seeds")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"unloaded session: calibration then {config.session.hours:g} h; {len(VARIANTS)} model/feature variants")
        results = run(config, **study.parallel)
        return study.conclude(results, title="Selected vs all input features (Fig. 8)", finding=finding,
                              tables=tables, figures=figures, extra={"published": {"parameters": PAPER_PARAMETERS}})


if __name__ == "__main__":
    main()
