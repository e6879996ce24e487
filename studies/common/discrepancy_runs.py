"""Runs of the model-discrepancy workflow (:mod:`simulation.discrepancy`) end to end: on simulated
data with a hidden effect, on recorded RAVEN-II data, and on generic data such as the dVRK
recordings. ``studies/discrepancy.py`` is their command line.

Step 0 starts from a model identified from the measured data itself
(:func:`simulation.identification.identify` on the fit part), never from the parameters that
generated the data.
"""

from __future__ import annotations

import numpy as np

from simulation.model.effects import Backlash, CapstanRunout, Drift
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

NOMINAL_STRUCTURE = ("cable_stretch", "gravity_stretch", "coupling", "coulomb_friction", "viscous_friction")
"""The starting model's structure: the cable model the identification fits (the UKF's model class)."""
MEASUREMENT_EFFECTS = ("quantization", "noise", "homing_offset")
"""Effects of how the robot is measured and registered, always on in generated data: they set the
noise floor and the offsets, and are not structure the workflow is asked to find."""
HIDDEN_EFFECT_SIZES = {
    "backlash": Backlash(half_width=np.array([1.2e-3, 1.5e-3, 6e-5])),
    "drift": Drift(time_scale=60.0),
    "capstan_runout": CapstanRunout(amplitude=np.array([1e-3, 1e-3, 5e-5])),
}
"""Hidden effects whose default size is below what minutes of data resolve are generated at these
sizes: three times the default backlash, drift with one minute standing for an hour of aging, and
the capstan runout of a 60 um eccentric capstan (the effect the library lacks, for the
"unexplained" check). The other effects hide at their virtual RAVEN-II defaults."""


def generate_measured(hidden=(), seed: int = 0, duration: float = 240.0, params: RavenParameters | None = None):
    """Simulated "measured" data: the nominal structure with ``hidden`` effects on.

    Returns the dataset (a :class:`~simulation.recordings.dataset.CalibrationDataset` of one homed session of
    random motion) and the generating parameters (for reports only; the workflow never sees them).
    """
    from kinematics import RavenII
    from simulation.recordings.recording import recording_to_dataset
    from simulation.engine.scenarios import powered_on, record_random_test

    hidden = tuple(hidden)
    base = params or RavenParameters()
    generator = base.only(*NOMINAL_STRUCTURE, *MEASUREMENT_EFFECTS, *hidden)
    for name in hidden:
        if name in HIDDEN_EFFECT_SIZES:
            generator = generator.with_effect(HIDDEN_EFFECT_SIZES[name])
    robot = powered_on(generator, seed=seed)
    recording = record_random_test(robot, duration, seed=seed + 1)
    return recording_to_dataset(recording, RavenII(generator.arm, check_limits=False)), generator


def uninformed_start(arm: str = "left") -> RavenParameters:
    """Round-number starting guesses for the identification, unrelated to any generator's values:
    cables of 50 N m/rad, 20 N m/rad and 1000 N/m hardening over 0.05 rad, 0.05 rad and 5 mm, the
    controller's coupling, small friction."""
    from simulation.model.effects import CableStretch, CoulombFriction, Coupling, ViscousFriction

    params = RavenParameters(arm=arm)
    params = params.with_effect(CableStretch(stiffness=[50.0, 20.0, 1000.0], hardening=[0.05, 0.05, 0.005]))
    params = params.with_effect(Coupling(delta=[0.0, 0.0, 0.0]))
    params = params.with_effect(CoulombFriction(force=[0.1, 0.1, 0.5]))
    return params.with_effect(ViscousFriction(coefficient=[0.1, 0.1, 1.0]))


def identified_model(dataset, mask: np.ndarray, structure=NOMINAL_STRUCTURE) -> RavenModel:
    """Step 0: the cable model of ``structure`` identified on the ``mask`` rows of the dataset,
    starting from :func:`uninformed_start`."""
    import warnings

    from simulation.identification import identify

    with warnings.catch_warnings():
        # how well each parameter is determined is reported by the identification itself; here the
        # workflow's refit and validation decide
        warnings.simplefilter("ignore")
        result = identify(dataset.select(mask), effects=tuple(structure), base=uninformed_start(dataset.arm))
    return RavenModel(result.parameters, np.asarray(result.offsets, dtype=float))


