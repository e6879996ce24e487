"""Time per sample of calibrators exported to C (`estimators.export_c`), per compiler flag set.

RAVEN-II's controller runs at 1 kHz in C++. Goal: the paper's 16-100-100-3 sigmoid DNN in under
1 us per sample (the numpy real-time predictor takes about 5.7 us on the reference machine).

Run:  python benchmarks/bench_export_c.py [--calls N] [--repeat K] [--cc COMPILER]

For each calibrator (linear, polynomial of degree 2, the paper's DNN, all in error mode on 16
synthetic robot-state features, see bench_training.py) and each flag set, the exported C is
compiled twice: as a shared library, called through ctypes on 2000 held-out rows and compared
with `predict` (the flag set is recommended only if every output agrees within 1e-6 relative),
and into a small timing program that calls the function N times over 1000 rows from C, so the
time is the function's own, without Python's call overhead (median and best of K runs). Times
are CPU time of the calling thread, so other work on a shared machine does not inflate them;
the numpy real-time predictor's CPU time is shown beside them to compare machines. The
weights come from a short fit: time does not depend on how long the model was trained.
"""

from __future__ import annotations

import argparse
import ctypes
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
import timeit
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import estimators as E  # noqa: E402
from bench_training import RAW_COLUMNS, synthetic_calibration_data  # noqa: E402
from estimators.export_c import export_c  # noqa: E402
from studies.common.runner import positive_int  # noqa: E402

GOAL_US = {"DNN 16-100-100-3 (sigmoid)": 1.0}
FLAG_SETS = {
    "-O2": ["-O2"],
    "-O2 -march=x86-64-v3": ["-O2", "-march=x86-64-v3"],  # AVX2 + FMA, any x86-64 since 2015
    "-O3 -march=x86-64-v3": ["-O3", "-march=x86-64-v3"],
    "-O3 -march=native": ["-O3", "-march=native"],
    "-O3 -march=native -ffast-math": ["-O3", "-march=native", "-ffast-math"],
}
AGREEMENT = 1e-6

TIMER = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "{name}.h"

static double seconds(void)
{{
    struct timespec t;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}}

