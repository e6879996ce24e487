"""Edges of the calibrators' `fit`: too few samples, repeated raw columns, windows too long.

A least-squares model with more parameters than samples has infinitely many exact fits, and
numpy would return one of them (the minimum-norm one) without a word; a window model fitted on
fewer rows than its window never sees one real window; a network or a Gaussian process on one
sample sees only constant features. Each is refused with a one-line ValueError that names the
calibrator, the number of samples it needs and why, and the number it got. The counts are
checked here against independent computations (scikit-learn's `PolynomialFeatures` for the
monomials), one below and at the boundary. The last test guards the network trainer's direct
call of torch's fused Adam kernel, which must update the weights bit for bit as
`torch.optim.Adam` does.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from sklearn.preprocessing import PolynomialFeatures

from estimators import DNNCalibrator, FixedOffsetCalibrator, GPRCalibrator, LinearCalibrator
from estimators import PolynomialCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator

N_FEATURES, N_TARGETS = 4, 2


def _data(n_samples, n_features=N_FEATURES, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n_samples, n_features))
    y = X[:, :N_TARGETS] + 0.1 * np.tanh(X[:, 1:1 + N_TARGETS]) + 0.01 * rng.normal(
        size=(n_samples, N_TARGETS))
    return X, y


def _small_dnn(**params):
    return DNNCalibrator(hidden_layer_sizes=(4,), max_epochs=1, n_threads=1, random_state=0,
                         **params)


def _monomials(n_features, degree):
    """Monomials of degree 1..degree plus the constant, counted by scikit-learn."""
    return PolynomialFeatures(degree).fit(np.zeros((1, n_features))).n_output_features_


# (calibrator, samples needed, a phrase of the reason)
CASES = {
    "fixed offset": (FixedOffsetCalibrator(raw_columns=[0, 1]), 1, None),
    "linear": (LinearCalibrator(raw_columns=[0, 1]), N_FEATURES + 1,
               r"its 5 parameters per target \(4 weights and an intercept\) by least squares"),
    "linear, ridge": (LinearCalibrator(alpha=0.1), 2, "for a ridge fit"),
    "polynomial": (PolynomialCalibrator(), _monomials(N_FEATURES, 2),
                   r"its 15 parameters per target \(14 monomials of degree 1 to 2 of 4 features"),
    "polynomial, degree 3": (PolynomialCalibrator(degree=3), _monomials(N_FEATURES, 3),
                             "its 35 parameters per target"),
    "polynomial, ridge": (PolynomialCalibrator(alpha=0.1), 2, "for a ridge fit"),
    "window linear": (WindowLinearCalibrator(window=3), 3 * N_FEATURES + 1,
                      r"its 13 parameters per target \(3 rows x 4 weights and an intercept\)"),
    "window linear, ridge, long window": (WindowLinearCalibrator(window=30, alpha=0.1), 30,
                                          "for one full window of 30 rows"),
    "DNN": (_small_dnn(), 2, "to train a network"),
    "DNN, early stopping": (_small_dnn(early_stopping=True, validation_fraction=0.75), 4,
                            r"to hold out validation_fraction=0\.75 of them for early stopping"),
    "GPR": (GPRCalibrator(subset_size=50, hyperparameter_subset_size=20,
                          max_optimizer_iterations=5, random_state=0, n_threads=1), 2,
            "to fit a Gaussian process"),
    "two-phase": (TwoPhaseCalibrator(dnn=_small_dnn(), n_estimators=2, random_state=0), 2,
                  "to train a network"),
    "window LSTM": (WindowLSTMCalibrator(window=6, hidden_size=3, max_epochs=1, n_threads=1,
                                         random_state=0), 6, "for one full window of 6 rows"),
}


def test_the_independent_counts_are_the_textbook_ones():
    assert _monomials(N_FEATURES, 2) == math.comb(N_FEATURES + 2, 2) == 15
    assert _monomials(16, 2) == 153  # the paper's 16 features: 152 monomials + intercept


@pytest.mark.parametrize("case", sorted(case for case in CASES if CASES[case][1] > 1))
def test_too_few_samples_are_refused_with_the_count_needed(case):
    calibrator, needed, reason = CASES[case]
    name = type(calibrator).__name__
    X, y = _data(needed - 1)
    plural = "" if needed - 1 == 1 else "s"
    with pytest.raises(ValueError, match=rf"^{name} needs at least {needed} samples .*{reason}"
                       rf".*; got {needed - 1} sample{plural}\.$") as info:
        calibrator.fit(X, y)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_count_needed_is_enough(case):
    calibrator, needed, _ = CASES[case]
    X, y = _data(needed)
    prediction = calibrator.fit(X, y).predict(X)
    assert prediction.shape == y.shape and np.all(np.isfinite(prediction))


@pytest.mark.parametrize("case", ["DNN", "GPR", "linear", "polynomial", "two-phase"])
def test_one_sample_is_refused_in_scikit_learns_words(case):
    # scikit-learn's check_fit2d_1sample accepts an error that says "1 sample".
    calibrator = CASES[case][0]
    X, y = _data(1)
    with pytest.raises(ValueError, match="got 1 sample"):
        calibrator.fit(X, y)


def test_at_the_boundary_the_least_squares_fit_is_determined():
    # With exactly as many generic samples as parameters the fit is unique and interpolates
    # the data: the counts are the models' true numbers of parameters.
    X, y = _data(N_FEATURES + 1, seed=3)
    np.testing.assert_allclose(LinearCalibrator().fit(X, y).predict(X), y, atol=1e-9)
    X, y = _data(_monomials(N_FEATURES, 2), seed=4)
    np.testing.assert_allclose(PolynomialCalibrator().fit(X, y).predict(X), y, atol=1e-7)


def test_the_polynomial_ridge_still_fits_few_samples():
    # A penalty makes the fit unique, so fewer samples than monomials are accepted.
    X, y = _data(6)
    model = PolynomialCalibrator(alpha=1e-3).fit(X, y)
    assert model.coef_.shape == (_monomials(N_FEATURES, 2) - 1, N_TARGETS)


REPEATABLE = [
    FixedOffsetCalibrator, LinearCalibrator, PolynomialCalibrator, WindowLinearCalibrator,
    lambda **kw: _small_dnn(**kw), lambda **kw: GPRCalibrator(max_optimizer_iterations=2, **kw),
    lambda **kw: TwoPhaseCalibrator(dnn=_small_dnn(), n_estimators=2, **kw),
    lambda **kw: WindowLSTMCalibrator(hidden_size=3, max_epochs=1, n_threads=1, **kw),
]


@pytest.mark.parametrize("make", REPEATABLE, ids=[
    "fixed offset", "linear", "polynomial", "window linear", "DNN", "GPR", "two-phase",
    "window LSTM"])
@pytest.mark.parametrize("raw_columns, repeated", [([0, 0, 0], 0), ([2, 1, 2], 2),
                                                   (np.array([3, 3, 1]), 3)])
def test_repeated_raw_columns_are_refused(make, raw_columns, repeated):
    rng = np.random.default_rng(1)
    X, y = rng.normal(size=(200, 5)), rng.normal(size=(200, 3))
    with pytest.raises(ValueError, match=rf"^raw_columns repeats column {repeated} "
                       r"\(\[\d, \d, \d\]\); each target needs its own column of X"):
        make(raw_columns=raw_columns).fit(X, y)


def test_distinct_raw_columns_in_any_order_are_accepted():
    rng = np.random.default_rng(2)
    X = rng.normal(size=(50, 5))
    y = X[:, [4, 0, 2]] + 0.01
    model = FixedOffsetCalibrator(raw_columns=[4, 0, 2]).fit(X, y)
    np.testing.assert_allclose(model.offset_, 0.01)


@pytest.mark.parametrize("make", [
    lambda window: WindowLinearCalibrator(window=window, alpha=1.0),
    lambda window: WindowLSTMCalibrator(window=window, hidden_size=3, max_epochs=1,
                                        n_threads=1),
], ids=["window linear", "window LSTM"])
def test_a_window_longer_than_the_data_is_refused(make):
    X, y = _data(20)
    with pytest.raises(ValueError, match=r"needs at least 21 samples for one full window of 21 "
                       r"rows; got 20 samples\.$"):
        make(21).fit(X, y)
    make(20).fit(X, y)  # one full window is enough


def test_the_trainers_direct_adam_step_is_torchs_fused_adam_bit_for_bit():
    # The network trainer calls torch's fused Adam kernel directly (no optimizer-class overhead);
    # a torch release that changed the kernel's state or arguments would change the trained
    # weights silently, so the update is compared bit for bit with torch.optim.Adam's.
    torch = pytest.importorskip("torch")
    from estimators._torch_training import MLP_ADAM_EPSILON, FusedAdam

    rng = np.random.default_rng(7)
    start = rng.normal(size=300)
    reference = torch.tensor(start.copy())
    reference.grad = torch.zeros_like(reference)
    optimizer = torch.optim.Adam([reference], lr=1e-3, betas=(0.9, 0.999), eps=MLP_ADAM_EPSILON,
                                 fused=True)
    mine, gradient = torch.tensor(start.copy()), torch.zeros(300, dtype=torch.float64)
    direct = FusedAdam(mine, gradient, 1e-3, 0.9, 0.999, MLP_ADAM_EPSILON)
    with torch.no_grad():
        for _ in range(20):
            step_gradient = torch.from_numpy(rng.normal(size=300) * rng.uniform(1e-3, 10))
            reference.grad.copy_(step_gradient)
            gradient.copy_(step_gradient)
            optimizer.step()
            direct.step()
    assert torch.equal(mine, reference)
    assert not np.array_equal(mine.numpy(), start)
