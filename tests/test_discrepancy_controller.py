"""The controller replay: the logged commands against the controller's law, and its one candidate."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from simulation.discrepancy.controller import ControllerLaw, check_controller
from simulation.discrepancy.signals import MeasuredSignals
from simulation.discrepancy.workflow import Split
from simulation.model.constants import RavenConstants
from studies.common.discrepancy_runs import controller_of, generate_measured

pytestmark = pytest.mark.xdist_group("discrepancy-controller")
"""One worker runs this module, so the short records (a module fixture) are generated once."""

DURATION = 30.0


@pytest.fixture(scope="module")
def records():
    """Thirty seconds of random motion with nothing hidden, with the controller's gravity model off
    by the effect's default scale (0.1), and with an undeclared 500 g payload."""
    return {name: generate_measured(hidden, seed=3, duration=DURATION)
            for name, hidden in (("none", ()), ("gravity", ("gravity_model_error",)), ("payload", ("payload",)))}


def _check(dataset):
    law, signals = controller_of(dataset)
    split = Split.by_time(MeasuredSignals.from_dataset(dataset))
    return check_controller(law, signals, split.fit, split.validation, split.held_out, min_shrink=0.1), law, signals


def test_the_law_replays_the_logged_commands_of_the_simulated_controller(records):
    # the engine's compiled controller and this numpy replay of pid_control.cpp + grav_comp.cpp
    # agree to the error of the desired velocity reconstructed from 30 Hz samples: under 1 % of the
    # gravity compensation on every joint
    dataset, _ = records["none"]
    check, law, signals = _check(dataset)
    # (the first and last rows have one-sided velocities only and are left out of the scores)
    assert not signals.usable[0] and not signals.usable[-1] and signals.usable[1:-1].all()
    compensation = law.gravity_compensation(signals)[signals.usable]
    left = (signals.command - law.command(signals))[signals.usable]
    assert np.all(np.sqrt(np.mean(left ** 2, axis=0)) < 0.01 * np.sqrt(np.mean(compensation ** 2, axis=0)))
    assert not check.named
    assert np.all(np.abs(check.scale_error) < 0.005), check.scale_error


def test_a_controller_gravity_model_off_by_a_scale_is_fitted_and_named(records):
    dataset, generator = records["gravity"]
    check, _, _ = _check(dataset)
    assert check.named
    np.testing.assert_allclose(check.scale_error, generator.effect("gravity_model_error").scale_error, atol=0.005)
    # the command gap closes where it was not fitted
    assert np.all(check.held_out_gap_after < 0.1 * check.held_out_gap_before)
    assert check.held_out_gap_kept is check.held_out_gap_after
    assert check.bic_after < check.bic_before


def test_a_payload_the_controller_does_not_know_is_not_a_controller_discrepancy(records):
    # the payload loads the arm, not the law: the controller computes its commands as it always does
    dataset, _ = records["payload"]
    check, _, _ = _check(dataset)
    assert not check.named
    assert check.held_out_gap_kept is check.held_out_gap_before
    assert np.all(np.abs(check.scale_error) < 0.005), check.scale_error


def test_the_workflow_names_it_first_and_leaves_the_transmission_model_as_it_was(records):
    from simulation.discrepancy.workflow import run_workflow
    from studies.common.discrepancy_runs import identified_model, raven_library

    dataset, generator = records["gravity"]
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    result = run_workflow(identified_model(dataset, split.fit), signals, split,
                          candidates=raven_library(signals, ("gravity_model_error",)),
                          controller=controller_of(dataset))
    assert result.named_effects == ("gravity_model_error",)
    np.testing.assert_allclose(result.fitted_parameters["gravity_model_error"]["scale_error"],
                               generator.effect("gravity_model_error").scale_error, atol=0.005)
    assert result.parameter_units["gravity_model_error"] == {"scale_error": ["1", "1", "1"]}
    # the transmission replay sees nothing of it: the joint gap is the starting model's
    np.testing.assert_array_equal(result.gap_after, result.gap_before)
    assert result.model_after is result.model_before
    # without the controller signals the candidate cannot be fitted at all
    blind = run_workflow(identified_model(dataset, split.fit), signals, split,
                         candidates=raven_library(signals, ("gravity_model_error",)))
    assert blind.named_effects == () and blind.controller is None


def test_a_law_with_an_integral_term_is_refused_with_the_problem_named():
    integrating = dataclasses.replace(RavenConstants(), ki=np.array([0.1, 0.0, 0.0, 0.05, 0.05, 0.05, 0.05]))
    with pytest.raises(ValueError, match="integrates the positioning joints' errors"):
        ControllerLaw.nominal(constants=integrating)


def test_the_workflow_refuses_controller_signals_of_another_record(records):
    from simulation.discrepancy.workflow import run_workflow
    from studies.common.discrepancy_runs import identified_model, raven_library

    dataset, _ = records["none"]
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    law, controller = controller_of(dataset)
    shorter = dataclasses.replace(controller, command=controller.command[:-1])
    with pytest.raises(ValueError, match="controller signals have"):
        run_workflow(identified_model(dataset, split.fit), signals, split,
                     candidates=raven_library(signals, ("gravity_model_error",)), controller=(law, shorter))
