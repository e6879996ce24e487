"""The model-discrepancy workflow: find where a model and measurements disagree, name the missing
effect from the simulator's library, add it with fitted parameters, and show the gap shrink.

Like a sparse model-discovery method, it is a library of candidate terms (the named effects of
:mod:`simulation.model.effects`) plus a selection (held-out residual reduction with a BIC penalty).
See :mod:`simulation.discrepancy.workflow` for the steps and ``studies/discrepancy.py`` for the
command line.
"""

from simulation.discrepancy.candidates import LIBRARY_NAMES, Candidate, library
from simulation.discrepancy.experiments import (
    HIDDEN_EFFECT_SIZES,
    MEASUREMENT_EFFECTS,
    NOMINAL_STRUCTURE,
    generate_measured,
    identified_model,
    run_hidden_effect,
    run_on_dvrk,
    run_on_generic,
    run_on_raven_dataset,
)
from simulation.discrepancy.generic import NominalModel
from simulation.discrepancy.localize import localize, strongest_dependence
from simulation.discrepancy.replay import RavenModel, ReplayState
from simulation.discrepancy.signals import MeasuredSignals
from simulation.discrepancy.workflow import DiscrepancyResult, Split, WorkflowSettings, run_workflow

__all__ = [
    "Candidate",
    "DiscrepancyResult",
    "HIDDEN_EFFECT_SIZES",
    "LIBRARY_NAMES",
    "MEASUREMENT_EFFECTS",
    "MeasuredSignals",
    "NOMINAL_STRUCTURE",
    "NominalModel",
    "RavenModel",
    "ReplayState",
    "Split",
    "WorkflowSettings",
    "generate_measured",
    "identified_model",
    "library",
    "localize",
    "run_hidden_effect",
    "run_on_dvrk",
    "run_on_generic",
    "run_on_raven_dataset",
    "run_workflow",
    "strongest_dependence",
]
