"""The numba kernels compiled ahead of the work that calls them.

A process compiles each numba kernel the first time it calls it and caches the machine code on disk
(``cache=True``, in the ``__pycache__`` folders beside the sources) for the processes after it. On a
fresh clone or install, workers started together (the test suite's, a sweep's) would each compile
the same kernels at once, the servo loop alone some 15 s to 30 s of CPU per process. Compiling them
ahead, in processes of their own, lets the workers load them from the cache instead.

Each group compiles by running the code that calls its kernels on a few rows, so the cached
signatures are the ones real work asks for:

- ``servo``: homing the virtual RAVEN-II and two seconds of random motion (the 1 kHz servo loop, the
  sensors, controller, plant and the kinematics they inline);
- ``identification``: the links' gravity and inertial loads of an identification's samples;
- ``replay``: the discrepancy replay's series of a cable model (cable, hysteresis, friction) and of
  backlash;
- ``plant_replay``: the plant driven by logged motor positions (the servo loop's plant functions,
  inlined into a loop of their own).

Run:  python -m simulation.kernels GROUP [GROUP ...] [--done FILE]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def _servo() -> None:
    from simulation.engine.scenarios import powered_on, record_random_test
    from simulation.model.parameters import RavenParameters

    record_random_test(powered_on(RavenParameters(), seed=2), 2.0, seed=3)


def _identification() -> None:
    from simulation.identification.nominal import nominal_parameters
    from simulation.identification.samples import _gravity_and_inertia, arm_model

    q = np.tile([0.5, 1.6, 0.4], (10, 1))
    _gravity_and_inertia(q, np.zeros((10, 3)), arm_model(nominal_parameters("left")).gravity_coefficients(0.0))


def _replay() -> None:
    from simulation.discrepancy.replay import _constant, _ones, _SeriesMemo, play_series

    n = 100
    x = np.linspace(0.0, 1.0, n)
    restart = np.zeros(n, dtype=np.bool_)
    restart[0] = True
    # through the replay's memo, with its read-only friction bounds and lag fractions: numba compiles
    # a kernel once per layout and writability of its arrays; the second call compares what it remembers
    memo = _SeriesMemo()
    for _ in range(2):
        memo.series(x, x, _constant(n, 0.1), np.ones(n), 40.0, 0.5, 1.0, 0.7, 0.3, x, restart, 0.01, _ones((n,)),
                    False, 0.0)
    play_series(x, 0.01, restart)


def _plant_replay() -> None:
    from kinematics import RavenII
    from simulation.engine.plant_replay import replay_links
    from simulation.identification.nominal import nominal_parameters

    pose = np.tile([0.5, 1.6, 0.4], (10, 1))
    replay_links(nominal_parameters("left"), RavenII("left", check_limits=False), np.arange(10) * 1e-3, pose, pose)


GROUPS = {"servo": _servo, "identification": _identification, "replay": _replay,
          "plant_replay": _plant_replay}
"""Kernel groups by name, each the code that compiles it."""


def compile_groups(names) -> None:
    """Compile the kernel groups ``names`` (keys of :data:`GROUPS`) in this process."""
    unknown = [name for name in names if name not in GROUPS]
    if unknown:
        raise ValueError(f"unknown kernel groups {unknown}; choose from {', '.join(GROUPS)}")
    for name in names:
        GROUPS[name]()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m simulation.kernels",
                                     description="Compile numba kernel groups into the on-disk cache.")
    parser.add_argument("groups", nargs="+", choices=sorted(GROUPS), metavar="GROUP",
                        help=f"kernel groups to compile: {', '.join(GROUPS)}")
    parser.add_argument("--done", type=Path, default=None,
                        help="file written when the groups are compiled or the compile has failed, so that "
                             "processes waiting for the cache know when to go on")
    args = parser.parse_args(argv)
    try:
        compile_groups(args.groups)
    finally:
        if args.done is not None:
            args.done.write_text("done\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
