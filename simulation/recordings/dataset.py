"""One synchronized calibration table: robot-state features of one arm, ground truth, labels.

``synchronize`` pairs every robot-state sample with the external-encoder ground truth linearly
interpolated at its time (the paper records ravenstate at 30 Hz and the encoders at 100 Hz).
``CalibrationDataset`` holds the result as a pandas table with these columns, all SI:

``time``
    s, the robot-state stamp.
feature columns (``FEATURE_COLUMNS``, 122)
    Every ravenstate entry of the arm, named ``<field>.<entry>`` (``jpos.shoulder``, ``tau.grasp2``,
    ``pos.x``, ``ori.R01``, ``jac_vel.wz``...), plus one-entry fields by their field name
    (``type``, ``grasp_d``) and the shared status fields (``runlevel``, ``sublevel``, ``last_seq``,
    ``dt``), in message order. The column names do not depend on the arm.
``truth.shoulder``, ``truth.elbow``, ``truth.z_ins``
    Ground truth of joints 1-3 (rad, rad, m).
``raw.shoulder``, ``raw.elbow``, ``raw.z_ins``
    The uncorrected joint positions of joints 1-3 (the arm's ``jpos``; rad, rad, m).
``valid``
    Boolean: False for a row holding a value the robot cannot produce, or synchronized with such
    a ground-truth sample (``simulation.recordings.limits``). Readers set it (``read_parquet``,
    ``read_csv``, and through ``synchronize`` the bag reader); a table without it is all valid.
    Such rows may hold non-finite values. Training and filtering should use ``valid_mask()``.
``label.<name>``
    Scenario labels (``label.payload_kg``...).

Named feature groups pick the model inputs: "selected" (the paper's 16 inputs: ``jpos.*`` then
``tau.*`` of the arm's 8 slots) and "all" (the 122 feature columns, the paper's "whole robot state
of the arm"). ``register_feature_group`` adds more.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd

from simulation.recordings import tables
from simulation.recordings.bags import read_bag
from simulation.recordings.limits import (
    VALID_COLUMN,
    RecordingLimits,
    check_on_invalid,
    find_invalid,
    resolve_invalid,
)
from simulation.recordings.ravenstate import (
    DOF_NAMES,
    GROUND_TRUTH_JOINTS,
    GROUND_TRUTH_UNITS,
    RAVENSTATE_FIELDS,
    FieldSpec,
    GroundTruthLog,
    RavenStateLog,
    check_arm,
)

DEFAULT_MAX_GAP = 0.05
"""Longest ground-truth gap (s) interpolated across: five missed samples of the 100 Hz encoders."""

TIME_COLUMN = "time"
TRUTH_COLUMNS = tuple(f"truth.{joint}" for joint in GROUND_TRUTH_JOINTS)
RAW_COLUMNS = tuple(f"raw.{joint}" for joint in GROUND_TRUTH_JOINTS)
RAW_FEATURE_COLUMNS = tuple(f"jpos.{joint}" for joint in GROUND_TRUTH_JOINTS)
LABEL_PREFIX = "label."
KNOWN_LABEL_UNITS = MappingProxyType(
    {"payload_kg": "kg", "operating_hours": "h", "homing_count": "1", "segment": "code"}
)


def _columns_of(spec: FieldSpec) -> tuple[str, ...]:
    if spec.per_arm <= 1:
        return (spec.name,)
    return tuple(f"{spec.name}.{entry}" for entry in spec.entry_names)


FEATURE_COLUMNS: tuple[str, ...] = tuple(column for spec in RAVENSTATE_FIELDS for column in _columns_of(spec))
COLUMN_UNITS: Mapping[str, str] = MappingProxyType({
    TIME_COLUMN: "s",
    **{column: unit for spec in RAVENSTATE_FIELDS for column, unit in zip(_columns_of(spec), spec.si_units)},
    **dict(zip(TRUTH_COLUMNS, GROUND_TRUTH_UNITS)),
    **dict(zip(RAW_COLUMNS, GROUND_TRUTH_UNITS)),
    VALID_COLUMN: "bool",
})


# ---------------------------------------------------------------------------------------------
# Feature groups


@dataclass(frozen=True)
class FeatureGroup:
    """A named, ordered choice of model-input columns.

    Parameters
    ----------
    name : str
    columns : tuple of str
        Feature columns (``FEATURE_COLUMNS``) or label columns (``label.<name>``); never ground
        truth, raw or time columns.
    description : str
    """

    name: str
    columns: tuple[str, ...]
    description: str = ""

    def __post_init__(self) -> None:
        columns = tuple(self.columns)
        object.__setattr__(self, "columns", columns)
        if not self.name:
            raise ValueError("a feature group needs a name")
        if not columns:
            raise ValueError(f"feature group {self.name!r} has no columns")
        if len(set(columns)) != len(columns):
            raise ValueError(f"feature group {self.name!r} repeats a column")
        foreign = [c for c in columns if c not in FEATURE_COLUMNS and not c.startswith(LABEL_PREFIX)]
        if foreign:
            raise ValueError(f"feature group {self.name!r}: {foreign} are not feature or label columns")

    def raw_column_indices(self) -> tuple[int, int, int]:
        """Positions of ``jpos.shoulder``, ``jpos.elbow``, ``jpos.z_ins`` among the columns."""
        missing = [c for c in RAW_FEATURE_COLUMNS if c not in self.columns]
        if missing:
            raise ValueError(f"feature group {self.name!r} lacks the raw joint columns {missing}")
        return tuple(self.columns.index(column) for column in RAW_FEATURE_COLUMNS)


class FeatureGroupRegistry:
    """Feature groups by name; ``FEATURE_GROUPS`` is the project's registry."""

    def __init__(self, groups: Iterable[FeatureGroup] = ()) -> None:
        self._groups: dict[str, FeatureGroup] = {}
        for group in groups:
            self.register(group)

    def register(self, group: FeatureGroup, *, replace: bool = False) -> FeatureGroup:
        """Add ``group``; an existing name is an error unless ``replace`` is True."""
        if group.name in self._groups and not replace:
            raise ValueError(f"feature group {group.name!r} exists already (pass replace=True)")
        self._groups[group.name] = group
        return group

    def __getitem__(self, name: str) -> FeatureGroup:
        if name not in self._groups:
            raise KeyError(f"no feature group {name!r}; known groups: {sorted(self._groups)}")
        return self._groups[name]

    def __contains__(self, name: object) -> bool:
        return name in self._groups

    def names(self) -> tuple[str, ...]:
        """Registered group names, in registration order."""
        return tuple(self._groups)


