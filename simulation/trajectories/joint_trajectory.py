"""The desired joint motion handed to the simulator: uniformly sampled positions and velocities.

Positions and velocities are stored as float32. Their resolution (about 1e-7 rad at 1 rad, 3e-8 m
at 0.42 m) is three orders of magnitude finer than the ground-truth encoders (7.9e-5 rad, 5e-6 m),
and it halves the memory: a 6-hour trajectory at 100 Hz holds 2.16 million samples, which take
138 MB instead of 259 MB. Times stay float64, which a 6-hour clock at 10 ms needs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.trajectories.poses import N_DOF

DEFAULT_RATE = 100.0
"""Sampling rate of trajectories (Hz)."""

STORAGE_DTYPE = np.float32
"""Floating type of :attr:`JointTrajectory.q` and :attr:`JointTrajectory.qd`."""

_TIME_TOLERANCE = 1e-6
"""Allowed deviation of a time stamp from ``k / rate``, as a fraction of the step."""


@dataclass(frozen=True)
class Segment:
    """A labelled run of consecutive samples ``start <= k < stop`` of a trajectory.

    Attributes
    ----------
    start, stop : int
        First sample and one past the last sample.
    label : str
        Name of the scenario part, e.g. ``"zigzag J2-J3 s=1/3"``, ``"go_to"``, ``"idle"``.
    """

    start: int
    stop: int
    label: str

    def __post_init__(self) -> None:
        if not (0 <= self.start < self.stop):
            raise ValueError(
                f"segment {self.label!r} needs 0 <= start < stop, got [{self.start}, {self.stop})"
            )

    def shifted(self, offset: int) -> Segment:
        """The same segment with both indices moved by ``offset`` samples."""
        return Segment(self.start + offset, self.stop + offset, self.label)


def uniform_times(n_samples: int, rate: float) -> np.ndarray:
    """Time stamps ``k / rate`` (s) of ``n_samples`` samples, float64."""
    return np.arange(n_samples, dtype=float) / rate


def _read_only(array: np.ndarray) -> np.ndarray:
    view = array.view()
    view.flags.writeable = False
    return view


def _dof_array(values, n_samples: int, name: str) -> np.ndarray:
    array = np.asarray(values, dtype=STORAGE_DTYPE)
    if array.shape != (n_samples, N_DOF):
        raise ValueError(f"{name} must have shape ({n_samples}, {N_DOF}) to match t, got {array.shape}")
    if not np.all(np.isfinite(array)):
        bad = np.argwhere(~np.isfinite(array))[0]
        raise ValueError(f"{name} must be finite; first non-finite value at sample {bad[0]}, DOF {bad[1]}")
    return _read_only(array)


def _validated_times(t, rate: float) -> np.ndarray:
    times = np.asarray(t, dtype=float)
    if times.ndim != 1 or times.size < 2:
        raise ValueError(f"t must be a 1-D array of at least 2 time stamps, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        raise ValueError("t must be finite")
    step = 1.0 / rate
    if abs(times[0]) > _TIME_TOLERANCE * step:
        raise ValueError(f"t must start at 0 s, got t[0] = {times[0]}")
    if not np.all(np.diff(times) > 0):
        raise ValueError("t must be strictly increasing")
    deviation = np.max(np.abs(times - uniform_times(times.size, rate)))
    if deviation > _TIME_TOLERANCE * step:
        raise ValueError(
            f"t must be uniformly spaced at 1/rate = {step} s; largest deviation {deviation:.3g} s"
        )
    return _read_only(times)


def _validated_segments(segments, n_samples: int, label: str) -> tuple[Segment, ...]:
    if len(segments) == 0:
        return (Segment(0, n_samples, label),)
    segments = tuple(segments)
    if not all(isinstance(segment, Segment) for segment in segments):
        raise ValueError("segments must be Segment instances")
    expected_start = 0
    for segment in segments:
        if segment.start != expected_start:
            raise ValueError(
                f"segments must be contiguous from sample 0: segment {segment.label!r} starts at "
                f"{segment.start}, expected {expected_start}"
            )
        expected_start = segment.stop
    if expected_start != n_samples:
        raise ValueError(f"segments must cover all {n_samples} samples, they end at {expected_start}")
    return segments


@dataclass(frozen=True, eq=False)
class JointTrajectory:
    """Desired joint motion sampled uniformly in time.

    The simulator interpolates ``q`` between samples with cubic Hermite splines using ``qd``, so
    ``qd`` is the exact time derivative of the motion that ``q`` samples.

    Attributes
    ----------
    t : numpy.ndarray, shape (N,)
        Time stamps (s), ``t[k] = k / rate``; N >= 2. Float64, read-only.
    q : numpy.ndarray, shape (N, 7)
        Desired DOF positions, SI, DOF order ``[shoulder rad, elbow rad, insertion m,
        tool_rot rad, wrist rad, grasp1 rad, grasp2 rad]``. Float32, read-only.
    qd : numpy.ndarray, shape (N, 7)
        Desired DOF velocities (rad/s, m/s), same order. Float32, read-only.
    rate : float
        Sampling rate (Hz).
    label : str
        Name of the motion, e.g. ``"zigzag J2-J3 s=1/3"``, ``"random"``, ``"idle"``.
    segments : tuple of Segment
        Contiguous labelled parts covering all samples; empty means one segment named ``label``.
        :func:`~simulation.trajectories.concatenate` keeps the parts of joined trajectories here.

    Raises
    ------
    ValueError
        On a non-positive rate, time stamps that do not start at 0 or are not strictly
        increasing and uniform at ``1 / rate``, arrays of the wrong shape, non-finite values, or
        segments that do not tile the samples.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    rate: float = DEFAULT_RATE
    label: str = ""
    segments: tuple[Segment, ...] = ()

    def __post_init__(self) -> None:
        rate = float(self.rate)
        if not (np.isfinite(rate) and rate > 0):
            raise ValueError(f"rate must be a positive finite frequency in Hz, got {self.rate}")
        times = _validated_times(self.t, rate)
        n_samples = times.size
        object.__setattr__(self, "rate", rate)
        object.__setattr__(self, "t", times)
        object.__setattr__(self, "q", _dof_array(self.q, n_samples, "q"))
        object.__setattr__(self, "qd", _dof_array(self.qd, n_samples, "qd"))
        object.__setattr__(self, "segments", _validated_segments(self.segments, n_samples, self.label))

    @classmethod
    def from_samples(cls, q, qd, rate: float = DEFAULT_RATE, label: str = "") -> JointTrajectory:
        """Build a trajectory whose time stamps are ``k / rate`` for the rows of ``q`` and ``qd``."""
        n_samples = np.shape(q)[0] if np.ndim(q) > 0 else 0
        return cls(uniform_times(n_samples, float(rate)), q, qd, rate, label)

    def __len__(self) -> int:
        return self.t.size

    @property
    def duration(self) -> float:
        """Time of the last sample (s)."""
        return float(self.t[-1])

    @property
    def nbytes(self) -> int:
        """Memory held by ``t``, ``q`` and ``qd`` (bytes)."""
        return self.t.nbytes + self.q.nbytes + self.qd.nbytes

    @property
    def segment_labels(self) -> tuple[str, ...]:
        """Label of each segment, in time order."""
        return tuple(segment.label for segment in self.segments)

    def segment_ids(self) -> np.ndarray:
        """Index into :attr:`segments` of every sample, shape (N,), int32."""
        stops = np.array([segment.stop for segment in self.segments])
        return np.repeat(np.arange(stops.size, dtype=np.int32), np.diff(stops, prepend=0))

    def segment_ids_at(self, times) -> np.ndarray:
        """Index into :attr:`segments` of the part that is running at each of ``times`` (s).

        A segment owns the time from its first sample up to the first sample of the next one;
        the last segment also owns its final instant. This labels a log recorded at any rate.

        Raises
        ------
        ValueError
            If a time is not finite or lies outside ``[0, duration]``.
        """
        times = np.asarray(times, dtype=float)
        if not np.all(np.isfinite(times)):
            raise ValueError("times must be finite")
        if times.size and (times.min() < 0 or times.max() > self.duration + _TIME_TOLERANCE / self.rate):
            raise ValueError(f"times must lie in [0, {self.duration}] s")
        starts = np.array([self.t[segment.start] for segment in self.segments])
        ids = np.searchsorted(starts, times, side="right") - 1
        return ids.astype(np.int32)
