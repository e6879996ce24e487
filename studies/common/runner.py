"""What every study script shares: its command line, the checks of it, its output folder, its end.

A study's ``main`` is thin::

    def main(argv=None):
        parser = study_parser(STUDY, __doc__)
        parser.add_argument("--hours", type=positive_float, default=None, help="hours of operation")
        with StudyRun(parser, argv, configure) as run:
            results = run_study(run.config, **run.parallel)
            return run.conclude(results, title="...", finding=finding, tables=tables, figures=figures)

Failing fast and cleanly: every argument is checked when it is parsed (paths exist and are of the
right kind, numbers in range, names known), then the configuration is built, then ``--out`` is
prepared, all before any work. A user's mistake, there or later while reading the input files
(:meth:`StudyRun.reading`), prints one line naming it and exits with status 2 (argparse's
convention), never a traceback. Results are written to a temporary folder beside ``--out`` and
moved into place only when the run has succeeded: a failed run leaves the previous results whole
and nothing partial.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

from studies.common import reporting
from studies.common.sweeps import BACKENDS

DEFAULT_RESULTS = Path("results")
USAGE_STATUS = 2
"""Exit status of a user's mistake (argparse's convention)."""
RESULT_MARKERS = ("results.json", "report.json", "confusion.json")
"""Files that mark a folder as the output of an earlier study run (which a new run replaces whole)."""


class UsageError(ValueError):
    """A mistake of the user (an argument, an input file): reported in one line, exit status 2."""


def say(message: str) -> None:
    """A progress line on stderr (stdout carries the tables)."""
    print(message, file=sys.stderr, flush=True)


def one_line(error: BaseException | str) -> str:
    """The first non-empty line of an error's message, with the error's type when it says more."""
    text = str(error).strip()
    line = next((part.strip() for part in text.splitlines() if part.strip()), "")
    if isinstance(error, BaseException) and not isinstance(error, (UsageError, ValueError, OSError)):
        line = f"{type(error).__name__}: {line}" if line else type(error).__name__
    return line or "invalid input"


def fail(prog: str, message: str) -> NoReturn:
    """Print ``prog: error: message`` on one line of stderr and exit with status 2."""
    print(f"{prog}: error: {one_line(message)}", file=sys.stderr, flush=True)
    raise SystemExit(USAGE_STATUS)


# ---------------------------------------------------------------------------------------------
# The command line


class StudyParser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (no usage block) and exit with status 2."""

    def error(self, message: str) -> NoReturn:
        fail(self.prog, message)


class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Help that shows each option's default, except None: such an option's help says what happens
    without it (an option whose default depends on the input, or that is off unless given)."""

    def _get_help_string(self, action):
        if action.default is None:
            return action.help
        return super()._get_help_string(action)


def script_parser(name: str, description: str) -> StudyParser:
    """A parser for ``python studies/NAME.py`` without the shared study options."""
    return StudyParser(prog=f"python studies/{name}.py", description=description.strip().splitlines()[0],
                       formatter_class=DefaultsHelpFormatter)


def study_parser(name: str, description: str) -> StudyParser:
    """A parser with ``--out``, ``--quick``, ``--seed``, ``--jobs``, ``--backend``, ``--scheduler``,
    ``--no-progress``; the study adds its own options."""
    parser = script_parser(name, description)
    parser.add_argument("--out", type=Path, default=DEFAULT_RESULTS / name,
                        help="output folder (results.json, report.md, figures)")
    parser.add_argument("--quick", action="store_true",
                        help="same physics, shorter runs, fewer seeds and epochs (a first look)")
    parser.add_argument("--seed", type=non_negative_int, default=0,
                        help="seed of every random draw of the study (>= 0)")
    parser.add_argument("--jobs", type=jobs_count, default=-1, help="parallel workers (>= 1; -1: all cores)")
    parser.add_argument("--backend", choices=BACKENDS, default="loky",
                        help="joblib backend: loky (this machine), ray or dask (a cluster)")
    parser.add_argument("--scheduler", default=None, help="address of an existing cluster: a Dask scheduler (tcp://host:8786) or Ray (ray://host:10001)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    return parser


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None


def _number(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if value != value or value in (float("inf"), float("-inf")):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite number")
    return value


def non_negative_int(text: str) -> int:
    """An integer >= 0 (seeds)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1 (counts)."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be >= 1, got {value}")
    return value


