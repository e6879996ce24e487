"""Joint-position estimators: learned calibrators (scikit-learn contract) and the UKF baseline.

The calibrators map one row of robot state X to corrected joint positions y and work on any
robot's (X, y) arrays. They follow scikit-learn's estimator contract, save to a pickle-free
format (`save_calibrator` / `load_calibrator`) and export to numpy-only single-sample
predictors for a servo loop (`to_realtime`) or to dependency-free C for the real-time
controller (`export_c`). A calibrator file that was edited, truncated or corrupted is refused with
`CalibratorFileError`, never loaded silently different.

The model-based baseline `UKFJointEstimator` (with `ProcessNoise`, `JointEstimates` and
`UKFFaultWarning`) lives in
the sub-package `estimators.ukf` and needs the simulator's model layer and identification (numba,
casadi); it is loaded on first access of one of its names (a module ``__getattr__``, PEP 562), so
``import estimators`` alone loads neither the simulator nor casadi.
"""

from estimators.dnn import LARGE_HIDDEN_LAYER_SIZES, LARGE_REGULARIZATION, DNNCalibrator
from estimators.export_c import export_c
from estimators.fixed_offset import FixedOffsetCalibrator
from estimators.gpr import GPRCalibrator
from estimators.linear import LinearCalibrator
from estimators.metrics import pooled_rmse, rmse_per_joint
from estimators.persistence import FORMAT_VERSION, CalibratorFileError, load_calibrator, save_calibrator
from estimators.polynomial import PolynomialCalibrator
from estimators.two_phase import TwoPhaseCalibrator
from estimators.window_linear import WindowLinearCalibrator
from estimators.window_lstm import WindowLSTMCalibrator

__all__ = [
    "CalibratorFileError",
    "DNNCalibrator",
    "FORMAT_VERSION",
    "FixedOffsetCalibrator",
    "GPRCalibrator",
    "LARGE_HIDDEN_LAYER_SIZES",
    "LARGE_REGULARIZATION",
    "LinearCalibrator",
    "PolynomialCalibrator",
    "TwoPhaseCalibrator",
    "JointEstimates",
    "ProcessNoise",
    "UKFFaultWarning",
    "UKFJointEstimator",
    "WindowLSTMCalibrator",
    "WindowLinearCalibrator",
    "export_c",
    "load_calibrator",
    "pooled_rmse",
    "rmse_per_joint",
    "save_calibrator",
]

_UKF_NAMES = {"UKFJointEstimator": "estimators.ukf.estimator", "ProcessNoise": "estimators.ukf.noise",
              "JointEstimates": "estimators.ukf.run", "UKFFaultWarning": "estimators.ukf.run"}


def __getattr__(name):
    """Import the UKF's module on first access of one of its names (see the module docstring)."""
    if name in _UKF_NAMES:
        import importlib

        return getattr(importlib.import_module(_UKF_NAMES[name]), name)
    raise AttributeError(f"module 'estimators' has no attribute {name!r}")
