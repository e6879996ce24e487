"""Step 2 of the workflow: where is the residual large?

Bins the residual of each joint by the variables an effect would depend on: the direction and
speed of motion, the gravity (and payload) load, the configuration, the accumulated travel (the
operating time of the cables: joint travel since the start of the record) and the homing count, and
reports the mean and RMS per bin. A residual whose mean flips with the direction of motion points at backlash or dry
friction, one that grows with speed at viscous friction, with load at gravity stretch, with
travel at fatigue, with homings at the registration.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from simulation.discrepancy.replay import ReplayState
from simulation.discrepancy.signals import MeasuredSignals, report_scale


def _quantile_bins(values: np.ndarray, n_bins: int) -> np.ndarray:
    edges = np.unique(np.quantile(values, np.linspace(0, 1, n_bins + 1)))
    if edges.size < 2:
        return np.zeros(values.shape, dtype=int)
    return np.clip(np.searchsorted(edges, values, side="right") - 1, 0, edges.size - 2)


def localize(signals: MeasuredSignals, residual: np.ndarray, state: ReplayState | None = None,
             mask: np.ndarray | None = None, n_bins: int = 4) -> pd.DataFrame:
    """Table of the residual per joint and per bin of each explanatory variable.

    Parameters
    ----------
    signals : the measured record.
    residual : (N, J) measured minus replayed joints over the whole record (SI).
    state : the replay, for the gravity load (RAVEN-II data).
    mask : the samples to study (default all).

    Returns
    -------
    pandas.DataFrame with columns ``joint``, ``variable``, ``bin``, ``samples``, ``mean``, ``rms``;
    ``mean`` and ``rms`` in degrees or millimetres.
    """
    mask = np.ones(len(signals), dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
    scale = report_scale(signals.units)
    velocity = signals.velocity[mask]
    rows = []
    for j, joint in enumerate(signals.joint_names):
        r = residual[mask, j] * scale[j]
        direction = np.sign(velocity[:, j]).astype(int)
        variables = {
            "direction": (direction + 1, ["moving down", "still", "moving up"]),
            "speed": (_quantile_bins(np.abs(velocity[:, j]), n_bins), None),
            "position": (_quantile_bins(signals.truth[mask, j], n_bins), None),
            "accumulated travel": (_quantile_bins(signals.travel[mask, j], n_bins), None),
            "homing": (np.searchsorted(np.unique(signals.homing[mask]), signals.homing[mask]), None),
        }
        if state is not None and state.gravity is not None:
            variables["gravity load"] = (_quantile_bins(state.gravity[mask, j], n_bins), None)
        if np.ptp(signals.payload_kg[mask]) > 0:
            variables["payload"] = (np.searchsorted(np.unique(signals.payload_kg[mask]), signals.payload_kg[mask]), None)
        for name, (bins, labels) in variables.items():
            for b in np.unique(bins):
                selected = bins == b
                label = labels[b] if labels is not None else f"{name} q{b + 1}" if name not in ("homing", "payload") \
                    else f"{name} {b}"
                rows.append({"joint": joint, "variable": name, "bin": label, "samples": int(selected.sum()),
                             "mean": float(r[selected].mean()), "rms": float(np.sqrt(np.mean(r[selected] ** 2)))})
    return pd.DataFrame(rows)


def strongest_dependence(table: pd.DataFrame) -> pd.DataFrame:
    """Per joint and variable, the spread of the bin means (deg or mm): large means the residual
    depends on that variable."""
    spread = table.groupby(["joint", "variable"])["mean"].agg(lambda m: float(m.max() - m.min()))
    return spread.rename("spread of bin means").reset_index().sort_values(["joint", "spread of bin means"],
                                                                          ascending=[True, False])
