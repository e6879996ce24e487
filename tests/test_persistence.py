"""Saving and loading calibrators: exact round trip, no pickle, clear refusals, and files that
cannot be silently wrong (hash, schema, probe predictions, atomic save)."""

from __future__ import annotations

import copy
import hashlib
import io
import json
import os
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from estimators import DNNCalibrator, FixedOffsetCalibrator, GPRCalibrator, LinearCalibrator
from estimators import PolynomialCalibrator, TwoPhaseCalibrator, WindowLinearCalibrator, WindowLSTMCalibrator
from estimators import load_calibrator, save_calibrator
from estimators.persistence import FORMAT_VERSION, CalibratorFileError

PROJECT = Path(__file__).resolve().parents[1]

NAMES = ("shoulder", "elbow", "insertion", "tau_shoulder")

CALIBRATORS = [
    FixedOffsetCalibrator(raw_columns=[0, 1]),
    LinearCalibrator(raw_columns=[0, 1], alpha=0.1),
    PolynomialCalibrator(degree=3),
    DNNCalibrator(raw_columns=[0, 1], hidden_layer_sizes=(6, 5), activation="tanh",
                  max_epochs=3, random_state=0, n_threads=1),
    GPRCalibrator(subset_size=60, hyperparameter_subset_size=30, random_state=0, n_threads=1),
    TwoPhaseCalibrator(raw_columns=[0, 1], n_estimators=4, random_state=np.random.RandomState(1),
                       dnn=DNNCalibrator(hidden_layer_sizes=(4,), max_epochs=2, n_threads=1)),
    WindowLinearCalibrator(raw_columns=[0, 1], window=3),
    WindowLSTMCalibrator(window=2, hidden_size=3, max_epochs=2, random_state=0, n_threads=1),
]


def data(n_samples=120, seed=0):
    rng = np.random.default_rng(seed)
    X = rng.normal(size=(n_samples, 4))
    X[:, 3] = 1.0  # constant column: infinite scale in the saved standardization
    y = X[:, :2] + 0.1 * np.sin(X[:, 1:3])
    return X, y


@pytest.fixture
def saved_linear(tmp_path):
    X, y = data()
    path = save_calibrator(LinearCalibrator(raw_columns=[0, 1]).fit(X, y),
                           tmp_path / "linear.rcal", feature_names=NAMES)
    return path


@pytest.mark.parametrize("calibrator", CALIBRATORS, ids=lambda c: type(c).__name__)
def test_round_trip_predicts_identically(tmp_path, calibrator):
    X, y = data()
    calibrator.fit(X, y)
    loaded = load_calibrator(save_calibrator(calibrator, tmp_path / "model.rcal"), n_features=4)
    assert type(loaded) is type(calibrator)
    np.testing.assert_array_equal(loaded.predict(X), calibrator.predict(X))
    X_new, _ = data(seed=1)
    predictor, original = loaded.to_realtime(), calibrator.to_realtime()
    np.testing.assert_array_equal([predictor(row) for row in X_new],
                                  [original(row) for row in X_new])


def test_file_holds_json_metadata_and_plain_arrays(saved_linear):
    with zipfile.ZipFile(saved_linear) as archive:
        assert sorted(archive.namelist()) == ["metadata.json", "state.npz"]
        document = json.loads(archive.read("metadata.json"))
        with np.load(io.BytesIO(archive.read("state.npz")), allow_pickle=False) as state:
            assert sorted(state.files) == ["coef", "intercept", "probe.inputs", "probe.outputs"]
    assert document["class"] == "LinearCalibrator"
    assert document["format_version"] == FORMAT_VERSION
    assert document["feature_names_in"]["names"] == list(NAMES)
    assert document["params"] == {"alpha": 0.0, "raw_columns": [0, 1]}
    assert document["sha256"] == independent_digest(document, state_arrays(saved_linear))


