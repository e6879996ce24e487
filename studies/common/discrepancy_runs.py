"""Runs of the model-discrepancy workflow (:mod:`simulation.discrepancy`) end to end: on simulated
data with a hidden effect, on recorded RAVEN-II data, and on generic data such as the dVRK
recordings. ``studies/discrepancy.py`` is their command line.

Generation and analysis meet only through one file: :func:`generate_measured` simulates the
starting structure plus a hidden effect, :func:`write_measured` writes ``measured.parquet``, and
:func:`analyse_measured` reads that file and nothing else. Step 0 of the analysis starts from the
model of :data:`STARTING_STRUCTURE` identified from the measured data itself
(:func:`simulation.identification.identify` on the fit part) and screens the one :data:`LIBRARY`,
whatever the data. Only a study that generated the data then adds what it knows
(:func:`oracle`, :func:`true_values`), after the analysis.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from contextvars import ContextVar
from pathlib import Path

import numpy as np

from simulation.model.parameters import RavenParameters

from simulation.discrepancy import (
    BaseIdentifier,
    DiscrepancyResult,
    MeasuredSignals,
    NominalModel,
    RavenModel,
    Split,
    WorkflowSettings,
    run_workflow,
)
from simulation.discrepancy.candidates import RAVEN_LIBRARY, library, oracle_candidates

STARTING_STRUCTURE = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction")
"""The starting model of every RAVEN-II analysis, whatever the data: the cable model the
identification fits (the UKF's model class), identified on the data's fit part."""
LIBRARY = RAVEN_LIBRARY
"""The candidates every RAVEN-II analysis screens (:data:`~simulation.discrepancy.candidates.RAVEN_LIBRARY`)."""
UNMODELLED_EFFECTS = ("capstan_runout",)
"""Simulator effects neither in the starting structure nor in the library: hiding one tests that the
workflow reports the residual as unexplained, with a signature, rather than under a wrong name."""
HIDDEN_CHOICES = ("none",) + LIBRARY + UNMODELLED_EFFECTS
"""What ``--hidden-effect`` accepts: nothing, any candidate of the library, or an unmodelled effect."""
SESSION_EFFECTS = ("payload",)
"""Hidden effects that are a condition of the session, not an effect of the simulator."""
ABLATION_CHOICES = tuple(n for n in STARTING_STRUCTURE if n != "cable_stretch")
"""What ``--ablate`` accepts: a term of the starting structure, which the analysis then lacks."""
MEASUREMENT_EFFECTS = ("quantization", "noise")
"""Effects of how the robot is measured, always on in generated data: they set the noise floor and
are not structure the workflow is asked to find."""
SIZE_FIELDS = {
    "backlash": ("half_width",),
    "hysteresis": ("stiffness",),
    "drift": ("time_scale",),
    "homing_offset": ("repeatability", "tool_repeatability"),
    "registration_offset": ("repeatability",),
    "transmission_error": ("ratio_error",),
    "motor_friction": ("coulomb", "gearbox_loss"),
    "capstan_friction": ("mu",),
    "gravity_model_error": ("scale_error",),
    "capstan_runout": ("amplitude",),
}
"""The fields a ``size_factor`` multiplies, per hidden effect (``drift``: its time scale, so a
minute of the record ages the cables as that many minutes of operation). Every hidden effect is
generated at its virtual RAVEN-II default, the size its source gives, unless a study asks for
another size explicitly; the payload's default is the paper's loaded test."""
HIDDEN_PAYLOAD_KG = 0.5
"""A hidden ``payload``: the paper's 500 g loaded-test mass hung at the tool tip, which the written
log does not declare (its ``payload_kg`` label stays 0)."""
PER_HOMING_EFFECTS = ("homing_offset", "registration_offset")
REHOMING_AT = 0.3
"""With a hidden ``homing_offset`` or ``registration_offset`` the session re-homes once, after this
fraction of the motion (in the fit part): registration offsets differ only between homings, so a
record of one homing cannot hold the effect. Every other record is of one homing."""

if set(STARTING_STRUCTURE) & set(LIBRARY + UNMODELLED_EFFECTS):
    raise ImportError("the starting structure must hold none of the candidates and no unmodelled effect")


def check_hidden(hidden) -> tuple[str, ...]:
    """``hidden`` (an effect name or a sequence of them; ``"none"`` alone: nothing) as a tuple of
    effect names, refusing any that cannot be hidden, with the reason."""
    hidden = (hidden,) if isinstance(hidden, str) else tuple(hidden)
    if hidden == ("none",):
        return ()
    if "none" in hidden:
        raise ValueError(f"'none' (nothing hidden) cannot be combined with other effects, got {', '.join(hidden)}")
    for name in hidden:
        if name in STARTING_STRUCTURE:
            raise ValueError(f"{name} is in the starting structure, so hiding it changes nothing in the data "
                             f"(--ablate {name} analyses a model lacking it)")
        if name in MEASUREMENT_EFFECTS:
            raise ValueError(f"{name} is always on in generated data (it is how the robot is measured)")
        if name not in HIDDEN_CHOICES or name == "none":
            raise ValueError(f"unknown hidden effect {name!r}; choose 'none' or from {', '.join(HIDDEN_CHOICES[1:])}")
    if len(set(hidden)) != len(hidden):
        raise ValueError(f"an effect is hidden twice in {', '.join(hidden)}")
    return hidden


def scaled(effect, factor: float):
    """``effect`` with its size fields (:data:`SIZE_FIELDS`) multiplied by ``factor``."""
    from dataclasses import replace

    return replace(effect, **{f: getattr(effect, f) * factor for f in SIZE_FIELDS[effect.name]})


def generator_parameters(hidden=(), params: RavenParameters | None = None, size_factor: float = 1.0
                         ) -> RavenParameters:
    """The simulator's parameters of generated data: the starting structure, the measurement
    effects and the ``hidden`` simulator effects at their defaults (times ``size_factor``), nothing else."""
    hidden = check_hidden(hidden)
    effects = [n for n in hidden if n not in SESSION_EFFECTS]
    generator = (params or RavenParameters()).only(*STARTING_STRUCTURE, *MEASUREMENT_EFFECTS, *effects)
    if size_factor != 1.0:
        for name in effects:
            generator = generator.with_effect(scaled(generator.effect(name), size_factor))
    return generator


def generate_measured(hidden=(), seed: int = 0, duration: float = 240.0, params: RavenParameters | None = None,
                      size_factor: float = 1.0, robot_options: dict | None = None):
    """Simulated "measured" data: the starting structure plus the ``hidden`` effects, nothing else.

    Returns the dataset (a :class:`~simulation.recordings.dataset.CalibrationDataset` of one session
    of random motion, re-homed once at :data:`REHOMING_AT` when a per-homing offset is hidden, with
    :data:`HIDDEN_PAYLOAD_KG` (times ``size_factor``) at the tool tip and undeclared when
    ``payload`` is hidden) and the generating parameters (for the oracle and the report only; the
    analysis never sees them). ``robot_options`` go to the virtual robot (e.g. ``log_rate``).
    """
    from kinematics import RavenII
    from simulation.engine.scenarios import powered_on, record_random_test, rehome
    from simulation.recordings.dataset import CalibrationDataset
    from simulation.recordings.recording import Recording, recording_to_dataset

    hidden = check_hidden(hidden)
    duration = check_record_length(duration)
    if not np.isfinite(size_factor) or size_factor <= 0:
        raise ValueError(f"size_factor must be a positive number, got {size_factor}")
    generator = generator_parameters(hidden, params, size_factor)
    robot = powered_on(generator, seed=seed, **(robot_options or {}))
    if "payload" in hidden:
        robot.set_payload(HIDDEN_PAYLOAD_KG * size_factor)
    if set(hidden) & set(PER_HOMING_EFFECTS):
        first = record_random_test(robot, REHOMING_AT * duration, seed=seed + 1)
        rehome(robot)
        second = record_random_test(robot, (1 - REHOMING_AT) * duration, seed=seed + 2)
        recording = Recording.concatenate([first, second])
    else:
        recording = record_random_test(robot, duration, seed=seed + 1)
    dataset = recording_to_dataset(recording, RavenII(generator.arm, check_limits=False))
    if "payload" in hidden:
        table = dataset.table.copy()
        table["label.payload_kg"] = 0.0
        dataset = CalibrationDataset(table, arm=dataset.arm)
    return dataset, generator


def log_rate_options(log_rate: float) -> dict:
    """The virtual robot's options (for :func:`generate_measured`) that log its state at ``log_rate``
    (Hz) and the ground truth at that rate or its own, whichever is faster; none at the robot's own
    rate."""
    from simulation.engine.robot import LOG_RATE, TRUTH_RATE

    if log_rate == LOG_RATE:
        return {}
    return {"log_rate": float(log_rate), "truth_rate": max(float(log_rate), TRUTH_RATE)}


def write_measured(dataset, folder) -> Path:
    """Write ``dataset`` as ``folder/measured.parquet``, the one file between generation and analysis."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    return dataset.to_parquet(folder / "measured.parquet")


def uninformed_start(arm: str = "left") -> RavenParameters:
    """The identification's starting guesses: the nominal parameter set
    (:func:`simulation.identification.nominal_parameters`), the controller's constants and round
    effect values, unrelated to any generator's values."""
    from simulation.identification import nominal_parameters

    return nominal_parameters(arm)


def identified_model(dataset, mask: np.ndarray, structure=STARTING_STRUCTURE,
                     joint_correction: np.ndarray | None = None) -> RavenModel:
    """Step 0: the cable model of ``structure`` identified on the ``mask`` rows of the dataset,
    starting from :func:`uninformed_start`. ``joint_correction`` (one row per dataset row) is
    subtracted from the joints the identification compares, not from the pose its loads are
    computed at (:func:`~simulation.identification.samples.prepare_samples`)."""
    import warnings

    from simulation.identification import identify
    from simulation.identification.samples import prepare_samples

    start = uninformed_start(dataset.arm)
    correction = None if joint_correction is None else np.asarray(joint_correction, dtype=float)[mask]
    samples = prepare_samples(dataset.select(mask), start, joint_correction=correction)
    with warnings.catch_warnings():
        # how well each parameter is determined is reported by the identification itself; here the
        # workflow's refit and validation decide
        warnings.simplefilter("ignore")
        result = identify(samples, effects=tuple(structure), base=start)
    return RavenModel(result.parameters, np.asarray(result.offsets, dtype=float),
                      standard_errors={e.name: float(e.standard_error) for e in result.estimates})


def _with_corrections(dataset, torques, payload_kg: float = 0.0):
    """The dataset with ``torques`` (N, 3, or None) subtracted from its motor torques (the
    measurement with an effect's share removed) and ``payload_kg`` added to the payload it
    declares; the dataset itself when neither changes anything. An effect's share of the joints is
    not applied here: it corrects the joints the identification compares, not the pose the links'
    loads are computed at (:func:`identified_model`)."""
    from simulation.identification.motor_log import PAYLOAD_LABEL
    from simulation.model.constants import POSITIONING_NAMES
    from simulation.recordings.dataset import CalibrationDataset

    shifts_torques = torques is not None and bool(np.any(torques))
    if not shifts_torques and not payload_kg:
        return dataset
    table = dataset.table.copy()
    if shifts_torques:
        columns = [f"tau.{n}" for n in POSITIONING_NAMES]
        table.loc[:, columns] = table[columns].to_numpy() - torques
    if payload_kg:
        declared = table[PAYLOAD_LABEL].to_numpy(float) if PAYLOAD_LABEL in table else np.zeros(len(table))
        table[PAYLOAD_LABEL] = declared + payload_kg
    return CalibrationDataset(table, arm=dataset.arm)


def raven_base_identifier(dataset, fit_mask: np.ndarray, structure=STARTING_STRUCTURE) -> BaseIdentifier:
    """Step 0 and its re-runs: the identification on the fit part of ``dataset``."""
    from simulation.identification import IDENTIFIABLE_EFFECTS

    def identify_structure(effects, correction, payload_kg=0.0):
        joints, torques = (None, None) if correction is None else correction
        return identified_model(_with_corrections(dataset, torques, payload_kg), fit_mask, effects, joints)

    return BaseIdentifier(identify=identify_structure, fittable=tuple(IDENTIFIABLE_EFFECTS),
                          structure=tuple(structure))


def raven_library(signals: MeasuredSignals, names=LIBRARY):
    """The candidates called ``names`` for RAVEN-II signals (by default the library of every analysis)."""
    every = {c.name: c for c in library(signals) + oracle_candidates(signals)}
    return [every[n] for n in names]


def controller_of(dataset):
    """The controller's nominal law and the log's controller signals, for the controller replay."""
    from simulation.discrepancy.controller import ControllerLaw, ControllerSignals

    return ControllerLaw.nominal(dataset.arm), ControllerSignals.from_dataset(dataset)


SPLIT_FRACTIONS = (0.5, 0.25, 0.25)
"""Shares of a RAVEN-II record, in time order, that the workflow fits on, chooses on and reports on."""


def check_analysable(dataset) -> None:
    """Raise ValueError naming what keeps the workflow from analysing the RAVEN-II ``dataset``:
    times that do not increase strictly, or a fit part (the record's first half) without a stretch
    long enough for the identification's derivatives. The analysis would find either only after
    reading and preparing the whole record; the command line checks first and reports it in one line.
    """
    from simulation.identification.samples import prepare_samples

    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals, SPLIT_FRACTIONS)
    try:
        prepare_samples(dataset.select(split.fit), uninformed_start(dataset.arm))
    except ValueError as error:
        seconds = float(np.ptp(signals.time[split.fit])) if split.fit.any() else 0.0
        raise ValueError(f"the starting structure is identified on the record's first half ({seconds:.1f} s "
                         f"here), and it cannot be: {error}") from error


