"""Speed and accuracy of the UKF baseline on the virtual RAVEN-II.

Run:  python benchmarks/bench_ukf.py [--seconds 600] [--seed 0]

Default (speed): identifies the cable model on five minutes of random motion, filters ``--seconds``
of an independent random test logged at 30 Hz, and prints exactly one line starting with
``realtime_factor `` (seconds of robot data per wall second; goal >= 60), then the speed-up of the
batch filter (process model over all sigma points at once) over plain filterpy with a
per-sigma-point ``fx`` on another line.

Other studies (each prints a table):

* ``--protocol``: the paper's protocol (``paper_protocol(seed)``: J2-J3 calibration zig-zags,
  20-minute unloaded and loaded tests); RMSE per joint (deg, deg, mm) of raw, fixed offset, the
  linear calibrator and the UKF (noise tuned by likelihood and by joint error).
* ``--rates 30 100 300 1000``: accuracy and speed of the UKF against the log rate it filters at
  (one identified model, noise tuned per rate on that rate's calibration log).
* ``--hours 6``: a loaded run of that many hours; smallest eigenvalue of the state covariance over
  the run (symmetric positive definite check), repairs, and the RMSE per hour.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

from estimators import FixedOffsetCalibrator, LinearCalibrator, UKFJointEstimator
from estimators.ukf.noise import encoder_noise
from estimators.ukf.process import ProcessModel
from estimators.ukf.run import initial_state
from kinematics import RavenII
from simulation.identification import MotorLog, PoorlyIdentifiedWarning, identify
from simulation.model.constants import REPORT_SCALE
from simulation.recordings.recording import recording_to_dataset
from simulation.engine.scenarios import long_operation, paper_protocol, powered_on, record_calibration, record_random_test
from studies.common.runner import non_negative_int, positive_float, positive_int


def rmse(error: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(np.square(error), axis=0))


def row(label: str, values: np.ndarray) -> str:
    shown = np.asarray(values) * REPORT_SCALE
    return f"  {label:28s} {shown[0]:8.3f} deg {shown[1]:8.3f} deg {shown[2]:8.3f} mm"


def plain_filterpy_step_time(estimator: UKFJointEstimator, log: MotorLog, steps: int) -> float:
    """Seconds per predict + update of filterpy's own UKF with a per-sigma-point ``fx``."""
    model = estimator.model_
    process = ProcessModel(model)
    ukf = UnscentedKalmanFilter(12, 3, 1 / 30, hx=lambda x: x[:3], fx=process.single,
                                points=MerweScaledSigmaPoints(12, 1.0, 2.0, 0.0))
    z = log.motor_positions / model.transmission_ratio
    torque = log.motor_torques * model.torque_scale
    ukf.x, ukf.P = initial_state(model, z[0])
    ukf.R = encoder_noise(model)
    start = time.perf_counter()
    for k in range(1, steps + 1):
        dt = log.time[k] - log.time[k - 1]
        ukf.Q = estimator.process_noise_.covariance(dt)
        ukf.predict(dt=dt, motor_torque=torque[k - 1])
        ukf.update(z[k])
    return (time.perf_counter() - start) / steps