def test_hyper_parameters_survive_including_tuples_and_nested_networks(tmp_path):
    X, y = data()
    calibrator = TwoPhaseCalibrator(n_estimators=3, random_state=2,
                                    dnn=DNNCalibrator(hidden_layer_sizes=(4, 3), max_epochs=2,
                                                      n_threads=1)).fit(X, y)
    loaded = load_calibrator(save_calibrator(calibrator, tmp_path / "two.rcal"))
    assert loaded.dnn.hidden_layer_sizes == (4, 3)
    assert loaded.get_params()["dnn__max_epochs"] == 2
    assert loaded.random_state == 2


def test_unsaveable_random_generator_is_recorded_not_pickled(tmp_path):
    X, y = data()
    calibrator = GPRCalibrator(subset_size=30, random_state=np.random.RandomState(0),
                               n_threads=1).fit(X, y)
    path = save_calibrator(calibrator, tmp_path / "gpr.rcal")
    with zipfile.ZipFile(path) as archive:
        assert json.loads(archive.read("metadata.json"))["unsaved_params"] == ["random_state"]
    assert load_calibrator(path).random_state is None


def test_dataframe_feature_names_are_restored(tmp_path):
    X, y = data()
    frame = pd.DataFrame(X, columns=list(NAMES))
    calibrator = LinearCalibrator(raw_columns=[0, 1]).fit(frame, y)
    loaded = load_calibrator(save_calibrator(calibrator, tmp_path / "frame.rcal"),
                             feature_names=NAMES)
    assert list(loaded.feature_names_in_) == list(NAMES)
    with pytest.raises(ValueError, match="feature names"):
        loaded.predict(frame[list(reversed(NAMES))])


@pytest.mark.parametrize("kwargs, message", [
    ({"n_features": 5}, "was made for 4 features, but the data has 5"),
    ({"feature_names": ["shoulder", "elbow", "insertion", "tau_elbow"]},
     r"made for another feature set.*missing \['tau_shoulder'\], unexpected \['tau_elbow'\]"),
    ({"feature_names": list(reversed(NAMES))}, "same names in another order"),
])
def test_other_feature_set_is_refused(saved_linear, kwargs, message):
    with pytest.raises(ValueError, match=message):
        load_calibrator(saved_linear, **kwargs)


def test_feature_count_is_checked_when_names_were_not_recorded(tmp_path):
    X, y = data()
    path = save_calibrator(LinearCalibrator().fit(X, y), tmp_path / "anonymous.rcal")
    load_calibrator(path, feature_names=["a", "b", "c", "d"])
    with pytest.raises(ValueError, match=r"made for 4 features \(names not recorded\)"):
        load_calibrator(path, feature_names=["a", "b", "c"])


def state_arrays(path):
    with zipfile.ZipFile(path) as archive, np.load(io.BytesIO(archive.read("state.npz")),
                                                   allow_pickle=False) as state:
        return {name: state[name] for name in state.files}


def independent_digest(document, arrays):
    """The file's hash computed as the format documents it."""
    digest = hashlib.sha256()
    content = {key: value for key, value in document.items() if key != "sha256"}
    digest.update(json.dumps(content, sort_keys=True, separators=(",", ":")).encode())
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        digest.update(b"\0" + name.encode() + b"\0" + array.dtype.str.encode() + b"\0"
                      + str(array.shape).encode() + b"\0" + array.tobytes())
    return digest.hexdigest()


def npz_bytes(arrays):
    buffer = io.BytesIO()
    np.savez(buffer, **arrays)
    return buffer.getvalue()


