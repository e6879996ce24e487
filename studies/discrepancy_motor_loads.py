"""The discrepancy command's hidden-effect run, replayed with the links' inertial loads from the motors.

A diagnostic that knows the generator, never part of an analysis. ``python
studies/discrepancy_motor_loads.py --hidden-effect NAME --seed S --out DIR`` runs ``python
studies/discrepancy.py --hidden-effect NAME --seed S --out DIR`` (the generated record written to
``DIR/measured.parquet``, its blind analysis scored with the plant replay where that applies, then
the oracle and both floors) with one change: every RAVEN-II record that the analysis, the oracle and
the quasi-static floor read is replayed with the links' inertial loads from the motors' acceleration
through the arm's nominal coupling (:func:`studies.discrepancy_floor.with_motor_side_loads`, causal
like the replay's own estimate) instead of from a causal second derivative of the measured joints.

The identification reads the record as always, and the plant replay that scores the starting and
final models takes no acceleration, so the plant floor is the command's (its bound moves only
through the starting model's offsets, which the replay fits: by under 1e-5 on seeds 30-34). What
changes is what the workflow names and fits on a replay whose floor is lower
(``studies/discrepancy_floor.py --analyse``), and what the plant then makes of those fits. The
acceleration comes from the motor encoders, which a real robot logs, through round nominal numbers;
nothing of the generator reaches the analysis, which still gets the record as a file.

``--seed``, ``--duration``, ``--size-factor`` and ``--backfit-patience`` are the command's.
``DIR/report.json`` is the command's report with ``motor_side_loads`` (true) added, and
``DIR/report.md`` says so in a line under its title. Run::

    python studies/discrepancy_motor_loads.py --hidden-effect hysteresis --seed 124 --out DIR
    python studies/discrepancy_motor_loads.py --hidden-effect drift --seed 124 --out DIR

A sweep (``--sweep``) is not offered: it runs its analyses in other processes, which the change
made here does not reach.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from studies.common.discrepancy_runs import DEFAULT_RECORD_S, hidden_effects, record_length
from studies.common.runner import StudyRun, non_negative_int, positive_float, script_parser

STUDY = "discrepancy_motor_loads"

MARK = ("Diagnostic: every record replayed with the links' inertial loads from the motors' acceleration "
        "(`studies/discrepancy_motor_loads.py`); the plant replay scores as always.")
"""The line :func:`mark_report` puts under the title of the command's ``report.md``."""


def command_arguments(args) -> list[str]:
    """The ``python studies/discrepancy.py`` arguments of this run's options."""
    out = ["--hidden-effect", ",".join(args.hidden_effect) or "none", "--seed", str(args.seed),
           "--duration", repr(float(args.duration)), "--size-factor", repr(float(args.size_factor)),
           "--out", str(args.out), "--no-progress"]
    if args.backfit_patience is not None:
        out += ["--backfit-patience", str(args.backfit_patience)]
    return out


def mark_report(folder: Path) -> None:
    """Record in the command's ``report.json`` and ``report.md`` in ``folder`` that the replay took
    the links' inertial loads from the motors."""
    path = folder / "report.json"
    report = json.loads(path.read_text())
    report["motor_side_loads"] = True
    path.write_text(json.dumps(report, indent=1))
    text = folder / "report.md"
    title, _, rest = text.read_text().partition("\n")
    text.write_text(f"{title}\n\n{MARK}\n{rest}")


def main(argv: list[str] | None = None) -> int:
    from studies import discrepancy
    from studies.discrepancy_floor import motor_side_loads_throughout

    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--hidden-effect", type=hidden_effects, required=True, metavar="NAME",
                        help="'none' or effects to hide, comma-separated, as the command takes them")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="seed of the generated data (>= 0)")
    parser.add_argument("--duration", type=record_length, default=DEFAULT_RECORD_S,
                        help="record length (s, at most six hours)")
    parser.add_argument("--size-factor", type=positive_float, default=1.0,
                        help="the hidden effect at this multiple of its default size")
    parser.add_argument("--backfit-patience", type=non_negative_int, default=None, metavar="N",
                        help="the command's --backfit-patience (without it, the workflow's default)")
    parser.add_argument("--out", type=Path, default=Path("results") / STUDY)
    # checks the options and --out as every study does; the command writes the results
    args = StudyRun(parser, argv).args
    with motor_side_loads_throughout():
        status = discrepancy.main(command_arguments(args))
    mark_report(args.out)
    return status


if __name__ == "__main__":
    sys.exit(main())
