"""Speed of the plant replay against the discrepancy workflow's quasi-static replay.

Run:  python benchmarks/bench_plant_replay.py [--seconds 1200] [--repeats 3] [--seed 30]

Generates the record of ``python studies/discrepancy.py --hidden-effect none --seed S`` of
``--seconds`` (the floor study's records are twenty minutes), identifies the starting structure on
its first half as the blind analysis does, and replays that model along the whole record
``--repeats`` times each way: quasi-statically (:meth:`RavenModel.replay`, each time with its
registration offsets moved by a nanoradian so that the series memo, which serves a candidate fit's
repeated inputs, cannot answer it) and with the plant
(:func:`studies.common.plant_scoring.plant_joints`, the links' swing followed). Prints the least
CPU seconds of each, their ratio (``ratio <plant / quasi-static>``) and the sub-steps per second
of the plant. The first call of each is left out (numba loads or compiles the kernels then).
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from studies.common.runner import non_negative_int, positive_int


def least_cpu(call, repeats: int) -> float:
    """The least CPU time (s) of ``repeats`` calls of ``call``."""
    times = []
    for _ in range(repeats):
        started = time.process_time()
        call()
        times.append(time.process_time() - started)
    return min(times)


def main(argv=None) -> int:
    from studies.common.discrepancy_runs import (
        generate_measured, read_measured, record_length, starting_model_on, write_measured)
    from studies.common.plant_scoring import plant_joints

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seconds", type=record_length, default=1200.0, help="record length (s)")
    parser.add_argument("--repeats", type=positive_int, default=3, help="timed replays of each kind")
    parser.add_argument("--seed", type=non_negative_int, default=30, help="seed of the generated record")
    args = parser.parse_args(argv)

    generated, _ = generate_measured((), args.seed, args.seconds)
    with tempfile.TemporaryDirectory() as folder:
        dataset = read_measured(write_measured(generated, folder))
    signals, _, robot, model = starting_model_on(dataset)
    shift = [0]

    def quasi_static():
        shift[0] += 1
        model.with_offsets(model.offsets + 1e-9 * shift[0]).replay(signals, robot)

    def plant():
        plant_joints(model, signals, robot)

    quasi_static()
    plant()
    quasi = least_cpu(quasi_static, args.repeats)
    dynamic = least_cpu(plant, args.repeats)
    substeps = 2 * float(np.ptp(signals.time)) / 1e-3
    print(f"{len(signals)} samples, {np.ptp(signals.time):.0f} s: quasi-static replay {quasi * 1e3:.1f} ms, "
          f"plant replay {dynamic:.3f} s ({substeps / dynamic / 1e6:.2f} million sub-steps per second)")
    print(f"ratio {dynamic / quasi:.0f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
