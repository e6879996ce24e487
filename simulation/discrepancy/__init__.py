"""The model-discrepancy workflow: find where a model and measurements disagree, name the missing
effect from the simulator's library, add it with fitted parameters, and show the gap shrink; what
no candidate explains is reported as unexplained, with a signature in words.

Like a sparse model-discovery method, it is a library of candidate terms (the named effects of
:mod:`simulation.model.effects`) plus a selection (held-out residual reduction with a BIC penalty).
See :mod:`simulation.discrepancy.workflow` for the steps; the runs on simulated data with a hidden
effect, on recorded RAVEN-II data and on the dVRK recordings are in
:mod:`studies.common.discrepancy_runs`, with ``studies/discrepancy.py`` as their command line.
"""

from simulation.discrepancy.candidates import LIBRARY_NAMES, RAVEN_LIBRARY, Candidate, library
from simulation.discrepancy.generic import NominalModel
from simulation.discrepancy.localize import localize, strongest_dependence
from simulation.discrepancy.replay import RavenModel, ReplayState
from simulation.discrepancy.signals import MeasuredSignals
from simulation.discrepancy.signature import Signature, describe_residual
from simulation.discrepancy.workflow import BaseIdentifier, DiscrepancyResult, Split, WorkflowSettings, run_workflow

__all__ = [
    "BaseIdentifier",
    "Candidate",
    "DiscrepancyResult",
    "LIBRARY_NAMES",
    "MeasuredSignals",
    "NominalModel",
    "RAVEN_LIBRARY",
    "RavenModel",
    "ReplayState",
    "Signature",
    "Split",
    "WorkflowSettings",
    "describe_residual",
    "library",
    "localize",
    "run_workflow",
    "strongest_dependence",
]
