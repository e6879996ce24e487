"""A short, nearly still RAVEN-II record that several discrepancy test files build (not a test module)."""

import numpy as np

from simulation.discrepancy.signals import RAVEN_JOINTS, RAVEN_UNITS, MeasuredSignals


def near_still_signals(n: int = 200, homings: int = 1, payload=None) -> MeasuredSignals:
    """``n`` samples at 100 Hz of the positioning joints wobbling by 1 mrad (1 mm) about one pose,
    split evenly into ``homings`` homings; reported equals true, the motors 1 % ahead, no torque,
    ``payload`` (kg per sample) or none."""
    time = np.arange(n) * 1e-2
    truth = np.tile([0.9, 1.6, 0.4], (n, 1)) + 1e-3 * np.sin(time)[:, None]
    homing = np.repeat(np.arange(homings), -(-n // homings))[:n]
    return MeasuredSignals(time=time, truth=truth, reported=truth, drive=truth * 1.01, torque=np.zeros((n, 3)),
                           payload_kg=np.zeros(n) if payload is None else payload, homing=homing,
                           joint_names=RAVEN_JOINTS, units=RAVEN_UNITS, kind="raven", tool_joints=np.zeros((n, 3)))