SELECTED = FeatureGroup(
    "selected",
    tuple(f"jpos.{dof}" for dof in DOF_NAMES) + tuple(f"tau.{dof}" for dof in DOF_NAMES),
    "joint positions and motor torques of the arm's 8 slots (the paper's 16 selected inputs)",
)
ALL = FeatureGroup("all", FEATURE_COLUMNS, "the whole robot state of the arm and the shared status fields")
FEATURE_GROUPS = FeatureGroupRegistry([SELECTED, ALL])


def register_feature_group(name: str, columns: Sequence[str], description: str = "",
                           *, replace: bool = False) -> FeatureGroup:
    """Define a feature group in ``FEATURE_GROUPS`` and return it."""
    return FEATURE_GROUPS.register(FeatureGroup(name, tuple(columns), description), replace=replace)


def feature_group(group: str | FeatureGroup) -> FeatureGroup:
    """Resolve a group name through ``FEATURE_GROUPS``; a ``FeatureGroup`` passes through."""
    return group if isinstance(group, FeatureGroup) else FEATURE_GROUPS[group]


# ---------------------------------------------------------------------------------------------
# The dataset


def _first_bad_row(bad: np.ndarray) -> int:
    return int(np.flatnonzero(bad)[0])


def _unflagged(frame: pd.DataFrame) -> pd.DataFrame:
    """A table read from a file, every row marked valid until checked (so that non-finite values
    reach the limit check, which flags them, instead of failing the constructor)."""
    frame = frame.drop(columns=[VALID_COLUMN], errors="ignore")
    with np.errstate(invalid="ignore"):
        finite = np.isfinite(frame.select_dtypes(include=[np.number]).to_numpy(dtype=np.float64)).all(axis=1)
    frame = frame.copy()
    frame[VALID_COLUMN] = finite
    return frame