_REPLAY_TRANSFORM: ContextVar[Callable[[MeasuredSignals], MeasuredSignals] | None] = ContextVar(
    "replay_transform", default=None)


@contextmanager
def replaying_with(transform: Callable[[MeasuredSignals], MeasuredSignals]) -> Iterator[None]:
    """Within the block, every RAVEN-II record these helpers replay (the blind analysis, the oracle,
    the starting model of :func:`starting_model_on` and of the floor) is replayed on
    ``transform(signals)`` instead of the record's own :class:`MeasuredSignals`, e.g. with other
    derivatives (:meth:`MeasuredSignals.with_derivatives`).

    The command enters one with ``--inertial-loads motors`` (:func:`inertial_loads_from`); the
    diagnostic studies with the transforms they compare. The identification reads the dataset as
    always. Blocks nest; the outer transform is back when an inner block ends, whether it ends
    normally or by an error."""
    if not callable(transform):
        raise TypeError(f"the replay's transform must be callable, not {type(transform).__name__}")
    token = _REPLAY_TRANSFORM.set(transform)
    try:
        yield
    finally:
        _REPLAY_TRANSFORM.reset(token)


def replay_transform() -> Callable[[MeasuredSignals], MeasuredSignals] | None:
    """The transform of the innermost :func:`replaying_with` block around the caller, None outside."""
    return _REPLAY_TRANSFORM.get()


