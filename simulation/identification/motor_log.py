"""The signals of a RAVEN-II log that the motor-cable-link model uses, as one time-ordered table.

Identification and the UKF read the same few channels of the positioning joints (shoulder, elbow,
insertion): motor positions (``mpos``), commanded motor torques (``tau``), and, where the log has
them, the external joint encoders (ground truth) and the payload label. :func:`as_motor_log`
takes them from a :class:`~simulation.recordings.dataset.CalibrationDataset` (simulated or read from a ROS
bag) or from a simulated :class:`~simulation.recordings.recording.Recording`, so both consumers accept either.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.recordings.dataset import TRUTH_COLUMNS, CalibrationDataset

POSITIONING = ("shoulder", "elbow", "z_ins")
"""The paper's joints 1-3 (rad, rad, m); the column suffixes of a calibration dataset."""
MOTOR_POSITION_COLUMNS = tuple(f"mpos.{joint}" for joint in POSITIONING)
MOTOR_TORQUE_COLUMNS = tuple(f"tau.{joint}" for joint in POSITIONING)
PAYLOAD_LABEL = "label.payload_kg"


def _three_columns(values, name: str, n: int, *, allow_nan: bool) -> np.ndarray:
    array = np.array(values, dtype=float)
    if array.shape != (n, 3):
        raise ValueError(f"{name} must have shape ({n}, 3), got {array.shape}")
    bad = np.isinf(array) if allow_nan else ~np.isfinite(array)
    if np.any(bad):
        row = int(np.flatnonzero(bad.any(axis=1))[0])
        raise ValueError(f"{name} is not finite at row {row}" + (" (NaN marks a lost sample)" if allow_nan else ""))
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class MotorLog:
    """Time-ordered motor signals of the positioning joints, SI units.

    Attributes
    ----------
    time : (N,) s, strictly increasing.
    motor_positions : (N, 3) motor shaft angles of shoulder, elbow and insertion motors (rad), as
        the controller reports them after homing (``mpos``). NaN marks a lost sample.
    motor_torques : (N, 3) commanded motor torques at the gearbox output (N m, ``tau``). NaN marks
        a lost sample.
    joints : (N, 3) ground-truth joint positions (rad, rad, m), or None when the log has no
        external encoders.
    payload_kg : (N,) mass hanging at the tool tip (kg), or None when the log does not say.
    arm : "left" or "right".
    """

    time: np.ndarray
    motor_positions: np.ndarray
    motor_torques: np.ndarray
    joints: np.ndarray | None = None
    payload_kg: np.ndarray | None = None
    arm: str = "left"

    def __post_init__(self) -> None:
        if self.arm not in ("left", "right"):
            raise ValueError(f"arm must be 'left' or 'right', got {self.arm!r}")
        time = np.array(self.time, dtype=float)
        if time.ndim != 1 or time.size == 0:
            raise ValueError(f"time must be a non-empty 1-D array, got shape {time.shape}")
        if not np.all(np.isfinite(time)):
            raise ValueError(f"time is not finite at row {int(np.flatnonzero(~np.isfinite(time))[0])}")
        steps = np.diff(time)
        if np.any(steps <= 0):
            row = int(np.flatnonzero(steps <= 0)[0]) + 1
            raise ValueError(f"time must increase strictly (one time-ordered log); it does not at row {row}")
        time.setflags(write=False)
        n = time.size
        object.__setattr__(self, "time", time)
        object.__setattr__(self, "motor_positions",
                           _three_columns(self.motor_positions, "motor_positions", n, allow_nan=True))
        object.__setattr__(self, "motor_torques",
                           _three_columns(self.motor_torques, "motor_torques", n, allow_nan=True))
        if self.joints is not None:
            object.__setattr__(self, "joints", _three_columns(self.joints, "joints", n, allow_nan=False))
        if self.payload_kg is not None:
            payload = np.array(self.payload_kg, dtype=float)
            if payload.shape == ():
                payload = np.full(n, float(payload))
            if payload.shape != (n,):
                raise ValueError(f"payload_kg must have shape ({n},), got {payload.shape}")
            if not np.all(np.isfinite(payload) & (payload >= 0)):
                raise ValueError("payload_kg must be finite and non-negative")
            payload.setflags(write=False)
            object.__setattr__(self, "payload_kg", payload)

    def __len__(self) -> int:
        return self.time.size

    @property
    def has_truth(self) -> bool:
        return self.joints is not None

    def select(self, mask) -> "MotorLog":
        """The rows picked by a boolean mask or by increasing row indices."""
        index = np.asarray(mask)
        return MotorLog(
            time=self.time[index],
            motor_positions=self.motor_positions[index],
            motor_torques=self.motor_torques[index],
            joints=None if self.joints is None else self.joints[index],
            payload_kg=None if self.payload_kg is None else self.payload_kg[index],
            arm=self.arm,
        )

    def between(self, start: float, stop: float) -> "MotorLog":
        """The rows with ``start <= time < stop`` (s)."""
        return self.select((self.time >= start) & (self.time < stop))

    @classmethod
    def from_dataset(cls, dataset: CalibrationDataset) -> "MotorLog":
        """The motor signals, ground truth and payload label of a calibration dataset."""
        table = dataset.table
        payload = table[PAYLOAD_LABEL].to_numpy(dtype=float) if PAYLOAD_LABEL in table.columns else None
        return cls(
            time=dataset.time,
            motor_positions=table.loc[:, list(MOTOR_POSITION_COLUMNS)].to_numpy(dtype=float),
            motor_torques=table.loc[:, list(MOTOR_TORQUE_COLUMNS)].to_numpy(dtype=float),
            joints=table.loc[:, list(TRUTH_COLUMNS)].to_numpy(dtype=float),
            payload_kg=payload,
            arm=dataset.arm,
        )

    @classmethod
    def from_recording(cls, recording) -> "MotorLog":
        """The motor signals of a simulated recording, with its truth interpolated at the log times."""
        time = np.asarray(recording.time, dtype=float)
        joints = None
        if len(recording.truth_time) >= 2:
            joints = np.column_stack([np.interp(time, recording.truth_time, recording.truth[:, i]) for i in range(3)])
        labels = getattr(recording, "labels", {})
        return cls(
            time=time,
            motor_positions=recording.channel("mpos")[:, :3],
            motor_torques=recording.channel("tau")[:, :3],
            joints=joints,
            payload_kg=labels.get("payload_kg"),
            arm=recording.arm,
        )


def as_motor_log(source) -> MotorLog:
    """A :class:`MotorLog` from a MotorLog, a CalibrationDataset or a simulated Recording."""
    if isinstance(source, MotorLog):
        return source
    if isinstance(source, CalibrationDataset):
        return MotorLog.from_dataset(source)
    if hasattr(source, "channel") and hasattr(source, "truth_time"):
        return MotorLog.from_recording(source)
    raise TypeError(f"expected a MotorLog, CalibrationDataset or Recording, got {type(source).__name__}")