@dataclass(frozen=True, eq=False)
class CalibrationDataset:
    """Synchronized robot state, ground truth and labels of one arm, as one table.

    Parameters
    ----------
    table : DataFrame
        Columns as described in the module docstring (SI units, see ``units``). The dataset keeps
        its own copy with a fresh index and columns in canonical order; treat it as read-only.
    arm : {"left", "right"}
        The arm the features belong to.
    n_dropped_outside : int
        Robot-state samples dropped because they lay outside the ground truth's time span.
    n_dropped_in_gaps : int
        Robot-state samples dropped because they fell in a ground-truth gap longer than ``max_gap``.
    max_gap : float or None
        The gap threshold used by ``synchronize``, s.

    Raises
    ------
    ValueError
        A required column is missing, a column is unknown or non-numeric, a valid row holds a
        non-finite value (naming the column and the first bad row), or ``valid`` is not boolean.
    """

    table: pd.DataFrame
    arm: str = "left"
    n_dropped_outside: int = 0
    n_dropped_in_gaps: int = 0
    max_gap: float | None = None

    def __post_init__(self) -> None:
        check_arm(self.arm)
        if not isinstance(self.table, pd.DataFrame):
            raise TypeError(f"table must be a pandas DataFrame, got {type(self.table).__name__}")
        required = (TIME_COLUMN, *FEATURE_COLUMNS, *TRUTH_COLUMNS, *RAW_COLUMNS)
        missing = [column for column in required if column not in self.table.columns]
        if missing:
            raise ValueError(f"dataset table lacks columns {missing}")
        labels = [column for column in self.table.columns if column not in (*required, VALID_COLUMN)]
        unknown = [column for column in labels if not str(column).startswith(LABEL_PREFIX)]
        if unknown:
            raise ValueError(f"dataset table has unknown columns {unknown} (labels start with {LABEL_PREFIX!r})")
        table = self.table.reset_index(drop=True)
        if VALID_COLUMN in table.columns:
            valid = table[VALID_COLUMN].to_numpy()
            if valid.dtype != np.bool_:
                raise ValueError(f"dataset column {VALID_COLUMN!r} must be boolean, got dtype {valid.dtype}")
        else:
            valid = np.ones(len(table), dtype=bool)
        table = table.loc[:, [*required, *labels]].copy()
        table.insert(len(required), VALID_COLUMN, valid)
        for column in table.columns:
            values = table[column].to_numpy()
            if not (np.issubdtype(values.dtype, np.number) or values.dtype == np.bool_):
                raise ValueError(f"dataset column {column!r} is not numeric (dtype {values.dtype})")
            finite = np.isfinite(values) | ~valid
            if not np.all(finite):
                raise ValueError(f"dataset column {column!r} is not finite at row {_first_bad_row(~finite)}")
        for count in ("n_dropped_outside", "n_dropped_in_gaps"):
            if int(getattr(self, count)) != getattr(self, count) or getattr(self, count) < 0:
                raise ValueError(f"{count} must be a non-negative integer")
        object.__setattr__(self, "table", table)

    def __len__(self) -> int:
        return len(self.table)

    @property
    def time(self) -> np.ndarray:
        """Sample times, s, shape (N,)."""
        return self.table[TIME_COLUMN].to_numpy(dtype=np.float64)

    @property
    def targets(self) -> np.ndarray:
        """Ground truth of joints 1-3, shape (N, 3): shoulder rad, elbow rad, insertion m."""
        return self.table.loc[:, list(TRUTH_COLUMNS)].to_numpy(dtype=np.float64)

    @property
    def raw_joints(self) -> np.ndarray:
        """Uncorrected joint positions of joints 1-3 from the motor encoders, shape (N, 3)."""
        return self.table.loc[:, list(RAW_COLUMNS)].to_numpy(dtype=np.float64)

    @property
    def raw_errors(self) -> np.ndarray:
        """``targets - raw_joints``: what an error-predicting calibrator learns, shape (N, 3)."""
        return self.targets - self.raw_joints

    def valid_mask(self) -> np.ndarray:
        """Rows free of impossible values, shape (N,) bool (a copy of the ``valid`` column).

        Learned calibrators should fit on ``dataset.select(dataset.valid_mask())``; a filter
        should predict through (coast over) the rows where it is False.
        """
        return self.table[VALID_COLUMN].to_numpy(dtype=bool).copy()

    @property
    def n_invalid(self) -> int:
        """Number of rows flagged as holding impossible values."""
        return int((~self.table[VALID_COLUMN].to_numpy(dtype=bool)).sum())

    def check(self, on_invalid: str = "flag", *, source: str = "dataset",
              limits: RecordingLimits | None = None) -> CalibrationDataset:
        """This dataset with its rows checked against the arm's physical limits.

        Parameters
        ----------
        on_invalid : {"flag", "drop", "raise"}
            Flag (``valid`` False, kept), drop, or raise ``ImpossibleValueError``; flagging and
            dropping warn once (``ImpossibleValueWarning``). Rows already flagged stay flagged.
        source : str
            How the warning or error names the data (the readers pass the file).
        limits : RecordingLimits, optional
            Default: ``RecordingLimits.for_arm(self.arm)``.

        Returns
        -------
        CalibrationDataset
        """
        return self._check(on_invalid, source, limits, stacklevel=4)

    def _check(self, on_invalid: str, source, limits: RecordingLimits | None, stacklevel: int) -> CalibrationDataset:
        check_on_invalid(on_invalid)
        table = self.table
        found = find_invalid(table[TIME_COLUMN].to_numpy(), {c: table[c].to_numpy() for c in table.columns},
                             self.arm, limits)
        resolve_invalid(source, [("", found)], on_invalid, stacklevel=stacklevel)
        valid = self.valid_mask() & ~found.mask
        if on_invalid == "drop":
            return self.select(valid)
        return CalibrationDataset(table.assign(**{VALID_COLUMN: valid}), self.arm, self.n_dropped_outside,
                                  self.n_dropped_in_gaps, self.max_gap)

    @property
    def label_names(self) -> tuple[str, ...]:
        """Scenario label names (without the ``label.`` prefix)."""
        return tuple(c[len(LABEL_PREFIX):] for c in self.table.columns if c.startswith(LABEL_PREFIX))

    @property
    def labels(self) -> pd.DataFrame:
        """Scenario labels, one column per label name, one row per sample."""
        columns = [LABEL_PREFIX + name for name in self.label_names]
        return self.table.loc[:, columns].rename(columns=lambda c: c[len(LABEL_PREFIX):])

    @property
    def units(self) -> dict[str, str]:
        """Unit of every column (labels: ``KNOWN_LABEL_UNITS`` or "")."""
        return {column: COLUMN_UNITS.get(column, KNOWN_LABEL_UNITS.get(column[len(LABEL_PREFIX):], ""))
                for column in self.table.columns}

    def features(self, group: str | FeatureGroup = "selected") -> tuple[np.ndarray, tuple[str, ...]]:
        """Model inputs of a feature group.

        Returns
        -------
        X : ndarray, shape (N, n_features), float64
        names : tuple of str
            Column names, in the order of ``X``.
        """
        group = feature_group(group)
        missing = [column for column in group.columns if column not in self.table.columns]
        if missing:
            raise ValueError(f"feature group {group.name!r} needs columns {missing} this dataset lacks")
        return self.table.loc[:, list(group.columns)].to_numpy(dtype=np.float64), group.columns

    def raw_column_indices(self, group: str | FeatureGroup = "selected") -> tuple[int, int, int]:
        """Positions of the raw joints 1-3 (``jpos`` shoulder, elbow, z_ins) in ``features(group)``."""
        return feature_group(group).raw_column_indices()

    def select(self, mask) -> CalibrationDataset:
        """A dataset of the rows picked by a boolean mask (N,) or row indices; drop counts are kept."""
        mask = np.asarray(mask)
        if mask.dtype == np.bool_ and mask.shape != (len(self),):
            raise ValueError(f"boolean mask has shape {mask.shape}, expected ({len(self)},)")
        if mask.dtype != np.bool_ and (mask.ndim != 1 or not np.issubdtype(mask.dtype, np.integer)):
            raise ValueError("select expects a boolean mask or a 1-D array of row indices")
        return CalibrationDataset(self.table.iloc[mask], self.arm, self.n_dropped_outside,
                                  self.n_dropped_in_gaps, self.max_gap)

    @classmethod
    def concat(cls, datasets: Sequence[CalibrationDataset]) -> CalibrationDataset:
        """Join datasets of the same arm and labels (rows in the given order; drop counts summed)."""
        datasets = list(datasets)
        if not datasets:
            raise ValueError("concat needs at least one CalibrationDataset")
        first = datasets[0]
        for position, dataset in enumerate(datasets[1:], start=1):
            if dataset.arm != first.arm:
                raise ValueError(f"dataset {position} is for arm {dataset.arm!r}, dataset 0 for {first.arm!r}")
            if set(dataset.label_names) != set(first.label_names):
                raise ValueError(f"dataset {position} has labels {dataset.label_names}, dataset 0 has "
                                 f"{first.label_names}")
        gaps = {dataset.max_gap for dataset in datasets}
        return cls(
            pd.concat([dataset.table for dataset in datasets], ignore_index=True),
            first.arm,
            sum(dataset.n_dropped_outside for dataset in datasets),
            sum(dataset.n_dropped_in_gaps for dataset in datasets),
            gaps.pop() if len(gaps) == 1 else None,
        )

    def _metadata(self) -> dict:
        return {"arm": self.arm, "units": self.units, "n_dropped_outside": int(self.n_dropped_outside),
                "n_dropped_in_gaps": int(self.n_dropped_in_gaps), "max_gap": self.max_gap}

    def to_parquet(self, path: str | os.PathLike, *, overwrite: bool = True) -> Path:
        """Write the table to Parquet, with arm, units, drop counts and format version as metadata.

        The file is written atomically (a failure leaves no file).
        """
        return tables.write_parquet(self.table, path, self._metadata(), overwrite=overwrite)

    def to_csv(self, path: str | os.PathLike, *, overwrite: bool = True) -> Path:
        """Write the table as CSV (SI units, column names as in the table), atomically."""
        return tables.write_csv(self.table, path, overwrite=overwrite)

    @classmethod
    def read_parquet(cls, path: str | os.PathLike, *, on_invalid: str = "flag",
                     limits: RecordingLimits | None = None) -> CalibrationDataset:
        """Read a dataset written by ``to_parquet`` and check it against the arm's limits.

        Parameters
        ----------
        path : path-like
        on_invalid : {"flag", "drop", "raise"}
            See ``check``; the warning or error names the file.
        limits : RecordingLimits, optional

        Raises
        ------
        TableFormatError
            Not a dataset file, another format version, other units, or a table that is not a
            dataset (missing or unknown columns, a non-finite value in a row marked valid...).
        ImpossibleValueError
            ``on_invalid="raise"`` and a row holds an impossible value.
        """
        check_on_invalid(on_invalid)
        frame, metadata = tables.read_parquet(path)
        try:
            file_units = metadata["units"]
            other = {c: u for c, u in file_units.items() if c in COLUMN_UNITS and COLUMN_UNITS[c] != u}
            if other:
                raise ValueError(f"columns in other units than this reader's: {other}")
            dataset = cls(_unflagged(frame), metadata["arm"], metadata["n_dropped_outside"],
                          metadata["n_dropped_in_gaps"], metadata["max_gap"])
        except (KeyError, TypeError, ValueError) as error:
            raise tables.TableFormatError(f"{path}: {error}") from error
        return dataset._checked_copy(frame, on_invalid, path, limits)

    @classmethod
    def read_csv(cls, path: str | os.PathLike, arm: str = "left", *, on_invalid: str = "flag",
                 limits: RecordingLimits | None = None) -> CalibrationDataset:
        """Read a dataset written by ``to_csv`` (SI units, the table's column names) and check it.

        Parameters
        ----------
        path : path-like
        arm : {"left", "right"}
            The arm of the features (a CSV file does not record it).
        on_invalid : {"flag", "drop", "raise"}
            See ``check``; the warning or error names the file.
        limits : RecordingLimits, optional

        Raises
        ------
        TableFormatError
            Not a readable CSV table, or a table that is not a dataset.
        ImpossibleValueError
            ``on_invalid="raise"`` and a row holds an impossible value.
        """
        check_arm(arm)
        check_on_invalid(on_invalid)
        frame = tables.read_csv(path)
        try:
            dataset = cls(_unflagged(frame), arm)
        except (TypeError, ValueError) as error:
            raise tables.TableFormatError(f"{path}: {error}") from error
        return dataset._checked_copy(frame, on_invalid, path, limits)

    def _checked_copy(self, frame: pd.DataFrame, on_invalid: str, path, limits) -> CalibrationDataset:
        """``check`` of a table just read, keeping the flags the file carried."""
        if VALID_COLUMN in frame.columns:
            stored = frame[VALID_COLUMN].to_numpy()
            if stored.dtype != np.bool_:
                raise tables.TableFormatError(f"{path}: column {VALID_COLUMN!r} must be boolean, "
                                              f"got dtype {stored.dtype}")
            marked = CalibrationDataset(self.table.assign(**{VALID_COLUMN: stored & self.valid_mask()}), self.arm,
                                        self.n_dropped_outside, self.n_dropped_in_gaps, self.max_gap)
        else:
            marked = self
        return marked._check(on_invalid, str(path), limits, stacklevel=5)