INERTIAL_LOADS = ("joints", "motors")
"""Where the replay takes the links' inertial loads from (``--inertial-loads``): ``joints``, the
workflow's default, from a causal second derivative of the measured joints
(:class:`MeasuredSignals`); ``motors``, from the motors' acceleration through the arm's nominal
coupling (:func:`with_motor_side_loads`). Both come from what a robot logs; the identification reads
the dataset alike either way, and the plant replay takes no acceleration."""


def motor_side_acceleration(signals: MeasuredSignals, coupling: np.ndarray) -> np.ndarray:
    """(N, 3) the cable ends' acceleration ``A u''`` (``coupling`` A, (3, 3); ``u`` the motor
    coordinates; rad/s^2 and m/s^2), causal like the replay's own estimate: the links' acceleration
    up to that of the cables' stretch, from the motor encoders, whose errors are not the ground
    truth's."""
    return signals.drive_acceleration @ np.asarray(coupling, dtype=float).T


def with_motor_side_loads(signals: MeasuredSignals) -> MeasuredSignals:
    """``signals`` whose replay takes the links' inertial loads from :func:`motor_side_acceleration`
    through the arm's nominal coupling (a round number of the model, nothing of a generator)."""
    from simulation.model.constants import RavenConstants

    coupling = RavenConstants(arm=signals.arm).nominal_coupling()
    return signals.with_derivatives(acceleration=motor_side_acceleration(signals, coupling))


