"""Models of robots known only through reported and measured joints (e.g. the dVRK data).

The nominal model says the measured joints equal the reported ones (plus a constant offset). The
effects of the library act on it directly in joint units, driven by the reported motion: a
backlash dead band, a direction-dependent lag from dry friction, a speed-dependent lag, a
Bouc-Wen loop, coupling from the other joints, and a creep that grows with accumulated motion.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from simulation.discrepancy.replay import ReplayState, bouc_wen_series, play_series
from simulation.discrepancy.signals import MeasuredSignals

GENERIC_EFFECTS = ("backlash", "coulomb_friction", "viscous_friction", "hysteresis", "coupling", "drift",
                   "transmission_error", "coupled_viscous_friction", "coupled_hysteresis")

HYSTERESIS_WIDTH_FRACTIONS = tuple(2.0 ** -k for k in range(1, 9))
"""Half-widths of the play operators of ``coupled_hysteresis``, as fractions of each joint's range of
reported motion in the record: 1/2 down to 1/256, a geometric grid, so that a loop of any width up
to the whole range is a weighted sum of them (the Prandtl-Ishlinskii construction of
rate-independent hysteresis). Of six grids tried on the dVRK wrist, this one left the smallest gap on
the workflow's validation part (the random motion; ``python studies/discrepancy_play_widths.py``
lists each grid's validation and held-out gaps)."""


def play_widths(signals: MeasuredSignals, fractions=HYSTERESIS_WIDTH_FRACTIONS) -> np.ndarray:
    """(J, R) half-widths of the ``coupled_hysteresis`` play operators: ``fractions`` of each joint's
    range of reported motion over the whole record (the robot's inputs only, never the measured joints)."""
    fractions = np.asarray(fractions, dtype=float)
    if fractions.ndim != 1 or fractions.size == 0 or not np.all((fractions > 0) & (fractions <= 1)):
        raise ValueError(f"play fractions must be a non-empty list of numbers in (0, 1], got {fractions.tolist()}")
    span = np.ptp(signals.reported, axis=0)
    return np.maximum(span, 1e-12)[:, None] * fractions[None, :]


def play_features(signals: MeasuredSignals, widths: np.ndarray) -> np.ndarray:
    """(N, J, R) hysteresis of each joint's reported motion through a play (backlash) operator of
    each half-width: ``reported - play(reported)``, within +- the half-width, whose sign says which way
    the joint last moved. Cached on ``signals``."""
    widths = np.asarray(widths, dtype=float)
    cache = signals.__dict__.setdefault("_plays", {})
    key = widths.tobytes()
    if key not in cache:
        reported = signals.reported
        features = np.empty((len(signals),) + widths.shape)
        for k in range(widths.shape[0]):
            column = np.ascontiguousarray(reported[:, k])
            for r in range(widths.shape[1]):
                features[:, k, r] = column - play_series(column, float(widths[k, r]), signals.restarts)
        features.setflags(write=False)
        cache[key] = features
    return cache[key]


def coupled_hysteresis_basis(signals: MeasuredSignals, widths: np.ndarray) -> np.ndarray:
    """(N, J, J * J * R) contribution of each ``coupled_hysteresis`` weight to each joint: weight
    ``(j, k, r)`` (flattened in that order) moves joint ``j`` by play feature ``(k, r)``."""
    features = play_features(signals, widths)
    n, n_joints, n_widths = features.shape
    flat = features.reshape(n, n_joints * n_widths)
    basis = np.zeros((n, n_joints, n_joints * n_joints * n_widths))
    for j in range(n_joints):
        basis[:, j, j * flat.shape[1]:(j + 1) * flat.shape[1]] = flat
    return basis


def velocity_scale(signals: MeasuredSignals) -> np.ndarray:
    """Speed below which a dry-friction lag is smoothed: 5 % of each joint's RMS reported speed."""
    speed = np.sqrt(np.mean(np.square(signals.drive_velocity), axis=0))
    return np.maximum(0.05 * speed, 1e-9)