# ---------------------------------------------------------------------------------------------
# Building datasets


def _truth_samples(state_time: np.ndarray, truth_time: np.ndarray, max_gap: float):
    """Masks of state samples outside the truth span and inside over-long truth gaps."""
    last = truth_time.size - 2
    interval = np.clip(np.searchsorted(truth_time, state_time, side="right") - 1, 0, last)
    before, after = truth_time[interval], truth_time[interval + 1]
    outside = (state_time < truth_time[0]) | (state_time > truth_time[-1])
    on_sample = (state_time == before) | (state_time == after)
    in_gap = ~outside & ~on_sample & ((after - before) > max_gap)
    return outside, in_gap


def _truth_valid(time: np.ndarray, truth_log: GroundTruthLog) -> np.ndarray:
    """Whether both ground-truth samples a time is interpolated between are valid."""
    interval = np.clip(np.searchsorted(truth_log.time, time, side="right") - 1, 0, truth_log.time.size - 2)
    return truth_log.valid[interval] & truth_log.valid[interval + 1]


def _feature_frame(state_log: RavenStateLog, arm: str, keep: np.ndarray) -> dict[str, np.ndarray]:
    columns = {}
    for spec in RAVENSTATE_FIELDS:
        values = state_log.arm_values(spec.name, arm)[keep]
        names = _columns_of(spec)
        if values.ndim == 1:
            columns[names[0]] = values
        else:
            columns.update({name: values[:, entry] for entry, name in enumerate(names)})
    return columns