def speed(args) -> None:
    robot = powered_on(seed=args.seed)
    calibration = record_random_test(robot, 300.0, seed=args.seed + 1)
    test = MotorLog.from_recording(record_random_test(robot, args.seconds, seed=args.seed + 2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
        estimator = UKFJointEstimator(tuning="none").fit(calibration)
    estimator.predict(test.between(test.time[0], test.time[0] + 5.0))  # compile and warm up
    start = time.perf_counter()
    estimator.predict(test)
    wall = time.perf_counter() - start
    duration = float(test.time[-1] - test.time[0])
    batch_step = wall / (len(test) - 1)
    plain_step = plain_filterpy_step_time(estimator, test, min(600, len(test) - 1))
    print(f"realtime_factor {duration / wall:.1f}")
    print(f"speedup_over_plain_filterpy {plain_step / batch_step:.2f} "
          f"({plain_step * 1e6:.0f} us vs {batch_step * 1e6:.0f} us per predict+update, 30 Hz log, 1 kHz sub-steps)")


def protocol(args) -> None:
    runs = paper_protocol(seed=args.seed)
    robot = RavenII(arm="left", check_limits=False)
    calibration = recording_to_dataset(runs.calibration, robot)
    x_cal, _ = calibration.features("selected")
    raw_columns = calibration.raw_column_indices("selected")
    fixed = FixedOffsetCalibrator(raw_columns=raw_columns).fit(x_cal, calibration.targets)
    linear = LinearCalibrator(raw_columns=raw_columns).fit(x_cal, calibration.targets)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
        result = identify(calibration)
    print(result.describe())
    filters = {}
    for tuning in ("likelihood", "joint_error"):
        start = time.perf_counter()
        filters[tuning] = UKFJointEstimator(tuning=tuning).fit_identified(result, calibration)
        print(f"noise tuned by {tuning} in {time.perf_counter() - start:.0f} s: {filters[tuning].process_noise_}")
    for name, recording in (("unloaded", runs.test_unloaded), ("loaded 0.5 kg", runs.test_loaded)):
        test = recording_to_dataset(recording, robot)
        x_test, _ = test.features("selected")
        print(f"test {name} ({recording.duration:.0f} s), RMSE per joint:")
        print(row("raw", rmse(test.raw_joints - test.targets)))
        print(row("fixed offset", rmse(fixed.predict(x_test) - test.targets)))
        print(row("linear", rmse(linear.predict(x_test) - test.targets)))
        for tuning, estimator in filters.items():
            start = time.perf_counter()
            estimates = estimator.predict(test)
            wall = time.perf_counter() - start
            print(row(f"UKF ({tuning})", rmse(estimates.joints - test.targets))
                  + f"   realtime factor {recording.duration / wall:.0f}")


def rates(args) -> None:
    shared = dict(seed=args.seed, sparsities=(1 / 3,), test_duration=args.rate_test_seconds)
    reference = paper_protocol(log_rate=30.0, **shared)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
        result = identify(reference.calibration)
    print(f"one identified model (30 Hz calibration); noise tuned by likelihood per rate over "
          f"{args.tuning_steps} log steps; tests of {args.rate_test_seconds:.0f} s")
    print(f"  {'rate':>6s}  {'unloaded RMSE (deg, deg, mm)':34s} {'loaded RMSE (deg, deg, mm)':34s} realtime factor")
    for rate in args.rates:
        runs = reference if rate == 30.0 else paper_protocol(log_rate=rate, **shared)
        estimator = UKFJointEstimator(tuning="likelihood", tuning_seconds=args.tuning_steps / rate,
                                      tuning_evaluations=30).fit_identified(result, runs.calibration)
        cells = []
        walls = 0.0
        duration = 0.0
        for recording in (runs.test_unloaded, runs.test_loaded):
            log = MotorLog.from_recording(recording)
            start = time.perf_counter()
            estimates = estimator.predict(log)
            walls += time.perf_counter() - start
            duration += recording.duration
            cells.append(" ".join(f"{v:8.3f}" for v in rmse(estimates.joints - log.joints) * REPORT_SCALE))
        print(f"  {rate:6.0f}  {cells[0]:34s} {cells[1]:34s} {duration / walls:8.1f}")


def long_run(args) -> None:
    robot = powered_on(seed=args.seed)
    calibration = record_calibration(robot)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PoorlyIdentifiedWarning)
        estimator = UKFJointEstimator(tuning="likelihood").fit(calibration)
    robot.start_operating_clock()
    operation = long_operation(robot, "loaded", hours=args.hours, seed=args.seed + 7)
    log = MotorLog.from_recording(operation)
    start = time.perf_counter()
    estimates = estimator.predict(log, eigenvalues=True)
    wall = time.perf_counter() - start
    symmetric = np.array_equal(estimates.covariance, np.swapaxes(estimates.covariance, 1, 2))
    print(f"{args.hours:.1f} h loaded run, {len(log)} samples filtered in {wall:.0f} s "
          f"(realtime factor {operation.duration / wall:.0f})")
    print(f"  smallest eigenvalue of the state covariance at each step: between {estimates.min_eigenvalue.min():.3e} "
          f"and {estimates.min_eigenvalue.max():.3e}; joint covariance symmetric: {symmetric}; "
          f"square-root repairs: {estimates.n_repairs}; restarts: {estimates.n_restarts}")
    hours = np.floor(operation.labels["operating_hours"]).astype(int)
    raw = operation.channel("jpos")[:, :3] - log.joints
    for hour in np.unique(hours):
        rows = hours == hour
        print(row(f"hour {hour} UKF RMSE", rmse(estimates.joints[rows] - log.joints[rows]))
              + "   raw " + " ".join(f"{v:.3f}" for v in rmse(raw[rows]) * REPORT_SCALE))


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seed", type=non_negative_int, default=0)
    parser.add_argument("--seconds", type=positive_float, default=600.0, help="length of the filtered test log (s)")
    parser.add_argument("--protocol", action="store_true", help="accuracy on the paper's protocol")
    parser.add_argument("--rates", type=positive_float, nargs="*", help="accuracy against the log rate (Hz)")
    parser.add_argument("--rate-test-seconds", type=positive_float, default=300.0)
    parser.add_argument("--tuning-steps", type=positive_int, default=3600, help="log steps the per-rate noise tuning filters")
    parser.add_argument("--hours", type=positive_float, help="length of the loaded robustness run (h)")
    args = parser.parse_args(argv)
    if args.protocol:
        protocol(args)
    elif args.rates:
        rates(args)
    elif args.hours:
        long_run(args)
    else:
        speed(args)


if __name__ == "__main__":
    main()
