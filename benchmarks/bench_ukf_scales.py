"""CPU time of the UKF's held-out choices of its friction smoothing scale and coasting noise.

Run:  python benchmarks/bench_ukf_scales.py [--repeats 2]

Runs the reduced comparison of ``tests/test_compare_sota.py`` (the paper's protocol, seed 4, one
sparsity, 60 s tests; the base methods and the window linear model on short budgets) with
``MethodSettings(ukf_scales="chosen")``, the default, and with ``"nominal"``, the setting of those
tests, and prints the median CPU seconds of each over ``--repeats`` runs in this process, after one
warm-up run (imports and compiles), and their ratio.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np

from studies import compare_sota
from studies.common.data_sources import simulated_comparison
from studies.common.methods import BASE_METHODS, MethodSettings
from studies.common.runner import positive_int

REDUCED = MethodSettings(dnn_seeds=1, dnn_epochs=60, lstm_epochs=2, forest_trees=5, two_phase_max_samples=800,
                         gpr_subset=300, gpr_hyper_subset=100, lstm_max_samples=800, ukf_tuning="none")


def cpu_seconds(data, scales: str) -> float:
    config = compare_sota.CompareConfig(seed=4, sparsities=(1 / 3,), test_duration=60.0,
                                        methods=(*BASE_METHODS, "window_linear"),
                                        settings=replace(REDUCED, ukf_scales=scales))
    started = time.process_time()
    compare_sota.compare(data, config, n_jobs=1, backend="sequential", progress=False)
    return time.process_time() - started


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=positive_int, default=2, help="timed runs per setting")
    args = parser.parse_args()
    data = simulated_comparison(seed=4, sparsities=(1 / 3,), test_duration=60.0)
    cpu_seconds(data, "nominal")
    medians = {}
    for scales in ("chosen", "nominal"):
        runs = [cpu_seconds(data, scales) for _ in range(args.repeats)]
        medians[scales] = float(np.median(runs))
        print(f"ukf_scales={scales}: {medians[scales]:.1f} s CPU (runs: {', '.join(f'{r:.1f}' for r in runs)})")
    print(f"ratio chosen/nominal {medians['chosen'] / medians['nominal']:.1f}")


if __name__ == "__main__":
    main()
