"""Writing study results: Markdown tables, ``results.json``, the report file, machine facts.

Every study writes the same things to its output folder: ``results.json`` (numbers, the
configuration and the seeds), ``report.md`` (tables with the paper's numbers beside, one line
on whether the simulation agrees with the paper's finding, the figures) and PNG figures.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import json
import math
import os
import platform
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

SIMULATED = "simulated here"
PUBLISHED = "published"


def format_value(value, digits: int = 3) -> str:
    """A number for a table: fixed digits; ``"-"`` for a missing one; ``"lo-hi"`` for a range."""
    if value is None:
        return "-"
    if isinstance(value, (tuple, list)) and len(value) == 2:
        return f"{format_value(value[0], digits)}-{format_value(value[1], digits)}"
    value = float(value)
    if not math.isfinite(value):
        return "-"
    return f"{value:.{digits}f}"


def markdown_table(headers: Sequence[str], rows: Sequence[Sequence[Any]], digits: int = 3) -> str:
    """A GitHub Markdown table; numbers formatted by :func:`format_value`, text kept."""
    def cell(value):
        if isinstance(value, str):
            return value
        return format_value(value, digits)

    lines = ["| " + " | ".join(headers) + " |", "|" + "|".join("---" for _ in headers) + "|"]
    for row in rows:
        if len(row) != len(headers):
            raise ValueError(f"row {row!r} has {len(row)} cells for {len(headers)} headers")
        lines.append("| " + " | ".join(cell(value) for value in row) + " |")
    return "\n".join(lines)


def _processor_name() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


RESULT_PACKAGES = ("numpy", "scipy", "casadi", "numba", "llvmlite", "pin", "scikit-learn", "torch", "pysindy",
                   "pandas", "pyarrow")
"""The installed packages whose releases can move a result in its last digits (the requirements
admit ranges, so two installations months apart may differ)."""


def _host_cpu_name() -> str | None:
    """The processor LLVM, and so numba, compiles the kernels for (its instructions decide their
    rounding), None without llvmlite."""
    try:
        from llvmlite import binding
    except ImportError:
        return None
    return binding.get_host_cpu_name()


def package_versions(names=RESULT_PACKAGES) -> dict[str, str | None]:
    """The installed release of each package of ``names``, None where it is not installed."""
    from importlib.metadata import PackageNotFoundError, version

    found = {}
    for name in names:
        try:
            found[name] = version(name)
        except PackageNotFoundError:
            found[name] = None
    return found


def machine_description() -> dict[str, Any]:
    """Where the numbers were measured: processor (and the one numba compiles for), cores, OS,
    Python and the releases of :data:`RESULT_PACKAGES`."""
    return {
        "processor": _processor_name(),
        "compiled_for": _host_cpu_name(),
        "cpu_count": os.cpu_count(),
        "platform": platform.platform(),
        "python": sys.version.split()[0],
        "packages": package_versions(),
    }


def now_iso() -> str:
    return _dt.datetime.now().astimezone().isoformat(timespec="seconds")


def to_jsonable(value: Any) -> Any:
    """Numbers, arrays, dataclasses, mappings and sequences as plain JSON values (NaN -> null)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: to_jsonable(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, Mapping):
        return {str(k): to_jsonable(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return to_jsonable(value.tolist())
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v) for v in value]
    if isinstance(value, (np.floating, float)):
        value = float(value)
        return value if math.isfinite(value) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, (np.bool_,)):
        return bool(value)
    if isinstance(value, (str, int, bool)) or value is None:
        return value
    return str(value)


