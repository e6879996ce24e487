"""Short motions of one arm that several simulator test files drive (not a test module)."""

import numpy as np

from simulation.engine.robot import Motion

POSE = np.array([np.deg2rad(40.0), np.deg2rad(80.0), 0.38, 0.0, 0.0, np.pi / 4, np.pi / 4])
"""A pose in the middle of the positioning joints' range, tool at its home angles (SI)."""


def sweep(joint: int, amplitude: float, period: float, cycles: float, rate: float = 100.0) -> Motion:
    """Sinusoidal back-and-forth of one DOF about POSE, starting and ending at rest."""
    t = np.arange(0.0, cycles * period + 1e-9, 1.0 / rate)
    q = np.tile(POSE, (t.size, 1))
    qd = np.zeros_like(q)
    q[:, joint] += amplitude * (1 - np.cos(2 * np.pi * t / period)) / 2
    qd[:, joint] = amplitude * np.pi / period * np.sin(2 * np.pi * t / period)
    return Motion(q=q, qd=qd, rate=rate)
