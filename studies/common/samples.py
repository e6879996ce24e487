"""What a study trains and evaluates on: model inputs, ground truth and context, one row per sample.

A :class:`Samples` holds the inputs X of the calibrators, the ground truth of joints 1-3, the
uncorrected joints, the tool joints that the tool-tip evaluation takes as exact, and an integer
recording id per row. Rows are in time order within each recording; recordings are never
interleaved, so the temporal-window calibrators see real histories. It is built from a
:class:`simulation.recordings.dataset.CalibrationDataset` (simulated runs, ROS bags, dataset files) or from
plain arrays (e.g. the dVRK recordings, which hold joint positions only).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from simulation.recordings.dataset import CalibrationDataset

TOOL_JOINT_COLUMNS = ("jpos.tool_rot", "jpos.wrist", "jpos.grasp1", "jpos.grasp2")
"""Dataset columns of the tool DOFs; they give the controller's J3 (roll), J4 (wrist) and
J5 = (grasp2 - grasp1) / 2."""


def tool_joints_of(dataset: CalibrationDataset) -> np.ndarray:
    """Controller joints J3..J5 (rad) of every row, from the recorded tool DOFs, shape (N, 3)."""
    roll, wrist, grasp1, grasp2 = (dataset.table[c].to_numpy(dtype=np.float64) for c in TOOL_JOINT_COLUMNS)
    return np.column_stack([roll, wrist, 0.5 * (grasp2 - grasp1)])


def _frozen(array, dtype=np.float64) -> np.ndarray:
    out = np.array(array, dtype=dtype, copy=True)
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class Samples:
    """Calibrator inputs with ground truth and context, rows time-ordered per recording.

    Parameters
    ----------
    X : ndarray, shape (N, F)
        Model inputs in SI units.
    feature_names : tuple of str, length F
    raw_columns : tuple of int, length 3
        Columns of X holding the uncorrected joints 1-3 (a calibrator trained "on error" adds its
        output to them).
    targets : ndarray, shape (N, 3)
        Ground truth of joints 1-3 (rad, rad, m).
    time : ndarray, shape (N,)
        Sample time, s (the clock of its recording).
    recording : ndarray of int, shape (N,)
        Recording id of each row; rows of one id are consecutive and in time order.
    tool_joints : ndarray, shape (N, 3), or None
        Joints J3..J5 (rad) taken as exact for the tool-tip error; None where the robot's
        kinematics is not RAVEN-II's (the tool-tip evaluation is then skipped).
    arm : {"left", "right"}
    labels : mapping of str to ndarray (N,)
        Scenario labels (``payload_kg``, ``operating_hours``, ``homing_count``...), may be empty.
    dataset : CalibrationDataset or None
        The full robot state of the same rows, for estimators that need more than X (the UKF).
    stride : int
        1 when consecutive rows are consecutive log samples; k when every k-th sample was kept
        (such rows are no history for a temporal-window model).

    Raises
    ------
    ValueError
        Shapes that disagree, values that are not finite, raw columns out of range, recording
        ids that are not in consecutive blocks, or times that do not increase within a recording.
    """

    X: np.ndarray
    feature_names: tuple[str, ...]
    raw_columns: tuple[int, int, int]
    targets: np.ndarray
    time: np.ndarray
    recording: np.ndarray
    tool_joints: np.ndarray | None = None
    arm: str = "left"
    labels: Mapping[str, np.ndarray] = field(default_factory=dict)
    dataset: CalibrationDataset | None = None
    stride: int = 1

    def __post_init__(self) -> None:
        X = _frozen(self.X)
        targets = _frozen(self.targets)
        n = X.shape[0] if X.ndim == 2 else -1
        if X.ndim != 2 or n == 0:
            raise ValueError(f"X must have shape (N >= 1, F), got {np.shape(self.X)}")
        if targets.shape != (n, 3):
            raise ValueError(f"targets must have shape ({n}, 3), got {targets.shape}")
        names = tuple(str(name) for name in self.feature_names)
        if len(names) != X.shape[1]:
            raise ValueError(f"{len(names)} feature names for {X.shape[1]} columns of X")
        raw = tuple(int(c) for c in self.raw_columns)
        if len(raw) != 3 or min(raw) < 0 or max(raw) >= X.shape[1]:
            raise ValueError(f"raw_columns must be 3 column indices of X (F = {X.shape[1]}), got {self.raw_columns}")
        time = _frozen(self.time)
        recording = _frozen(self.recording, np.int64)
        if time.shape != (n,) or recording.shape != (n,):
            raise ValueError(f"time and recording must have shape ({n},), got {time.shape} and {recording.shape}")
        target_names = ("joint 1", "joint 2", "joint 3")
        for name, values, columns in (("X", X, names), ("targets", targets, target_names), ("time", time, None)):
            finite = np.isfinite(values)
            if not np.all(finite):
                row, *column = np.argwhere(~finite)[0]
                where = f"row {row}" + (f", column {columns[column[0]]!r}" if column and columns else "")
                raise ValueError(f"{name} contains NaN or infinity (first at {where})")
        starts = recording[np.r_[True, recording[1:] != recording[:-1]]]
        if np.unique(starts).size != starts.size:
            raise ValueError("rows of one recording must be consecutive (recordings are never interleaved)")
        # the temporal models (windows, the UKF) read a recording's rows as one time series
        backwards = np.flatnonzero((recording[1:] == recording[:-1]) & (np.diff(time) <= 0))
        if backwards.size:
            row = int(backwards[0]) + 1
            raise ValueError(f"time must increase strictly within a recording; it does not at row {row} "
                             f"(recording {recording[row]}, t = {time[row]:.6f} s after {time[row - 1]:.6f} s)")
        tool = None
        if self.tool_joints is not None:
            tool = _frozen(self.tool_joints)
            if tool.shape != (n, 3) or not np.all(np.isfinite(tool)):
                raise ValueError(f"tool_joints must be finite with shape ({n}, 3), got {tool.shape}")
        labels = {}
        for key, values in dict(self.labels).items():
            values = np.asarray(values)
            if values.shape != (n,):
                raise ValueError(f"label {key!r} has shape {values.shape}, expected ({n},)")
            labels[key] = values
        if self.dataset is not None and len(self.dataset) != n:
            raise ValueError(f"dataset has {len(self.dataset)} rows for {n} samples")
        if int(self.stride) < 1:
            raise ValueError(f"stride must be a positive integer, got {self.stride}")
        for attribute, value in (("X", X), ("targets", targets), ("feature_names", names),
                                 ("raw_columns", raw), ("time", time), ("recording", recording),
                                 ("tool_joints", tool), ("labels", MappingProxyType(labels)),
                                 ("stride", int(self.stride))):
            object.__setattr__(self, attribute, value)

    def __len__(self) -> int:
        return self.X.shape[0]

    @property
    def raw_joints(self) -> np.ndarray:
        """Uncorrected joints 1-3, shape (N, 3), the raw columns of X."""
        return self.X[:, list(self.raw_columns)]

    @property
    def has_motor_torques(self) -> bool:
        """Whether the full robot state (with motor torques) of these rows is available."""
        return self.dataset is not None

    @property
    def duration(self) -> float:
        """Summed time span of the recordings, s."""
        return float(sum(np.ptp(self.time[self.recording == r]) for r in np.unique(self.recording)))

    def recordings(self) -> list[np.ndarray]:
        """Row indices of each recording, in the order they appear."""
        change = np.flatnonzero(np.r_[True, self.recording[1:] != self.recording[:-1], True])
        return [np.arange(a, b) for a, b in zip(change[:-1], change[1:])]

    @classmethod
    def from_dataset(cls, dataset: CalibrationDataset, group: str = "selected", recording: int = 0,
                     *, keep_dataset: bool = True, stride: int = 1) -> "Samples":
        """Samples of one time-ordered recording, inputs from a feature group of the dataset.

        Parameters
        ----------
        dataset : CalibrationDataset
        group : feature group name ("selected": the paper's 16 inputs, "all": the whole state).
        recording : id given to all rows.
        keep_dataset : keep the full dataset for estimators that need it (the UKF).
        stride : how many log samples apart the dataset's rows are (see the class).
        """
        X, names = dataset.features(group)
        labels = {name: dataset.labels[name].to_numpy() for name in dataset.label_names}
        return cls(X=X, feature_names=names, raw_columns=dataset.raw_column_indices(group),
                   targets=dataset.targets, time=dataset.time,
                   recording=np.full(len(dataset), recording, dtype=np.int64),
                   tool_joints=tool_joints_of(dataset), arm=dataset.arm, labels=labels,
                   dataset=dataset if keep_dataset else None, stride=stride)

    def select(self, rows) -> "Samples":
        """The samples of a boolean mask or of increasing row indices (order is kept)."""
        rows = np.asarray(rows)
        if rows.dtype == np.bool_:
            if rows.shape != (len(self),):
                raise ValueError(f"mask has shape {rows.shape}, expected ({len(self)},)")
            rows = np.flatnonzero(rows)
        if rows.ndim != 1 or not np.issubdtype(rows.dtype, np.integer):
            raise ValueError("select expects a boolean mask or a 1-D array of row indices")
        if rows.size == 0:
            raise ValueError("select would leave no sample")
        if np.any(np.diff(rows) <= 0):
            raise ValueError("row indices must be strictly increasing (time order is kept)")
        # consecutive log samples within each recording (a jump to another recording is no gap)
        same_recording = self.recording[rows[1:]] == self.recording[rows[:-1]]
        contiguous = bool(np.all(np.diff(rows)[same_recording] == 1))
        return Samples(
            X=self.X[rows], feature_names=self.feature_names, raw_columns=self.raw_columns,
            targets=self.targets[rows], time=self.time[rows], recording=self.recording[rows],
            tool_joints=None if self.tool_joints is None else self.tool_joints[rows], arm=self.arm,
            labels={k: v[rows] for k, v in self.labels.items()},
            dataset=None if self.dataset is None else self.dataset.select(rows),
            stride=self.stride if contiguous else max(self.stride, 2),
        )

    def without_dataset(self) -> "Samples":
        """The same samples without the full robot state (smaller to send to a worker)."""
        return Samples(X=self.X, feature_names=self.feature_names, raw_columns=self.raw_columns,
                       targets=self.targets, time=self.time, recording=self.recording,
                       tool_joints=self.tool_joints, arm=self.arm, labels=self.labels,
                       dataset=None, stride=self.stride)

    @staticmethod
    def concat(parts: Sequence["Samples"]) -> "Samples":
        """Join samples of distinct recordings (ids are renumbered 0, 1, ... in part order).

        The full robot state is kept only if every part has it.
        """
        parts = list(parts)
        if not parts:
            raise ValueError("concat needs at least one Samples")
        first = parts[0]
        for position, part in enumerate(parts[1:], start=1):
            if part.feature_names != first.feature_names or part.raw_columns != first.raw_columns:
                raise ValueError(f"part {position} has other features than part 0")
            if part.arm != first.arm:
                raise ValueError(f"part {position} is of arm {part.arm!r}, part 0 of {first.arm!r}")
            if (part.tool_joints is None) != (first.tool_joints is None):
                raise ValueError(f"part {position} and part 0 disagree on having tool joints")
        ids, offset = [], 0
        for part in parts:
            order = {rec: k for k, rec in enumerate(dict.fromkeys(part.recording.tolist()))}
            ids.append(np.array([order[r] for r in part.recording.tolist()], dtype=np.int64) + offset)
            offset += len(order)
        keys = set(first.labels)
        for part in parts[1:]:
            keys &= set(part.labels)
        datasets = [part.dataset for part in parts]
        return Samples(
            X=np.vstack([p.X for p in parts]), feature_names=first.feature_names,
            raw_columns=first.raw_columns, targets=np.vstack([p.targets for p in parts]),
            time=np.concatenate([p.time for p in parts]), recording=np.concatenate(ids),
            tool_joints=None if first.tool_joints is None else np.vstack([p.tool_joints for p in parts]),
            arm=first.arm, labels={k: np.concatenate([p.labels[k] for p in parts]) for k in sorted(keys)},
            dataset=None if any(d is None for d in datasets) else CalibrationDataset.concat(datasets),
            stride=max(p.stride for p in parts),
        )