def jobs_count(text: str) -> int:
    """Parallel workers: an integer >= 1, or -1 for all cores (joblib's convention)."""
    value = _integer(text)
    if value < 1 and value != -1:
        raise argparse.ArgumentTypeError(f"must be >= 1, or -1 for all cores, got {value}")
    return value


def positive_float(text: str) -> float:
    """A finite number > 0 (durations, hours)."""
    value = _number(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {value:g}")
    return value


def open_fraction(text: str) -> float:
    """A number strictly between 0 and 1."""
    value = _number(text)
    if not 0.0 < value < 1.0:
        raise argparse.ArgumentTypeError(f"must be between 0 and 1 (exclusive), got {value:g}")
    return value


def number_between(low: float, high: float, unit: str = "", note: str = "") -> Callable[[str], float]:
    """A parser of a finite number from ``low`` to ``high`` (both allowed); its error names the
    range with ``unit`` (e.g. " s") and ``note`` (e.g. " (the candidate's range)")."""

    def parse(text: str) -> float:
        value = _number(text)
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"must be between {low:g} and {high:g}{unit}{note}, got {value:g}")
        return value

    return parse


def existing_path(text: str) -> Path:
    """A file or folder that exists and can be read."""
    path = Path(text)
    if not path.exists():
        raise argparse.ArgumentTypeError(f"no file or folder {path}")
    if not os.access(path, os.R_OK | (os.X_OK if path.is_dir() else 0)):
        raise argparse.ArgumentTypeError(f"{path} cannot be read (permission denied)")
    return path


def robot_parameters(text: str):
    """An argument type: a robot parameter file (JSON of ``RavenParameters.to_json``), read now, so
    that a missing, corrupt or unknown-field file stops the run before any simulation."""
    from simulation.model.parameters import RavenParameters

    try:
        return RavenParameters.from_json(text)
    except (OSError, ValueError, TypeError) as error:
        raise argparse.ArgumentTypeError(one_line(error)) from None


def names(known: Sequence[str], what: str) -> Callable[[str], tuple[str, ...]]:
    """An argument type: comma-separated names among ``known``, duplicates dropped, order kept."""
    def parse(text: str) -> tuple[str, ...]:
        chosen = tuple(dict.fromkeys(n.strip() for n in text.split(",") if n.strip()))
        if not chosen:
            raise argparse.ArgumentTypeError(f"no {what} given; choose from {', '.join(known)}")
        unknown = [n for n in chosen if n not in known]
        if unknown:
            raise argparse.ArgumentTypeError(
                f"unknown {what} {', '.join(map(repr, unknown))}; choose from {', '.join(known)}")
        return chosen

    parse.__name__ = what  # argparse names the type in its messages
    return parse


def refuse_options_that_do_not_apply(parser: argparse.ArgumentParser, args: argparse.Namespace,
                                      applies: dict[str, tuple[bool, str]], defaults: dict[str, Any]) -> None:
    """Refuse an option given with an input it does nothing for, then fill in the defaults.

    Parameters
    ----------
    parser, args
        The parser and what it parsed. The options named in ``applies`` must have the parser default
        None, so that a given option can be told from an absent one.
    applies
        Option (its ``args`` attribute) -> (whether it applies to this input, where it applies, as
        the error message says it: "--seed applies to WHERE").
    defaults
        Option -> its value when not given.

    A seed or a record length given with recorded data would otherwise be dropped without a word, and
    the user could believe that the analysis used it. Exits with a one-line usage error (status 2)
    naming the first such option.
    """
    for name, (applicable, where) in applies.items():
        if getattr(args, name) is not None and not applicable:
            parser.error(f"--{name.replace('_', '-')} applies to {where}")
    for name, value in defaults.items():
        if getattr(args, name) is None:
            setattr(args, name, value)


