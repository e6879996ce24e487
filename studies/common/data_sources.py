"""Where a comparison's training and test samples come from: the virtual RAVEN-II or recorded data.

* :func:`simulated_comparison` runs the paper's protocol on the virtual RAVEN-II
  (:func:`simulation.paper_protocol`): J2-J3 zig-zag calibration at the paper's sparsities, then
  independent 20-minute random tests, unloaded and with 500 g at the tool tip; with
  ``loaded_calibration`` the loaded test is read a second time, after a calibration whose zig-zags
  were also recorded with the load (:data:`LOADED_CALIBRATION_TEST`).
* :func:`recorded_comparison` reads one's own robot data: a folder of ROS bags, a dataset file
  (``.parquet`` written by ``CalibrationDataset.to_parquet``, or its ``.csv``), a single bag, or
  the dVRK recordings of Hwang et al. (folder with ``q_des.npy``/``q_act.npy``/``t_stamp.npy``,
  or the root holding ``random_unfiltered`` and ``peg_transfer``).

Recorded data are split in time, never shuffled: unless a separate test file is given, the last
``test_fraction`` of the rows (in recording order) is the test set.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from simulation import paper_protocol, recording_to_dataset
from simulation.model.parameters import RavenParameters
from simulation.recordings.dataset import CalibrationDataset, synchronize
from simulation.recordings.bags import read_bag, read_bag_folder
from simulation.recordings.dvrk import SPLITS as DVRK_SPLITS
from simulation.recordings.dvrk import load_dvrk
from simulation.trajectories import PAPER_SPARSITIES

from studies.common.evaluation import raven_model
from studies.common.samples import Samples

DEFAULT_TEST_FRACTION = 0.3
LOADED_CALIBRATION_TEST = "loaded_load_in_calibration"
"""Test name of the loaded test scored by methods trained on zig-zags recorded unloaded and loaded."""


@dataclass(frozen=True, eq=False)
class ComparisonData:
    """Training samples and named test sets of one comparison.

    Attributes
    ----------
    train : Samples
    tests : test name -> Samples (e.g. ``"unloaded"``, ``"loaded"``)
    source : what the data are, in words.
    notes : lines for the report (what is missing from the data, how it was split...).
    trainings : test name -> the Samples the methods are trained on for that test, for tests read
        after another calibration than ``train`` (e.g. :data:`LOADED_CALIBRATION_TEST`); every
        other test is scored by the methods trained on ``train``.
    """

    train: Samples
    tests: dict[str, Samples]
    source: str
    notes: tuple[str, ...] = field(default_factory=tuple)
    trainings: dict[str, Samples] = field(default_factory=dict)

    def __post_init__(self) -> None:
        unknown = [name for name in self.trainings if name not in self.tests]
        if unknown:
            raise ValueError(f"trainings given for tests {unknown} that are not among the tests {list(self.tests)}")

    def training_for(self, test: str) -> Samples:
        """The samples the methods scored on ``test`` are trained on."""
        return self.trainings.get(test, self.train)

    def describe(self) -> dict:
        """Sizes and durations of the training and test sets."""
        def one(samples: Samples) -> dict:
            return {"samples": len(samples), "recordings": len(samples.recordings()),
                    "duration_s": round(samples.duration, 1)}

        sizes = {"train": one(self.train), **{name: one(test) for name, test in self.tests.items()}}
        if self.trainings:
            sizes["trainings"] = {name: one(train) for name, train in self.trainings.items()}
        return sizes


def simulated_comparison(seed: int = 0, direction: str = "J2-J3", sparsities=PAPER_SPARSITIES,
                         test_duration: float = 1200.0, payload_kg: float = 0.5,
                         params: RavenParameters | None = None,
                         loaded_calibration: bool = False) -> ComparisonData:
    """The paper's protocol on the virtual RAVEN-II, as training and test samples.

    The calibration is recorded unloaded; the ``"loaded"`` test hangs ``payload_kg`` at the tool
    tip, which no training sample saw. With ``loaded_calibration`` the loaded test is read a second
    time as :data:`LOADED_CALIBRATION_TEST`, by methods trained on the same zig-zags recorded twice,
    unloaded and then with the payload (two recordings). ``params`` describes the simulated robot
    (default: the virtual RAVEN-II, ``RavenParameters()``); the methods see only its logs.
    """
    runs = paper_protocol(params, seed=seed, direction=direction, sparsities=tuple(sparsities),
                          test_duration=test_duration, loaded_payload_kg=payload_kg,
                          loaded_calibration=loaded_calibration)
    robot = raven_model(runs.calibration.arm)
    train = Samples.from_dataset(recording_to_dataset(runs.calibration, robot))
    loaded = Samples.from_dataset(recording_to_dataset(runs.test_loaded, robot))
    tests = {"unloaded": Samples.from_dataset(recording_to_dataset(runs.test_unloaded, robot)), "loaded": loaded}
    sparsity_text = ", ".join(f"1/{round(1 / s)}" for s in sparsities)
    notes = [f"Calibration: {direction} zig-zags at sparsities {sparsity_text} "
             f"({train.duration:.0f} s, unloaded); tests: independent random motions of "
             f"{test_duration:.0f} s, unloaded and with {payload_kg * 1e3:.0f} g at the tool tip "
             "(the 'loaded' test: the load is not in the training data)."]
    trainings = {}
    if loaded_calibration:
        tests[LOADED_CALIBRATION_TEST] = loaded
        trainings[LOADED_CALIBRATION_TEST] = Samples.concat(
            [train, Samples.from_dataset(recording_to_dataset(runs.calibration_loaded, robot))])
        notes.append(f"The '{LOADED_CALIBRATION_TEST}' test is the same loaded test, read by the methods trained "
                     f"on the zig-zags recorded twice: unloaded, then again with {payload_kg * 1e3:.0f} g at the "
                     f"tool tip ({trainings[LOADED_CALIBRATION_TEST].duration:.0f} s in all, two recordings).")
    robot_name = "virtual RAVEN-II" if params is None or params == RavenParameters(arm=params.arm) else "simulated robot (given parameters)"
    return ComparisonData(train, tests, f"{robot_name} ({runs.calibration.arm} arm, seed {seed})", tuple(notes),
                          trainings)


# ---------------------------------------------------------------------------------------------
# Recorded data


def is_dvrk_folder(path: Path) -> bool:
    """Does ``path`` hold the dVRK recordings of Hwang et al. (one split, or the root of several)?"""
    path = Path(path)
    return path.is_dir() and ((path / "q_des.npy").is_file()
                              or any((path / split / "q_des.npy").is_file() for split in DVRK_SPLITS))


def _dvrk_samples(folder: Path, split: str, recording: int = 0) -> Samples:
    data = load_dvrk(folder, split=split)
    return Samples(X=data.X, feature_names=data.feature_names, raw_columns=(0, 1, 2),
                   targets=data.y[:, :3], time=data.t, recording=np.full(len(data.t), recording),
                   tool_joints=None, arm="left")


def _split_in_time(samples: Samples, test_fraction: float) -> tuple[Samples, Samples]:
    if not 0.0 < test_fraction < 1.0:
        raise ValueError(f"test_fraction must be in (0, 1), got {test_fraction}")
    n_test = int(round(len(samples) * test_fraction))
    if n_test < 2 or len(samples) - n_test < 2:
        raise ValueError(f"{len(samples)} samples are too few to hold out a test fraction of {test_fraction}")
    cut = len(samples) - n_test
    return samples.select(np.arange(cut)), samples.select(np.arange(cut, len(samples)))


def recorded_datasets(path: str | Path, arm: str = "left") -> tuple[list[CalibrationDataset], str]:
    """The recorded RAVEN-II datasets at ``path`` (one per bag or dataset file) and a description.

    ``path`` is a folder of ROS bags or of ``.parquet`` dataset files, a single bag, or a dataset
    file (``.parquet``, or its ``.csv``).

    Raises
    ------
    FileNotFoundError
        No such file or folder, or a folder holding no recognised data.
    ValueError
        An unknown file type (and the readers' own errors for corrupt files).
    """
    path = Path(path)
    if path.is_dir():
        bags = sorted(path.glob("*.bag"))
        parquets = sorted(path.glob("*.parquet"))
        if bags:
            logs = read_bag_folder(path, arm)
            return [synchronize(state, truth, arm) for _, state, truth in logs], f"{len(bags)} ROS bags in {path}"
        if parquets:
            return [CalibrationDataset.read_parquet(p) for p in parquets], f"{len(parquets)} dataset files in {path}"
        raise FileNotFoundError(f"{path} holds no .bag or .parquet file and is not a dVRK data folder")
    if not path.exists():
        raise FileNotFoundError(f"no file or folder {path}")
    suffix = path.suffix.lower()
    if suffix == ".parquet":
        return [CalibrationDataset.read_parquet(path)], f"dataset file {path}"
    if suffix == ".csv":
        return [CalibrationDataset(pd.read_csv(path), arm)], f"dataset file {path}"
    if suffix == ".bag":
        state, truth = read_bag(path, arm)
        return [synchronize(state, truth, arm)], f"ROS bag {path}"
    raise ValueError(f"{path}: unknown data file type {suffix!r} (expected .bag, .parquet or .csv, or a folder)")


def read_recorded(path: str | Path, arm: str = "left") -> tuple[Samples, str]:
    """Samples of recorded RAVEN-II data (see :func:`recorded_datasets`), one recording id per file."""
    datasets, description = recorded_datasets(path, arm)
    if not Path(path).is_dir():
        return Samples.from_dataset(datasets[0]), description
    return Samples.concat([Samples.from_dataset(d, recording=k) for k, d in enumerate(datasets)]), description


def recorded_comparison(path: str | Path, *, test_path: str | Path | None = None, arm: str = "left",
                        test_fraction: float = DEFAULT_TEST_FRACTION) -> ComparisonData:
    """Training and test samples from recorded data (see the module docstring for the formats)."""
    path = Path(path)
    if is_dvrk_folder(path):
        return _dvrk_comparison(path, test_fraction)
    train, description = read_recorded(path, arm)
    notes = []
    if test_path is not None:
        test, test_description = read_recorded(test_path, arm)
        tests = {"test": test}
        notes.append(f"Training: {description}; test: {test_description}.")
    else:
        train, test = _split_in_time(train, test_fraction)
        tests = {"test": test}
        notes.append(f"Training: the first {1 - test_fraction:.0%} of the rows of {description}; "
                     f"test: the last {test_fraction:.0%} (split in time, not shuffled).")
    return ComparisonData(train, tests, description, tuple(notes))


def _dvrk_comparison(path: Path, test_fraction: float) -> ComparisonData:
    notes = ["dVRK patient-side manipulator (Hwang et al., RA-L 2020): inputs are the 6 joint positions "
             "the controller reports; targets joints 1-3 measured by RGB-D tracked fiducials.",
             "The tool-tip error is not computed: this toolkit models RAVEN-II's kinematics, not the dVRK's."]
    if (path / "q_des.npy").is_file():
        train, test = _split_in_time(_dvrk_samples(path, DVRK_SPLITS[0]), test_fraction)
        notes.append(f"Training: the first {1 - test_fraction:.0%} of {path.name}; test: the rest (in time).")
        return ComparisonData(train, {"test": test}, f"dVRK recording {path}", tuple(notes))
    train, held_out = _split_in_time(_dvrk_samples(path, "random_unfiltered"), test_fraction)
    tests = {"random": held_out}
    if (path / "peg_transfer" / "q_des.npy").is_file():
        tests["peg_transfer"] = _dvrk_samples(path, "peg_transfer")
    notes.append(f"Training: the first {1 - test_fraction:.0%} of random_unfiltered; tests: its last "
                 f"{test_fraction:.0%} ('random') and the whole peg_transfer recording.")
    return ComparisonData(train, tests, f"dVRK recordings in {path}", tuple(notes))
