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
                   "transmission_error", "coupled_viscous_friction")


def velocity_scale(signals: MeasuredSignals) -> np.ndarray:
    """Speed below which a dry-friction lag is smoothed: 5 % of each joint's RMS reported speed."""
    speed = np.sqrt(np.mean(np.square(signals.drive_velocity), axis=0))
    return np.maximum(0.05 * speed, 1e-9)


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