def inertial_loads_from(source: str):
    """A block within which the helpers replay RAVEN-II records with the links' inertial loads from
    ``source`` (one of :data:`INERTIAL_LOADS`): ``motors`` is :func:`replaying_with`
    :func:`with_motor_side_loads`; ``joints``, the default, changes nothing."""
    if source not in INERTIAL_LOADS:
        raise ValueError(f"the inertial loads come from one of {', '.join(INERTIAL_LOADS)}, not {source!r}")
    return replaying_with(with_motor_side_loads) if source == "motors" else nullcontext()


def replayed_signals(dataset) -> MeasuredSignals:
    """The signals the workflow replays for a RAVEN-II ``dataset``: the record's own, transformed
    within a :func:`replaying_with` block."""
    signals = MeasuredSignals.from_dataset(dataset)
    transform = _REPLAY_TRANSFORM.get()
    return signals if transform is None else transform(signals)


def run_on_raven_dataset(dataset, structure=STARTING_STRUCTURE, settings: WorkflowSettings = WorkflowSettings(),
                         fractions=SPLIT_FRACTIONS, exclude=(), candidates=LIBRARY,
                         progress: bool = False) -> tuple[DiscrepancyResult, MeasuredSignals, Split]:
    """The workflow on a RAVEN-II dataset: split in time, identify ``structure`` on the fit part,
    screen the ``candidates`` (effect names); ``progress`` shows the candidate fits on stderr. The
    replay runs on :func:`replayed_signals`."""
    signals = replayed_signals(dataset)
    split = Split.by_time(signals, fractions)
    base = raven_base_identifier(dataset, split.fit, structure)
    model = base.identify(tuple(structure), None)
    return run_workflow(model, signals, split, settings, candidates=raven_library(signals, candidates),
                        exclude=exclude, base=base, progress=progress,
                        controller=controller_of(dataset)), signals, split


def read_flagged(path, arm: str = "left"):
    """The RAVEN-II dataset of a dataset file (``.parquet``, ``.csv``), a ROS bag or a folder of
    either, with the rows that hold impossible values flagged (``valid`` False), not removed.
    ``arm`` is for bags and CSV files (a Parquet dataset file records its arm)."""
    from simulation.recordings.dataset import CalibrationDataset
    from studies.common.data_sources import recorded_datasets

    datasets, _ = recorded_datasets(path, arm)
    return CalibrationDataset.concat(datasets) if len(datasets) > 1 else datasets[0]


def analysed_rows(dataset, max_rate: float | None = None):
    """The rows of a :func:`read_flagged` dataset that the workflow analyses: those not flagged
    invalid, thinned to at most ``max_rate`` (Hz; see :func:`thinned`)."""
    dataset = dataset.select(dataset.valid_mask()) if dataset.n_invalid else dataset
    return thinned(dataset, max_rate)


def read_measured(path, arm: str = "left", max_rate: float | None = None):
    """The RAVEN-II dataset at ``path`` (see :func:`read_flagged`) without the rows flagged invalid,
    thinned to at most ``max_rate`` (Hz; see :func:`thinned`)."""
    return analysed_rows(read_flagged(path, arm), max_rate)


def thinning_step(time, max_rate: float | None) -> int:
    """Every how many rows a log sampled at ``time`` (s) is kept to bring its median rate to at most
    ``max_rate`` (Hz): 1 when ``max_rate`` is None or the log is no faster."""
    if max_rate is None:
        return 1
    if not (np.isfinite(max_rate) and max_rate > 0):
        raise ValueError(f"the highest log rate must be a positive number of Hz, got {max_rate}")
    from simulation.discrepancy.signals import median_interval

    step = median_interval(time)
    return max(1, int(np.ceil(1.0 / (step * max_rate) - 1e-9))) if step > 0 else 1


def thinned(dataset, max_rate: float | None):
    """``dataset`` with every ``k``-th row kept, ``k`` the :func:`thinning_step` that brings its median
    log rate to at most ``max_rate`` (Hz); the dataset itself when it is no faster. The workflow's
    cost grows with the rows (two minutes at 100 Hz cost four times what they cost at 30 Hz), and its
    thresholds were set on 30 Hz logs."""
    step = thinning_step(dataset.time, max_rate)
    if step == 1:
        return dataset
    keep = np.zeros(len(dataset.time), dtype=bool)
    keep[::step] = True
    return dataset.select(keep)


def analysis_settings(backfit_rounds: int | None = None, max_effects: int | None = None,
                      backfit_patience: int | None = None,
                      named_backfit_patience: int | None = None) -> WorkflowSettings:
    """The default :class:`WorkflowSettings`, with at most ``backfit_rounds`` backfit rounds, at
    most ``max_effects`` named effects (``max_iterations``), a backfit that goes on past
    ``backfit_patience`` rounds in a row that do not lower the residual, and a named effect's past
    ``named_backfit_patience``, when given."""
    changes = {"backfit_rounds": backfit_rounds, "max_iterations": max_effects, "backfit_patience": backfit_patience,
               "named_backfit_patience": named_backfit_patience}
    return WorkflowSettings(**{k: v for k, v in changes.items() if v is not None})


