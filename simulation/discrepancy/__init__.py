"""The model-discrepancy workflow: find where a model and measurements disagree, name the missing
effect from the simulator's library, add it with fitted parameters, and show the gap shrink; what
no candidate explains is reported as unexplained, with a signature in words. A RAVEN-II log is
replayed twice: its transmission (motor positions to joints and motor torques) and its controller
(desired and measured motor positions to the logged commands, :mod:`~simulation.discrepancy.controller`).

Like a sparse model-discovery method, it is a library of candidate terms (the named effects of
:mod:`simulation.model.effects`) plus a selection (held-out residual reduction with a BIC penalty).
See :mod:`simulation.discrepancy.workflow` for the steps; the runs on simulated data with a hidden
effect, on recorded RAVEN-II data and on the dVRK recordings are in
:mod:`studies.common.discrepancy_runs`, with ``studies/discrepancy.py`` as their command line.
"""

from simulation.discrepancy.candidates import CONTROLLER_CANDIDATES, LIBRARY_NAMES, RAVEN_LIBRARY, Candidate, library
from simulation.discrepancy.controller import ControllerCheck, ControllerLaw, ControllerSignals, check_controller
from simulation.discrepancy.generic import NominalModel
from simulation.discrepancy.localize import localize, strongest_dependence
from simulation.discrepancy.replay import RavenModel, ReplayState
from simulation.discrepancy.signals import MeasuredSignals
from simulation.discrepancy.signature import Signature, describe_residual
from simulation.discrepancy.workflow import BaseIdentifier, DiscrepancyResult, Split, WorkflowSettings, run_workflow

__all__ = [
    "BaseIdentifier",
    "CONTROLLER_CANDIDATES",
    "Candidate",
    "ControllerCheck",
    "ControllerLaw",
    "ControllerSignals",
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
    "check_controller",
    "describe_residual",
    "library",
    "localize",
    "run_workflow",
    "strongest_dependence",
]
