"""Single-sample inference latency of the real-time calibrators, beside the paper's figures.

The paper measured 0.38 ms per sample for its linear model and 61 ms for its DNN (CPU, Table V)
and judged the DNN too slow for RAVEN-II's 1 kHz servo loop. Goals here for the exported
real-time predictors (`to_realtime`): linear <= 5 us, DNN <= 50 us per sample.

Run:  python benchmarks/bench_inference.py [--number N] [--repeat K] [--all]

Latency is the time of one call ``f(x)`` on a float64 sample of 16 features, as a servo loop
would make it (median and best of K timing runs of N calls each). The scikit-learn `predict`
on a (1, 16) array is shown for contrast. The weights come from a short fit on synthetic data
(see bench_training.py): latency does not depend on how long the model was trained.
"""

from __future__ import annotations

import argparse
import statistics
import timeit

import numpy as np
from threadpoolctl import threadpool_limits

import estimators as E
from bench_training import RAW_COLUMNS, synthetic_calibration_data
from studies.common.runner import positive_int

SERVO_PERIOD_US = 1000.0  # RAVEN-II servo loop: 1 kHz
PAPER_US = {"linear": 380.0, "DNN 16-100-100-3": 61_000.0}
GOAL_US = {"linear": 5.0, "DNN 16-100-100-3": 50.0}


def latency_us(function, sample: np.ndarray, number: int, repeat: int) -> tuple[float, float]:
    """Median and best time per call of ``function(sample)``, in microseconds."""
    runs = timeit.repeat(lambda: function(sample), number=number, repeat=repeat)
    per_call = [run / number * 1e6 for run in runs]
    return statistics.median(per_call), min(per_call)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--number", type=positive_int, default=20_000, help="calls per timing run")
    parser.add_argument("--repeat", type=positive_int, default=7, help="timing runs")
    parser.add_argument("--all", action="store_true", help="also time the other calibrators")
    args = parser.parse_args()

    X, y = synthetic_calibration_data(n_samples=5000)
    raw = list(RAW_COLUMNS)
    calibrators = {
        "linear": E.LinearCalibrator(raw_columns=raw),
        "DNN 16-100-100-3": E.DNNCalibrator(raw_columns=raw, max_epochs=20, random_state=0,
                                            n_threads=1),
    }
    if args.all:
        calibrators.update({
            "fixed offset": E.FixedOffsetCalibrator(raw_columns=raw),
            "polynomial (degree 2)": E.PolynomialCalibrator(raw_columns=raw),
            "DNN 600-500-400 (large)": E.DNNCalibrator.large(raw_columns=raw, max_epochs=2,
                                                             random_state=0, n_threads=1),
            "GPR (2000 support points)": E.GPRCalibrator(raw_columns=raw, random_state=0,
                                                          n_threads=1),
            "two-phase (DNN + 100 trees)": E.TwoPhaseCalibrator(
                raw_columns=raw, random_state=0,
                dnn=E.DNNCalibrator(max_epochs=20, n_threads=1)),
            "window linear (5 rows)": E.WindowLinearCalibrator(raw_columns=raw),
            "window LSTM (5 rows, 100 units)": E.WindowLSTMCalibrator(
                raw_columns=raw, max_epochs=2, random_state=0, n_threads=1),
        })

    # a servo loop calls the predictor from one thread
    threadpool_limits(limits=1)
    sample = np.ascontiguousarray(X[0])
    print(f"single-sample latency, {X.shape[1]} features -> {y.shape[1]} targets; "
          f"{args.repeat} runs x {args.number} calls")
    print(f"{'calibrator':34s} {'realtime us':>12s} {'best':>7s} {'predict() us':>13s} "
          f"{'paper us':>9s} {'x faster':>9s} {'goal us':>8s} {'met':>4s} {'1 kHz margin':>13s}")
    for name, calibrator in calibrators.items():
        calibrator.fit(X, y)
        realtime = calibrator.to_realtime()
        deviation = np.max(np.abs(realtime(sample) - calibrator.predict(sample[None])[0]))
        if deviation > 1e-6:
            raise RuntimeError(f"{name}: real-time output deviates from predict by {deviation:g}")
        median, best = latency_us(realtime, sample, args.number, args.repeat)
        predict_median, _ = latency_us(lambda x: calibrator.predict(x[None]), sample,
                                       max(args.number // 20, 100), args.repeat)
        paper = PAPER_US.get(name)
        goal = GOAL_US.get(name)
        print(f"{name:34s} {median:12.2f} {best:7.2f} {predict_median:13.1f} "
              f"{'' if paper is None else f'{paper:9.0f}':>9s} "
              f"{'' if paper is None else f'{paper / median:9.0f}':>9s} "
              f"{'' if goal is None else f'{goal:8g}':>8s} "
              f"{'' if goal is None else ('yes' if median <= goal else 'NO'):>4s} "
              f"{SERVO_PERIOD_US / median:12.0f}x")


if __name__ == "__main__":
    main()
