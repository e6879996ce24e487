"""The calibration methods a study compares, each as a named recipe that builds a fresh estimator.

Every method answers ``fit(samples)`` then ``predict(samples)`` with joints 1-3 (N, 3) in SI
units. The learned calibrators of :mod:`estimators` are wrapped by :class:`CalibratorOnSamples`
(train on the error by default, time-ordered prediction per recording for the temporal-window
models); ``raw`` returns the motor-encoder joints; the UKF
(:class:`estimators.UKFJointEstimator`) filters each recording of the samples' robot state
(:class:`UKFOnSamples`; ``ukf_disturbance`` with disturbance-torque states), and ``ukf_hybrid``
corrects its estimates with a learned calibrator of its residual (:class:`UKFHybridOnSamples`). A :class:`Method` is picklable, so sweeps can ship it to workers.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial
from typing import Callable, Protocol

import numpy as np
from sklearn.base import clone

from estimators import DNNCalibrator, FixedOffsetCalibrator, GPRCalibrator, LinearCalibrator
from estimators import PolynomialCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator

from studies.common.samples import Samples


class SampleEstimator(Protocol):
    """What every method builds: fit on samples, predict joints 1-3 (N, 3) in SI units."""

    def fit(self, samples: Samples) -> "SampleEstimator": ...

    def predict(self, samples: Samples) -> np.ndarray: ...


class RawJoints:
    """No calibration: the joints the motor encoders report."""

    def fit(self, samples: Samples) -> "RawJoints":
        return self

    def predict(self, samples: Samples) -> np.ndarray:
        return samples.raw_joints.copy()


class CalibratorOnSamples:
    """A learned calibrator (scikit-learn contract) trained and applied on :class:`Samples`.

    Parameters
    ----------
    calibrator : an unfitted calibrator of :mod:`estimators`; cloned at fit time.
    train_on_error : learn ``truth - raw`` and add it to the raw joints (the paper's choice),
        else learn the joints end-to-end.
    temporal : the calibrator reads a window of past rows: training rows must be consecutive log
        samples, and prediction runs recording by recording from its first row.
    max_train_samples : train on at most this many rows, drawn at random without replacement
        with ``seed`` (for a temporal model, a contiguous block from the start of each recording,
        the same number of rows from each, so every recording is seen); None: all.
    seed : seeds the subsample.
    """

    def __init__(self, calibrator, *, train_on_error: bool = True, temporal: bool = False,
                 max_train_samples: int | None = None, seed: int = 0) -> None:
        self.calibrator = calibrator
        self.train_on_error = train_on_error
        self.temporal = temporal
        self.max_train_samples = max_train_samples
        self.seed = seed

    def _training_rows(self, samples: Samples) -> Samples:
        limit = self.max_train_samples
        if limit is None or len(samples) <= limit:
            return samples
        if self.temporal:
            blocks = samples.recordings()
            share = int(limit) // len(blocks)
            if share < 2:
                return samples.select(np.arange(int(limit)))
            return samples.select(np.concatenate([block[:share] for block in blocks]))
        rows = np.sort(np.random.default_rng(self.seed).choice(len(samples), int(limit), replace=False))
        return samples.select(rows)

    def _check_history(self, samples: Samples) -> None:
        if self.temporal and samples.stride != 1:
            raise ValueError(
                f"{type(self.calibrator).__name__} reads a window of past rows, but these samples keep "
                f"only every {samples.stride}th log sample")

    def fit(self, samples: Samples) -> "CalibratorOnSamples":
        self._check_history(samples)
        train = self._training_rows(samples)
        model = clone(self.calibrator)
        model.set_params(raw_columns=list(train.raw_columns) if self.train_on_error else None)
        if self.temporal and len(train.recordings()) > 1:
            X, y = _separated_recordings(train, int(model.get_params()["window"]))
        else:
            X, y = train.X, train.targets
        model.fit(X, y)
        self.model_ = model
        return self

    def predict(self, samples: Samples) -> np.ndarray:
        self._check_history(samples)
        if not self.temporal:
            return np.asarray(self.model_.predict(samples.X), dtype=np.float64)
        out = np.empty((len(samples), 3))
        for rows in samples.recordings():
            out[rows] = self.model_.predict(samples.X[rows])
        return out


class UKFOnSamples:
    """The UKF of Haghighipanah et al. (:class:`estimators.UKFJointEstimator`) on :class:`Samples`.

    The filter reads the full robot state of consecutive log samples (``samples.dataset``): it
    identifies its cable model on the training samples and filters each test recording from its
    start. It is deterministic: it has no seed, and one run stands for all seeds.

    Parameters
    ----------
    **options
        Hyper-parameters of :class:`estimators.UKFJointEstimator` (e.g. ``tuning="none"``).
    """

    def __init__(self, **options) -> None:
        self.options = options

    @staticmethod
    def _check(samples: Samples) -> None:
        if samples.dataset is None:
            raise ValueError("the UKF needs the full robot state (motor torques); these samples do not carry it")
        if samples.stride != 1:
            raise ValueError("the UKF filters consecutive log samples; these samples were thinned")

    def fit(self, samples: Samples) -> "UKFOnSamples":
        # imported here: the filter's model class loads the identification (casadi), which the
        # learned calibrators do not need
        from estimators import UKFJointEstimator

        self._check(samples)
        self.filter_ = UKFJointEstimator(**self.options).fit(samples.dataset)
        return self

    def predict(self, samples: Samples) -> np.ndarray:
        """Filter each recording of the samples from its start; joints 1-3 (N, 3), SI."""
        self._check(samples)
        out = np.empty((len(samples), 3))
        self.events_ = {"rejected": 0, "coasted": 0, "reinitialised": 0}     # summed over the recordings
        for rows in samples.recordings():
            estimates = self.filter_.predict(samples.dataset.select(rows))
            self.events_ = {key: count + estimates.events[key] for key, count in self.events_.items()}
            joints = np.asarray(estimates.joints, dtype=np.float64)
            if joints.ndim != 2 or joints.shape[0] != rows.size or joints.shape[1] < 3:
                raise ValueError(f"the UKF returned estimates of shape {joints.shape}; expected ({rows.size}, >=3)")
            if not np.all(np.isfinite(joints[:, :3])):
                raise ValueError("the UKF returned non-finite joint estimates")
            out[rows] = joints[:, :3]
        return out


class UKFHybridOnSamples:
    """The UKF followed by a learned calibrator of its residual (truth minus the UKF's joints).

    A :class:`Method` on :class:`Samples` rather than a calibrator of :mod:`estimators`, because it
    needs both what a calibrator reads (``samples.X``) and the consecutive robot state the filter
    reads (``samples.dataset``), which only :class:`Samples` carries together.

    The calibrator reads the samples' usual features plus the UKF's joint estimates (three columns
    appended) and is trained on the error relative to those estimates (its ``raw_columns`` are the
    appended columns), so it learns ``truth - UKF``. Its training estimates come from the filter
    run causally over each calibration recording from its start (the same filtered, never
    smoothed, estimates a test log gets). They are still somewhat optimistic: the cable model and
    the noise were identified on that same log, so its residual there is smaller than on new data.

    Parameters
    ----------
    calibrator : an unfitted calibrator with a ``raw_columns`` parameter (default: linear regression).
    **options
        Hyper-parameters of :class:`estimators.UKFJointEstimator`.
    """

    def __init__(self, calibrator=None, **options) -> None:
        self.calibrator = calibrator
        self.options = options

    def _features(self, samples: Samples) -> np.ndarray:
        return np.hstack([samples.X, self.filter_.predict(samples)])

    def fit(self, samples: Samples) -> "UKFHybridOnSamples":
        self.filter_ = UKFOnSamples(**self.options).fit(samples)
        X = self._features(samples)
        model = clone(self.calibrator if self.calibrator is not None else LinearCalibrator())
        model.set_params(raw_columns=list(range(samples.X.shape[1], X.shape[1])))
        model.fit(X, samples.targets)
        self.model_ = model
        return self

    def predict(self, samples: Samples) -> np.ndarray:
        """Joints 1-3 (N, 3), SI: the UKF's estimates plus the calibrator's predicted residual."""
        X = self._features(samples)
        self.events_ = self.filter_.events_
        return np.asarray(self.model_.predict(X), dtype=np.float64)


def _separated_recordings(samples: Samples, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Rows of several recordings for a window model, so that no window spans two of them.

    Each recording after the first is preceded by ``window - 1`` copies of its own first row
    (with that row's targets): a window reaching back past the start of a recording sees the
    robot at rest at its first state, as the window models pad the start of a single recording.
    """
    X_parts, y_parts = [], []
    for k, rows in enumerate(samples.recordings()):
        X, y = samples.X[rows], samples.targets[rows]
        if k and window > 1:
            X_parts.append(np.repeat(X[:1], window - 1, axis=0))
            y_parts.append(np.repeat(y[:1], window - 1, axis=0))
        X_parts.append(X)
        y_parts.append(y)
    return np.vstack(X_parts), np.vstack(y_parts)


UKF_TUNINGS = ("likelihood", "joint_error", "none")
UKF_SCALES = ("chosen", "nominal")


@dataclass(frozen=True)
class MethodSettings:
    """Training budgets of the methods (the paper's values by default).

    Attributes
    ----------
    dnn_seeds : training seeds averaged for the networks (the paper: 5).
    dnn_epochs : epochs of the paper's DNN (200).
    lstm_epochs : epochs of the window LSTM.
    window : rows in the window of the temporal models (Hwang et al.: the current one and 4 before).
    forest_trees : trees of the two-phase model's random forest.
    two_phase_max_samples : training rows of the two-phase model (None: all).
    gpr_subset : support points of the Gaussian process.
    gpr_hyper_subset : points of the kernel hyper-parameter fit.
    lstm_max_samples : training rows of the window LSTM (None: all).
    ukf_tuning : how the UKF tunes its process noise on the calibration run (``"likelihood"``,
        ``"joint_error"``, or ``"none"``: keep the noise derived from the identification).
    ukf_scales : ``"chosen"``: the UKF chooses its friction smoothing scale and its coasting noise
        on the calibration run (held-out filter runs, most of its fit's time); ``"nominal"``: it keeps
        the nominal smoothing scale and no extra coasting noise, for checks of the pipeline.
    n_threads : torch/BLAS threads per fit (1 lets parallel sweeps use one core per task).
    """

    dnn_seeds: int = 5
    dnn_epochs: int = 200
    lstm_epochs: int = 20
    window: int = 5
    forest_trees: int = 50
    two_phase_max_samples: int | None = None
    gpr_subset: int = 2000
    gpr_hyper_subset: int = 500
    lstm_max_samples: int | None = None
    ukf_tuning: str = "likelihood"
    ukf_scales: str = "chosen"
    n_threads: int = 1

    def __post_init__(self) -> None:
        for name in ("dnn_seeds", "dnn_epochs", "lstm_epochs", "window", "forest_trees", "gpr_subset",
                     "gpr_hyper_subset", "n_threads"):
            value = getattr(self, name)
            if int(value) != value or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.ukf_tuning not in UKF_TUNINGS:
            raise ValueError(f"ukf_tuning must be one of {UKF_TUNINGS}, got {self.ukf_tuning!r}")
        if self.ukf_scales not in UKF_SCALES:
            raise ValueError(f"ukf_scales must be one of {UKF_SCALES}, got {self.ukf_scales!r}")
        for name in ("two_phase_max_samples", "lstm_max_samples"):
            value = getattr(self, name)
            if value is not None and (int(value) != value or value < 1):
                raise ValueError(f"{name} must be None or a positive integer, got {value!r}")

    @classmethod
    def quick(cls) -> "MethodSettings":
        """Short budgets for a quick look: one network seed, few LSTM epochs, subsampled slow peers,
        an untuned UKF."""
        return cls(dnn_seeds=1, lstm_epochs=3, forest_trees=10, two_phase_max_samples=2000,
                   gpr_subset=600, gpr_hyper_subset=200, lstm_max_samples=3000, ukf_tuning="none")

    def with_(self, **changes) -> "MethodSettings":
        return replace(self, **changes)


@dataclass(frozen=True)
class Method:
    """A named calibration method of a study.

    Attributes
    ----------
    key : results key (``"dnn"``, ``"ukf"``...).
    label : row label in tables and plots.
    model : the "Model" column of the paper's Tables III and IV (``"DNN"``, ``"Lin Reg"``...).
    reference : whose method it is.
    make : ``make(seed)`` returns a new unfitted :class:`SampleEstimator`.
    n_seeds : training seeds whose scores are averaged.
    needs_robot_state : needs the full robot state (motor torques) beyond the model inputs.
    cost : expected training time relative to the paper's DNN; sweeps start the costly runs first.
    """

    key: str
    label: str
    model: str
    reference: str
    make: Callable[[int], SampleEstimator]
    n_seeds: int = 1
    needs_robot_state: bool = False
    cost: float = 0.05


MODEL_LABELS = {"dnn": "DNN", "polynomial": "2nd Reg", "linear": "Lin Reg", "fixed_offset": "Fixed Offset",
                "raw": "Raw"}
"""The paper's names of its models (the "Model" column of its tables), by method key."""


def _raw(seed: int) -> RawJoints:
    return RawJoints()


def _calibrator(calibrator, seed: int, *, seeded: bool = False, **options) -> CalibratorOnSamples:
    model = clone(calibrator)
    if seeded:
        model.set_params(random_state=int(seed))
    return CalibratorOnSamples(model, seed=seed, **options)


def _ukf_scale_options(scales: str) -> dict:
    """The UKF's options for ``MethodSettings.ukf_scales``: none (its own choices) or the nominal
    smoothing scale alone and a coasting-noise factor of one."""
    return {} if scales == "chosen" else {"velocity_scale_factors": (1.0,), "coast_noise_scale": 1.0}


def _ukf(tuning: str, scales: str, seed: int, **options) -> UKFOnSamples:
    return UKFOnSamples(tuning=tuning, **_ukf_scale_options(scales), **options)


def _ukf_hybrid(tuning: str, scales: str, seed: int) -> UKFHybridOnSamples:
    return UKFHybridOnSamples(tuning=tuning, **_ukf_scale_options(scales))


DISTURBANCE_DENSITY = 1.0
"""Random-walk density of the ``ukf_disturbance`` method's disturbance torques (N m s^-0.5, N s^-0.5
on the insertion axis): a round number, a payload's holding load of order 1 N m or 10 N settles in
seconds."""


def raw() -> Method:
    """No calibration: the motor-encoder joints."""
    return Method("raw", "Raw (motor encoders)", MODEL_LABELS["raw"], "no calibration", _raw)


def dnn(settings: MethodSettings, *, large: bool = False, train_on_error: bool = True, key: str = "dnn",
        label: str = "DNN") -> Method:
    """The paper's DNN (2 x 100 sigmoid units; ``large``: 600-500-400 with regularization)."""
    network = (DNNCalibrator.large if large else DNNCalibrator)(
        max_epochs=settings.dnn_epochs, n_threads=settings.n_threads)
    return Method(key, label, MODEL_LABELS["dnn"], "Peng et al. (the paper)",
                  partial(_calibrator, network, seeded=True, train_on_error=train_on_error),
                  n_seeds=settings.dnn_seeds, cost=15.0 if large else 1.0)


def regression(kind: str, *, train_on_error: bool = True, key: str | None = None, label: str | None = None) -> Method:
    """Fixed offset, linear or 2nd-order polynomial regression of the paper."""
    calibrators = {"fixed_offset": (FixedOffsetCalibrator(), "Fixed offset"),
                   "linear": (LinearCalibrator(), "Linear regression"),
                   "polynomial": (PolynomialCalibrator(degree=2), "2nd-order polynomial")}
    if kind not in calibrators:
        raise ValueError(f"kind must be one of {sorted(calibrators)}, got {kind!r}")
    calibrator, default_label = calibrators[kind]
    return Method(key or kind, label or default_label, MODEL_LABELS[kind], "Peng et al. (the paper)",
                  partial(_calibrator, calibrator, train_on_error=train_on_error),
                  cost=0.1 if kind == "polynomial" else 0.01)


BASE_METHODS = ("raw", "fixed_offset", "linear", "polynomial", "dnn", "ukf")
"""Methods every comparison reports."""
UKF_VARIANTS = ("ukf_disturbance", "ukf_hybrid")
"""The UKF with disturbance-torque states, and the UKF followed by a learned calibrator of its residual."""
PEER_METHODS = ("gpr", "two_phase", "window_linear", "window_lstm")
"""Published peers re-run here on the same data."""
ALL_METHODS = BASE_METHODS + UKF_VARIANTS + PEER_METHODS


def method_catalogue(settings: MethodSettings | None = None) -> dict[str, Method]:
    """Every method of the comparison, keyed as in ``results.json``, in table order."""
    s = settings or MethodSettings()
    lstm = WindowLSTMCalibrator(window=s.window, max_epochs=s.lstm_epochs, n_threads=s.n_threads)
    gpr = GPRCalibrator(subset_size=s.gpr_subset, hyperparameter_subset_size=s.gpr_hyper_subset,
                        n_threads=s.n_threads)
    two_phase = TwoPhaseCalibrator(dnn=DNNCalibrator(max_epochs=s.dnn_epochs, n_threads=s.n_threads),
                                   n_estimators=s.forest_trees, n_jobs=1)
    methods = [
        raw(),
        regression("fixed_offset"),
        regression("linear"),
        regression("polynomial"),
        dnn(s),
        Method("ukf", "UKF", "UKF", "Haghighipanah et al. (IROS 2015)", partial(_ukf, s.ukf_tuning, s.ukf_scales),
               needs_robot_state=True, cost=1.0),
        Method("ukf_disturbance", "UKF + disturbance", "UKF + dist", "Haghighipanah et al. with a disturbance state",
               partial(_ukf, s.ukf_tuning, s.ukf_scales, disturbance_density=DISTURBANCE_DENSITY), needs_robot_state=True, cost=1.0),
        Method("ukf_hybrid", "UKF + learned residual", "UKF + Lin Reg", "UKF then linear regression of its residual",
               partial(_ukf_hybrid, s.ukf_tuning, s.ukf_scales), needs_robot_state=True, cost=1.2),
        Method("gpr", "Gaussian process", "GPR", "Mahler et al. (CASE 2014)",
               partial(_calibrator, gpr, seeded=True), cost=0.3),
        Method("two_phase", "Two-phase DNN + forest", "DNN + RF", "Seita et al. (ICRA 2018)",
               partial(_calibrator, two_phase, seeded=True, max_train_samples=s.two_phase_max_samples),
               cost=3.0),
        Method("window_linear", f"Window linear ({s.window} rows)", "Lin Reg (window)",
               "Hwang et al. (RA-L 2020)",
               partial(_calibrator, WindowLinearCalibrator(window=s.window), temporal=True)),
        Method("window_lstm", f"Window LSTM ({s.window} rows)", "RNN (LSTM)", "Hwang et al. (RA-L 2020)",
               partial(_calibrator, lstm, seeded=True, temporal=True, max_train_samples=s.lstm_max_samples),
               cost=2.5),
    ]
    return {method.key: method for method in methods}


def seeds_for(method: Method, base_seed: int) -> list[int]:
    """Training seeds of a method: independent streams spawned from the study's seed."""
    return [int(s.generate_state(1)[0]) for s in np.random.SeedSequence(base_seed).spawn(method.n_seeds)]