# ---------------------------------------------------------------------------------------------
# One run of a study


def _first_existing(path: Path) -> Path:
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


class StudyRun:
    """One run of a study: its checked arguments and configuration, its output folder, its clock.

    Parameters
    ----------
    parser : the study's parser (with an ``--out`` option).
    argv : the arguments (None: ``sys.argv[1:]``).
    configure : ``configure(args)`` returns the study's configuration; a ``ValueError`` it raises is
        a user's mistake (one line, status 2).
    study : the name written in ``results.json`` (default: the parser's script name).

    Used as a context manager: entering it creates the temporary output folder :attr:`folder`
    beside ``--out``; leaving it after an error removes that folder (a :class:`UsageError` then
    prints one line and exits with status 2); :meth:`publish` moves the results into place.
    """

    def __init__(self, parser: argparse.ArgumentParser, argv: Sequence[str] | None = None,
                 configure: Callable[[argparse.Namespace], Any] | None = None, *, study: str | None = None) -> None:
        self.prog = parser.prog
        self.study = study or Path(parser.prog.split()[-1]).stem
        self.args = parser.parse_args(argv)
        try:
            self.config = configure(self.args) if configure is not None else None
        except ValueError as error:
            fail(self.prog, str(error))
        self.out = Path(self.args.out)
        self._check_out()
        self._check_backend()
        self.folder: Path | None = None
        self.runtime_s: float | None = None
        self.started = reporting.now_iso()
        self._clock = time.perf_counter()
        self._created: list[Path] = []
        self._published = False

    # -- arguments ------------------------------------------------------------------------

    @property
    def parallel(self) -> dict[str, Any]:
        """``n_jobs``, ``backend``, ``scheduler`` and ``progress`` from the shared options."""
        a = self.args
        return {"n_jobs": a.jobs, "backend": a.backend, "scheduler": a.scheduler, "progress": not a.no_progress}

    def _check_backend(self) -> None:
        backend, scheduler = getattr(self.args, "backend", None), getattr(self.args, "scheduler", None)
        if scheduler is not None and backend not in ("dask", "ray"):
            fail(self.prog, "--scheduler needs --backend dask or --backend ray")
        needs = {"ray": ("ray", "pip install -e '.[ray]'"), "dask": ("distributed", "pip install -e '.[cluster]'")}
        if backend in needs and importlib.util.find_spec(needs[backend][0]) is None:
            module, command = needs[backend]
            fail(self.prog, f"--backend {backend} needs {module}, which is not installed: {command}")

    def _check_out(self) -> None:
        out = self.out
        if out.exists() and not out.is_dir():
            fail(self.prog, f"--out {out} is a file, not a folder")
        ancestor = _first_existing(out.resolve().parent)
        if not ancestor.is_dir():
            fail(self.prog, f"--out {out}: {ancestor} is not a folder")
        if not os.access(ancestor, os.W_OK | os.X_OK):
            fail(self.prog, f"--out {out}: cannot write in {ancestor} (permission denied)")

    # -- the output folder ----------------------------------------------------------------

    def __enter__(self) -> "StudyRun":
        parent = self.out.resolve().parent
        missing = []
        path = parent
        while not path.exists():
            missing.append(path)
            path = path.parent
        try:
            parent.mkdir(parents=True, exist_ok=True)
            self._created = list(reversed(missing))
            self.folder = Path(tempfile.mkdtemp(prefix=f".{self.out.name}.", suffix=".partial", dir=parent))
        except OSError as error:
            self._remove_created()
            fail(self.prog, f"--out {self.out}: cannot write there ({error.strerror or error})")
        self._clock = time.perf_counter()
        return self

    def __exit__(self, kind, error, trace) -> bool:
        if error is None:
            if not self._published:
                self.publish()
            return False
        self._discard()
        if isinstance(error, UsageError):
            fail(self.prog, str(error))
        return False

    def _discard(self) -> None:
        if self.folder is not None and self.folder.exists():
            shutil.rmtree(self.folder, ignore_errors=True)
        self._remove_created()

    def _remove_created(self) -> None:
        for path in reversed(self._created):
            try:
                path.rmdir()
            except OSError:
                break
        self._created = []

    def final(self, path: Path) -> Path:
        """Where a file written in :attr:`folder` is once the results are in place."""
        return self.out / Path(path).relative_to(self.folder)

    def publish(self) -> Path:
        """Move the results into ``--out``.

        ``--out`` missing or empty, or holding an earlier study run: it is replaced whole. A folder
        holding anything else (or the current folder): the new files are moved into it one by
        one, and the rest is kept.
        """
        out, folder = self.out.resolve(), self.folder
        if not out.exists():
            os.replace(folder, out)
        elif self._replaceable(out):
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".old", dir=out.parent))
            os.replace(out, old / out.name)
            os.replace(folder, out)
            shutil.rmtree(old, ignore_errors=True)
        else:
            for item in folder.iterdir():
                target = out / item.name
                if target.is_dir() and not item.is_dir():
                    shutil.rmtree(target)
                os.replace(item, target)
            folder.rmdir()
        self._published = True
        return self.out

    @staticmethod
    def _replaceable(out: Path) -> bool:
        """May ``out`` be replaced whole: empty or an earlier run's results, and not around the current folder?"""
        if Path.cwd().resolve().is_relative_to(out):
            return False
        return not any(out.iterdir()) or any((out / marker).is_file() for marker in RESULT_MARKERS)

    @contextmanager
    def reading(self, path: Path) -> Iterator[None]:
        """Errors raised while reading the user's input files become one-line usage errors."""
        try:
            yield
        except UsageError:
            raise
        except Exception as error:  # noqa: BLE001 - readers of foreign formats raise their own types
            message = one_line(error)
            raise UsageError(message if str(path) in message else f"cannot read {path}: {message}") from error

    # -- the end of a run -----------------------------------------------------------------

    def stop_clock(self) -> float:
        """The run time in s, measured once (later calls return the same value)."""
        if self.runtime_s is None:
            self.runtime_s = time.perf_counter() - self._clock
        return self.runtime_s

    def document(self, results: dict, **content: Any) -> dict[str, Any]:
        """The common part of ``results.json`` with the study's results; stops the clock."""
        return reporting.study_document(self.study, self.config, self.started, self.stop_clock(),
                                        **results, **content)

    def conclude(self, results: dict, *, title: str, finding: Callable[[dict], str],
                 tables: Callable[[dict], list[str]], figures: Callable[[dict, Path], list[Path]],
                 extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """The common end of a study: ``results.json``, ``report.md`` and figures written and moved
        into place, the tables and the finding printed, where they are and the run time said."""
        document = self.document(results)
        document["finding"] = finding(results)
        document.update(extra or {})
        sections = tables(results)
        paths = reporting.write_study(self.folder, document, title, sections, figures(results, self.folder))
        self.publish()
        print("\n".join(sections))
        print(document["finding"])
        self.done(len(paths))
        return document

    def done(self, n_files: int | None = None) -> None:
        """The last line: where the report is and the run time."""
        files = f" ({n_files} files)" if n_files is not None else ""
        report = next((self.out / name for name in ("report.md", "confusion.md") if (self.out / name).exists()),
                      self.out)
        say(f"report: {report}{files}; run time {self.stop_clock():.0f} s")
