r"""Saving and loading fitted calibrators without pickle, so that a file is never silently wrong.

File format (one zip archive, conventionally ``*.rcal``), version 2:

- ``metadata.json``: format name and version, calibrator class, hyper-parameters, the feature
  set it was fitted on (count and, when known, names), the target layout, the list of arrays
  with their shapes and dtypes, the library versions that wrote it, and ``sha256``: the hex
  SHA-256 of the metadata without that key, as ``json.dumps(metadata, sort_keys=True,
  separators=(",", ":"))`` in UTF-8, followed, for every array in sorted name order, by
  ``f"\0{name}\0{dtype.str}\0{shape}\0"`` (shape as a Python tuple) and the array's
  C-order bytes.
- ``state.npz``: the learned state as named float64/int arrays (a state dict), read with
  ``allow_pickle=False``, plus ``probe.inputs`` and ``probe.outputs``: a few deterministic input
  rows around the training data (for a forest, also rows on both sides of its splits) and the
  saved calibrator's predictions for them.

Saving is atomic: the archive is written to a temporary file in the target's folder, flushed and
fsynced, then renamed over the target, so a save that fails part-way (a full disk) leaves the
previous file whole.

Loading never executes code from the file and checks, in order: the archive, the format and
version, the hash (a file changed after it was written is refused), every metadata field against
its schema (types, known classes and parameter names, the class's own parameter checks, positive
counts, valid ``raw_columns``, arrays as listed, finite values), the feature set the caller
expects, the consistency of the architecture with the arrays, and finally that the restored
calibrator reproduces the probe predictions (within 1e-12 of their scale, which only allows for
another machine's floating-point rounding). An edit that passes the hash and the schema therefore
either changes nothing the calibrator predicts, or is refused. Files of format version 1 (no hash,
no probe) are still read, with every other check.

Every refusal is a `CalibratorFileError` (a `ValueError`) naming the file and the field.
"""

from __future__ import annotations

import hashlib
import inspect
import io
import json
import math
import numbers
import os
import secrets
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
FORMAT_VERSION = 2
READABLE_VERSIONS = (1, 2)

_METADATA_ENTRY = "metadata.json"
_STATE_ENTRY = "state.npz"
_PROBE_INPUTS = "probe.inputs"
_PROBE_OUTPUTS = "probe.outputs"
_N_PROBES = 8
_MAX_SPLIT_PROBES = 2048
_PROBE_SEED = 20240607
# Loaded predictions of the probe rows may differ from the stored ones by this fraction of their
# largest magnitude: room for another machine's BLAS summation order, far below any real edit.
_PROBE_TOLERANCE = 1e-12
_ARRAY_DTYPES = ("<f8", "<i8", "<i4")
# Arrays in which +inf is meaningful: the input scale of constant columns, leaves of a forest.
_INFINITY_ALLOWED_SUFFIXES = ("x_scale", "threshold")

_KEYS_V1 = ("format", "format_version", "class", "params", "unsaved_params", "n_features_in",
            "feature_names_in", "n_outputs", "raw_columns", "y_is_1d", "arrays", "versions")
_KEYS = {1: frozenset(_KEYS_V1), 2: frozenset(_KEYS_V1 + ("sha256",))}

CALIBRATOR_CLASSES = {
    cls.__name__: cls
    for cls in (FixedOffsetCalibrator, LinearCalibrator, PolynomialCalibrator, DNNCalibrator,
                GPRCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator)
}


class CalibratorFileError(ValueError):
    """A calibrator file that cannot be written or read as it is.

    Attributes
    ----------
    path : Path
        The file.
    field : str or None
        The metadata field or array at fault (``"arrays['coef']"``, ``"params.activation"``),
        None when the file as a whole is at fault.
    problem : str
        What is wrong.
    """

    def __init__(self, path, field: str | None, problem: str):
        self.path = Path(path)
        self.field = field
        self.problem = problem
        where = f"{path}" if field is None else f"{path}, field {field!r}"
        super().__init__(f"{where}: {problem}")

    def __reduce__(self):
        # Rebuilt from its parts when it crosses a process boundary (parallel studies).
        return type(self), (self.path, self.field, self.problem)


