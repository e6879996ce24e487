"""Inference and training speed (the paper's Table V).

Trains each calibrator on about 30k samples x 16 selected features recorded on the virtual
RAVEN-II (the J2-J3 zig-zags at sparsities 1/6, 1/4, 1/3, like the paper's largest training set)
and times: the fit, a single-sample call of the real-time export (``to_realtime()``, what a servo
loop would call) and a single-sample ``predict``. Runs in one process, one model after the other,
so that the timings do not compete with each other; on a shared machine they still vary.

Run: ``python studies/speed.py [--quick] [--out DIR] [--models linear,dnn,...]``
"""

from __future__ import annotations

import statistics
import sys
import time
import timeit
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from simulation import powered_on, record_calibration
from simulation.trajectories import PAPER_SPARSITIES
from studies.common import paper_numbers as paper
from studies.common import plots, reporting
from studies.common.methods import MethodSettings, method_catalogue
from studies.common.runner import StudyRun, names, say, study_parser
from studies.common.samples import Samples
from studies.common.sessions import samples_of

STUDY = "speed"
SERVO_PERIOD_US = 1000.0
"""RAVEN-II's servo loop runs at 1 kHz."""
TIMED_METHODS = ("linear", "dnn", "fixed_offset", "polynomial", "gpr", "two_phase", "window_linear", "window_lstm")


@dataclass(frozen=True)
class SpeedConfig:
    """Training-set size, models and timing repetitions of the study."""

    seed: int = 0
    sparsities: tuple[float, ...] = PAPER_SPARSITIES
    n_train: int = 30000
    methods: tuple[str, ...] = TIMED_METHODS
    number: int = 2000
    repeat: int = 5
    settings: MethodSettings = field(default_factory=lambda: MethodSettings(dnn_seeds=1))

    def __post_init__(self) -> None:
        unknown = [m for m in self.methods if m not in TIMED_METHODS]
        if unknown or not self.methods:
            raise ValueError(f"methods must be among {TIMED_METHODS}, got {self.methods}")
        for name in ("n_train", "number", "repeat"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value}")

    @classmethod
    def quick(cls, seed: int = 0, **changes) -> "SpeedConfig":
        """One sparsity (1/3), 3000 training samples, linear and DNN only, short timing runs."""
        return cls(**{"seed": seed, "sparsities": (1 / 3,), "n_train": 3000, "methods": ("linear", "dnn"),
                      "number": 300, "repeat": 3, "settings": MethodSettings.quick(), **changes})


def training_samples(config: SpeedConfig) -> Samples:
    """The first ``n_train`` samples of a J2-J3 calibration recording (fewer if it is shorter)."""
    robot = powered_on(seed=config.seed)
    samples = samples_of(record_calibration(robot, "J2-J3", config.sparsities))["selected"]
    return samples.select(np.arange(min(config.n_train, len(samples))))


def latency_us(function, sample: np.ndarray, number: int, repeat: int) -> float:
    """Median time of one call ``function(sample)`` over ``repeat`` runs of ``number`` calls, in µs."""
    runs = timeit.repeat(lambda: function(sample), number=number, repeat=repeat)
    return statistics.median(run / number * 1e6 for run in runs)


