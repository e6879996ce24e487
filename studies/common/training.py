"""Train methods on one set of samples and score them on test sets, seed by seed, in parallel.

:func:`fit_and_score` is the unit of work of every study (one method, one seed, one training
set); :func:`run_methods` runs a method list with all their seeds through
:func:`studies.common.sweeps.run_tasks` and averages the scores over seeds as the paper did.
"""

from __future__ import annotations

import time
import traceback
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from studies.common.evaluation import Scores, mean_scores, score, std_scores
from studies.common.methods import Method, seeds_for
from studies.common.samples import Samples
from studies.common.sweeps import run_tasks


@dataclass(frozen=True)
class FitOutcome:
    """One method trained with one seed and scored on each test set.

    Attributes
    ----------
    key : method key.
    seed : training seed.
    scores : test name -> :class:`Scores` (empty when the fit failed).
    predictions : test name -> joints 1-3 (N, 3) SI, when asked for.
    fit_seconds, predict_seconds : wall-clock times of ``fit`` and of all ``predict`` calls.
    error : None, or the failure's message (the traceback's last line).
    warnings : distinct warnings the method raised (at most :data:`MAX_WARNINGS`).
    events : test name -> the estimator's ``events_`` after predicting it (the UKF's counts of
        rejected, coasted and re-initialised samples), for estimators that keep them.
    """

    key: str
    seed: int
    scores: Mapping[str, Scores] = field(default_factory=dict)
    predictions: Mapping[str, np.ndarray] = field(default_factory=dict)
    fit_seconds: float = 0.0
    predict_seconds: float = 0.0
    error: str | None = None
    warnings: tuple[str, ...] = ()
    events: Mapping[str, dict] = field(default_factory=dict)


MAX_WARNINGS = 5


def _distinct(caught) -> tuple[str, ...]:
    messages = dict.fromkeys(f"{w.category.__name__}: {str(w.message).splitlines()[0]}" for w in caught)
    return tuple(messages)[:MAX_WARNINGS]


def fit_and_score(method: Method, seed: int, train: Samples, tests: Mapping[str, Samples],
                  keep_predictions: bool = False) -> FitOutcome:
    """Fit ``method`` with ``seed`` on ``train`` and score it on every test set.

    A failure of the method is returned as ``error`` (so one broken method does not end a
    sweep); bad inputs of the study itself still raise. Warnings of the method are collected
    in ``warnings`` instead of being printed.
    """
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")
        try:
            estimator = method.make(seed)
            start = time.perf_counter()
            estimator.fit(train)
            fitted = time.perf_counter()
            predictions, events = {}, {}
            for name, test in tests.items():
                predictions[name] = estimator.predict(test)
                if getattr(estimator, "events_", None) is not None:
                    events[name] = dict(estimator.events_)
            predicted = time.perf_counter()
        except Exception as error:  # noqa: BLE001 - reported per method, see docstring
            last = traceback.format_exception_only(type(error), error)[-1].strip()
            return FitOutcome(method.key, seed, error=last, warnings=_distinct(caught))
    scores = {name: score(predictions[name], test) for name, test in tests.items()}
    return FitOutcome(method.key, seed, scores, predictions if keep_predictions else {},
                      fitted - start, predicted - fitted, warnings=_distinct(caught), events=events)


@dataclass(frozen=True)
class MethodRun:
    """A method's results over its seeds.

    Attributes
    ----------
    method : the method.
    status : ``"ok"``, ``"skipped"`` or ``"failed"``.
    note : why it did not run (one line), else "".
    seeds : training seeds used.
    outcomes : one :class:`FitOutcome` per seed.
    """

    method: Method
    status: str
    note: str = ""
    seeds: tuple[int, ...] = ()
    outcomes: tuple[FitOutcome, ...] = ()

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def mean(self, test: str) -> Scores:
        """Scores on ``test`` averaged over seeds."""
        return mean_scores([o.scores[test] for o in self.outcomes])

    def std(self, test: str) -> Scores:
        """Standard deviation of the scores on ``test`` over seeds."""
        return std_scores([o.scores[test] for o in self.outcomes])

    def predictions(self, test: str) -> np.ndarray | None:
        """The first seed's predictions on ``test``, when they were kept."""
        return self.outcomes[0].predictions.get(test) if self.outcomes else None

    @property
    def warnings(self) -> tuple[str, ...]:
        """Distinct warnings over the seeds."""
        return tuple(dict.fromkeys(w for o in self.outcomes for w in o.warnings))

    @property
    def fit_seconds(self) -> float:
        return float(np.mean([o.fit_seconds for o in self.outcomes])) if self.outcomes else 0.0


def why_not_runnable(method: Method, train: Samples, tests: Mapping[str, Samples]) -> tuple[str, str] | None:
    """(status, note) when a method cannot run on these samples, else None."""
    if method.needs_robot_state and (train.dataset is None or any(t.dataset is None for t in tests.values())):
        return "skipped", "skipped: the data hold no full robot state (motor torques) for this model-based method"
    return None


