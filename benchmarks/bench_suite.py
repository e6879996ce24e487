"""The test suite's time on a fresh clone, as CI meets it, and where it goes.

Run:  python benchmarks/bench_suite.py [--ref HEAD] [--against REF] [--rounds 1] [--top 15] [--keep]

Each run clones this repository at a commit into a new temporary folder and runs the README's test
command there (``python -m pytest -n auto``) with this interpreter's installed environment, an empty
numba cache (``NUMBA_CACHE_DIR`` set to a new folder, as on a fresh clone), no pytest cache and
``--durations=0``. The clone's own packages are the ones imported (it is the working directory of
the run; the script checks it before running). It prints, per run:

- pytest's test time, against the README's budget of three minutes on 2 cores (180 s);
- the wall time and the CPU seconds (user and system) of the run and every process it waited for
  (workers, the kernels compiled ahead, the processes tests start), and how busy the cores were:
  CPU / (wall x cores). Near 100 %, only less CPU makes the run shorter;
- the test durations (setup, call and teardown) summed by module, the slowest calls, and the
  workers' time outside them (start, collection, waiting for the kernels compiled ahead).

``--against REF`` runs that commit too, in turn with ``--ref`` (``REF`` first), ``--rounds`` times,
and prints the ratio of the mean test times: this host's speed moves by up to a third within a day
(``benchmarks/SUITE_TIME.md``), so only runs made in turn compare. One run takes about four minutes
on 2 cores.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

from studies.common.runner import StudyParser, positive_int

ROOT = Path(__file__).resolve().parents[1]
BUDGET_S = 180.0
"""The README's budget for its test command on 2 cores (s)."""
PACKAGES = ("kinematics", "simulation", "estimators", "studies")
"""The project's packages, which a run must import from its clone."""

DURATION = re.compile(r"^\s*(?P<seconds>\d+(?:\.\d+)?)s (?P<phase>setup|call|teardown)\s+(?P<node>\S.*?)\s*$")
SUMMARY = re.compile(r"^=*\s*(?P<counts>(?:\d+ \w+(?:, )?)+) in (?P<seconds>\d+(?:\.\d+)?)s\b")
COUNT = re.compile(r"(\d+) (\w+)")


@dataclass(frozen=True)
class Duration:
    """One line of ``--durations=0``: seconds of a test's setup, call or teardown."""

    seconds: float
    phase: str
    node: str

    @property
    def module(self) -> str:
        """The test file of the node id (``tests/test_x.py``)."""
        return self.node.split("::", 1)[0]


@dataclass(frozen=True)
class SuiteRun:
    """What one run of the suite measured."""

    ref: str
    commit: str
    test_s: float
    wall_s: float
    cpu_s: float
    workers: int
    counts: dict = field(default_factory=dict)
    durations: tuple = ()
    returncode: int = 0

    @property
    def busy(self) -> float:
        """CPU over the cores' time (wall x workers)."""
        return self.cpu_s / (self.wall_s * self.workers)

    def by_module(self) -> list[tuple[str, float]]:
        """Summed durations per test file, the largest first."""
        sums: dict[str, float] = defaultdict(float)
        for row in self.durations:
            sums[row.module] += row.seconds
        return sorted(sums.items(), key=lambda item: -item[1])


def parse_durations(text: str) -> list[Duration]:
    """Every ``--durations`` line of a pytest output, in order."""
    rows = []
    for line in text.splitlines():
        match = DURATION.match(line)
        if match:
            rows.append(Duration(float(match["seconds"]), match["phase"], match["node"]))
    return rows


def parse_summary(text: str) -> tuple[dict[str, int], float]:
    """The outcome counts (``{"passed": 1879, ...}``) and the test time (s) of pytest's last summary
    line; raises ValueError when the output has none (pytest did not finish)."""
    for line in reversed(text.splitlines()):
        match = SUMMARY.match(line.strip())
        if match:
            counts = {word: int(number) for number, word in COUNT.findall(match["counts"])}
            return counts, float(match["seconds"])
    raise ValueError("the pytest output has no summary line (the run did not finish)")


def resolve(ref: str) -> str:
    """The full commit id of ``ref`` in this repository; ValueError naming it when there is none."""
    done = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet", f"{ref}^{{commit}}"],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise ValueError(f"{ref!r} is not a commit of {ROOT}")
    return done.stdout.strip()


def clone(commit: str, folder: Path) -> Path:
    """A checkout of ``commit`` in ``folder / "repo"``."""
    target = folder / "repo"
    subprocess.run(["git", "clone", "-q", "--no-checkout", str(ROOT), str(target)], check=True)
    subprocess.run(["git", "-C", str(target), "checkout", "-q", commit], check=True)
    return target


