"""Command-line options every study shares, and the common end of a study run."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from studies.common.sweeps import BACKENDS

DEFAULT_RESULTS = Path("results")


def study_parser(name: str, description: str) -> argparse.ArgumentParser:
    """A parser with ``--out``, ``--quick``, ``--seed``, ``--jobs``, ``--backend``, ``--scheduler``,
    ``--no-progress``; the study adds its own options."""
    parser = argparse.ArgumentParser(prog=f"python studies/{name}.py", description=description,
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--out", type=Path, default=DEFAULT_RESULTS / name,
                        help="output folder (results.json, report.md, figures)")
    parser.add_argument("--quick", action="store_true",
                        help="same physics, shorter runs, fewer seeds and epochs (a first look)")
    parser.add_argument("--seed", type=int, default=0, help="seed of every random draw of the study")
    parser.add_argument("--jobs", type=int, default=-1, help="parallel workers (-1: all cores)")
    parser.add_argument("--backend", choices=BACKENDS, default="loky",
                        help="joblib backend: loky (this machine), ray or dask (a cluster)")
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address, e.g. tcp://host:8786")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    return parser


def say(message: str) -> None:
    """A progress line on stderr (stdout carries the tables)."""
    print(message, file=sys.stderr, flush=True)