def write_file(target, document, arrays, fix_hash, state=None):
    """A calibrator file with the given content; its hash recomputed if `fix_hash`.

    `state`, if given, is `arrays` already in npz form.
    """
    if fix_hash and "sha256" in document:
        document = {**document, "sha256": independent_digest(document, arrays)}
    content = io.BytesIO()
    with zipfile.ZipFile(content, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("metadata.json", json.dumps(document))
        archive.writestr("state.npz", npz_bytes(arrays) if state is None else state)
    target.write_bytes(content.getvalue())
    return target


def read_file(path):
    with zipfile.ZipFile(path) as archive:
        document = json.loads(archive.read("metadata.json"))
    return document, state_arrays(path)


def _rewrite(path, metadata=None, state=None, fix_hash=True):
    """Copy of a saved file with its metadata document and/or state arrays replaced."""
    document, arrays = read_file(path)
    if metadata is not None:
        document = metadata(document)
    if state is not None:
        arrays = state(arrays)
    return write_file(path.with_name("edited.rcal"), document, arrays, fix_hash)


def test_other_format_version_is_refused_with_both_versions_named(saved_linear):
    edited = _rewrite(saved_linear, metadata=lambda d: {**d, "format_version": FORMAT_VERSION + 1})
    with pytest.raises(CalibratorFileError, match=rf"format version {FORMAT_VERSION + 1}.*reads "
                                                  rf"format versions 1, {FORMAT_VERSION}"):
        load_calibrator(edited)


@pytest.mark.parametrize("metadata, state, message", [
    (lambda d: {**d, "class": "MagicCalibrator"}, None,
     "field 'class': unknown calibrator class 'MagicCalibrator'"),
    (lambda d: {**d, "format": "something-else"}, None, "not a calibrator file"),
    (None, lambda s: {k: v for k, v in s.items() if k != "intercept"},
     "do not match the metadata"),
    (None, lambda s: {**s, "coef": s["coef"][:2]}, r"field \"arrays\['coef'\]\": has shape"),
    (None, lambda s: {**s, "coef": np.full_like(s["coef"], np.nan)}, "contains NaN"),
    (None, lambda s: {**s, "coef": s["coef"] * 1.01}, "does not reproduce the predictions"),
    (None, lambda s: {**s, "intercept": s["intercept"] + np.inf}, "contains an infinite value"),
    (lambda d: {**d, "n_features_in": 3, "feature_names_in": None}, None,
     "field 'arrays.probe.inputs'|probe.inputs"),
    (lambda d: {**d, "raw_columns": None}, None, "field 'raw_columns'"),
    (lambda d: {**d, "raw_columns": [0, 0]}, None, "field 'raw_columns'"),
    (lambda d: {**d, "feature_names_in": "shoulder"}, None, "field 'feature_names_in'"),
    (lambda d: {**d, "params": {**d["params"], "alpha": "0.1"}}, None, "field 'params'"),
    (lambda d: {**d, "params": {**d["params"], "beta": 1.0}}, None,
     r"unknown LinearCalibrator parameters \['beta'\]"),
    (lambda d: {**d, "y_is_1d": 1}, None, "field 'y_is_1d'"),
])
def test_inconsistent_files_are_refused_naming_the_file_and_field(saved_linear, metadata, state,
                                                                  message):
    edited = _rewrite(saved_linear, metadata, state)
    with pytest.raises(CalibratorFileError, match=message) as caught:
        load_calibrator(edited)
    assert str(edited) in str(caught.value)
    assert isinstance(caught.value, ValueError)


def test_a_network_edited_as_the_issue_describes_is_refused(tmp_path):
    X, y = data()
    dnn = DNNCalibrator(raw_columns=[0, 1], hidden_layer_sizes=(5,), max_epochs=2,
                        random_state=0, n_threads=1).fit(X, y)
    path = save_calibrator(dnn, tmp_path / "dnn.rcal")
    edits = {
        "params.activation": (lambda d: {**d, "params": {**d["params"], "activation": "tanh"}},
                              None),
        "params": (lambda d: {**d, "params": {**d["params"], "activation": "bogus"}}, None),
        "raw_columns": (lambda d: {**d, "raw_columns": None}, None),
        "arrays['coef.0']": (None, lambda s: {**s, "coef.0": s["coef.0"] * 1.01}),
        "arrays['coef.1']": (None, lambda s: {**s, "coef.1": np.where(
            np.arange(s["coef.1"].size).reshape(s["coef.1"].shape) == 0, np.inf, s["coef.1"])}),
        "feature_names_in": (lambda d: {**d, "feature_names_in": "abcd"}, None),
    }
    for fix_hash in (False, True):
        for metadata, state in edits.values():
            with pytest.raises(CalibratorFileError):
                load_calibrator(_rewrite(path, metadata, state, fix_hash=fix_hash))


def test_other_files_are_refused(tmp_path):
    text = tmp_path / "notes.rcal"
    text.write_text("not a model")
    with pytest.raises(CalibratorFileError, match="not a calibrator file \\(not a zip archive\\)"):
        load_calibrator(text)
    archive = tmp_path / "other.zip"
    with zipfile.ZipFile(archive, "w") as handle:
        handle.writestr("data.csv", "1,2")
    with pytest.raises(CalibratorFileError, match="lacks metadata.json or state.npz"):
        load_calibrator(archive)


def test_unfitted_calibrator_cannot_be_saved(tmp_path):
    from sklearn.exceptions import NotFittedError

    with pytest.raises(NotFittedError):
        save_calibrator(LinearCalibrator(), tmp_path / "empty.rcal")


def test_feature_names_must_match_the_fitted_feature_count(tmp_path):
    X, y = data()
    with pytest.raises(ValueError,
                       match="feature_names has 2 names but the calibrator was fitted on 4"):
        save_calibrator(LinearCalibrator().fit(X, y), tmp_path / "m.rcal", feature_names=["a", "b"])


def test_non_finite_weights_are_not_written(tmp_path):
    X, y = data()
    calibrator = LinearCalibrator().fit(X, y)
    calibrator.coef_[0, 0] = np.inf
    target = tmp_path / "bad.rcal"
    with pytest.raises(CalibratorFileError, match="arrays\\['coef'\\].*infinite"):
        save_calibrator(calibrator, target)
    assert not target.exists() and not list(tmp_path.iterdir())


# --- every field edited, every class -------------------------------------------------------

STRING_CHOICES = ("bogus", "sigmoid", "tanh", "relu", "DNNCalibrator", "<f4", "<i8")


def replacements(value):
    """Other values for one metadata entry: neighbours, other choices, other types."""
    if isinstance(value, bool):
        return [not value, int(value), None]
    if isinstance(value, int):
        return [value + 1, -value - 1, value + 0.5, str(value), None]
    if isinstance(value, float):
        return [value * 1.01 if value else 1e-3, float("nan"), str(value)]
    if isinstance(value, str):
        return [s for s in STRING_CHOICES if s != value] + [None]
    if value is None:
        return [1, "bogus", [0]]
    if isinstance(value, list):
        return [None, value[:-1], value[::-1]] if value else [None, [0]]
    return [None, [], {**value, "unexpected": 1}] + [
        {k: v for k, v in value.items() if k != key} for key in value]


def metadata_edits(document):
    """(field, edited document) for every entry of the metadata, nested ones included."""
    def walk(node, where):
        yield where, node
        children = node.items() if isinstance(node, dict) else (
            enumerate(node) if isinstance(node, list) else ())
        for key, child in children:
            yield from walk(child, where + (key,))

    for where, node in walk(document, ()):
        if not where:
            continue
        for replacement in replacements(node):
            edited = copy.deepcopy(document)
            parent = edited
            for key in where[:-1]:
                parent = parent[key]
            parent[where[-1]] = replacement
            yield where, edited


def array_edits(arrays):
    """(field, edited arrays, whether the metadata's array list is updated to match)."""
    for name, array in arrays.items():
        variants = []
        if array.dtype.kind == "f":
            first = array.copy().reshape(-1)
            if first.size:
                first[0] = first[0] * 1.01 + 1e-3
            variants += [array * 1.01, first.reshape(array.shape)]
            for bad in (np.inf, np.nan):
                spoiled = array.copy().reshape(-1)
                if spoiled.size:
                    spoiled[-1] = bad
                variants.append(spoiled.reshape(array.shape))
            variants.append(array.astype(np.float32))
        else:
            variants += [array + 1, array - 1, array.astype(np.int32)]
        if array.ndim:
            variants.append(array[:-1])
        for variant in variants:
            for sync in (False, True):
                yield name, {**arrays, name: variant}, sync
        yield name, {k: v for k, v in arrays.items() if k != name}, True
    yield "extra", {**arrays, "extra": np.zeros(2)}, True


def synced(document, arrays):
    return {**document, "arrays": {name: {"shape": list(a.shape), "dtype": a.dtype.str}
                                   for name, a in arrays.items()}}


@pytest.fixture(scope="module")
def fitted():
    X, y = data()
    from sklearn.base import clone

    return X, {type(c).__name__: clone(c).fit(X, y) for c in CALIBRATORS}


def assert_refused_or_identical(path, original, X, changed_content):
    try:
        loaded = load_calibrator(path)
    except CalibratorFileError:
        return "refused"
    assert not changed_content, "an edit without its hash fixed was accepted"
    np.testing.assert_array_equal(loaded.predict(X), original.predict(X), strict=True)
    return "identical"


@pytest.mark.parametrize("class_name", [type(c).__name__ for c in CALIBRATORS])
def test_every_edit_of_every_field_is_refused_or_harmless(tmp_path, fitted, class_name):
    X, calibrators = fitted
    original = calibrators[class_name]
    source = save_calibrator(original, tmp_path / "original.rcal")
    document, arrays = read_file(source)
    target = tmp_path / "edited.rcal"
    state = npz_bytes(arrays)
    outcomes = {"refused": 0, "identical": 0}
    # Every edit with the hash recomputed (the schema and the probe must catch it), every
    # fourth one also as it is (the hash must catch it).
    for count, (field, edited) in enumerate(metadata_edits(document)):
        for fix_hash in (False, True)[count % 4 != 0:]:
            if fix_hash and field == ("sha256",):
                continue
            write_file(target, edited, arrays, fix_hash, state)
            changed = not fix_hash and edited != document
            outcomes[assert_refused_or_identical(target, original, X, changed)] += 1
    for count, (field, edited_arrays, sync) in enumerate(array_edits(arrays)):
        edited = synced(document, edited_arrays) if sync else document
        for fix_hash in (False, True)[count % 4 != 0:]:
            write_file(target, edited, edited_arrays, fix_hash)
            changed = not fix_hash and (independent_digest(edited, edited_arrays)
                                        != independent_digest(document, arrays))
            outcomes[assert_refused_or_identical(target, original, X, changed)] += 1
    # Edits of what the prediction needs are refused; harmless ones (versions, training-only
    # hyper-parameters, the loss curve) are accepted.
    assert outcomes["refused"] > 50 and outcomes["identical"] > 0


@pytest.mark.parametrize("class_name", ["LinearCalibrator", "DNNCalibrator",
                                        "TwoPhaseCalibrator"])
def test_random_byte_flips_are_refused_or_harmless(tmp_path, fitted, class_name):
    X, calibrators = fitted
    original = calibrators[class_name]
    content = save_calibrator(original, tmp_path / "original.rcal").read_bytes()
    rng = np.random.default_rng(15)
    target = tmp_path / "flipped.rcal"
    outcomes = {"refused": 0, "identical": 0}
    for _ in range(200):
        damaged = bytearray(content)
        for position in rng.integers(0, len(content), size=rng.integers(1, 4)):
            damaged[position] ^= int(rng.integers(1, 256))
        target.write_bytes(bytes(damaged))
        outcomes[assert_refused_or_identical(target, original, X, False)] += 1
    for length in rng.integers(0, len(content), size=30):
        target.write_bytes(content[:length])
        outcomes[assert_refused_or_identical(target, original, X, True)] += 1
    assert outcomes["refused"] > 150


# --- version 1 files -----------------------------------------------------------------------


def as_version_1(path, target):
    """The file as format version 1 wrote it: no hash, no probe arrays."""
    document, arrays = read_file(path)
    arrays = {k: v for k, v in arrays.items() if not k.startswith("probe.")}
    document = {k: v for k, v in synced(document, arrays).items() if k != "sha256"}
    return write_file(target, {**document, "format_version": 1}, arrays, fix_hash=False)


@pytest.mark.parametrize("class_name", [type(c).__name__ for c in CALIBRATORS])
def test_version_1_files_still_load(tmp_path, fitted, class_name):
    X, calibrators = fitted
    original = calibrators[class_name]
    old = as_version_1(save_calibrator(original, tmp_path / "v2.rcal"), tmp_path / "v1.rcal")
    np.testing.assert_array_equal(load_calibrator(old).predict(X), original.predict(X))


def test_version_1_files_are_still_checked_against_the_schema(tmp_path, fitted):
    X, calibrators = fitted
    old = as_version_1(save_calibrator(calibrators["DNNCalibrator"], tmp_path / "v2.rcal"),
                       tmp_path / "v1.rcal")
    for edit in ({"activation": "bogus"}, {"hidden_layer_sizes": {"tuple": [6, 0]}}):
        edited = _rewrite(old, lambda d: {**d, "params": {**d["params"], **edit}})
        with pytest.raises(CalibratorFileError, match="field 'params"):
            load_calibrator(edited)


# --- atomic save ---------------------------------------------------------------------------

FAILING_SAVE = textwrap.dedent("""
    import resource, signal, sys
    from estimators import load_calibrator, save_calibrator
    calibrator = load_calibrator(sys.argv[1])
    limit = int(sys.argv[3])
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    try:
        save_calibrator(calibrator, sys.argv[2])
    except OSError as error:
        print(error.errno)
        sys.exit(0)
    sys.exit(3)
""")


@pytest.mark.skipif(sys.platform == "win32", reason="RLIMIT_FSIZE is POSIX")
def test_a_save_that_fails_part_way_keeps_the_earlier_file(tmp_path):
    import errno

    X, y = data()
    earlier = LinearCalibrator(raw_columns=[0, 1]).fit(X, y)
    target = save_calibrator(earlier, tmp_path / "model.rcal")
    before = target.read_bytes()
    big = DNNCalibrator(hidden_layer_sizes=(60, 60), max_epochs=1, random_state=0,
                        n_threads=1).fit(X, y)
    source = save_calibrator(big, tmp_path / "big.rcal")
    limit = source.stat().st_size // 2
    assert limit > len(before)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(PROJECT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])}
    result = subprocess.run([sys.executable, "-c", FAILING_SAVE, str(source), str(target),
                             str(limit)], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert int(result.stdout.split()[-1]) == errno.EFBIG
    assert target.read_bytes() == before
    np.testing.assert_array_equal(load_calibrator(target).predict(X), earlier.predict(X))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["big.rcal", "model.rcal"]


def test_saving_over_a_file_replaces_it_whole(tmp_path):
    X, y = data()
    target = save_calibrator(LinearCalibrator().fit(X, y), tmp_path / "model.rcal")
    second = PolynomialCalibrator(degree=2).fit(X, y)
    save_calibrator(second, target)
    np.testing.assert_array_equal(load_calibrator(target).predict(X), second.predict(X))
    assert [p.name for p in tmp_path.iterdir()] == ["model.rcal"]


def test_a_parameter_added_to_the_class_later_takes_its_default(tmp_path, fitted):
    X, calibrators = fitted
    original = calibrators["DNNCalibrator"]
    path = save_calibrator(original, tmp_path / "dnn.rcal")
    older = _rewrite(path, lambda d: {**d, "params": {k: v for k, v in d["params"].items()
                                                      if k != "n_threads"}})
    loaded = load_calibrator(older)
    assert loaded.n_threads is None
    np.testing.assert_array_equal(loaded.predict(X), original.predict(X))


def test_the_error_names_file_and_field_and_survives_pickling(saved_linear):
    import pickle

    edited = _rewrite(saved_linear, lambda d: {**d, "n_outputs": 0})
    with pytest.raises(CalibratorFileError) as caught:
        load_calibrator(edited)
    error = caught.value
    assert (error.path, error.field) == (edited, "n_outputs")
    assert str(error).startswith(f"{edited}, field 'n_outputs': must be a positive integer")
    copy_ = pickle.loads(pickle.dumps(error))
    assert type(copy_) is CalibratorFileError and str(copy_) == str(error)


def test_saving_into_a_missing_folder_names_it(tmp_path):
    X, y = data()
    with pytest.raises(FileNotFoundError, match="the folder .*missing does not exist"):
        save_calibrator(LinearCalibrator().fit(X, y), tmp_path / "missing" / "model.rcal")
