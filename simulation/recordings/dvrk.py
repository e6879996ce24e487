"""Loader of the real dVRK calibration data of Hwang et al. (RA-L 2020).

The data (public repository ``BerkeleyAutomation/dvrkCalibration``, folder
experiment/3_training) holds, per recording ("split"), three numpy arrays:

- ``q_des.npy`` (N, 6): joint positions the dVRK controller commands/reports, the uncorrected
  input;
- ``q_act.npy`` (N, 6): joint positions measured with RGB-D tracked fiducials, the ground truth;
- ``t_stamp.npy`` (N,): time in seconds, about 0.4 s apart.

Joints are those of a patient-side manipulator, in SI units: outer yaw (rad), outer pitch
(rad), insertion (m), tool roll (rad), wrist pitch (rad), wrist yaw (rad). The loader turns a
split into calibrator inputs X (from ``q_des``, optionally with past samples and velocities)
and targets y = ``q_act``.

The data folder is found from, in order: an explicit path, the environment variable
``RAVEN_DVRK_DATA``, or ``<repository>/../shared/data/dvrk_hwang2020``.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ENVIRONMENT_VARIABLE = "RAVEN_DVRK_DATA"
SPLITS = ("random_unfiltered", "peg_transfer")
JOINT_NAMES = ("outer_yaw", "outer_pitch", "insertion", "tool_roll", "wrist_pitch", "wrist_yaw")
# Only the insertion joint is prismatic (m); the others are rotational (rad).
PRISMATIC_JOINTS = (False, False, True, False, False, False)
# Indices of the wrist joints (the paper's joints 4-6, counted from 1), whose errors depend on
# the motion history.
WRIST_JOINTS = (3, 4, 5)

_REPOSITORY = Path(__file__).resolve().parents[2]
_DEFAULT_LOCATION = _REPOSITORY.parent / "shared" / "data" / "dvrk_hwang2020"
_FILES = ("q_des.npy", "q_act.npy", "t_stamp.npy")


class DvrkDataError(ValueError):
    """dVRK data files that are missing, unreadable or inconsistent."""


@dataclass(frozen=True, eq=False)
class DvrkDataset:
    """Calibrator inputs and targets of one dVRK recording (arrays are read-only).

    Unpacks as ``X, y, t, feature_names = load_dvrk(...)``.

    Attributes
    ----------
    X : ndarray, shape (n_samples, n_features)
        Commanded joint positions at t (columns 0-5), then, if requested, at each of the
        `history` previous samples, then commanded joint velocities (rad/s, m/s).
    y : ndarray, shape (n_samples, 6)
        Measured joint positions (rad, m).
    t : ndarray, shape (n_samples,)
        Time (s), strictly increasing.
    feature_names : tuple of str
        Name of each column of X.
    target_names : tuple of str
        Name of each column of y.
    raw_columns : tuple of int
        Columns of X holding the uncorrected position of each column of y: (0, ..., 5).
    split : str
        Recording name.
    """

    X: np.ndarray
    y: np.ndarray
    t: np.ndarray
    feature_names: tuple[str, ...]
    target_names: tuple[str, ...]
    raw_columns: tuple[int, ...]
    split: str

    def __iter__(self):
        return iter((self.X, self.y, self.t, self.feature_names))


def locate_dvrk_data(folder_or_root: str | os.PathLike | None = None) -> Path:
    """The dVRK data folder: the given path, else ``$RAVEN_DVRK_DATA``, else the shared folder.

    Raises
    ------
    FileNotFoundError
        If the chosen folder does not exist (the message says where it looked and how to
        point to the data).
    """
    if folder_or_root is not None:
        candidate, origin = Path(folder_or_root), "the given path"
    elif os.environ.get(ENVIRONMENT_VARIABLE):
        candidate, origin = Path(os.environ[ENVIRONMENT_VARIABLE]), f"${ENVIRONMENT_VARIABLE}"
    else:
        candidate, origin = _DEFAULT_LOCATION, "the default location"
    if not candidate.is_dir():
        raise FileNotFoundError(
            f"dVRK data folder not found at {candidate} ({origin}); pass its path or set "
            f"{ENVIRONMENT_VARIABLE} to the folder holding {', '.join(SPLITS)}."
        )
    return candidate


def load_dvrk(folder_or_root: str | os.PathLike | None = None, split: str = "random_unfiltered",
              history: int = 0, velocity: bool = False) -> DvrkDataset:
    """Load one dVRK recording as calibrator inputs and targets.

    Parameters
    ----------
    folder_or_root : path-like, optional
        The dataset root (holding one folder per split) or one split's folder (holding the
        three .npy files). Default: see `locate_dvrk_data`.
    split : {"random_unfiltered", "peg_transfer"}
        Recording to load when `folder_or_root` is the root (ignored for a split folder).
    history : int, default=0
        Number of previous commanded positions appended to each row (lag 1 first).
    velocity : bool, default=False
        Append the commanded joint velocities, backward differences over the sample interval.

    Returns
    -------
    DvrkDataset
        The first ``max(history, 1 if velocity else 0)`` samples are dropped so that every row
        holds real history, never padding.

    Raises
    ------
    FileNotFoundError
        If the folder or a file is missing.
    DvrkDataError
        If a file is unreadable, shapes disagree, values are not finite or time does not
        strictly increase.
    ValueError
        For an unknown split or a negative history.
    """
    if split not in SPLITS:
        raise ValueError(f"split must be one of {SPLITS}; got {split!r}.")
    if isinstance(history, bool) or not isinstance(history, (int, np.integer)) or history < 0:
        raise ValueError(f"history must be an integer >= 0; got {history!r}.")
    folder = locate_dvrk_data(folder_or_root)
    if not (folder / _FILES[0]).exists():
        folder = folder / split
    q_des, q_act, t = (_read_array(folder / name) for name in _FILES)
    _check_consistency(folder, q_des, q_act, t)

    drop = max(int(history), 1 if velocity else 0)
    if q_des.shape[0] <= drop:
        raise DvrkDataError(
            f"{folder} holds {q_des.shape[0]} samples, too few for history={history}.")
    blocks = [q_des[drop - lag: q_des.shape[0] - lag] for lag in range(int(history) + 1)]
    names = [f"q_des.{joint}" for joint in JOINT_NAMES]
    names += [f"q_des.{joint}[t-{lag}]"
              for lag in range(1, int(history) + 1) for joint in JOINT_NAMES]
    if velocity:
        rates = np.diff(q_des, axis=0) / np.diff(t)[:, None]
        blocks.append(rates[drop - 1:])
        names += [f"qd_des.{joint}" for joint in JOINT_NAMES]
    return DvrkDataset(
        X=_read_only(np.hstack(blocks)),
        y=_read_only(q_act[drop:]),
        t=_read_only(t[drop:]),
        feature_names=tuple(names),
        target_names=tuple(f"q_act.{joint}" for joint in JOINT_NAMES),
        raw_columns=tuple(range(len(JOINT_NAMES))),
        split=folder.name,
    )


def _read_array(path: Path) -> np.ndarray:
    if not path.is_file():
        raise FileNotFoundError(f"dVRK data file {path} is missing.")
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as error:
        raise DvrkDataError(f"dVRK data file {path} is unreadable or corrupt ({error}).") from None
    if not isinstance(array, np.ndarray) or array.dtype.kind not in "fiu":
        raise DvrkDataError(f"dVRK data file {path} does not hold a numeric array.")
    return np.asarray(array, dtype=np.float64)


def _check_consistency(folder: Path, q_des: np.ndarray, q_act: np.ndarray, t: np.ndarray) -> None:
    n_joints = len(JOINT_NAMES)
    for name, array in (("q_des", q_des), ("q_act", q_act)):
        if array.ndim != 2 or array.shape[1] != n_joints:
            raise DvrkDataError(
                f"{folder}/{name}.npy has shape {array.shape}; expected (n_samples, {n_joints}).")
    if t.ndim != 1:
        raise DvrkDataError(f"{folder}/t_stamp.npy has shape {t.shape}; expected (n_samples,).")
    if not q_des.shape[0] == q_act.shape[0] == t.shape[0]:
        raise DvrkDataError(
            f"{folder}: q_des, q_act and t_stamp hold {q_des.shape[0]}, {q_act.shape[0]} and "
            f"{t.shape[0]} samples; they must match.")
    for name, array in (("q_des", q_des), ("q_act", q_act), ("t_stamp", t)):
        bad = ~np.isfinite(array.reshape(array.shape[0], -1)).all(axis=1)
        if bad.any():
            raise DvrkDataError(
                f"{folder}/{name}.npy contains NaN or infinity (first at sample "
                f"{int(np.argmax(bad))}).")
    steps = np.diff(t)
    if np.any(steps <= 0):
        first = int(np.argmax(steps <= 0))
        raise DvrkDataError(
            f"{folder}/t_stamp.npy is not strictly increasing: t[{first + 1}] = {t[first + 1]} "
            f"after t[{first}] = {t[first]}.")


def _read_only(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.flags.writeable = False
    return array
