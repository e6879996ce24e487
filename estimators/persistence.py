"""Saving and loading fitted calibrators without pickle.

File format (one zip archive, conventionally ``*.rcal``):

- ``metadata.json``: format name and version, calibrator class, hyper-parameters, the feature
  set it was fitted on (count and, when known, names), the target layout, the list of arrays
  with their shapes and dtypes, and the library versions that wrote it.
- ``state.npz``: the learned state as named float64/int arrays (a state dict), read with
  ``allow_pickle=False``.

Loading never executes code from the file. It fails with a `ValueError` that says why when the
file is not a calibrator file, was written in another format version, names an unknown
calibrator, is inconsistent, or was made for another feature set than the caller expects.
"""

from __future__ import annotations

import io
import json
import numbers
import warnings
import zipfile
from importlib import metadata as package_metadata
from pathlib import Path

import numpy as np
import sklearn
from sklearn.utils.validation import check_is_fitted

from estimators._base import CalibratorBase
from estimators.dnn import DNNCalibrator
from estimators.fixed_offset import FixedOffsetCalibrator
from estimators.gpr import GPRCalibrator
from estimators.linear import LinearCalibrator
from estimators.polynomial import PolynomialCalibrator
from estimators.two_phase import TwoPhaseCalibrator
from estimators.window_linear import WindowLinearCalibrator
from estimators.window_lstm import WindowLSTMCalibrator

FORMAT_NAME = "raven-calibration/calibrator"
FORMAT_VERSION = 1

_METADATA_ENTRY = "metadata.json"
_STATE_ENTRY = "state.npz"

CALIBRATOR_CLASSES = {
    cls.__name__: cls
    for cls in (FixedOffsetCalibrator, LinearCalibrator, PolynomialCalibrator, DNNCalibrator,
                GPRCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator)
}


def save_calibrator(calibrator: CalibratorBase, path, *, feature_names=None) -> Path:
    """Write a fitted calibrator to `path` (see the module docstring for the format).

    Parameters
    ----------
    calibrator : fitted calibrator from `estimators`
    path : str or Path
    feature_names : sequence of str, optional
        Names of the columns of X, recorded so that `load_calibrator` can check them. Taken
        from ``calibrator.feature_names_in_`` when it was fitted on a DataFrame; giving
        different names then is an error.

    Returns
    -------
    Path of the written file.
    """
    if type(calibrator).__name__ not in CALIBRATOR_CLASSES:
        raise TypeError(
            f"cannot save {type(calibrator).__name__}: not a calibrator of this package.")
    check_is_fitted(calibrator)
    names = _feature_names_to_save(calibrator, feature_names)
    arrays = {name: np.asarray(value) for name, value in calibrator._fitted_arrays().items()}
    params, unsaved = _encode_params(calibrator.get_params(deep=False))
    document = {
        "format": FORMAT_NAME,
        "format_version": FORMAT_VERSION,
        "class": type(calibrator).__name__,
        "params": params,
        "unsaved_params": unsaved,
        "n_features_in": int(calibrator.n_features_in_),
        "feature_names_in": names,
        "n_outputs": int(calibrator.n_outputs_),
        "raw_columns": (None if calibrator.raw_columns_ is None
                        else [int(c) for c in calibrator.raw_columns_]),
        "y_is_1d": bool(calibrator._y_is_1d),
        "arrays": {name: {"shape": list(array.shape), "dtype": array.dtype.str}
                   for name, array in arrays.items()},
        "versions": _versions(),
    }
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    path = Path(path)
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(_METADATA_ENTRY, json.dumps(document, indent=2))
        archive.writestr(_STATE_ENTRY, buffer.getvalue())
    return path


def load_calibrator(path, *, feature_names=None, n_features: int | None = None) -> CalibratorBase:
    """Read a calibrator written by `save_calibrator`.

    Parameters
    ----------
    path : str or Path
    feature_names : sequence of str, optional
        The feature set the caller will predict on. If given, it must equal the names stored in
        the file (or, when the file stores none, have the stored number of features).
    n_features : int, optional
        The number of features the caller will predict on.

    Returns
    -------
    A fitted calibrator, predicting exactly as the saved one.

    Raises
    ------
    ValueError
        Not a calibrator file, unsupported format version, unknown class, inconsistent content,
        or a feature set other than the expected one.
    """
    path = Path(path)
    document, arrays = _read_archive(path)
    file_version = document.get("format_version")
    if file_version != FORMAT_VERSION:
        raise ValueError(
            f"{path} was written in calibrator file format version {file_version!r} "
            f"(by raven-calibration {document.get('versions', {}).get('raven-calibration', '?')}); "
            f"this version of raven-calibration reads format version {FORMAT_VERSION} only. "
            "Load it with a matching version and re-save, or retrain."
        )
    class_name = document.get("class")
    if class_name not in CALIBRATOR_CLASSES:
        raise ValueError(f"{path} holds an unknown calibrator class {class_name!r}.")
    _check_feature_set(path, document, feature_names, n_features)
    _check_arrays(path, document, arrays)
    try:
        calibrator = CALIBRATOR_CLASSES[class_name](**_decode_params(document["params"]))
        calibrator._set_fitted_layout(
            n_features_in=document["n_features_in"],
            n_outputs=document["n_outputs"],
            raw_columns=document["raw_columns"],
            y_is_1d=document["y_is_1d"],
            feature_names_in=(_stored_names(document) if _names_from_dataframe(document)
                              else None),
        )
        calibrator._restore_fitted_arrays(arrays)
        _probe(calibrator)
    except (KeyError, TypeError, ValueError, IndexError) as error:
        raise ValueError(
            f"{path} is corrupt: its state does not fit a {class_name} ({error}).") from error
    return calibrator


