"""Imports go one way: the calibrators do not load the simulator, the UKF does not load the engine.

Each check runs in a fresh interpreter (the test session itself has imported everything) and
looks at ``sys.modules`` after one import statement.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

HEAVY = ("simulation.engine", "simulation.trajectories", "rosbags", "casadi")


def loaded_after(statement: str) -> set[str]:
    """Top-level packages and simulation sub-packages in ``sys.modules`` after ``statement``."""
    probe = (
        "import json, sys\n"
        f"{statement}\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stderr
    return set(json.loads(done.stdout.strip().splitlines()[-1]))


def test_importing_the_calibrators_loads_no_simulator_engine_trajectories_bags_or_casadi():
    modules = loaded_after("import estimators")
    assert not modules & set(HEAVY), sorted(modules & set(HEAVY))


def test_importing_the_ukf_loads_no_engine_and_no_trajectories():
    modules = loaded_after("from estimators import UKFJointEstimator")
    assert "estimators.ukf.estimator" in modules
    assert not modules & {"simulation.engine", "simulation.trajectories"}


@pytest.mark.parametrize("statement", ["import simulation.model.parameters", "import simulation.model.layout",
                                       "import simulation.model.laws"])
def test_the_model_layer_loads_nothing_above_it(statement):
    modules = loaded_after(statement)
    above = {"simulation.engine", "simulation.trajectories", "simulation.recordings", "simulation.identification",
             "simulation.discrepancy", "rosbags", "casadi", "pandas"}
    assert not modules & above, sorted(modules & above)


def test_the_simulator_names_users_call_still_import_from_simulation():
    modules = loaded_after(
        "from simulation import (CalibrationDataset, RavenParameters, paper_protocol, powered_on,\n"
        "                        record_random_test, recording_to_dataset)\n"
        "import simulation\n"
        "assert set(simulation.__all__) <= set(dir(simulation))\n"
        "for name in simulation.__all__:\n"
        "    getattr(simulation, name)\n"
    )
    assert "simulation.engine.scenarios" in modules


def test_an_unknown_name_is_a_clear_attribute_error():
    import simulation

    with pytest.raises(AttributeError, match="module 'simulation' has no attribute 'paper_protocl'"):
        simulation.paper_protocl  # noqa: B018
