"""Training time of the learned calibrators on 30k samples x 16 features.

The paper trained its DNN in under 50 s and its linear model in under 2 s (CPU, Table V). Goals
here: linear <= 0.1 s, DNN (200 epochs, batch 1024) <= 20 s, Gaussian process <= 60 s.

Run:  python benchmarks/bench_training.py [--all] [--threads N ...] [--repeat K] [--dnn-repeat K]

The last line gives the DNN's training time on one thread and its ratio to the 20 s goal, both
as wall-clock and as CPU time: on a CPU shared with other busy processes the wall-clock time
includes waiting for the core, so compare CPU times (and runs of the same session) there.

The data are synthetic but shaped like the paper's "selected features" of one RAVEN-II arm:
8 joint positions (slot 3 unused, always 0) and 8 motor torques; targets are the true positions
of the 3 positioning joints (rad, rad, m). Only their shape matters for the timing.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from threadpoolctl import threadpool_limits

import estimators as E
from studies.common.runner import positive_int

N_SAMPLES = 30_000
RAW_COLUMNS = (0, 1, 2)
DNN_NAME = "DNN 16-100-100-3, 200 epochs"
DNN_GOAL_S = 20.0


def synthetic_calibration_data(n_samples: int = N_SAMPLES, seed: int = 0):
    """Robot-state-like inputs X (n, 16) and true positions y (n, 3), SI units.

    Columns 0-7: encoder joint positions (J0, J1 rad, J2 m, unused slot 0, tool joints rad);
    columns 8-15: motor torques (N m). The true positions differ from the encoder ones by a
    torque-dependent stretch, a coupling and a small hysteresis-like term.
    """
    rng = np.random.default_rng(seed)
    positions = np.column_stack([
        rng.uniform(np.radians(20), np.radians(60), n_samples),
        rng.uniform(np.radians(55), np.radians(110), n_samples),
        rng.uniform(0.33, 0.42, n_samples),
        np.zeros(n_samples),
        rng.uniform(-1.0, 1.0, (n_samples, 4)),
    ])
    torques = (0.3 * np.sin(positions[:, [0, 1, 2, 3, 4, 5, 6, 7]] + 0.5)
               + 0.02 * rng.standard_normal((n_samples, 8)))
    stretch = np.column_stack([
        0.01 * torques[:, 0] + 0.002 * np.sin(3 * positions[:, 1]),
        0.012 * torques[:, 1] - 0.003 * torques[:, 0] * torques[:, 1],
        0.002 * torques[:, 2] + 0.0005 * np.cos(2 * positions[:, 0]),
    ])
    X = np.column_stack([positions, torques])
    y = positions[:, :3] + stretch + 1e-4 * rng.standard_normal((n_samples, 3))
    return X, y


def time_fit(make, X, y, repeat: int) -> tuple[float, float, float]:
    """Median and best wall-clock time of ``make().fit(X, y)`` over `repeat` runs, and the
    process CPU time (all threads) of the median run, in seconds.

    On a CPU shared with other busy processes the wall-clock time includes waiting for a core;
    the CPU time does not.
    """
    runs = []
    for _ in range(repeat):
        estimator = make()
        wall, cpu = time.perf_counter(), time.process_time()
        estimator.fit(X, y)
        runs.append((time.perf_counter() - wall, time.process_time() - cpu))
    runs.sort()
    return runs[len(runs) // 2][0], runs[0][0], runs[len(runs) // 2][1]


def cases(include_all: bool, threads: int, repeat: int, dnn_repeat: int = 1):
    """(name, paper figure, factory, runs, goal in s) of the calibrators to time."""
    raw = list(RAW_COLUMNS)
    timed = [
        ("fixed offset", None, lambda: E.FixedOffsetCalibrator(raw_columns=raw), repeat, None),
        ("linear", "< 2 s", lambda: E.LinearCalibrator(raw_columns=raw), repeat, 0.1),
        (DNN_NAME, "< 50 s",
         lambda: E.DNNCalibrator(raw_columns=raw, random_state=0, n_threads=threads),
         dnn_repeat, DNN_GOAL_S),
        ("GPR (2000-point subset)", None,
         lambda: E.GPRCalibrator(raw_columns=raw, random_state=0, n_threads=threads), 1, 60.0),
    ]
    if include_all:
        timed += [
            ("polynomial (degree 2)", None, lambda: E.PolynomialCalibrator(raw_columns=raw),
             repeat, None),
            ("two-phase (DNN + 100 trees)", None,
             lambda: E.TwoPhaseCalibrator(raw_columns=raw, random_state=0,
                                          dnn=E.DNNCalibrator(n_threads=threads)), 1, None),
            ("window linear (5 rows)", None, lambda: E.WindowLinearCalibrator(raw_columns=raw),
             repeat, None),
            ("window LSTM (5 rows, 100 units, 30 epochs)", None,
             lambda: E.WindowLSTMCalibrator(raw_columns=raw, random_state=0, n_threads=threads),
             1, None),
        ]
    return timed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--all", action="store_true",
                        help="also time the polynomial, two-phase and window calibrators")
    parser.add_argument("--threads", type=positive_int, nargs="*", default=[1, 2],
                        help="thread counts (torch and BLAS) to time with")
    parser.add_argument("--repeat", type=positive_int, default=5, help="runs of the fast calibrators")
    parser.add_argument("--dnn-repeat", type=positive_int, default=1,
                        help="runs of the DNN (the median is reported)")
    args = parser.parse_args()

    X, y = synthetic_calibration_data()
    # Import torch and warm its kernels outside the timed runs.
    E.DNNCalibrator(raw_columns=list(RAW_COLUMNS), max_epochs=1, n_threads=1).fit(X[:2048],
                                                                                  y[:2048])
    print(f"training on {X.shape[0]} samples x {X.shape[1]} features -> {y.shape[1]} targets")
    dnn_one_thread = None
    for threads in args.threads:
        print(f"\n{threads} thread(s) for torch and BLAS")
        print(f"{'calibrator':44s} {'median s':>9s} {'best s':>8s} {'cpu s':>8s} {'goal s':>7s} "
              f"{'met':>4s} {'paper':>7s}")
        with threadpool_limits(limits=threads, user_api="blas"):
            for name, paper, make, repeat, goal in cases(args.all, threads, args.repeat,
                                                         args.dnn_repeat):
                median, best, cpu = time_fit(make, X, y, repeat)
                met = "" if goal is None else ("yes" if median <= goal else "NO")
                goal_text = "" if goal is None else f"{goal:g}"
                print(f"{name:44s} {median:9.3f} {best:8.3f} {cpu:8.3f} {goal_text:>7s} "
                      f"{met:>4s} {paper or '':>7s}", flush=True)
                if name == DNN_NAME and threads == 1:
                    dnn_one_thread = (median, cpu)
    if dnn_one_thread is not None:
        wall, cpu = dnn_one_thread
        print(f"\n{DNN_NAME} on one thread: {wall:.2f} s wall-clock ({wall / DNN_GOAL_S:.2f} of "
              f"the {DNN_GOAL_S:g} s goal), {cpu:.2f} s CPU ({cpu / DNN_GOAL_S:.2f} of the goal)")


if __name__ == "__main__":
    main()
