"""The UKF baseline (Haghighipanah et al., IROS 2015) as one method among the others of a study.

The filter lives in ``estimators.ukf.estimator``: ``fit(dataset)`` identifies what it needs from a
time-ordered :class:`~simulation.recordings.dataset.CalibrationDataset` with ground truth, and
``predict(dataset)`` runs over a time-ordered dataset and returns its joint estimates (optionally
with their covariance). This adapter gives it the interface of the other methods of a study
(``fit(samples)`` / ``predict(samples)`` on :class:`~studies.common.samples.Samples`) and says, in one
line, why it cannot run when the module or the inputs it needs (motor torques) are missing.
"""

from __future__ import annotations

import importlib

import numpy as np

from studies.common.samples import Samples

UKF_MODULE = "estimators.ukf.estimator"
UKF_CLASS_NAMES = ("UKFJointEstimator",)
"""Names under which the filter's estimator class is looked up in :data:`UKF_MODULE`, in order;
any other public class of the module with ``fit`` and ``predict`` is taken when none matches."""


def _module():
    try:
        return importlib.import_module(UKF_MODULE)
    except ModuleNotFoundError as error:
        if error.name == UKF_MODULE:
            return None
        raise


def ukf_class():
    """The filter's estimator class, or None when ``estimators.ukf.estimator`` does not provide one."""
    module = _module()
    if module is None:
        return None
    for name in UKF_CLASS_NAMES:
        if hasattr(module, name):
            return getattr(module, name)
    public = getattr(module, "__all__", [n for n in vars(module) if not n.startswith("_")])
    for name in public:
        candidate = getattr(module, name, None)
        if isinstance(candidate, type) and callable(getattr(candidate, "fit", None)) \
                and callable(getattr(candidate, "predict", None)) and candidate.__module__ == module.__name__:
            return candidate
    return None


def ukf_unavailable_reason() -> str | None:
    """None when the UKF can run, else one line saying why not."""
    if _module() is None:
        return f"not available: the UKF module {UKF_MODULE} is not part of this installation yet"
    if ukf_class() is None:
        return f"not available: {UKF_MODULE} defines no estimator class with fit(dataset)/predict(dataset)"
    return None


def _joint_estimates(output, n_rows: int) -> np.ndarray:
    """Joints 1-3 (N, 3) from what the filter's predict returns (array, (mean, cov) or an object)."""
    if isinstance(output, tuple):
        output = output[0]
    for attribute in ("joints", "mean", "estimate", "q"):
        if not isinstance(output, np.ndarray) and hasattr(output, attribute):
            output = getattr(output, attribute)
            break
    estimates = np.asarray(output, dtype=np.float64)
    if estimates.ndim != 2 or estimates.shape[0] != n_rows or estimates.shape[1] < 3:
        raise ValueError(f"the UKF returned estimates of shape {estimates.shape}; expected ({n_rows}, >=3)")
    if not np.all(np.isfinite(estimates[:, :3])):
        raise ValueError("the UKF returned non-finite joint estimates")
    return estimates[:, :3]


class UKFOnSamples:
    """The UKF with a study's ``fit(samples)`` / ``predict(samples)`` interface.

    Parameters
    ----------
    **options
        Hyper-parameters of the filter's estimator (e.g. ``tuning="none"``).

    The filter is deterministic: it has no seed, and one run stands for all seeds.
    """

    def __init__(self, **options) -> None:
        self.options = options

    def _new_filter(self):
        cls = ukf_class()
        if cls is None:
            raise RuntimeError(ukf_unavailable_reason())
        return cls(**self.options)

    @staticmethod
    def _check(samples: Samples) -> None:
        if samples.dataset is None:
            raise ValueError("the UKF needs the full robot state (motor torques); these samples do not carry it")
        if samples.stride != 1:
            raise ValueError("the UKF filters consecutive log samples; these samples were thinned")

    def fit(self, samples: Samples) -> "UKFOnSamples":
        self._check(samples)
        unfitted = self._new_filter()
        fitted = unfitted.fit(samples.dataset)
        self.filter_ = unfitted if fitted is None else fitted
        return self

    def predict(self, samples: Samples) -> np.ndarray:
        """Filter each recording of the samples from its start; joints 1-3 (N, 3), SI."""
        self._check(samples)
        out = np.empty((len(samples), 3))
        for rows in samples.recordings():
            out[rows] = _joint_estimates(self.filter_.predict(samples.dataset.select(rows)), rows.size)
        return out
