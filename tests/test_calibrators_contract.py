"""scikit-learn's estimator contract (`check_estimator`) for every calibrator.

Each calibrator is default-constructed, except that the networks train briefly on one thread
(`max_epochs` low, small hidden sizes for the LSTM and the forest) so that the ~60 checks per
estimator stay fast, and that the polynomial and window-linear models get a small ridge penalty:
some checks fit on 11 to 40 samples of 5 to 10 features, fewer than the 21 to 66 parameters per
target of those models, which refuse such an undetermined least-squares fit without a penalty.
The window calibrators are expected to fail exactly the two checks that assume rows are
independent samples; every other check must pass, except the array-API check that is not run
(see NOT_RUN).
"""

from __future__ import annotations

from functools import partial

import pytest
from sklearn.utils.estimator_checks import parametrize_with_checks

from estimators import DNNCalibrator, FixedOffsetCalibrator, GPRCalibrator, LinearCalibrator
from estimators import PolynomialCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator

# A window calibrator predicts row t from rows t - window + 1 ... t of the given X, so
# predicting a subset or a permutation of X changes the predictions: the two checks below
# assume independent rows and fail by design. They are listed here, with the reason, and not
# hidden with an estimator tag.
ROW_ORDER_DEPENDENT = {
    "check_methods_subset_invariance":
        "a window calibrator's prediction for a row depends on the rows before it",
    "check_methods_sample_order_invariance":
        "a window calibrator's prediction for a row depends on the rows before it",
}

# scikit-learn's check_array_api_input, for an estimator without array-API support (none of the
# calibrators declares it), checks that numpy input gives the same results with array-API dispatch
# switched on; it needs SCIPY_ARRAY_API=1 set before scipy is first imported, and otherwise skips
# itself. Setting it would switch scipy's experimental array-API mode on for the whole test
# session, so the check is left out here rather than reported as 8 skips. (Run with the variable
# set, every calibrator passes it: SCIPY_ARRAY_API=1 and check_array_api_input(name, estimator,
# array_namespace="numpy", expect_only_array_outputs=False).)
NOT_RUN = {"check_array_api_input": "needs SCIPY_ARRAY_API=1 for the whole session"}

CALIBRATORS = [
    FixedOffsetCalibrator(),
    LinearCalibrator(),
    PolynomialCalibrator(alpha=1e-3),
    DNNCalibrator(max_epochs=100, n_threads=1),
    GPRCalibrator(n_threads=1),
    TwoPhaseCalibrator(dnn=DNNCalibrator(max_epochs=100, n_threads=1), n_estimators=10),
    WindowLinearCalibrator(alpha=1e-3),
    WindowLSTMCalibrator(hidden_size=8, learning_rate=1e-2, max_epochs=30, n_threads=1),
]


def _expected_failures(estimator):
    if isinstance(estimator, (WindowLinearCalibrator, WindowLSTMCalibrator)):
        return ROW_ORDER_DEPENDENT
    return {}


def _check_name(check) -> str:
    return check.func.__name__ if isinstance(check, partial) else check.__name__


def _contract_checks():
    """scikit-learn's parametrization of every (calibrator, check) pair, without NOT_RUN."""
    marker = parametrize_with_checks(CALIBRATORS, expected_failed_checks=_expected_failures)
    names, cases = marker.args
    kept = [case for case in cases
            if _check_name(getattr(case, "values", case)[1]) not in NOT_RUN]
    return pytest.mark.parametrize(names, kept, **marker.kwargs)


@_contract_checks()
def test_sklearn_contract(estimator, check):
    check(estimator)