def run_methods(methods: Sequence[Method], train: Samples, tests: Mapping[str, Samples], *, seed: int = 0,
                n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
                progress: bool = True, keep_predictions: bool = True) -> dict[str, MethodRun]:
    """Train and score every method with each of its seeds; results keyed by method key.

    Methods that cannot run here come back with their status and one line saying why. The
    full robot state is shipped to workers only for the methods that need it.
    """
    return run_method_groups(methods, [(train, tests)], seed=seed, n_jobs=n_jobs, backend=backend,
                             scheduler=scheduler, progress=progress, keep_predictions=keep_predictions)[0]


def run_method_groups(methods: Sequence[Method], groups: Sequence[tuple[Samples, Mapping[str, Samples]]], *,
                      seed: int = 0, n_jobs: int = -1, backend: str = "loky", scheduler: str | None = None,
                      progress: bool = True, keep_predictions: bool = True) -> list[dict[str, MethodRun]]:
    """:func:`run_methods` for several (training samples, test sets) pairs sharing one pool of workers.

    Every method is trained on each pair's training samples and scored on that pair's tests; one
    result dict per pair, in order. One pool keeps both cores busy to the end of the last pair.
    """
    blocked: list[dict[str, MethodRun]] = [{} for _ in groups]
    tasks, owners = [], []
    for g, (train, tests) in enumerate(groups):
        light_train = train.without_dataset()
        light_tests = {name: test.without_dataset() for name, test in tests.items()}
        for method in methods:
            why = why_not_runnable(method, train, tests)
            if why:
                blocked[g][method.key] = MethodRun(method, *why)
                continue
            heavy = method.needs_robot_state
            for method_seed in seeds_for(method, seed):
                tasks.append((method, method_seed, train if heavy else light_train,
                              tests if heavy else light_tests, keep_predictions))
                owners.append((g, method.key))
    # longest tasks first keeps the workers busy to the end
    order = sorted(range(len(tasks)), key=lambda i: -tasks[i][0].cost * len(tasks[i][2]))
    results = run_tasks(fit_and_score, [tasks[i] for i in order], n_jobs=n_jobs, backend=backend,
                        scheduler=scheduler, progress=progress, description="training")
    outcomes: dict[tuple[int, str], list[FitOutcome]] = {}
    for index, outcome in zip(order, results):
        outcomes.setdefault(owners[index], []).append(outcome)
    grouped = []
    for g in range(len(groups)):
        runs = blocked[g]
        for method in methods:
            if method.key in runs:
                continue
            done = sorted(outcomes[(g, method.key)], key=lambda o: seeds_for(method, seed).index(o.seed))
            failed = [o for o in done if o.error]
            if failed:
                runs[method.key] = MethodRun(method, "failed", f"failed: {failed[0].error}",
                                             tuple(o.seed for o in done), ())
            else:
                runs[method.key] = MethodRun(method, "ok", "", tuple(o.seed for o in done), tuple(done))
        grouped.append({method.key: runs[method.key] for method in methods})
    return grouped


@dataclass(frozen=True, eq=False)
class GridCell:
    """One training run of a sweep: a method trained on one training set, scored on test sets.

    ``key`` identifies the cell in the results (e.g. ``("J2-J3", "dnn")``).
    """

    key: tuple
    method: Method
    train: Samples
    tests: Mapping[str, Samples]


def fit_grid(cells: Sequence[GridCell], *, seed: int = 0, n_jobs: int = -1, backend: str = "loky",
             scheduler: str | None = None, progress: bool = True,
             description: str = "training") -> dict[tuple, list[FitOutcome]]:
    """Train every cell with each of its method's seeds, in parallel; outcomes per cell key, seed order.

    The seeds of a method are the same in every cell (the paper repeated its DNN with the same 5
    global seeds for every training set), so cells differ only by their data. The full robot
    state is shipped to workers only for the methods that need it (the UKF).
    """
    keys = [cell.key for cell in cells]
    if len(set(keys)) != len(keys):
        raise ValueError("grid cell keys must be unique")
    tasks, owners = [], []
    for cell in cells:
        heavy = cell.method.needs_robot_state
        train = cell.train if heavy else cell.train.without_dataset()
        tests = dict(cell.tests) if heavy else {name: test.without_dataset() for name, test in cell.tests.items()}
        for method_seed in seeds_for(cell.method, seed):
            tasks.append((cell.method, method_seed, train, tests, False))
            owners.append(cell.key)
    order = sorted(range(len(tasks)), key=lambda i: -tasks[i][0].cost * len(tasks[i][2]))
    results = run_tasks(fit_and_score, [tasks[i] for i in order], n_jobs=n_jobs, backend=backend,
                        scheduler=scheduler, progress=progress, description=description)
    by_task = dict(zip(order, results))
    outcomes: dict[tuple, list[FitOutcome]] = {cell.key: [] for cell in cells}
    for index in range(len(tasks)):
        outcomes[owners[index]].append(by_task[index])
    return outcomes


def mean_joint_rmse(outcomes: Sequence[FitOutcome], test: str) -> np.ndarray:
    """Joint RMSE (deg, deg, mm) on ``test`` averaged over seeds; NaN when a seed failed."""
    if not outcomes or any(o.error for o in outcomes):
        return np.full(3, np.nan)
    return np.mean([o.scores[test].joint for o in outcomes], axis=0)


def failures(outcomes: Mapping[tuple, Sequence[FitOutcome]]) -> list[str]:
    """One line per failed training run of a grid."""
    return [f"{key}: seed {o.seed}: {o.error}" for key, runs in outcomes.items() for o in runs if o.error]