def _with_truth_corrected(dataset, correction: np.ndarray):
    """The dataset with ``correction`` (N, 3) subtracted from its ground-truth joints."""
    from simulation.recordings.dataset import TRUTH_COLUMNS, CalibrationDataset

    table = dataset.table.copy()
    table.loc[:, list(TRUTH_COLUMNS)] = table[list(TRUTH_COLUMNS)].to_numpy() - correction
    return CalibrationDataset(table, arm=dataset.arm)


def raven_base_identifier(dataset, fit_mask: np.ndarray, structure=NOMINAL_STRUCTURE) -> BaseIdentifier:
    """Step 0 and its re-runs: the identification on the fit part of ``dataset``."""
    from simulation.identification import FITTABLE_EFFECTS

    def identify_structure(effects, correction):
        data = dataset if correction is None else _with_truth_corrected(dataset, correction)
        return identified_model(data, fit_mask, effects)

    return BaseIdentifier(identify=identify_structure, fittable=tuple(FITTABLE_EFFECTS), structure=tuple(structure))


def run_on_raven_dataset(dataset, structure=NOMINAL_STRUCTURE, settings: WorkflowSettings = WorkflowSettings(),
                         fractions=(0.5, 0.25, 0.25), exclude=()) -> tuple[DiscrepancyResult, MeasuredSignals, Split]:
    """The workflow on a RAVEN-II dataset: split in time, identify ``structure`` on the fit part, run."""
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals, fractions)
    base = raven_base_identifier(dataset, split.fit, structure)
    model = base.identify(tuple(structure), None)
    return run_workflow(model, signals, split, settings, exclude=exclude, base=base), signals, split


def run_hidden_effect(hidden=(), seed: int = 0, duration: float = 240.0,
                      settings: WorkflowSettings = WorkflowSettings()):
    """Hide ``hidden`` in generated data and run the workflow from the nominal structure without it."""
    hidden = tuple(hidden)
    dataset, generator = generate_measured(hidden, seed, duration)
    structure = tuple(e for e in NOMINAL_STRUCTURE if e not in hidden)
    result, signals, split = run_on_raven_dataset(dataset, structure, settings)
    return result, signals, split, generator


def run_on_generic(time, reported, truth, joint_names, units, held_out_start: int | None = None,
                   settings: WorkflowSettings = WorkflowSettings()):
    """The workflow on data known only by reported and measured joints (nominal model: equal).

    With ``held_out_start``, the samples from that index on (e.g. a second recording appended in
    time) are the held-out part and the rest is split 2:1 into fit and validation.
    """
    signals = MeasuredSignals.generic(time, reported, truth, joint_names, units)
    if held_out_start is None:
        split = Split.by_time(signals)
    else:
        index = np.arange(len(signals))
        first = index < held_out_start
        cut = int(held_out_start * 2 / 3)
        split = Split(fit=index < cut, validation=first & (index >= cut), held_out=~first)
    model = NominalModel(offsets=np.zeros(signals.n_joints))
    return run_workflow(model, signals, split, settings), signals, split


def run_on_dvrk(root=None, joints=(3, 4, 5), settings: WorkflowSettings = WorkflowSettings()):
    """The workflow on the dVRK data of Hwang et al. 2020: fit and choose on the random motion,
    report on the peg-transfer recording (appended after it in time)."""
    from simulation.recordings.dvrk import JOINT_NAMES, PRISMATIC_JOINTS, load_dvrk

    joints = tuple(joints)
    train = load_dvrk(root, "random_unfiltered")
    test = load_dvrk(root, "peg_transfer")
    t_test = test.t - test.t[0] + train.t[-1] + 1.0
    time = np.concatenate([train.t, t_test])
    reported = np.concatenate([train.X[:, :6], test.X[:, :6]])[:, joints]
    truth = np.concatenate([train.y, test.y])[:, joints]
    names = tuple(JOINT_NAMES[j] for j in joints)
    units = tuple("m" if PRISMATIC_JOINTS[j] else "rad" for j in joints)
    return run_on_generic(time, reported, truth, names, units, held_out_start=len(train.t), settings=settings)
