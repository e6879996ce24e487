"""Speed of the casadi identification, compiled against casadi's virtual machine.

Run:  python benchmarks/bench_identification.py [--seconds 120] [--repeats 3] [--seed 0]

Records ``--seconds`` of random motion on the virtual RAVEN-II (every effect on), identifies the
cable model of the nominal structure on it ``--repeats`` times with the per-sample functions
compiled by the system C compiler and as many times in casadi's virtual machine
(``RAVEN_CALIBRATION_COMPILE=0``), and prints the median seconds of each, the speed-up
(``speedup <ratio>``) and the largest difference between the two fits' estimates, in standard
errors. The first compiled fit includes the compilation; later fits of the same structure reuse it.
It then times the compiled fits again, alternating between maps over the samples run by the virtual
machine (calling the compiled per-sample code) and maps compiled whole (what a structure refitted
to one record gets from its ``COMPILE_MAPS_AT``-th identification on), and prints both medians,
their ratio (``maps speedup <ratio>``) and whether the estimates are equal to the last digit.
It also times the Newey-West score covariance of the fit's Jacobian (one second of lags) as the
identification computes it, from window sums, against the lag-by-lag sum it replaces, and prints
their largest relative difference.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings

import numpy as np

from simulation.engine.scenarios import powered_on, record_random_test
from simulation.identification import FITTABLE_EFFECTS, PoorlyIdentifiedWarning, identify
from simulation.identification import compiled
from simulation.model.parameters import RavenParameters
from studies.common.runner import non_negative_int, positive_float, positive_int


def lag_by_lag_scores(jac: np.ndarray, residuals: np.ndarray, lags: int) -> np.ndarray:
    """The Bartlett-weighted score covariance as one product per lag (the reference)."""
    scores = np.einsum("nrp,nr->np", jac, residuals)
    omega = scores.T @ scores
    for lag in range(1, min(lags, scores.shape[0] - 1) + 1):
        cross = scores[lag:].T @ scores[:-lag]
        omega += (1.0 - lag / (lags + 1.0)) * (cross + cross.T)
    return omega


def hac_timing(recording) -> None:
    """Time the score covariance both ways on the Jacobian and residuals of one fit."""
    from simulation.identification import fit

    captured = {}
    covariance = fit._covariance

    def keep(jac, residuals, used, method, lags):
        captured.update(jac=jac, residuals=residuals, lags=lags)
        return covariance(jac, residuals, used, method, lags)

    fit._covariance = keep
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
            identify(recording, effects=FITTABLE_EFFECTS)
    finally:
        fit._covariance = covariance
    jac, residuals, lags = captured["jac"], captured["residuals"], captured["lags"]
    timings = {}
    for name, function in (("window sums", fit._hac_scores), ("lag by lag", lag_by_lag_scores)):
        started = time.process_time()
        timings[name] = (function(jac, residuals, lags), time.process_time() - started)
    (fast, t_fast), (slow, t_slow) = timings["window sums"], timings["lag by lag"]
    print(f"Newey-West score covariance ({jac.shape[0]} samples, {jac.shape[2]} unknowns, {lags} lags): window sums "
          f"{1e3 * t_fast:.1f} ms, lag by lag {1e3 * t_slow:.1f} ms (ratio {t_slow / max(t_fast, 1e-9):.0f}); "
          f"largest relative difference {np.max(np.abs(fast - slow)) / np.max(np.abs(slow)):.1e}")


def timed_fits(recording, repeats: int) -> tuple[list[float], object]:
    seconds, result = [], None
    for _ in range(repeats):
        started = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
            result = identify(recording, effects=FITTABLE_EFFECTS)
        seconds.append(time.perf_counter() - started)
    return seconds, result


def map_timing(recording, repeats: int) -> None:
    """Compiled fits alternating between the virtual machine's maps and maps compiled whole."""
    from simulation.identification import fit

    at = fit.COMPILE_MAPS_AT
    seconds, results = {False: [], True: []}, {}
    try:
        for whole in (False, True) * (repeats + 1):
            fit.COMPILE_MAPS_AT = 1 if whole else 2 ** 62
            timing, results[whole] = timed_fits(recording, 1)
            seconds[whole] += timing
    finally:
        fit.COMPILE_MAPS_AT = at
    # the first of each includes building (and for whole maps compiling) them
    machine, whole = (np.median(seconds[k][1:]) for k in (False, True))
    same = all(a.value == b.value and a.standard_error == b.standard_error
               for a, b in zip(results[False].estimates, results[True].estimates))
    print(f"maps over the samples: virtual machine median {machine:.3f} s, compiled whole median {whole:.3f} s "
          f"(first {seconds[True][0]:.2f} s, with the compilation)")
    print(f"maps speedup {machine / whole:.2f}; estimates equal to the last digit: {same}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=positive_float, default=120.0, help="length of the random-motion record (s)")
    parser.add_argument("--repeats", type=positive_int, default=3, help="identifications per variant")
    parser.add_argument("--seed", type=non_negative_int, default=0)
    args = parser.parse_args()

    robot = powered_on(RavenParameters(), seed=args.seed)
    recording = record_random_test(robot, args.seconds, seed=args.seed)
    fast, fast_result = timed_fits(recording, args.repeats)
    hac_timing(recording)
    map_timing(recording, args.repeats)
    os.environ[compiled.COMPILE_ENV] = "0"
    compiled._CACHE.clear()
    slow, slow_result = timed_fits(recording, args.repeats)
    deviation = max(abs(a.value - b.value) / b.standard_error
                    for a, b in zip(fast_result.estimates, slow_result.estimates) if b.standard_error > 0)
    print(f"samples {fast_result.report.n_samples}, unknowns {len(fast_result.estimates)}, "
          f"IPOPT iterations (last pass) {fast_result.report.iterations} / {slow_result.report.iterations}")
    print(f"compiled: first {fast[0]:.2f} s (with the compilation), median {np.median(fast):.2f} s")
    print(f"virtual machine: median {np.median(slow):.2f} s")
    print(f"speedup {np.median(slow) / np.median(fast):.2f}")
    print(f"largest difference of the estimates: {deviation:.2e} standard errors")


if __name__ == "__main__":
    main()