def _feature_names_to_save(calibrator, feature_names):
    fitted = getattr(calibrator, "feature_names_in_", None)
    if fitted is not None:
        fitted = [str(name) for name in fitted]
        if feature_names is not None and list(map(str, feature_names)) != fitted:
            raise ValueError(
                "feature_names differ from the names the calibrator was fitted with "
                f"({fitted})."
            )
        return {"names": fitted, "from_dataframe": True}
    if feature_names is None:
        return None
    names = [str(name) for name in feature_names]
    if len(names) != calibrator.n_features_in_:
        raise ValueError(
            f"feature_names has {len(names)} names but the calibrator was fitted on "
            f"{calibrator.n_features_in_} features."
        )
    return {"names": names, "from_dataframe": False}


def _names_from_dataframe(document) -> bool:
    names = document.get("feature_names_in")
    return bool(names) and bool(names.get("from_dataframe"))


def _stored_names(document):
    names = document.get("feature_names_in")
    return None if not names else list(names["names"])


def _read_archive(path: Path):
    try:
        with zipfile.ZipFile(path) as archive:
            entries = set(archive.namelist())
            if not {_METADATA_ENTRY, _STATE_ENTRY} <= entries:
                raise ValueError(
                    f"{path} is not a calibrator file: it lacks {_METADATA_ENTRY} or "
                    f"{_STATE_ENTRY}."
                )
            document = json.loads(archive.read(_METADATA_ENTRY).decode("utf-8"))
            state = archive.read(_STATE_ENTRY)
    except zipfile.BadZipFile:
        raise ValueError(f"{path} is not a calibrator file (not a zip archive).") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise ValueError(
            f"{path} is not a calibrator file: unreadable metadata ({error}).") from None
    if not isinstance(document, dict) or document.get("format") != FORMAT_NAME:
        raise ValueError(f"{path} is not a calibrator file (format is not {FORMAT_NAME!r}).")
    try:
        with np.load(io.BytesIO(state), allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except (ValueError, OSError, zipfile.BadZipFile) as error:
        raise ValueError(f"{path} is corrupt: unreadable state arrays ({error}).") from None
    return document, arrays


def _check_feature_set(path, document, feature_names, n_features):
    stored_count = document.get("n_features_in")
    stored_names = _stored_names(document)
    if n_features is not None and n_features != stored_count:
        raise ValueError(
            f"{path} was made for {stored_count} features, but the data has {n_features}."
        )
    if feature_names is None:
        return
    names = [str(name) for name in feature_names]
    if stored_names is None:
        if len(names) != stored_count:
            raise ValueError(
                f"{path} was made for {stored_count} features (names not recorded), but the "
                f"data has {len(names)}: {names}."
            )
    elif names != stored_names:
        missing = [n for n in stored_names if n not in names]
        extra = [n for n in names if n not in stored_names]
        detail = (f"missing {missing}, unexpected {extra}" if missing or extra
                  else "same names in another order")
        raise ValueError(
            f"{path} was made for another feature set: {stored_names}; the data has {names} "
            f"({detail})."
        )


def _check_arrays(path, document, arrays):
    listed = document.get("arrays", {})
    if set(listed) != set(arrays):
        raise ValueError(
            f"{path} is corrupt: state arrays {sorted(arrays)} do not match the metadata's "
            f"{sorted(listed)}."
        )
    for name, spec in listed.items():
        array = arrays[name]
        if list(array.shape) != spec.get("shape") or array.dtype.str != spec.get("dtype"):
            raise ValueError(
                f"{path} is corrupt: array {name!r} has shape {array.shape} and dtype "
                f"{array.dtype.str}, the metadata says {spec}."
            )
        if array.dtype.kind == "f" and np.any(np.isnan(array)):
            raise ValueError(f"{path} is corrupt: array {name!r} contains NaN.")


def _probe(calibrator):
    """Predict one all-zero row, so that inconsistent array shapes fail now, not later."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        calibrator.predict(np.zeros((1, calibrator.n_features_in_)))


def _encode_params(params):
    """JSON form of hyper-parameters; values JSON cannot hold (random generators) become None."""
    encoded, unsaved = {}, []
    for name, value in params.items():
        try:
            encoded[name] = _encode_value(value)
        except TypeError:
            encoded[name] = None
            unsaved.append(name)
    return encoded, unsaved


def _encode_value(value):
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, numbers.Integral):
        return int(value)
    if isinstance(value, numbers.Real):
        return float(value)
    if isinstance(value, tuple):
        return {"tuple": [_encode_value(v) for v in value]}
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, list):
        return [_encode_value(v) for v in value]
    if isinstance(value, CalibratorBase) and type(value).__name__ in CALIBRATOR_CLASSES:
        params, unsaved = _encode_params(value.get_params(deep=False))
        if unsaved:
            raise TypeError(f"nested calibrator parameters {unsaved} cannot be saved")
        return {"calibrator": type(value).__name__, "params": params}
    raise TypeError(f"cannot encode {value!r}")


def _decode_params(params):
    return {name: _decode_value(value) for name, value in params.items()}


def _decode_value(value):
    if isinstance(value, list):
        return [_decode_value(v) for v in value]
    if isinstance(value, dict):
        if "tuple" in value:
            return tuple(_decode_value(v) for v in value["tuple"])
        if value.get("calibrator") in CALIBRATOR_CLASSES:
            return CALIBRATOR_CLASSES[value["calibrator"]](**_decode_params(value["params"]))
        raise ValueError(f"unknown parameter encoding {value!r}")
    return value


def _versions():
    try:
        own = package_metadata.version("raven-calibration")
    except package_metadata.PackageNotFoundError:
        own = "unknown"
    return {"raven-calibration": own, "numpy": np.__version__, "scikit-learn": sklearn.__version__}
