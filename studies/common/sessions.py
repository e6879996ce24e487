"""Recording sessions of the studies on the virtual RAVEN-II, turned into training and test samples.

A session is one powered-on robot: calibration zig-zags recorded sparsity by sparsity (so that
any combination of them can be a training set, as in the paper's Figs. 5, 6 and 8), then the
test motions of the study, e.g. hours of operation (:func:`operation_session`). Every session is
determined by its seed; the functions here are module-level so that sweeps can run sessions in
worker processes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from itertools import combinations

import numpy as np

from simulation import Recording, VirtualRaven, powered_on, record_calibration, recording_to_dataset
from simulation import long_operation as operate
from simulation.recordings.dataset import CalibrationDataset
from simulation.trajectories import PAPER_SPARSITIES

from studies.common.evaluation import raven_model
from studies.common.samples import Samples

CHUNK_SECONDS = 1800.0
"""Recordings are converted to datasets in chunks of this many seconds (bounded memory)."""
KINDS = ("idle", "unloaded", "loaded")
"""Kinds of operation after a calibration: holding the pose, random motion, random motion with a load."""
SEED_MODULUS = 2**31 - 2
"""Session seeds are kept below this bound (the simulator's seeds are 31-bit)."""


def spawn_seeds(base_seed: int, n: int, modulus: int = SEED_MODULUS) -> list[int]:
    """``n`` independent session seeds spawned from ``base_seed`` (numpy's ``SeedSequence``), each
    reduced modulo ``modulus``."""
    return [int(s.generate_state(1)[0]) % modulus for s in np.random.SeedSequence(base_seed).spawn(n)]


def sparsity_label(sparsity: float) -> str:
    """``"1/6"`` for 1/6 (the paper names sparsities as unit fractions)."""
    fraction = Fraction(float(sparsity)).limit_denominator(100)
    return f"{fraction.numerator}/{fraction.denominator}"


def combination_label(sparsities: Sequence[float]) -> str:
    """``"1/6+1/4+1/3"``: a training set made of the zig-zags of several sparsities."""
    return "+".join(sparsity_label(s) for s in sparsities)


def record_zigzags(robot: VirtualRaven, direction: str, sparsities: Sequence[float]) -> dict[float, Recording]:
    """The zig-zags of one direction, one recording per sparsity, in the given order."""
    return {float(s): record_calibration(robot, direction, (s,)) for s in sparsities}


def samples_of(recording: Recording, groups: Sequence[str] = ("selected",), stride: int = 1,
               recording_id: int = 0) -> dict[str, Samples]:
    """Samples of a recording for each feature group, keeping every ``stride``-th log sample.

    The recording is synchronized in chunks of :data:`CHUNK_SECONDS`, each thinned before the
    next is converted, so hours of operation never hold the whole robot state at once.
    """
    if int(stride) < 1:
        raise ValueError(f"stride must be a positive integer, got {stride}")
    robot = raven_model(recording.arm)
    edges = np.arange(recording.time[0], recording.time[-1] + CHUNK_SECONDS, CHUNK_SECONDS)
    parts = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        mask = (recording.time >= lo) & (recording.time < hi)
        if mask.sum() < 2:
            continue
        dataset = recording_to_dataset(recording.select(mask), robot, chunk_seconds=CHUNK_SECONDS)
        parts.append(dataset.select(np.arange(0, len(dataset), int(stride))) if stride > 1 else dataset)
    dataset = parts[0] if len(parts) == 1 else CalibrationDataset.concat(parts)
    return {group: Samples.from_dataset(dataset, group, recording_id, keep_dataset=False, stride=int(stride))
            for group in groups}


def training_sets(parts: Mapping[float, Samples], combos: Sequence[Sequence[float]]) -> dict[str, Samples]:
    """Training sets made of the zig-zags of the given sparsity combinations, keyed by label."""
    out = {}
    for combo in combos:
        missing = [s for s in combo if float(s) not in parts]
        if missing:
            raise ValueError(f"no zig-zag recorded at sparsities {missing}")
        out[combination_label(combo)] = Samples.concat([parts[float(s)] for s in combo])
    return out


def all_combinations(sparsities: Sequence[float]) -> list[tuple[float, ...]]:
    """Every non-empty combination of the sparsities, singles first, in the given order."""
    return [combo for size in range(1, len(sparsities) + 1) for combo in combinations(sparsities, size)]


def by_hour(samples: Samples, n_blocks: int | None = None, block_hours: float = 1.0) -> dict[str, Samples]:
    """Samples split into blocks of ``block_hours`` counted from the first sample.

    Keys name each block by its start, ``"hour 0"``, ``"hour 1"``... (``"hour 0.1"`` for blocks of
    0.1 h); blocks without samples are left out.
    """
    if not (np.isfinite(block_hours) and block_hours > 0):
        raise ValueError(f"block_hours must be positive, got {block_hours}")
    blocks = np.floor((samples.time - samples.time[0]) / (3600.0 * block_hours) + 1e-9).astype(int)
    count = int(blocks.max()) + 1 if n_blocks is None else int(n_blocks)
    return {f"hour {round(b * block_hours, 6):g}": samples.select(blocks == b)
            for b in range(count) if np.any(blocks == b)}


def training_duration(samples: Samples) -> float:
    """Recording time of a training set, s (what the paper calls the calibration time)."""
    return samples.duration


MAX_OPERATION_HOURS = 24.0
"""Longest operation the studies simulate after a calibration (h): one day, four times the paper's
six hours. The simulation's time grows with the hours (its memory with the 30 Hz log), so a
mistyped length is refused rather than run for days."""


@dataclass(frozen=True)
class OperationSessionConfig:
    """A calibration followed by hours of operation (the long-operation, input-feature and
    train-on-error studies share it)."""

    seed: int = 0
    hours: float = 6.0
    direction: str = "J2-J3"
    sparsities: tuple[float, ...] = PAPER_SPARSITIES
    payload_kg: float = 0.5
    eval_stride: int = 10
    block_hours: float = 1.0

    def __post_init__(self) -> None:
        for name in ("hours", "block_hours"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be positive, got {value}")
        if self.hours > MAX_OPERATION_HOURS:
            raise ValueError(f"hours must be at most {MAX_OPERATION_HOURS:g} (one day of operation), got {self.hours:g}")
        if int(self.eval_stride) != self.eval_stride or self.eval_stride < 1:
            raise ValueError(f"eval_stride must be a positive integer, got {self.eval_stride}")

    @classmethod
    def quick(cls, seed: int = 0) -> "OperationSessionConfig":
        """Two sparsities (1/2, 1/3), 18 minutes of operation scored in 6-minute blocks."""
        return cls(seed=seed, hours=0.3, sparsities=(1 / 2, 1 / 3), eval_stride=10, block_hours=0.1)


def operation_session(kind: str, seed: int, session: OperationSessionConfig,
                      groups: tuple[str, ...] = ("selected",)) -> tuple[dict, dict]:
    """Calibrate then operate for ``session.hours``: zig-zag samples per sparsity and group, test per hour.

    Returns
    -------
    parts : group -> {sparsity: Samples}
    hours : group -> {"hour 0": Samples, ...} (blocks of ``session.block_hours``), thinned by
        ``session.eval_stride``.
    """
    robot = powered_on(seed=seed)
    if kind == "loaded":
        robot.set_payload(session.payload_kg)
    zigzags = record_zigzags(robot, session.direction, session.sparsities)
    parts = {group: {} for group in groups}
    for k, (sparsity, recording) in enumerate(zigzags.items()):
        for group, samples in samples_of(recording, groups, recording_id=k).items():
            parts[group][sparsity] = samples
    operation = operate(robot, kind, session.hours, seed=seed + 1, payload_kg=session.payload_kg)
    tests = samples_of(operation, groups, stride=session.eval_stride)
    n_blocks = int(np.ceil(session.hours / session.block_hours - 1e-9))
    return parts, {group: by_hour(samples, n_blocks, session.block_hours) for group, samples in tests.items()}


def kind_seed(base_seed: int, kind: str) -> int:
    """Session seed of one kind of operation (independent sessions per kind)."""
    return spawn_seeds(base_seed, len(KINDS))[KINDS.index(kind)]


def longest_sets(train_sets: dict[str, Samples], n: int = 3) -> list[str]:
    """Labels of the ``n`` training sets with the longest recording time."""
    return sorted(train_sets, key=lambda label: -train_sets[label].duration)[:n]