def analyse_measured(path, *, progress: bool = False, max_rate: float | None = None,
                     backfit_rounds: int | None = None, max_effects: int | None = None,
                     backfit_patience: int | None = None,
                     named_backfit_patience: int | None = None) -> tuple[DiscrepancyResult, MeasuredSignals, Split]:
    """The blind analysis of RAVEN-II data: all it knows is the file (or folder) at ``path``.

    Always the same :data:`STARTING_STRUCTURE`, identified on the first half of the record, the
    same :data:`LIBRARY` of candidates and the default :class:`WorkflowSettings`: no seed, no
    generator, no name of what the data may hide. ``max_rate`` (Hz) thins a faster log first
    (:func:`thinned`); None analyses every row. ``backfit_rounds`` caps the backfit's rounds,
    ``max_effects`` the effects named and ``backfit_patience`` (``named_backfit_patience``, once a
    candidate is named) lets the backfit go on past rounds that do not lower the residual, instead
    of the defaults (:func:`analysis_settings`; a search
    that names ``max_effects`` stops without checking for more, ``search_capped``).
    """
    return run_on_raven_dataset(read_measured(path, max_rate=max_rate), progress=progress,
                                settings=analysis_settings(backfit_rounds, max_effects, backfit_patience,
                                                           named_backfit_patience))


SHORT_RECORD_S = 60.0
"""RAVEN-II records shorter than this (s) get a warning in the report. The starting structure is
identified on the record's first half, and on a short record it may itself leave a gap that a
candidate then takes: with nothing hidden, 30 s records named an effect on 4 of 5 seeds (hysteresis
twice, capstan friction, backlash), 40 s and 50 s records on 1 of 5 (capstan friction, closing 25 % of
a gap that is the base's own error; backlash, 4 %), 60 s records on none (``python
studies/discrepancy.py --sweep --effects none --seeds 5 --duration 30``, then 40, 50 and 60)."""


DEFAULT_RECORD_S = 1200.0
"""Length of the random motion ``studies/discrepancy.py`` generates unless told otherwise (s): the
twenty minutes of the paper's random test sessions. Drift, the one candidate that grows with time,
is below what shorter records resolve at its published size (one hour of aging per hour): named on 0
of 20 seeds of four-minute records and 0 of 5 of ten-minute ones, whose true structure closes at
most 14 % and 41 % of the held-out gap; named alone on every seed of twenty-minute ones
(``studies/DISCREPANCY_MEASUREMENTS.md``, **Ten- and twenty-minute records**)."""

MAX_RECORD_S = 6 * 3600.0
"""Longest random motion :func:`generate_measured` makes (s): six hours, the paper's longest
operation (its Fig. 6). Generating it holds about 4 GB at its peak (3.8 GB and 91 s for six hours
with nothing hidden), and the memory grows with the length."""


MIN_RECORD_S = 5.0
"""Shortest random motion :func:`generate_measured` makes (s). The workflow identifies the starting
structure on the record's first half, and needs a stretch there without gaps over two of the
identification's derivative windows (1.2 s); a hidden per-homing offset re-homes 30 % into the
record. Records under a minute are analysed with a warning all the same (:data:`SHORT_RECORD_S`)."""


def check_record_length(duration) -> float:
    """``duration`` (s) as a float, refused unless it is a finite number in
    [:data:`MIN_RECORD_S`, :data:`MAX_RECORD_S`]."""
    try:
        value = float(duration)
    except (TypeError, ValueError):
        raise ValueError(f"the record length must be a number of seconds, got {duration!r}") from None
    if not (np.isfinite(value) and MIN_RECORD_S <= value <= MAX_RECORD_S):
        raise ValueError(f"the record length must be at least {MIN_RECORD_S:g} s and at most {MAX_RECORD_S:.0f} s "
                         f"(six hours), got {duration!r}")
    return value


