"""The releases `.ci/floors` installs are the lower bounds `pyproject.toml` declares.

`.ci/floors` runs the suite on the oldest release of each requirement; the check means something
only while its list and the declared bounds are the same releases.
"""

import tomllib
from pathlib import Path

import pytest
from packaging.requirements import Requirement
from packaging.version import Version

ROOT = Path(__file__).resolve().parent.parent


def _declared():
    """Requirements of the package and of the extras the tests install (dev, cluster)."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = project["optional-dependencies"]
    texts = [*project["dependencies"], *extras["dev"], *extras["cluster"]]
    requirements = [Requirement(text) for text in texts]
    return [r for r in requirements if r.name != project["name"]]


def _floors():
    pins = {}
    for line in (ROOT / ".ci" / "floors.txt").read_text().splitlines():
        line = line.split("#", 1)[0].strip()
        if line:
            name, version = line.split("==")
            pins[name.strip().lower()] = Version(version.strip())
    return pins


def _lower_bound(requirement):
    bounds = [Version(spec.version) for spec in requirement.specifier if spec.operator == ">="]
    assert len(bounds) == 1, f"{requirement}: expected one '>=' bound"
    return bounds[0]


@pytest.mark.parametrize("requirement", _declared(), ids=str)
def test_each_declared_lower_bound_is_the_release_the_floor_run_installs(requirement):
    floors = _floors()
    assert requirement.name.lower() in floors, f"{requirement.name} is missing from .ci/floors.txt"
    assert floors[requirement.name.lower()] == _lower_bound(requirement)
    assert requirement.specifier.contains(floors[requirement.name.lower()], prereleases=True)


def test_the_floor_list_names_only_declared_requirements_and_their_extras():
    declared = _declared()
    allowed = {r.name.lower() for r in declared} | {e.lower() for r in declared for e in r.extras}
    assert set(_floors()) <= allowed