def synchronize(state_log: RavenStateLog, truth_log: GroundTruthLog, arm: str | None = None,
                *, max_gap: float = DEFAULT_MAX_GAP) -> CalibrationDataset:
    """Pair each robot-state sample with the ground truth linearly interpolated at its time.

    Parameters
    ----------
    state_log : RavenStateLog
    truth_log : GroundTruthLog
        At least two samples.
    arm : {"left", "right"}, optional
        The arm whose state becomes the features (default: ``state_log.arm``).
    max_gap : float
        Longest interval between two ground-truth samples that is interpolated across, s.
        Robot-state samples inside a longer gap are dropped (unless they coincide with a
        ground-truth sample).

    Returns
    -------
    CalibrationDataset
        With ``n_dropped_outside`` (samples before the first or after the last ground-truth
        sample) and ``n_dropped_in_gaps`` set; a row is ``valid`` when its robot-state sample
        and the two ground-truth samples around it are.

    Raises
    ------
    ValueError
        Fewer than two ground-truth samples, a non-positive ``max_gap``, or no robot-state sample
        left after dropping.
    """
    if not isinstance(state_log, RavenStateLog) or not isinstance(truth_log, GroundTruthLog):
        raise TypeError("synchronize expects a RavenStateLog and a GroundTruthLog")
    arm = check_arm(arm or state_log.arm)
    if not (np.isfinite(max_gap) and max_gap > 0.0):
        raise ValueError(f"max_gap must be a positive number of seconds, got {max_gap!r}")
    if len(truth_log) < 2:
        raise ValueError(f"ground truth has {len(truth_log)} samples; interpolation needs at least 2")
    outside, in_gap = _truth_samples(state_log.time, truth_log.time, max_gap)
    keep = ~outside & ~in_gap
    if not np.any(keep):
        raise ValueError(
            f"no robot-state sample is within the ground truth's time span [{float(truth_log.time[0])}, "
            f"{float(truth_log.time[-1])}] s outside gaps longer than {max_gap} s "
            f"({int(outside.sum())} outside, {int(in_gap.sum())} in gaps)"
        )
    time = state_log.time[keep]
    truth = np.column_stack([np.interp(time, truth_log.time, truth_log.joints[:, j]) for j in range(3)])
    valid = state_log.valid[keep] & _truth_valid(time, truth_log)
    features = _feature_frame(state_log, arm, keep)
    raw = np.column_stack([features[column] for column in RAW_FEATURE_COLUMNS])
    table = pd.DataFrame({
        TIME_COLUMN: time,
        **features,
        **dict(zip(TRUTH_COLUMNS, truth.T)),
        **dict(zip(RAW_COLUMNS, raw.T)),
        VALID_COLUMN: valid,
        **{LABEL_PREFIX + name: values[keep] for name, values in state_log.labels.items()},
    })
    return CalibrationDataset(table, arm, int(outside.sum()), int(in_gap.sum()), float(max_gap))