def write_text(path: Path, text: str) -> Path:
    """Write a text file atomically (a failure leaves the previous file or none)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(f".{path.name}.tmp")
    temporary.write_text(text, encoding="utf-8")
    os.replace(temporary, path)
    return path


def write_json(path: Path, results: Mapping[str, Any]) -> Path:
    """``results.json``: indented, plain JSON values, no NaN."""
    return write_text(path, json.dumps(to_jsonable(results), indent=2, allow_nan=False) + "\n")


FINDING_KINDS = ("test", "built in")
"""How a study's finding relates to the simulator: a ``"test"`` (a prediction nothing was tuned to)
or ``"built in"`` (the simulator's defaults were tuned so that it comes out)."""


def agreement_line(agrees: bool, simulated: str, paper: str, kind: str = "test", measured: bool = False) -> str:
    """The one line each study ends with.

    A ``"test"`` is reported as agreement or disagreement with the paper; a ``"built in"`` finding
    (the simulator was tuned to it, see ``simulation/model/effects.py``) only as reproduced or not,
    because reproducing what the simulator was made to do says nothing about the paper. ``measured``
    marks a finding on recorded data (a test whatever ``kind`` says of the simulator): its evidence
    is labelled "Measured", not "Simulated".
    """
    if kind not in FINDING_KINDS:
        raise ValueError(f"kind must be one of {FINDING_KINDS}, got {kind!r}")
    if measured or kind == "test":
        verdict = "AGREES with the paper" if agrees else "DOES NOT AGREE with the paper"
        label, evidence = ("test on recorded data", "Measured") if measured else ("test", "Simulated")
        return f"**Finding ({label}): {verdict}.** {evidence}: {simulated} Paper: {paper}"
    verdict = "reproduced" if agrees else "NOT reproduced"
    return (f"**Finding (built in: the simulator was tuned to it, so this is no agreement): {verdict}.** "
            f"Simulated: {simulated} Paper: {paper}")


def report_header(title: str, command: str, started: str, runtime_s: float, config: Mapping[str, Any]) -> str:
    """Title, when/where/how long, the command and the configuration, as Markdown."""
    machine = machine_description()
    lines = [
        f"# {title}",
        "",
        f"- run: {started}, {runtime_s:.0f} s on {machine['cpu_count']} cores "
        f"({machine['processor']}, {machine['platform']}, Python {machine['python']})",
        f"- command: `{command}`",
        "- configuration: " + ", ".join(f"{k}={_short(v)}" for k, v in to_jsonable(config).items()),
        "",
    ]
    return "\n".join(lines)


def _short(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    if isinstance(value, list) and all(isinstance(v, float) for v in value):
        return "[" + ", ".join(f"{v:.4g}" for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_short(v)}" for k, v in value.items()) + "}"
    return str(value)


def figure_links(paths: Sequence[Path], folder: Path) -> str:
    """Markdown image links of figures relative to the report's folder."""
    return "\n\n".join(f"![{Path(p).stem}]({Path(p).relative_to(folder).as_posix()})" for p in paths)


def command_line() -> str:
    return " ".join([Path(sys.argv[0]).as_posix(), *sys.argv[1:]]) if sys.argv and sys.argv[0] else "python"


def write_study(out: Path, document: Mapping[str, Any], title: str, sections: Sequence[str],
                figures: Sequence[Path]) -> list[Path]:
    """Write ``results.json`` and ``report.md`` (header, the finding line, sections, figures).

    ``document`` must hold ``command``, ``created``, ``runtime_s``, ``configuration`` and
    ``finding`` (the agreement line).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    json_path = write_json(out / "results.json", document)
    parts = [report_header(title, document["command"], document["created"], document["runtime_s"],
                           document["configuration"]), document["finding"], "", *sections, "", "## Figures", "",
             figure_links(list(figures), out), ""]
    report_path = write_text(out / "report.md", "\n".join(parts))
    return [json_path, report_path, *figures]


def failure_lines(failures: Sequence[str]) -> list[str]:
    """Report lines listing the failed training runs of a study (none when nothing failed)."""
    return ["", "Failed training runs:", *[f"- {line}" for line in failures]] if failures else []


def study_document(study: str, config: Any, started: str, runtime_s: float, **content: Any) -> dict[str, Any]:
    """The common part of every study's ``results.json``."""
    return {"study": study, "created": started, "runtime_s": round(runtime_s, 1),
            "machine": machine_description(), "command": command_line(),
            "configuration": to_jsonable(config), **content}