def hidden_effects(text: str) -> tuple[str, ...]:
    """A command line's ``--hidden-effect``: ``"none"`` -> (); ``"backlash,drift"`` -> ("backlash",
    "drift"), refusing what cannot be hidden (:func:`check_hidden`)."""
    import argparse

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    if names == ("none",):
        return ()
    if not names:
        raise argparse.ArgumentTypeError(f"unknown hidden effect {text!r}; choose 'none' or from "
                                         f"{', '.join(HIDDEN_CHOICES[1:])}")
    try:
        return check_hidden(names)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def record_length(text: str) -> float:
    """A command line's ``--duration``: seconds of generated motion (:func:`check_record_length`)."""
    import argparse

    try:
        return check_record_length(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


AGING_RECORD_S = DEFAULT_RECORD_S
"""RAVEN-II records shorter than this (s) get a note in the report that drift at its published size
was never named on records that short, so its absence from the names says little."""


def _raven_record_under(signals: MeasuredSignals, seconds_limit: float) -> float | None:
    """The length (s) of a RAVEN-II record shorter than ``seconds_limit``; None for a longer record
    or another robot's (the notes on short records concern the RAVEN-II starting structure only)."""
    if signals.kind != "raven":
        return None
    seconds = float(signals.time[-1] - signals.time[0])
    return seconds if seconds < seconds_limit else None


def drift_record_note(signals: MeasuredSignals) -> str | None:
    """A sentence on why a RAVEN-II record shorter than :data:`AGING_RECORD_S` cannot show drift, or
    None. Drift grows with the cables' hours of use; the workflow fits on the record's first half,
    where it is smallest, so a short record leaves it below the naming test's thresholds."""
    seconds = _raven_record_under(signals, AGING_RECORD_S)
    if seconds is None:
        return None
    return (f"the record lasts {seconds:.0f} s, under {AGING_RECORD_S:.0f} s: drift at its published size (one hour "
            "of aging per hour of use) was named on none of the generated four- and ten-minute records, so its "
            "absence from the names does not mean the cables do not age")


def short_record_note(signals: MeasuredSignals) -> str | None:
    """A sentence on why the names of an analysis of a short RAVEN-II record are in doubt, or None."""
    seconds = _raven_record_under(signals, SHORT_RECORD_S)
    if seconds is None:
        return None
    return (f"the record lasts {seconds:.0f} s, under {SHORT_RECORD_S:.0f} s: the starting structure, identified "
            "on its first half, may itself leave a gap that a candidate then takes (with nothing hidden, 30 s "
            "of random motion named an effect on 4 of 5 seeds, 40 s and 50 s on 1 of 5, 60 s on none)")


def largest_share(shares) -> float | None:
    """The structure check's largest share of one joint's residual variance, in %, 0 where the
    library predicts no better than the blocks' means (None where the check did not run)."""
    return None if shares is None else 100.0 * max(max(shares), 0.0)


def verdict(named, unexplained: bool) -> str:
    """What an analysis reported, in a few words: the ``named`` effects, and whether a residual was
    left ``unexplained`` ("hysteresis (then unexplained)", "unexplained", "none")."""
    if named:
        return ", ".join(named) + (" (then unexplained)" if unexplained else "")
    return "unexplained" if unexplained else "none"


def run_hidden_effect(hidden=(), seed: int = 0, duration: float = 240.0, folder=None, size_factor: float = 1.0,
                      backfit_rounds: int | None = None, max_effects: int | None = None):
    """Hide ``hidden`` in generated data, write it to ``folder/measured.parquet`` (a temporary folder
    by default) and analyse that file blind (:func:`analyse_measured`, with at most
    ``backfit_rounds`` backfit rounds and ``max_effects`` named effects when given).

    Returns the analysis (result, signals, split) and the generator's parameters.
    """
    import tempfile

    dataset, generator = generate_measured(hidden, seed, duration, size_factor=size_factor)
    options = {"backfit_rounds": backfit_rounds, "max_effects": max_effects}
    if folder is None:
        with tempfile.TemporaryDirectory() as tmp:
            result, signals, split = analyse_measured(write_measured(dataset, tmp), **options)
    else:
        result, signals, split = analyse_measured(write_measured(dataset, folder), **options)
    return result, signals, split, generator


def run_ablation(name: str, seed: int = 0, duration: float = 240.0, folder=None):
    """Ablation, not a hidden effect: data generated with the full starting structure (the "none"
    data), analysed from the structure without ``name``, with ``name`` added to the candidates: can
    the workflow put back a term the model lacks?"""
    import tempfile

    if name not in ABLATION_CHOICES:
        raise ValueError(f"cannot ablate {name!r}; choose from {', '.join(ABLATION_CHOICES)}")
    dataset, generator = generate_measured((), seed, duration)
    structure = tuple(e for e in STARTING_STRUCTURE if e != name)

    def analyse(path):
        return run_on_raven_dataset(read_measured(path), structure, candidates=LIBRARY + (name,))

    if folder is None:
        with tempfile.TemporaryDirectory() as tmp:
            result, signals, split = analyse(write_measured(dataset, tmp))
    else:
        result, signals, split = analyse(write_measured(dataset, folder))
    return result, signals, split, generator


def starting_model_on(dataset):
    """Step 0 of the blind analysis on a RAVEN-II ``dataset``: its signals, its split in time, the
    arm's kinematics and the starting structure identified on the fit part (:func:`run_on_raven_dataset`
    then fits the offsets on the fit part too, as :func:`held_out_gap` does)."""
    from kinematics import RavenII

    signals = replayed_signals(dataset)
    split = Split.by_time(signals)
    model = raven_base_identifier(dataset, split.fit).identify(STARTING_STRUCTURE, None)
    return signals, split, RavenII(signals.arm, check_limits=False), model


def held_out_residual(model, signals: MeasuredSignals, split: Split, robot) -> np.ndarray:
    """(N_held_out, J) joint residual (SI) of ``model`` on the held-out part, with its offsets fitted
    on the fit part, as the workflow scores its starting model."""
    from simulation.discrepancy.fitting import residual

    offsets = model.offsets + residual(model, signals, robot, mask=split.fit).joint_offsets
    return residual(model.with_offsets(offsets), signals, robot, offsets=np.zeros(signals.n_joints),
                    mask=split.held_out).joints


def held_out_gap(model, signals: MeasuredSignals, split: Split, robot) -> np.ndarray:
    """RMS per joint (SI) of :func:`held_out_residual`: the workflow's ``gap_before`` for the
    starting model."""
    return np.sqrt(np.mean(np.square(held_out_residual(model, signals, split, robot)), axis=0))


def floor_record(seed: int, duration: float, robot_options: dict | None = None):
    """The floor's record and its starting model: seed ``seed``'s motion of ``duration`` seconds
    with nothing hidden, written and read as the blind analysis reads its file, and the starting
    structure identified on it (the signals, split, robot and model of :func:`starting_model_on`).
    The record has the same commanded motion as the seed's hidden-effect records, without the
    re-homing or the payload some hidden effects bring."""
    import tempfile

    dataset, _ = generate_measured((), seed, duration, robot_options=robot_options)
    with tempfile.TemporaryDirectory() as folder:
        dataset = read_measured(write_measured(dataset, folder))
    return starting_model_on(dataset)


def floor_gap(seed: int, duration: float, robot_options: dict | None = None) -> np.ndarray:
    """The floor under an analysis of seed ``seed``'s motion: the held-out gap per joint (SI) the
    identified starting model leaves on the record of the same seed and length with nothing hidden
    (:func:`floor_record`). A hidden effect adds to it; a model of the right structure takes at
    best the effect's part (``studies/discrepancy_floor.py``)."""
    signals, split, robot, model = floor_record(seed, duration, robot_options)
    return held_out_gap(model, signals, split, robot)


def shrink_bound(floor: float, gap: float) -> float:
    """``1 - floor / gap`` of two pooled gaps: about the most of ``gap`` a model replayed this way
    closes (0 where the gap is at the floor or below it)."""
    return max(0.0, 1.0 - floor / gap) if gap > 0 else 0.0


def floor_bound(floor, gap_before, units) -> float:
    """:func:`shrink_bound` of per-joint gaps (SI, in ``units``), each pooled in degrees and
    millimetres."""
    from simulation.discrepancy.signals import pooled_rmse

    return shrink_bound(pooled_rmse(np.asarray(floor)[None, :], units), pooled_rmse(np.asarray(gap_before)[None, :], units))


def oracle(path, hidden, *, backfit_rounds: int = WorkflowSettings().backfit_rounds,
           backfit_acceleration: bool = False, backfit_patience: int = 0,
           named_backfit_patience: int = WorkflowSettings().named_backfit_patience) -> DiscrepancyResult:
    """The generator's true structure fitted to the same fit part of the same file.

    The starting structure is identified as in the blind analysis, then every hidden effect is
    added with its parameters fitted (never given) by the workflow's own steps, whatever it scores.
    Its held-out gap is what a model of the right structure closes by those steps, with at most
    ``backfit_rounds`` backfit rounds, accelerated with ``backfit_acceleration``, going on past
    ``backfit_patience`` rounds in a row that do not lower the residual, and each hidden effect's
    past ``named_backfit_patience`` once it is added (the workflow's defaults unless given).
    """
    hidden = check_hidden(hidden)
    dataset = read_measured(path)
    signals = replayed_signals(dataset)
    split = Split.by_time(signals)
    base = raven_base_identifier(dataset, split.fit, STARTING_STRUCTURE)
    model = base.identify(STARTING_STRUCTURE, None)
    settings = WorkflowSettings(accept_all=True, max_iterations=len(hidden), screen_top=max(len(hidden), 1),
                                backfit_rounds=backfit_rounds, backfit_acceleration=backfit_acceleration,
                                backfit_patience=backfit_patience, named_backfit_patience=named_backfit_patience)
    return run_workflow(model, signals, split, settings, candidates=raven_library(signals, hidden), base=base,
                        controller=controller_of(dataset))


STRUCTURE_FIELDS = {
    "cable_stretch": {"stiffness": ("N m/rad", "N m/rad", "N/m"), "hardening": ("rad", "rad", "m"),
                      "damping": ("N m s/rad", "N m s/rad", "N s/m")},
    "gravity_stretch": {"load_scale": ("1", "1", "1")},
    "coupling": {"delta": ("1", "1", "1")},
    "coulomb_friction": {"force": ("N m", "N m", "N")},
    "viscous_friction": {"coefficient": ("N m s/rad", "N m s/rad", "N s/m")},
}
"""The parameters of each effect of :data:`STARTING_STRUCTURE` that the identification fits, with
the SI unit of each of their three values (the coupling's three: the terms c01, c02, c12)."""


def structure_values(params: RavenParameters, structure=STARTING_STRUCTURE) -> dict[str, dict[str, list[float]]]:
    """The values of the ``structure``'s effects in ``params`` (:data:`STRUCTURE_FIELDS`; SI), for
    the effects ``params`` has enabled: what the identification fitted, or a generator's values."""
    return {name: {field: np.asarray(getattr(params.effect(name), field), dtype=float)[:3].tolist()
                   for field in STRUCTURE_FIELDS[name]}
            for name in structure if name in STRUCTURE_FIELDS and params.is_enabled(name)}


def true_values(generator: RavenParameters, name: str, payload_kg: float = 0.0) -> dict | None:
    """The generator's values of effect ``name`` in its candidate's parameters (for reports after the
    analysis), or None where the generator holds no single value (per-homing offsets are drawn
    anew at each homing). ``payload_kg`` is the undeclared payload of a hidden ``payload``."""
    if name == "payload":
        return {"mass": [float(payload_kg)]}
    if name in PER_HOMING_EFFECTS or not generator.is_enabled(name):
        return None
    effect = generator.effect(name)
    if name == "hysteresis":
        # the candidate's width is 1 / beta and its shape gamma / beta
        return {"stiffness": effect.stiffness.tolist(), "width": (1.0 / effect.beta).tolist(),
                "shape": (effect.gamma / effect.beta).tolist()}
    if name == "drift":
        # the candidate's fatigue dose runs one hour per hour of travel at its own reference speed
        # (time scale 1): its rates carry the generator's scale and the ratio of the reference
        # speeds (the generator's payload term has no counterpart in the candidate)
        from simulation.discrepancy.candidates import DRIFT_REFERENCE_SPEED

        per_dose = effect.time_scale * DRIFT_REFERENCE_SPEED / effect.reference_speed
        return {"creep_rate": (effect.creep_rate * per_dose).tolist(),
                "stiffness_loss": (effect.stiffness_loss * per_dose).tolist()}
    if name == "motor_friction":
        return {"coulomb": effect.coulomb[:3].tolist(), "gearbox_loss": effect.gearbox_loss[:3].tolist()}
    if name == "capstan_friction":
        return {"coefficient": effect.coefficient.tolist()}
    fields = {"backlash": ("half_width",), "capstan_runout": ("amplitude",), "coulomb_friction": ("force",),
              "viscous_friction": ("coefficient",), "gravity_stretch": ("load_scale",), "coupling": ("delta",),
              "transmission_error": ("ratio_error",), "gravity_model_error": ("scale_error",)}
    return {f: np.asarray(getattr(effect, f), dtype=float).tolist() for f in fields.get(name, ())} or None


def run_on_generic(time, reported, truth, joint_names, units, held_out_start: int | None = None,
                   settings: WorkflowSettings = WorkflowSettings(), play_fractions=None, play_drivers: str = "every"):
    """The workflow on data known only by reported and measured joints (nominal model: equal).

    With ``held_out_start``, the samples from that index on (e.g. a second recording appended in
    time) are the held-out part and the rest is split 2:1 into fit and validation.
    ``play_fractions`` replaces the default half-widths of ``coupled_hysteresis``
    (:data:`~simulation.discrepancy.generic.HYSTERESIS_WIDTH_FRACTIONS`) and ``play_drivers`` which
    joints' motion drives each joint's (:data:`~simulation.discrepancy.candidates.PLAY_DRIVERS`;
    every joint's by default).
    """
    signals = MeasuredSignals.generic(time, reported, truth, joint_names, units)
    if held_out_start is None:
        split = Split.by_time(signals)
    else:
        index = np.arange(len(signals))
        first = index < held_out_start
        cut = int(held_out_start * 2 / 3)
        split = Split(fit=index < cut, validation=first & (index >= cut), held_out=~first)
    from simulation.discrepancy.candidates import generic_candidates
    from simulation.discrepancy.generic import HYSTERESIS_WIDTH_FRACTIONS

    model = NominalModel(offsets=np.zeros(signals.n_joints))
    fractions = HYSTERESIS_WIDTH_FRACTIONS if play_fractions is None else play_fractions
    candidates = generic_candidates(signals, fractions, play_drivers)
    return run_workflow(model, signals, split, settings, candidates=candidates), signals, split


def run_on_dvrk(root=None, joints=(3, 4, 5), settings: WorkflowSettings = WorkflowSettings(), play_fractions=None):
    """The workflow on the dVRK data of Hwang et al. 2020: fit and choose on the random motion,
    report on the peg-transfer recording (appended after it in time); ``play_fractions`` as in
    :func:`run_on_generic`. The split "random -> peg" of :func:`~studies.common.dvrk_splits.run_split`."""
    from studies.common.dvrk_splits import ISSUE_SPLIT, run_split

    analysis, _ = run_split(ISSUE_SPLIT, root, joints, settings, play_fractions)
    return analysis


DVRK_CALIBRATORS = ("fixed offset", "linear", "window linear, 5 rows", "DNN 100-100")
"""The learned calibrators the dVRK analysis is compared with (the best of the README's dVRK table
and the paper's network), trained on the same random motion and scored on the same peg transfer."""


def learned_calibrators_on_dvrk(root=None, joints=(3, 4, 5)) -> dict:
    """Held-out RMSE per studied joint (SI) of learned calibrators on the split of :func:`run_on_dvrk`.

    Each is trained on the whole random motion (the workflow's fit and validation parts) with the
    six commanded joints as inputs, in error mode, and scored on the peg-transfer recording (the
    workflow's held-out part). Returns {name: (J,) RMSE}.
    """
    from estimators import DNNCalibrator, FixedOffsetCalibrator, LinearCalibrator, WindowLinearCalibrator
    from studies.common.dvrk_splits import ISSUE_SPLIT, split_parts

    raw = list(range(6))
    makers = {
        "fixed offset": lambda: FixedOffsetCalibrator(raw_columns=raw),
        "linear": lambda: LinearCalibrator(raw_columns=raw),
        "window linear, 5 rows": lambda: WindowLinearCalibrator(raw_columns=raw, window=5),
        "DNN 100-100": lambda: DNNCalibrator(raw_columns=raw, random_state=0, n_threads=1),
    }
    (_, x_train, y_train), (_, x_test, y_test) = split_parts(ISSUE_SPLIT, root)
    joints = list(joints)
    scores = {}
    for name in DVRK_CALIBRATORS:
        predicted = makers[name]().fit(x_train, y_train).predict(x_test)
        scores[name] = np.sqrt(np.mean(np.square(y_test[:, joints] - predicted[:, joints]), axis=0))
    return scores
