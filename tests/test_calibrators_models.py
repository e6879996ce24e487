"""Each calibrator against an independent computation of the same model."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from sklearn.ensemble import RandomForestRegressor
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel
from sklearn.linear_model import LinearRegression, Ridge
from sklearn.pipeline import make_pipeline
from sklearn.preprocessing import PolynomialFeatures, StandardScaler
from threadpoolctl import threadpool_limits

from estimators import LARGE_HIDDEN_LAYER_SIZES, LARGE_REGULARIZATION, DNNCalibrator, FixedOffsetCalibrator
from estimators import GPRCalibrator, LinearCalibrator, PolynomialCalibrator, TwoPhaseCalibrator, pooled_rmse
from estimators import rmse_per_joint
from estimators import _gaussian_process as gp
from estimators._forest import FlatForest
from estimators._torch_training import MLPSettings, TrainingSettings, _MLPTrainee
from estimators._monomials import MonomialPlan
from estimators.realtime import ForestPredictor


def regression_data(n_samples=300, n_features=4, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n_samples, n_features)) * [1.0, 0.1, 5.0, 0.01][:n_features]
    y = np.column_stack([
        X[:, 0] + 0.3 * np.sin(2 * X[:, 0]) + 0.1 * X[:, 2],
        X[:, 1] - 0.2 * X[:, 0] * X[:, 2] + 0.05 * rng.normal(size=n_samples),
    ])
    return X, y


# --- fixed offset -------------------------------------------------------------------------

def test_fixed_offset_adds_the_mean_training_error():
    X, y = regression_data()
    calibrator = FixedOffsetCalibrator(raw_columns=[0, 1]).fit(X, y)
    X_new, _ = regression_data(seed=1)
    expected = X_new[:, [0, 1]] + (y - X[:, [0, 1]]).mean(axis=0)
    np.testing.assert_allclose(calibrator.predict(X_new), expected)


def test_fixed_offset_end_to_end_predicts_the_mean_of_y():
    X, y = regression_data()
    calibrator = FixedOffsetCalibrator().fit(X, y)
    np.testing.assert_allclose(calibrator.predict(X[:7] * 100.0), np.tile(y.mean(axis=0), (7, 1)))


# --- linear and polynomial ----------------------------------------------------------------

def test_linear_recovers_an_exact_affine_map_with_a_constant_column():
    rng = np.random.default_rng(2)
    X = rng.normal(size=(50, 4))
    X[:, 2] = 3.0
    weights = np.array([[1.5, -0.2], [0.3, 2.0], [0.0, 0.0], [-4.0, 0.1]])
    y = X @ weights + [0.7, -1.1]
    calibrator = LinearCalibrator().fit(X, y)
    np.testing.assert_allclose(calibrator.coef_, weights, atol=1e-10)
    np.testing.assert_allclose(calibrator.intercept_ + 3.0 * calibrator.coef_[2], [0.7, -1.1],
                               atol=1e-10)


def test_linear_error_mode_and_end_to_end_agree():
    """With the raw positions among the inputs, learning the error or the position itself
    spans the same affine models (the paper found no difference for regression)."""
    X, y = regression_data()
    error_mode = LinearCalibrator(raw_columns=[0, 1]).fit(X, y)
    end_to_end = LinearCalibrator().fit(X, y)
    np.testing.assert_allclose(error_mode.predict(X), end_to_end.predict(X), atol=1e-10)


@pytest.mark.parametrize("alpha", [0.0, 3.0])
def test_linear_matches_scikit_learn_ridge_on_standardized_features(alpha):
    X, y = regression_data()
    reference = make_pipeline(StandardScaler(), Ridge(alpha=alpha) if alpha else LinearRegression())
    np.testing.assert_allclose(LinearCalibrator(alpha=alpha).fit(X, y).predict(X),
                               reference.fit(X, y).predict(X), atol=1e-9)


@pytest.mark.parametrize("degree", [2, 3])
def test_polynomial_matches_scikit_learn_polynomial_regression(degree):
    X, y = regression_data(n_samples=400)
    reference = make_pipeline(StandardScaler(), PolynomialFeatures(degree, include_bias=False),
                              LinearRegression())
    calibrator = PolynomialCalibrator(degree=degree).fit(X, y)
    np.testing.assert_allclose(calibrator.predict(X), reference.fit(X, y).predict(X), atol=1e-8)
    assert calibrator.coef_.shape[0] == reference[1].n_output_features_


def test_monomial_reexpansion_is_exact():
    rng = np.random.default_rng(4)
    plan = MonomialPlan.build(n_features=3, degree=3)
    coef, intercept = rng.normal(size=(plan.n_terms, 2)), rng.normal(size=2)
    slope, offset = rng.uniform(0.5, 2.0, 3), rng.normal(size=3)
    x = rng.normal(size=(10, 3))
    coef_x, intercept_x = plan.reexpand(coef, intercept, slope, offset)
    np.testing.assert_allclose(plan.evaluate(x) @ coef_x + intercept_x,
                               plan.evaluate(slope * x + offset) @ coef + intercept, atol=1e-10)


# --- DNN ----------------------------------------------------------------------------------

def test_dnn_defaults_are_the_papers_network():
    params = DNNCalibrator().get_params()
    assert params["hidden_layer_sizes"] == (100, 100)
    assert params["activation"] == "sigmoid"
    assert params["kernel_l2"] == 5e-4
    assert (params["learning_rate"], params["beta_1"], params["beta_2"]) == (1e-3, 0.9, 0.999)
    assert params["batch_size"] == 1024 and params["max_epochs"] == 200
    assert params["early_stopping"] is False


def test_dnn_large_preset_keeps_overrides():
    large = DNNCalibrator.large(max_epochs=3, kernel_l2=0.0)
    assert large.hidden_layer_sizes == LARGE_HIDDEN_LAYER_SIZES == (600, 500, 400)
    assert large.kernel_l2 == 0.0 and large.max_epochs == 3
    assert large.kernel_l1 == LARGE_REGULARIZATION["kernel_l1"]
    assert large.activity_l2 == LARGE_REGULARIZATION["activity_l2"]


def _keras_loss(weights, biases, inputs, targets, config):
    """The regularized batch loss written directly with autograd."""
    layer, penalty = inputs, 0.0
    activation = {"sigmoid": torch.sigmoid, "tanh": torch.tanh,
                  "relu": torch.relu}[config.activation]
    for index, (weight, bias) in enumerate(zip(weights, biases)):
        layer = layer @ weight + bias
        penalty = penalty + config.kernel_l2 * torch.sum(weight**2) \
            + config.kernel_l1 * torch.sum(torch.abs(weight)) + config.bias_l2 * torch.sum(bias**2)
        if index < len(weights) - 1:
            layer = activation(layer)
            penalty = penalty + config.activity_l2 * torch.sum(layer**2) / inputs.shape[0]
    return torch.mean((layer - targets) ** 2) + penalty


@pytest.mark.parametrize("activation", ["sigmoid", "tanh", "relu"])
def test_dnn_hand_written_gradients_match_autograd(activation):
    rng = np.random.default_rng(5)
    sizes = (4, 7, 5, 3)
    weights = [rng.normal(size=(a, b)) * 0.5 for a, b in zip(sizes[:-1], sizes[1:])]
    biases = [rng.normal(size=b) * 0.1 for b in sizes[1:]]
    inputs, targets = rng.normal(size=(32, 4)), rng.normal(size=(32, 3))
    config = MLPSettings(activation=activation, kernel_l2=3e-3, kernel_l1=2e-3, bias_l2=1e-2,
                         activity_l2=5e-3)
    settings = TrainingSettings(learning_rate=1e-3, beta_1=0.9, beta_2=0.999, batch_size=32,
                                max_epochs=1, early_stopping=None)
    network = _MLPTrainee(weights, biases, config, settings, batch_size=32)
    network.optimizer.step = lambda: None  # keep the gradients, skip the update
    with torch.no_grad():
        network.step(torch.from_numpy(inputs), torch.from_numpy(targets), torch.arange(32))

    leaves_w = [torch.tensor(w, requires_grad=True) for w in weights]
    leaves_b = [torch.tensor(b, requires_grad=True) for b in biases]
    _keras_loss(leaves_w, leaves_b, torch.from_numpy(inputs), torch.from_numpy(targets),
                config).backward()
    for mine, reference in zip(network.weight_grads + network.bias_grads, leaves_w + leaves_b):
        np.testing.assert_allclose(mine.numpy(), reference.grad.numpy(), rtol=1e-10, atol=1e-12)


def test_dnn_learns_a_nonlinear_error_that_a_linear_model_cannot():
    rng = np.random.default_rng(6)
    X = rng.uniform(-2, 2, size=(3000, 2))
    y = X[:, :1] + 0.1 * X[:, 1:2] ** 2  # symmetric: no affine map can follow it
    dnn = DNNCalibrator(raw_columns=[0], hidden_layer_sizes=(32, 32), batch_size=128,
                        max_epochs=60, learning_rate=1e-2, kernel_l2=1e-6, random_state=0,
                        n_threads=1).fit(X, y)
    linear = LinearCalibrator(raw_columns=[0]).fit(X, y)
    assert rmse_per_joint(y, dnn.predict(X))[0] < 0.1 * rmse_per_joint(y, linear.predict(X))[0]
    assert dnn.coefs_[0].dtype == np.float64 and dnn.predict(X).dtype == np.float64
    assert dnn.loss_curve_[-1] < dnn.loss_curve_[0]


@pytest.mark.parametrize("calibrator", [
    DNNCalibrator(activation="tanh", hidden_layer_sizes=(9, 7)),
    DNNCalibrator(activation="relu", hidden_layer_sizes=(9,)),
    DNNCalibrator(hidden_layer_sizes=()),
    DNNCalibrator.large(),
], ids=["tanh", "relu", "no hidden layer", "large preset"])
def test_dnn_realtime_form_matches_predict_for_every_architecture(calibrator):
    X, y = regression_data(n_samples=200)
    calibrator.set_params(raw_columns=[0, 1], max_epochs=2, random_state=0, n_threads=1)
    calibrator.fit(X, y)
    predictor = calibrator.to_realtime()
    np.testing.assert_allclose([predictor(row) for row in X[:30]], calibrator.predict(X[:30]),
                               rtol=0, atol=1e-9)


def test_dnn_early_stopping_keeps_the_best_validation_epoch():
    rng = np.random.default_rng(7)
    X, y = rng.normal(size=(400, 3)), rng.normal(size=400)  # nothing to learn: stops early
    dnn = DNNCalibrator(hidden_layer_sizes=(64,), learning_rate=3e-2, batch_size=32,
                        max_epochs=200, early_stopping=True, n_iter_no_change=3,
                        random_state=0, n_threads=1).fit(X, y)
    assert dnn.n_epochs_ < 200
    assert len(dnn.validation_loss_curve_) == dnn.n_epochs_
    assert dnn.best_epoch_ == int(np.argmin(dnn.validation_loss_curve_)) + 1
    held_out = slice(360, 400)  # the last 10 % of the rows, in the given order
    standardized = (dnn.predict(X[held_out]) - dnn.target_mean_) / dnn.target_scale_
    target = (y[held_out] - dnn.target_mean_) / dnn.target_scale_
    np.testing.assert_allclose(np.mean((standardized - target) ** 2),
                               dnn.validation_loss_curve_.min(), rtol=1e-9)


def test_dnn_thread_setting_is_restored():
    before = torch.get_num_threads()
    X, y = regression_data(n_samples=50)
    # a thread count other than the current one, so that a fit that kept its own would be seen
    DNNCalibrator(hidden_layer_sizes=(4,), max_epochs=2, n_threads=before % 2 + 1).fit(X, y)
    assert torch.get_num_threads() == before


# --- Gaussian process ---------------------------------------------------------------------

def test_gp_likelihood_gradient_matches_finite_differences():
    rng = np.random.default_rng(8)
    X, Y = rng.normal(size=(40, 3)), rng.normal(size=(40, 2))
    point = np.log([0.7, 1.3, 2.0, 1.5, 0.2])
    _, gradient = gp.negative_log_likelihood(point, X, Y)
    step = 1e-6
    numeric = [(gp.negative_log_likelihood(point + step * e, X, Y)[0]
                - gp.negative_log_likelihood(point - step * e, X, Y)[0]) / (2 * step)
               for e in np.eye(point.size)]
    np.testing.assert_allclose(gradient, numeric, rtol=1e-5, atol=1e-6)


def test_gpr_posterior_mean_matches_scikit_learn_with_the_same_kernel():
    X, y = regression_data(n_samples=150)
    calibrator = GPRCalibrator(subset_size=500, random_state=0, n_threads=1).fit(X, y)
    scaler = StandardScaler().fit(X)
    kernel = (ConstantKernel(calibrator.signal_variance_, "fixed")
              * RBF(calibrator.length_scale_, "fixed")
              + WhiteKernel(calibrator.noise_variance_, "fixed"))
    reference = GaussianProcessRegressor(kernel, optimizer=None, normalize_y=True)
    reference.fit(scaler.transform(X), y)
    # scikit-learn predicts the noise-free latent mean too; its normalization uses the same
    # per-column mean and standard deviation.
    np.testing.assert_allclose(calibrator.predict(X[:50]),
                               reference.predict(scaler.transform(X[:50])), atol=1e-6)


def test_kernel_fit_raises_the_likelihood_and_gpr_fits_a_smooth_function():
    X, y = regression_data(n_samples=300)
    standardized, targets = StandardScaler().fit_transform(X), StandardScaler().fit_transform(y)
    initial = gp.KernelParameters(np.full(4, 2.0), 1.0, 0.1)
    with threadpool_limits(limits=1, user_api="blas"):
        fitted, _ = gp.optimize_kernel(standardized, targets, initial, (1e-2, 1e3), (1e-6, 1.0),
                                       100)
    assert (gp.negative_log_likelihood(fitted.to_log_vector(), standardized, targets)[0]
            < gp.negative_log_likelihood(initial.to_log_vector(), standardized, targets)[0] - 10)
    assert GPRCalibrator(random_state=0, n_threads=1).fit(X, y).score(X, y) > 0.95


# --- two-phase and forests ----------------------------------------------------------------

@pytest.mark.parametrize("n_outputs", [1, 2])
def test_flat_forest_predicts_like_scikit_learn(n_outputs):
    X, y = regression_data(n_samples=300)
    target = y[:, 0] if n_outputs == 1 else y
    forest = RandomForestRegressor(n_estimators=7, min_samples_leaf=3, random_state=0)
    forest.fit(X, target)
    flat = FlatForest.from_sklearn(forest)
    expected = forest.predict(X).reshape(len(X), -1)
    np.testing.assert_allclose(flat.predict(X), expected, atol=1e-12)
    predictor = ForestPredictor(flat)
    np.testing.assert_allclose([predictor(row) for row in X[:20]], expected[:20], atol=1e-12)


def test_two_phase_adds_a_forest_on_the_network_residual():
    X, y = regression_data(n_samples=400)
    calibrator = TwoPhaseCalibrator(
        raw_columns=[0, 1], n_estimators=20, random_state=0,
        dnn=DNNCalibrator(hidden_layer_sizes=(8,), max_epochs=30, batch_size=64,
                          n_threads=1)).fit(X, y)
    network = calibrator.dnn_.predict(X)
    np.testing.assert_allclose(calibrator.predict(X),
                               X[:, [0, 1]] + network + calibrator.forest_.predict(X), atol=1e-12)
    assert (pooled_rmse(y, calibrator.predict(X))
            < pooled_rmse(y, X[:, [0, 1]] + network))


# --- metrics ------------------------------------------------------------------------------

def test_rmse_helpers_match_their_definitions():
    truth = np.array([[0.0, 1.0], [1.0, 1.0], [2.0, 1.0]])
    estimate = np.array([[0.0, 1.3], [1.2, 0.7], [2.0, 1.0]])
    np.testing.assert_allclose(rmse_per_joint(truth, estimate),
                               [np.sqrt(0.04 / 3), np.sqrt(0.18 / 3)])
    assert pooled_rmse(truth, estimate) == pytest.approx(np.sqrt(0.22 / 6))
    assert pooled_rmse(truth, estimate, columns=[1]) == pytest.approx(np.sqrt(0.18 / 3))


@pytest.mark.parametrize("truth, estimate, columns, message", [
    (np.zeros((3, 2)), np.zeros((3, 3)), None, "same shape"),
    (np.zeros((0, 2)), np.zeros((0, 2)), None, "no samples"),
    (np.array([[np.nan, 0.0]]), np.zeros((1, 2)), None, "y_true contains NaN"),
    (np.zeros((3, 2)), np.zeros((3, 2)), [2], "not valid joint indices"),
])
def test_rmse_helpers_refuse_bad_input(truth, estimate, columns, message):
    with pytest.raises(ValueError, match=message):
        pooled_rmse(truth, estimate, columns)