def convert_bag(bag_path: str | os.PathLike, out_path: str | os.PathLike, *, arm: str = "left",
                max_gap: float = DEFAULT_MAX_GAP, overwrite: bool = True, **topics: str) -> CalibrationDataset:
    """Read a bag, synchronize it and write the dataset (``.parquet`` or ``.csv`` by suffix).

    Nothing is written unless every step succeeds.

    Parameters
    ----------
    bag_path, out_path : path-like
    arm : {"left", "right"}
    max_gap : float
        See ``synchronize``, s.
    overwrite : bool
        Whether an existing output file may be replaced.
    **topics
        Topic names, ``on_invalid`` and ``limits`` as in ``simulation.recordings.bags.read_bag``.

    Returns
    -------
    CalibrationDataset
        The dataset that was written.
    """
    suffix = Path(out_path).suffix.lower()
    if suffix not in (".parquet", ".csv"):
        raise ValueError(f"output file {out_path} must end in .parquet or .csv")
    state_log, truth_log = read_bag(bag_path, arm, **topics)
    dataset = synchronize(state_log, truth_log, arm, max_gap=max_gap)
    if suffix == ".parquet":
        dataset.to_parquet(out_path, overwrite=overwrite)
    else:
        dataset.to_csv(out_path, overwrite=overwrite)
    return dataset