def coupled_hysteresis_pairs(values: dict, signals: MeasuredSignals) -> np.ndarray:
    """(N, J, J) what each joint's motion (last axis) adds to each joint (middle axis) through
    ``coupled_hysteresis`` with parameters ``values`` (joint units); summed over the last axis, the
    effect's contribution."""
    features = play_features(signals, values["widths"])
    n_joints = features.shape[1]
    weight = np.asarray(values["weight"], dtype=float).reshape(n_joints, n_joints, -1)
    return np.einsum("nkr,jkr->njk", features, weight)


def coupled_hysteresis_shares(values: dict, signals: MeasuredSignals, mask: np.ndarray | None = None) -> np.ndarray:
    """(J, J) RMS over the ``mask`` samples of :func:`coupled_hysteresis_pairs`: which joint drags
    which, and by how much (joint units)."""
    added = coupled_hysteresis_pairs(values, signals)
    if mask is not None:
        added = added[np.asarray(mask, dtype=bool)]
    return np.sqrt(np.mean(np.square(added), axis=0))


def generic_contribution(name: str, values: dict, signals: MeasuredSignals) -> np.ndarray:
    """What effect ``name`` with parameters ``values`` adds to the measured joints (N, J)."""
    reported = signals.reported
    n_joints = signals.n_joints
    if name == "backlash":
        half = values["half_width"]
        return np.column_stack([play_series(np.ascontiguousarray(reported[:, j]), half[j], signals.restarts)
                                - reported[:, j]
                                for j in range(n_joints)])
    if name == "coulomb_friction":
        return -values["lag"] * np.tanh(signals.drive_velocity / velocity_scale(signals))
    if name == "viscous_friction":
        return -values["lag_per_speed"] * signals.drive_velocity
    if name == "hysteresis":
        # Bouc-Wen with beta = 1 / width and gamma = shape / width, both fitted
        width = values["width"]
        shape = values["shape"]
        z = np.column_stack([bouc_wen_series(np.ascontiguousarray(signals.drive_velocity[:, j]), signals.time,
                                             1.0 / width[j], shape[j] / width[j]) for j in range(n_joints)])
        return -values["amplitude"] * z / width
    if name == "coupling":
        # off-diagonal terms only: how much each joint moves with the others
        matrix = np.zeros((n_joints, n_joints))
        matrix[~np.eye(n_joints, dtype=bool)] = values["matrix"]
        return reported @ matrix.T
    if name == "drift":
        return -values["creep"] * signals.cumulative_motion()
    if name == "coupled_viscous_friction":
        # a joint lags in proportion to the other joints' speeds (cables routed over their pulleys)
        matrix = np.zeros((n_joints, n_joints))
        matrix[~np.eye(n_joints, dtype=bool)] = values["lag_per_speed"]
        return -signals.drive_velocity @ matrix.T
    if name == "coupled_hysteresis":
        # each joint moves by a weighted sum of every joint's play features
        return coupled_hysteresis_pairs(values, signals).sum(axis=2)
    if name == "transmission_error":
        # the joint moves (1 + ratio_error) times what the controller reports
        return values["ratio_error"] * reported
    raise ValueError(f"effect {name!r} has no generic form; generic effects: {GENERIC_EFFECTS}")


@dataclass(frozen=True, eq=False)
class NominalModel:
    """Measured joints = reported joints + offsets + the contributions of the added effects."""

    offsets: np.ndarray
    effects: dict = field(default_factory=dict)

    @property
    def enabled_effects(self) -> tuple[str, ...]:
        return tuple(self.effects)

    def with_effect(self, name: str, values: dict) -> "NominalModel":
        effects = dict(self.effects)
        effects[name] = values
        return NominalModel(offsets=self.offsets, effects=effects)

    def with_offsets(self, offsets) -> "NominalModel":
        return NominalModel(offsets=np.asarray(offsets, dtype=float), effects=self.effects)

    def replay(self, signals: MeasuredSignals, robot=None) -> ReplayState:
        joints = signals.reported + self.offsets
        for name, values in self.effects.items():
            joints = joints + generic_contribution(name, values, signals)
        return ReplayState(joints=joints, torque=None, tension=None, stretch=np.zeros_like(joints), gravity=None)
