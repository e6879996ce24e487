"""The default fit's drift target: the error operation adds, in quadrature, never negative."""

import numpy as np
import pytest

from simulation.default_fit import (PUBLISHED_DRIFT_PART, PUBLISHED_LINEAR_HOUR0, PUBLISHED_LINEAR_HOUR5,
                                    drift_part)


def test_drift_part_is_what_adds_in_quadrature_to_the_hour0_error():
    assert drift_part(np.array([3.0, 0.5]), np.array([5.0, 1.3])) == pytest.approx([4.0, 1.2])
    # an independent error of that size added to hour 0 gives hour 5 back
    rebuilt = np.hypot(PUBLISHED_LINEAR_HOUR0, PUBLISHED_DRIFT_PART)
    assert rebuilt == pytest.approx(PUBLISHED_LINEAR_HOUR5, rel=1e-12)


def test_drift_part_is_zero_when_operation_did_not_raise_the_error():
    assert drift_part(np.array([0.4, 0.2]), np.array([0.3, 0.2])) == pytest.approx([0.0, 0.0])