def time_method(key: str, samples: Samples, config: SpeedConfig) -> dict:
    """Fit time (s), single-sample real-time and ``predict`` latency (µs) of one method."""
    method = method_catalogue(config.settings)[key]
    # a first fit on a few samples pays the one-time costs (imports, thread pools) untimed
    method.make(config.seed).fit(samples.select(np.arange(min(200, len(samples)))))
    estimator = method.make(config.seed)
    start = time.perf_counter()
    estimator.fit(samples)
    fit_seconds = time.perf_counter() - start
    model = estimator.model_
    realtime = model.to_realtime()
    sample = np.ascontiguousarray(samples.X[len(samples) // 2])
    if hasattr(realtime, "reset"):
        realtime.reset()
    elif not np.allclose(realtime(sample), model.predict(sample[None])[0], rtol=0, atol=1e-6):
        raise RuntimeError(f"{key}: the real-time export disagrees with predict")
    return {"label": method.label, "fit_s": fit_seconds,
            "realtime_us": latency_us(realtime, sample, config.number, config.repeat),
            "predict_us": latency_us(lambda x: model.predict(x[None]), sample, max(config.number // 10, 100),
                                     config.repeat),
            "n_features": samples.X.shape[1], "n_train": len(samples)}


def run(config: SpeedConfig, *, progress: bool = True) -> dict:
    samples = training_samples(config)
    timings = {}
    for key in tqdm(config.methods, desc="timing", disable=not progress, file=sys.stderr):
        timings[key] = time_method(key, samples, config)
    return {"n_train": len(samples), "n_features": samples.X.shape[1], "timings": timings}


def speedup(results: dict, kind: str = "realtime_us") -> float | None:
    """How many times faster linear regression infers than the DNN."""
    t = results["timings"]
    if "linear" not in t or "dnn" not in t:
        return None
    return t["dnn"][kind] / t["linear"][kind]


def finding(results: dict) -> str:
    t = results["timings"]
    ratio = speedup(results)
    if ratio is None:
        return reporting.agreement_line(False, "linear regression and the DNN were not both timed.",
                                        paper.FINDINGS["speed"], paper.FINDING_KIND["speed"])
    claims = [ratio >= paper.TABLE_V["inference_speedup_linear_over_dnn"],
              t["linear"]["fit_s"] < paper.TABLE_V["training_time_s"]["linear"][1],
              t["dnn"]["fit_s"] < paper.TABLE_V["training_time_s"]["dnn"][1],
              t["linear"]["realtime_us"] < SERVO_PERIOD_US]
    simulated = (f"real-time call linear {t['linear']['realtime_us']:.1f} us vs DNN {t['dnn']['realtime_us']:.1f} us "
                 f"({ratio:.2g}x; both {'within' if t['dnn']['realtime_us'] < SERVO_PERIOD_US else 'not both within'} "
                 f"the 1 ms servo period); predict() {speedup(results, 'predict_us'):.2g}x; training linear "
                 f"{t['linear']['fit_s']:.2f} s, DNN {t['dnn']['fit_s']:.1f} s on {results['n_train']} x "
                 f"{results['n_features']}.")
    return reporting.agreement_line(all(claims), simulated, paper.FINDINGS["speed"],
                                    paper.FINDING_KIND["speed"])


def tables(results: dict) -> list[str]:
    rows = []
    for key, t in results["timings"].items():
        rows.append([t["label"], "measured here", f"{t['fit_s']:.2f}", f"{t['realtime_us'] / 1e3:.4f}",
                     f"{t['predict_us'] / 1e3:.3f}", f"{SERVO_PERIOD_US / t['realtime_us']:.0f}"])
    for key, label in (("linear", "Linear regression"), ("dnn", "DNN")):
        bound, seconds = paper.TABLE_V["training_time_s"][key]
        ms = paper.TABLE_V["inference_time_ms"][key]
        rows.append([label, f"published ({paper.TABLE_V['cpu']})", f"{bound} {seconds:g}", f"{ms:g}", "-",
                     f"{1.0 / ms:.2f}"])
    headers = ["Model", "Data", "Training (s)", "Real-time call (ms)", "predict() one sample (ms)",
               "Calls per servo period (1 ms)"]
    return ["## Training and single-sample inference time (Table V)", "", reporting.markdown_table(headers, rows), "",
            f"Training on {results['n_train']} samples x {results['n_features']} features, one thread. "
            "'Real-time call' is the numpy export of `to_realtime()` on one sample; `predict()` includes "
            "scikit-learn's input validation. The paper timed one Keras call per sample on a Xeon 2.2 GHz."]


def figures(results: dict, out: Path) -> list[Path]:
    values = {t["label"]: [t["fit_s"], t["realtime_us"], t["predict_us"]] for t in results["timings"].values()}
    return [plots.method_bars(values, ["training (s)", "real-time call (us)", "predict() call (us)"],
                            out / "speed.png", "Training and inference time", quantity="time")]


def configure(args) -> SpeedConfig:
    config = (SpeedConfig.quick if args.quick else SpeedConfig)(seed=args.seed)
    if args.methods:
        config = replace(config, methods=args.methods)
    return config


def main(argv: list[str] | None = None) -> dict:
    parser = study_parser(STUDY, __doc__)
    parser.add_argument("--methods", type=names(TIMED_METHODS, "method"), default=None,
                        help=f"comma-separated, among {', '.join(TIMED_METHODS)}")
    with StudyRun(parser, argv, configure) as study:
        config = study.config
        say(f"timing {', '.join(config.methods)} on {config.n_train} samples (one process, one thread)")
        results = run(config, progress=study.parallel["progress"])
        return study.conclude(results, title="Inference and training speed (Table V)", finding=finding,
                              tables=tables, figures=figures, extra={"published": {"table_v": paper.TABLE_V}})


if __name__ == "__main__":
    main()