def save_calibrator(calibrator: CalibratorBase, path, *, feature_names=None) -> Path:
    """Write a fitted calibrator to `path` atomically (see the module docstring for the format).

    Parameters
    ----------
    calibrator : fitted calibrator from `estimators`
    path : str or Path
        Target file; its folder must exist. An existing file is replaced only once the new one
        is completely on disk.
    feature_names : sequence of str, optional
        Names of the columns of X, recorded so that `load_calibrator` can check them. Taken
        from ``calibrator.feature_names_in_`` when it was fitted on a DataFrame; giving
        different names then is an error.

    Returns
    -------
    Path of the written file.

    Raises
    ------
    TypeError
        Not a calibrator of this package.
    sklearn.exceptions.NotFittedError
        The calibrator is not fitted.
    CalibratorFileError
        Its fitted state cannot be stored faithfully (non-finite weights, for example).
    OSError
        Writing failed (the previous file, if any, is left as it was).
    """
    if type(calibrator).__name__ not in CALIBRATOR_CLASSES:
        raise TypeError(
            f"cannot save {type(calibrator).__name__}: not a calibrator of this package.")
    check_is_fitted(calibrator)
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"cannot save {path}: the folder {path.parent} does not exist.")
    names = _feature_names_to_save(calibrator, feature_names)
    arrays = {name: np.asarray(value) for name, value in calibrator._fitted_arrays().items()}
    probe_inputs = _probe_inputs(calibrator)
    arrays[_PROBE_INPUTS] = probe_inputs
    arrays[_PROBE_OUTPUTS] = _predict_quietly(calibrator, probe_inputs)
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
    document["sha256"] = _digest(document, arrays)
    # What cannot be read back must not be written: the reader's checks run on the new content.
    _check_document(path, document)
    _check_arrays(path, document, arrays)
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    archive_bytes = io.BytesIO()
    with zipfile.ZipFile(archive_bytes, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr(_METADATA_ENTRY, json.dumps(document, indent=2))
        archive.writestr(_STATE_ENTRY, buffer.getvalue())
    _write_atomically(path, archive_bytes.getvalue())
    return path


def load_calibrator(path, *, feature_names=None, n_features: int | None = None) -> CalibratorBase:
    """Read a calibrator written by `save_calibrator` (format version 1 or 2).

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
    CalibratorFileError
        (a ValueError) Not a calibrator file, unsupported format version, changed after it was
        written, a field outside its schema, inconsistent content, or a feature set other than
        the expected one. The message names the file and the field.
    OSError
        The file cannot be opened.
    """
    path = Path(path)
    with open(path, "rb") as handle:
        content = handle.read()
    document, arrays = _read_archive(path, content)
    version = document["format_version"]
    if version >= 2:
        _check_digest(path, document, arrays)
    _check_document(path, document)
    _check_arrays(path, document, arrays)
    _check_feature_set(path, document, feature_names, n_features)
    class_name = document["class"]
    state = {name: value for name, value in arrays.items() if not name.startswith("probe.")}
    try:
        calibrator = CALIBRATOR_CLASSES[class_name](**_decode_params(path, document["params"]))
        calibrator._set_fitted_layout(
            n_features_in=document["n_features_in"],
            n_outputs=document["n_outputs"],
            raw_columns=document["raw_columns"],
            y_is_1d=document["y_is_1d"],
            feature_names_in=(_stored_names(document) if _names_from_dataframe(document)
                              else None),
        )
        calibrator._restore_fitted_arrays(state)
        _check_architecture(path, calibrator, state)
    except CalibratorFileError:
        raise
    except Exception as error:  # any failure to rebuild is a property of the file's content
        raise CalibratorFileError(
            path, "arrays", f"the state does not fit a {class_name} ({error!r}).") from error
    if version >= 2:
        _check_probe(path, calibrator, arrays)
    else:
        _check_predicts(path, calibrator)
    return calibrator


# --- writing -------------------------------------------------------------------------------


def _write_atomically(path: Path, payload: bytes) -> None:
    """Write `payload` to a new file beside `path`, fsync it, then rename it over `path`."""
    temporary = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    # os.open with mode 0o666 gives the new file the permissions the umask allows, as open() does.
    descriptor = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    try:
        with os.fdopen(descriptor, "wb") as handle:
            handle.write(payload)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        try:
            os.unlink(temporary)
        except OSError:
            pass
        raise
    _fsync_directory(path.parent)


def _fsync_directory(directory: Path) -> None:
    """Make the rename durable (POSIX); platforms that cannot open a folder skip this."""
    try:
        descriptor = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(descriptor)
    except OSError:
        pass
    finally:
        os.close(descriptor)


def _probe_inputs(calibrator) -> np.ndarray:
    """Deterministic rows around the training inputs (standard normal when their spread is
    not stored), and for a forest, rows on both sides of its splits."""
    z = np.random.default_rng(_PROBE_SEED).standard_normal((_N_PROBES, calibrator.n_features_in_))
    source = calibrator if hasattr(calibrator, "x_mean_") else getattr(calibrator, "dnn_", None)
    if source is None or not hasattr(source, "x_mean_"):
        rows = z
        center = np.zeros(calibrator.n_features_in_)
    else:
        spread = np.where(np.isfinite(source.x_scale_), source.x_scale_, 0.0)
        rows = np.asarray(source.x_mean_ + spread * z, dtype=np.float64)
        center = np.asarray(source.x_mean_, dtype=np.float64)
    forest = getattr(calibrator, "forest_", None)
    if forest is not None:
        rows = np.vstack([rows, _split_probes(forest, center)])
    return rows


def _split_probes(forest, center) -> np.ndarray:
    """Inputs that reach each split of a forest and land just left and just right of it.

    A tree goes left when ``float32(x[feature]) <= threshold``; the two rows of a split hold the
    largest float32 on the left and the smallest on the right, the other features at `center`
    moved inside the bounds of the split's path. Any change of a threshold that an input could
    notice, and of any leaf value, then changes the prediction of some probe row. Splits are
    taken level by level over all trees (the splits most inputs pass first), up to
    `_MAX_SPLIT_PROBES` rows.
    """
    rows = []
    queue = [(int(root), {}) for root in forest.roots]  # node, {feature: (low, high]}
    while queue and len(rows) < _MAX_SPLIT_PROBES:
        node, bounds = queue.pop(0)
        left, right = int(forest.left[node]), int(forest.right[node])
        if left == node:
            continue
        feature, threshold = int(forest.feature[node]), float(forest.threshold[node])
        base = center.copy()
        for column, (low, high) in bounds.items():
            base[column] = _float32_inside(base[column], low, high)
        below = np.float32(threshold)
        if below > threshold:
            below = np.nextafter(below, np.float32(-np.inf))
        above = np.nextafter(below, np.float32(np.inf))
        for value in (below, above):
            row = base.copy()
            row[feature] = float(value)
            rows.append(row)
        low, high = bounds.get(feature, (-np.inf, np.inf))
        queue.append((left, {**bounds, feature: (low, min(high, threshold))}))
        queue.append((right, {**bounds, feature: (max(low, threshold), high)}))
    return np.array(rows[:_MAX_SPLIT_PROBES]).reshape(-1, center.size)


def _float32_inside(value, low, high) -> float:
    """`value`, or the float32 nearest to it with ``low < float32(x) <= high``."""
    candidate = np.float32(value)
    if not candidate > low:
        candidate = np.nextafter(np.float32(low), np.float32(np.inf))
        while not candidate > low:
            candidate = np.nextafter(candidate, np.float32(np.inf))
    if not candidate <= high:
        candidate = np.float32(high)
        while not candidate <= high:
            candidate = np.nextafter(candidate, np.float32(-np.inf))
    return float(candidate)


def _predict_quietly(calibrator, inputs):
    with warnings.catch_warnings():
        # A calibrator fitted on a DataFrame warns about the probe's missing column names.
        warnings.simplefilter("ignore")
        return np.asarray(calibrator.predict(inputs), dtype=np.float64)


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


def _digest(document, arrays) -> str:
    """SHA-256 of the metadata without its ``sha256`` key (canonical JSON) and of the arrays."""
    digest = hashlib.sha256()
    content = {key: value for key, value in document.items() if key != "sha256"}
    digest.update(json.dumps(content, sort_keys=True, separators=(",", ":")).encode("utf-8"))
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(f"\0{name}\0{array.dtype.str}\0{array.shape}\0".encode("utf-8"))
        digest.update(array.tobytes())
    return digest.hexdigest()


# --- reading -------------------------------------------------------------------------------


def _read_archive(path: Path, content: bytes):
    """The metadata document and the arrays, or a CalibratorFileError saying why not."""
    try:
        with zipfile.ZipFile(io.BytesIO(content)) as archive:
            entries = set(archive.namelist())
            if not {_METADATA_ENTRY, _STATE_ENTRY} <= entries:
                raise CalibratorFileError(
                    path, None, f"not a calibrator file: it lacks {_METADATA_ENTRY} or "
                                f"{_STATE_ENTRY}.")
            metadata_bytes = archive.read(_METADATA_ENTRY)
            state = archive.read(_STATE_ENTRY)
    except CalibratorFileError:
        raise
    except zipfile.BadZipFile as error:
        message = ("not a calibrator file (not a zip archive)." if not zipfile.is_zipfile(
            io.BytesIO(content)) else f"corrupt archive ({error}).")
        raise CalibratorFileError(path, None, message) from None
    except Exception as error:  # zlib, EOF, header fields: every one means a damaged archive
        raise CalibratorFileError(path, None, f"corrupt archive ({error!r}).") from None
    try:
        document = json.loads(metadata_bytes.decode("utf-8"))
    except (ValueError, RecursionError) as error:
        raise CalibratorFileError(
            path, _METADATA_ENTRY, f"not a calibrator file: unreadable metadata ({error})."
        ) from None
    if not isinstance(document, dict) or document.get("format") != FORMAT_NAME:
        raise CalibratorFileError(
            path, "format", f"not a calibrator file (format is not {FORMAT_NAME!r}).")
    version = document.get("format_version")
    if not _is_int(version) or version not in READABLE_VERSIONS:
        writer = document.get("versions")
        writer = writer.get("raven-calibration", "?") if isinstance(writer, dict) else "?"
        raise CalibratorFileError(
            path, "format_version",
            f"written in calibrator file format version {version!r} (by raven-calibration "
            f"{writer}); this version of raven-calibration reads format versions "
            f"{', '.join(map(str, READABLE_VERSIONS))}. Load it with a matching version and "
            "re-save, or retrain.")
    try:
        with np.load(io.BytesIO(state), allow_pickle=False) as npz:
            arrays = {name: npz[name] for name in npz.files}
    except Exception as error:  # a damaged npz fails in many ways; all mean the same
        raise CalibratorFileError(
            path, _STATE_ENTRY, f"corrupt: unreadable state arrays ({error!r}).") from None
    return document, arrays


def _check_digest(path, document, arrays):
    stored = document.get("sha256")
    if not isinstance(stored, str) or len(stored) != 64:
        raise CalibratorFileError(path, "sha256", f"missing or malformed hash {stored!r}.")
    if stored != _digest(document, arrays):
        raise CalibratorFileError(
            path, "sha256", "the content does not match its SHA-256: the file was changed or "
                            "damaged after it was written.")


def _is_int(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _check_document(path, document):
    """Every metadata field against its schema (the arrays are checked by `_check_arrays`)."""
    version = document["format_version"]
    keys = set(document)
    if keys != _KEYS[version]:
        missing, extra = sorted(_KEYS[version] - keys), sorted(keys - _KEYS[version])
        field = (missing or extra)[0]
        raise CalibratorFileError(path, field,
                                  f"metadata keys: missing {missing}, unknown {extra}.")
    class_name = document["class"]
    if not isinstance(class_name, str) or class_name not in CALIBRATOR_CLASSES:
        raise CalibratorFileError(path, "class", f"unknown calibrator class {class_name!r}.")
    n_features, n_outputs = document["n_features_in"], document["n_outputs"]
    for name, value in (("n_features_in", n_features), ("n_outputs", n_outputs)):
        if not _is_int(value) or value < 1:
            raise CalibratorFileError(path, name, f"must be a positive integer; got {value!r}.")
    if not isinstance(document["y_is_1d"], bool):
        raise CalibratorFileError(path, "y_is_1d", f"must be true or false; got "
                                                   f"{document['y_is_1d']!r}.")
    if document["y_is_1d"] and n_outputs != 1:
        raise CalibratorFileError(path, "y_is_1d", f"true with {n_outputs} outputs.")
    _check_feature_names(path, document["feature_names_in"], n_features)
    raw_columns = document["raw_columns"]
    if raw_columns is not None:
        if (not isinstance(raw_columns, list) or len(raw_columns) != n_outputs
                or not all(_is_int(c) and 0 <= c < n_features for c in raw_columns)
                or len(set(raw_columns)) != len(raw_columns)):
            raise CalibratorFileError(
                path, "raw_columns", f"must be null or {n_outputs} distinct column indices in "
                                     f"[0, {n_features}); got {raw_columns!r}.")
    _check_params(path, class_name, document["params"], document["unsaved_params"],
                  raw_columns, n_features, n_outputs)
    versions = document["versions"]
    if not isinstance(versions, dict) or not all(
            isinstance(k, str) and isinstance(v, str) for k, v in versions.items()):
        raise CalibratorFileError(path, "versions", f"must map names to version strings; got "
                                                    f"{versions!r}.")
    specs = document["arrays"]
    if not isinstance(specs, dict) or not specs:
        raise CalibratorFileError(path, "arrays", f"must list the state arrays; got {specs!r}.")
    for name, spec in specs.items():
        field = f"arrays[{name!r}]"
        if (not isinstance(spec, dict) or set(spec) != {"shape", "dtype"}
                or not isinstance(spec["shape"], list)
                or not all(_is_int(n) and n >= 0 for n in spec["shape"])
                or spec["dtype"] not in _ARRAY_DTYPES):
            raise CalibratorFileError(
                path, field, f"must be {{'shape': [non-negative ints], 'dtype': one of "
                             f"{list(_ARRAY_DTYPES)}}}; got {spec!r}.")
    if version >= 2:
        inputs = specs.get(_PROBE_INPUTS)
        n_probes = inputs["shape"][0] if isinstance(inputs, dict) and inputs["shape"] else 0
        if not _N_PROBES <= n_probes <= _N_PROBES + _MAX_SPLIT_PROBES:
            raise CalibratorFileError(path, f"arrays[{_PROBE_INPUTS!r}]",
                                      f"must hold {_N_PROBES} to {_N_PROBES + _MAX_SPLIT_PROBES} "
                                      f"rows; got {inputs!r}.")
        probe_shapes = {_PROBE_INPUTS: [n_probes, n_features],
                        _PROBE_OUTPUTS: [n_probes] if document["y_is_1d"]
                        else [n_probes, n_outputs]}
        for name, shape in probe_shapes.items():
            if specs.get(name) != {"shape": shape, "dtype": "<f8"}:
                raise CalibratorFileError(
                    path, f"arrays[{name!r}]", f"must be float64 of shape {shape}; got "
                                               f"{specs.get(name)!r}.")


def _check_feature_names(path, names, n_features):
    if names is None:
        return
    if (not isinstance(names, dict) or set(names) != {"names", "from_dataframe"}
            or not isinstance(names["from_dataframe"], bool)
            or not isinstance(names["names"], list)
            or not all(isinstance(n, str) for n in names["names"])):
        raise CalibratorFileError(
            path, "feature_names_in", "must be null or {'names': [str, ...], 'from_dataframe': "
                                      f"bool}}; got {names!r}.")
    if len(names["names"]) != n_features:
        raise CalibratorFileError(
            path, "feature_names_in", f"{len(names['names'])} names for {n_features} features.")


def _parameter_names(cls) -> set[str]:
    return {name for name, parameter in inspect.signature(cls.__init__).parameters.items()
            if name != "self" and parameter.kind == parameter.KEYWORD_ONLY}


def _check_params(path, class_name, params, unsaved, raw_columns, n_features, n_outputs):
    if not isinstance(params, dict):
        raise CalibratorFileError(path, "params", f"must be an object; got {params!r}.")
    if not isinstance(unsaved, list) or not all(
            isinstance(name, str) and name in params and params[name] is None
            for name in unsaved):
        raise CalibratorFileError(
            path, "unsaved_params", f"must list parameters stored as null; got {unsaved!r}.")
    calibrator = _build(path, class_name, params, "params")
    try:
        from estimators._validation import resolve_raw_columns

        declared = resolve_raw_columns(calibrator.raw_columns, n_features, n_outputs)
    except (TypeError, ValueError) as error:
        raise CalibratorFileError(path, "params.raw_columns", str(error)) from None
    declared = None if declared is None else [int(c) for c in declared]
    if declared != raw_columns:
        raise CalibratorFileError(
            path, "raw_columns", f"{raw_columns!r} differs from the calibrator's parameter "
                                 f"raw_columns={params.get('raw_columns')!r}.")


def _build(path, class_name, params, field):
    """A calibrator of `class_name` from encoded parameters, checked like `fit` checks them."""
    cls = CALIBRATOR_CLASSES[class_name]
    if not isinstance(params, dict):
        raise CalibratorFileError(path, field, f"must be an object; got {params!r}.")
    # A parameter missing from the file is one added to the class after the file was written:
    # it takes its default (which the probe predictions confirm). An unknown one is refused.
    unknown = sorted(set(params) - _parameter_names(cls))
    if unknown:
        raise CalibratorFileError(path, field, f"unknown {class_name} parameters {unknown}.")
    decoded = {name: _decode_value(path, f"{field}.{name}", value)
               for name, value in params.items()}
    for name in ("random_state", "n_threads", "n_jobs"):
        value = decoded.get(name)
        if name in decoded and value is not None and not _is_int(value):
            raise CalibratorFileError(path, f"{field}.{name}",
                                      f"must be null or an integer; got {value!r}.")
    calibrator = cls(**decoded)
    try:
        calibrator._check_params()
        for name, value in decoded.items():
            if isinstance(value, CalibratorBase):
                value._check_params()
    except (TypeError, ValueError) as error:
        raise CalibratorFileError(path, field, str(error)) from None
    return calibrator


def _decode_value(path, field, value):
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, numbers.Real):
        if isinstance(value, float) and not math.isfinite(value):
            raise CalibratorFileError(path, field, f"must be finite; got {value!r}.")
        return value
    if isinstance(value, list):
        return [_decode_value(path, f"{field}[{i}]", v) for i, v in enumerate(value)]
    if isinstance(value, dict):
        if set(value) == {"tuple"} and isinstance(value["tuple"], list):
            return tuple(_decode_value(path, f"{field}[{i}]", v)
                         for i, v in enumerate(value["tuple"]))
        if set(value) == {"calibrator", "params"} and value["calibrator"] in CALIBRATOR_CLASSES:
            return _build(path, value["calibrator"], value["params"], f"{field}.params")
    raise CalibratorFileError(path, field, f"unknown parameter encoding {value!r}.")


def _decode_params(path, params):
    return {name: _decode_value(path, f"params.{name}", value) for name, value in params.items()}


def _names_from_dataframe(document) -> bool:
    names = document.get("feature_names_in")
    return bool(names) and bool(names.get("from_dataframe"))


def _stored_names(document):
    names = document.get("feature_names_in")
    return None if not names else list(names["names"])


def _check_feature_set(path, document, feature_names, n_features):
    stored_count = document["n_features_in"]
    stored_names = _stored_names(document)
    if n_features is not None and n_features != stored_count:
        raise CalibratorFileError(
            path, "n_features_in",
            f"was made for {stored_count} features, but the data has {n_features}.")
    if feature_names is None:
        return
    names = [str(name) for name in feature_names]
    if stored_names is None:
        if len(names) != stored_count:
            raise CalibratorFileError(
                path, "n_features_in",
                f"was made for {stored_count} features (names not recorded), but the data has "
                f"{len(names)}: {names}.")
    elif names != stored_names:
        missing = [n for n in stored_names if n not in names]
        extra = [n for n in names if n not in stored_names]
        detail = (f"missing {missing}, unexpected {extra}" if missing or extra
                  else "same names in another order")
        raise CalibratorFileError(
            path, "feature_names_in",
            f"was made for another feature set: {stored_names}; the data has {names} "
            f"({detail}).")


def _check_arrays(path, document, arrays):
    listed = document["arrays"]
    if set(listed) != set(arrays):
        raise CalibratorFileError(
            path, "arrays", f"state arrays {sorted(arrays)} do not match the metadata's "
                            f"{sorted(listed)}.")
    for name, spec in listed.items():
        array = arrays[name]
        field = f"arrays[{name!r}]"
        if list(array.shape) != spec["shape"] or array.dtype.str != spec["dtype"]:
            raise CalibratorFileError(
                path, field, f"has shape {array.shape} and dtype {array.dtype.str}, the "
                             f"metadata says {spec}.")
        if array.dtype.kind != "f":
            continue
        if np.any(np.isnan(array)):
            raise CalibratorFileError(path, field, "contains NaN.")
        allowed = np.isposinf(array) if name.endswith(_INFINITY_ALLOWED_SUFFIXES) else False
        if np.any(np.isinf(array) & ~allowed):
            raise CalibratorFileError(path, field, "contains an infinite value.")


def _check_architecture(path, calibrator, state):
    """Hyper-parameters that describe the state's shapes must agree with them."""
    networks = [calibrator] if isinstance(calibrator, DNNCalibrator) else []
    prefix = "params"
    if isinstance(calibrator, TwoPhaseCalibrator):
        networks, prefix = [calibrator.dnn_], "params.dnn.params"
    for network in networks:
        hidden = tuple(w.shape[1] for w in network.coefs_[:-1])
        declared = tuple(int(n) for n in np.atleast_1d(network.hidden_layer_sizes))
        if hidden != declared:
            raise CalibratorFileError(
                path, f"{prefix}.hidden_layer_sizes",
                f"{declared} but the stored network has hidden layers {hidden}.")
    if isinstance(calibrator, WindowLinearCalibrator):
        shape = state["coef"].shape
        if shape[:2] != (calibrator.window, calibrator.n_features_in_):
            raise CalibratorFileError(
                path, "params.window", f"{calibrator.window} does not match the stored "
                                       f"weights of shape {shape}.")
    if isinstance(calibrator, WindowLSTMCalibrator):
        stored = calibrator.weights_.recurrent_weight.shape[0]
        if stored != calibrator.hidden_size:
            raise CalibratorFileError(
                path, "params.hidden_size", f"{calibrator.hidden_size} but the stored LSTM has "
                                            f"{stored} units.")


def _check_probe(path, calibrator, arrays):
    """The restored calibrator must predict the stored outputs of the stored probe rows."""
    expected = arrays[_PROBE_OUTPUTS]
    try:
        predicted = _predict_quietly(calibrator, arrays[_PROBE_INPUTS])
    except Exception as error:
        raise CalibratorFileError(
            path, "arrays", f"the restored {type(calibrator).__name__} cannot predict "
                            f"({error!r}).") from error
    scale = float(np.max(np.abs(expected))) if expected.size else 0.0
    if (predicted.shape != expected.shape or not np.all(np.isfinite(predicted))
            or np.any(np.abs(predicted - expected) > _PROBE_TOLERANCE * scale)):
        raise CalibratorFileError(
            path, _PROBE_OUTPUTS, f"the restored {type(calibrator).__name__} does not reproduce "
                                  "the predictions stored with it: its content was changed.")


def _check_predicts(path, calibrator):
    """Version 1 files store no probe: predict one row, so that shape errors fail now."""
    try:
        predicted = _predict_quietly(calibrator, np.zeros((1, calibrator.n_features_in_)))
    except Exception as error:
        raise CalibratorFileError(
            path, "arrays", f"the restored {type(calibrator).__name__} cannot predict "
                            f"({error!r}).") from error
    if not np.all(np.isfinite(predicted)):
        raise CalibratorFileError(path, "arrays", "the restored calibrator predicts non-finite "
                                                  "values.")


# --- hyper-parameters as JSON --------------------------------------------------------------


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


def _versions():
    try:
        own = package_metadata.version("raven-calibration")
    except package_metadata.PackageNotFoundError:
        own = "unknown"
    return {"raven-calibration": own, "numpy": np.__version__, "scikit-learn": sklearn.__version__}