int main(int argc, char **argv)
{{
    const int rows = atoi(argv[2]);
    const long calls = atol(argv[3]);
    const int repeat = atoi(argv[4]);
    double *X = malloc(sizeof(double) * (size_t)rows * {NAME}_N_FEATURES);
    double y[{NAME}_N_TARGETS];
    double sink = 0.0;
    FILE *file = fopen(argv[1], "rb");
    if (argc < 5 || X == NULL || file == NULL
            || fread(X, sizeof(double), (size_t)rows * {NAME}_N_FEATURES, file)
               != (size_t)rows * {NAME}_N_FEATURES)
        return 1;
    fclose(file);
    for (int r = 0; r < repeat; ++r) {{
        const double start = seconds();
        for (long k = 0; k < calls; ++k) {{
            {name}(X + (k % rows) * {NAME}_N_FEATURES, y);
            sink += y[0];
        }}
        printf("%.6f\n", (seconds() - start) / (double)calls * 1e6);
    }}
    fprintf(stderr, "%g\n", sink);
    free(X);
    return 0;
}}
"""


def build(compiler, flags, sources, output, shared):
    command = [compiler, *flags, *(["-shared", "-fPIC"] if shared else []),
               *map(str, sources), "-lm", "-o", str(output)]
    subprocess.run(command, check=True, capture_output=True, text=True)


def max_relative_deviation(compiler, flags, calibrator, c_path, folder, X):
    library = folder / f"lib{c_path.stem}{abs(hash(tuple(flags)))}.so"
    build(compiler, flags, [c_path], library, shared=True)
    function = getattr(ctypes.CDLL(str(library)), c_path.stem)
    function.argtypes = [ctypes.POINTER(ctypes.c_double)] * 2
    function.restype = None
    output = np.empty((X.shape[0], calibrator.n_outputs_))
    for row, out in zip(X, output):
        function(row.ctypes.data_as(ctypes.POINTER(ctypes.c_double)),
                 out.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
    expected = calibrator.predict(X).reshape(output.shape)
    return float(np.max(np.abs(output - expected) / np.maximum(np.abs(expected), 1e-300)))


def time_per_call_us(compiler, flags, c_path, folder, inputs_file, rows, calls, repeat):
    timer = folder / f"timer_{c_path.stem}.c"
    timer.write_text(TIMER.format(name=c_path.stem, NAME=c_path.stem.upper()))
    program = folder / f"timer_{c_path.stem}"
    build(compiler, flags, [timer, c_path], program, shared=False)
    result = subprocess.run([str(program), str(inputs_file), str(rows), str(calls), str(repeat)],
                            check=True, capture_output=True, text=True)
    per_call = [float(v) for v in result.stdout.split()]
    return statistics.median(per_call), min(per_call)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=positive_int, default=200_000, help="calls per timing run")
    parser.add_argument("--repeat", type=positive_int, default=7, help="timing runs")
    parser.add_argument("--cc", default=os.environ.get("CC") or shutil.which("cc"),
                        help="C compiler (default: $CC or cc)")
    args = parser.parse_args()
    if not args.cc:
        parser.error("no C compiler found: install one (cc) or pass --cc")

    X, y = synthetic_calibration_data(n_samples=5000)
    X_check, _ = synthetic_calibration_data(n_samples=2000, seed=1)
    raw = list(RAW_COLUMNS)
    calibrators = {
        "linear": E.LinearCalibrator(raw_columns=raw),
        "polynomial (degree 2)": E.PolynomialCalibrator(raw_columns=raw),
        "DNN 16-100-100-3 (sigmoid)": E.DNNCalibrator(raw_columns=raw, max_epochs=20,
                                                      random_state=0, n_threads=1),
    }
    version = subprocess.run([args.cc, "--version"], capture_output=True, text=True)
    print(f"compiler: {version.stdout.splitlines()[0] if version.stdout else args.cc}")
    print(f"time per sample of the exported C function, {X.shape[1]} features -> {y.shape[1]} "
          f"targets; {args.repeat} runs x {args.calls} calls from C")
    print(f"{'calibrator':28s} {'flags':30s} {'C us':>7s} {'best':>7s} {'numpy us':>9s} "
          f"{'max rel dev':>12s} {'agrees':>7s} {'goal us':>8s} {'met':>4s}")
    with tempfile.TemporaryDirectory() as directory:
        folder = Path(directory)
        inputs_file = folder / "inputs.bin"
        rows = 1000
        np.ascontiguousarray(X_check[:rows]).tofile(inputs_file)
        for index, (label, calibrator) in enumerate(calibrators.items()):
            calibrator.fit(X, y)
            c_path, _ = export_c(calibrator, folder, name=f"calibrator{index}")
            realtime, sample = calibrator.to_realtime(), np.ascontiguousarray(X_check[0])
            numpy_us = min(timeit.repeat(lambda: realtime(sample), number=20_000, repeat=5,
                                         timer=time.thread_time)) / 20_000 * 1e6
            goal = GOAL_US.get(label)
            for flags_label, flags in FLAG_SETS.items():
                deviation = max_relative_deviation(args.cc, flags, calibrator, c_path, folder,
                                                   X_check)
                median, best = time_per_call_us(args.cc, flags, c_path, folder, inputs_file,
                                                rows, args.calls, args.repeat)
                print(f"{label:28s} {flags_label:30s} {median:7.3f} {best:7.3f} "
                      f"{numpy_us:9.2f} {deviation:12.1e} "
                      f"{'yes' if deviation <= AGREEMENT else 'NO':>7s} "
                      f"{'' if goal is None else f'{goal:8g}':>8s} "
                      f"{'' if goal is None else ('yes' if median <= goal else 'NO'):>4s}")


if __name__ == "__main__":
    main()