def check_imports(repo: Path) -> None:
    """Raise if a run in ``repo`` would import the project's packages from anywhere else."""
    probe = "import importlib, sys\n" + "".join(
        f"print(importlib.import_module({name!r}).__file__)\n" for name in PACKAGES)
    done = subprocess.run([sys.executable, "-c", probe], cwd=repo, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise RuntimeError(f"the clone's packages do not import: {done.stderr.strip().splitlines()[-1]}")
    outside = [path for path in done.stdout.split() if not Path(path).resolve().is_relative_to(repo.resolve())]
    if outside:
        raise RuntimeError(f"a run in the clone would import {outside[0]}, outside it; install the project in "
                           "editable mode or in a virtual environment without it")


def run_suite(ref: str, commit: str, workers: str, keep: bool) -> SuiteRun:
    """Clone ``commit`` (named ``ref``), run the test command there with an empty numba cache, and
    measure it."""
    folder = Path(tempfile.mkdtemp(prefix="raven-suite-"))
    try:
        repo = clone(commit, folder)
        check_imports(repo)
        environment = {**os.environ, "NUMBA_CACHE_DIR": str(folder / "numba-cache")}
        command = [sys.executable, "-m", "pytest", "-n", workers, "-p", "no:cacheprovider", "-q", "--durations=0"]
        print(f"running {ref} ({commit[:7]}) in {repo}: {' '.join(command[1:])}", file=sys.stderr, flush=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        started = time.perf_counter()
        done = subprocess.run(command, cwd=repo, env=environment, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - started
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        try:
            counts, test_s = parse_summary(done.stdout)
        except ValueError:
            print(done.stdout[-3000:] + done.stderr[-3000:], file=sys.stderr)
            raise
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        n_workers = (os.cpu_count() or 1) if workers == "auto" else int(workers)
        return SuiteRun(ref, commit, test_s, wall, cpu, n_workers, counts, tuple(parse_durations(done.stdout)),
                        done.returncode)
    finally:
        if keep:
            print(f"kept {folder}", file=sys.stderr)
        else:
            shutil.rmtree(folder, ignore_errors=True)


def report(run: SuiteRun, top: int) -> str:
    """The figures of one run, as text."""
    counts = ", ".join(f"{number} {word}" for word, number in run.counts.items())
    summed = sum(row.seconds for row in run.durations)
    lines = [
        f"{run.ref} ({run.commit[:7]}): {counts}; exit status {run.returncode}",
        f"  test time {run.test_s:.1f} s, {run.test_s / BUDGET_S:.2f} of the {BUDGET_S:.0f} s budget; "
        f"wall {run.wall_s:.1f} s",
        f"  CPU {run.cpu_s:.1f} s over {run.workers} cores: busy {100 * run.busy:.0f} %",
        f"  durations {summed:.1f} s summed; the workers' time outside them "
        f"{run.workers * run.test_s - summed:.1f} s ({run.workers} x test time - durations)",
        "  by module:"]
    lines += [f"    {seconds:7.1f} s  {module}" for module, seconds in run.by_module()[:top]]
    lines.append("  slowest:")
    for row in sorted(run.durations, key=lambda r: -r.seconds)[:top]:
        lines.append(f"    {row.seconds:7.2f} s  {row.phase:8s} {row.node}")
    return "\n".join(lines)


def parse_args(argv=None) -> argparse.Namespace:
    def workers(text: str) -> str:
        if text == "auto" or (text.isdigit() and int(text) > 0):
            return text
        raise argparse.ArgumentTypeError(f"workers must be 'auto' or a positive number, got {text!r}")

    parser = StudyParser(prog="python benchmarks/bench_suite.py", description=__doc__.splitlines()[0])
    parser.add_argument("--ref", default="HEAD", help="commit to run (default HEAD)")
    parser.add_argument("--against", default=None, metavar="REF", help="another commit, run in turn with --ref")
    parser.add_argument("--rounds", type=positive_int, default=1, help="runs of each commit (default 1)")
    parser.add_argument("--workers", type=workers, default="auto", help="pytest -n (default auto)")
    parser.add_argument("--top", type=positive_int, default=15, help="modules and calls listed (default 15)")
    parser.add_argument("--keep", action="store_true", help="keep each clone and its numba cache")
    args = parser.parse_args(argv)
    args.commits = {}
    for name in ("against", "ref"):
        value = getattr(args, name)
        if value is not None:
            try:
                args.commits[value] = resolve(value)
            except ValueError as error:
                parser.error(f"--{name}: {error}")
    if args.against is not None and len(set(args.commits.values())) == 1:
        parser.error(f"--against {args.against} is the same commit as --ref {args.ref}; compare two commits")
    return args


def main(argv=None) -> int:
    args = parse_args(argv)
    runs: dict[str, list[SuiteRun]] = {ref: [] for ref in args.commits}
    for _ in range(args.rounds):
        for ref, commit in args.commits.items():
            run = run_suite(ref, commit, args.workers, args.keep)
            runs[ref].append(run)
            print(report(run, args.top), flush=True)
    means = {ref: sum(r.test_s for r in done) / len(done) for ref, done in runs.items()}
    for ref, mean in means.items():
        print(f"mean test time {ref}: {mean:.1f} s over {len(runs[ref])} run(s)")
    if args.against is not None:
        print(f"ratio {args.ref} / {args.against}: {means[args.ref] / means[args.against]:.3f}")
    return 0 if all(r.returncode == 0 for done in runs.values() for r in done) else 1


if __name__ == "__main__":
    raise SystemExit(main())
