"""What the virtual RAVEN-II measures: its motor encoders and the external ground-truth encoders.

Compiled functions called once per servo tick by :func:`simulation.engine.loop.servo_loop`:
:func:`read_motor_encoders` turns the plant's motor angles into the encoder counts, motor
positions (rad) and finite-difference motor velocities (rad/s) the controller sees (with the
``quantization`` effect, whole counts); :func:`read_joint_encoders` reads the true link positions
as the external encoders the paper used as ground truth do (with the ``noise`` and
``quantization`` effects, a noisy reading rounded to the encoder's resolution).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from simulation.engine.tables import (
    C_OFF, C_POWERON, C_PREV, C_READY, E_NOISE, E_QUANT, R_TRUTHNOISE, R_TRUTHRES, X_Q, X_U,
)


@njit(cache=True, inline="always")
def read_motor_encoders(plant, ctrl, flags, tr, counts_per_rad, dt, enc, mpos, mvel):
    """Read the seven motor encoders (``rt_raven.cpp``: encoder to motor position and velocity).

    Parameters
    ----------
    plant, ctrl : plant and controller state vectors; ``ctrl``'s previous motor positions (and,
        on the first tick after power-on or a registration, its filter flag) are updated.
    flags : effect switches; tr : (7,) transmission ratios (motor rad per joint unit).
    counts_per_rad : encoder counts per motor radian; dt : servo period (s).
    enc, mpos, mvel : (7,) outputs: encoder counts (power-on count included), motor positions
        from the registered offsets (rad) and their backward differences (rad/s).
    """
    for j in range(7):
        m_true = plant[X_U + j] * tr[j]
        if flags[E_QUANT] == 1:
            enc[j] = np.floor(m_true * counts_per_rad) + ctrl[C_POWERON + j]
        else:
            enc[j] = m_true * counts_per_rad + ctrl[C_POWERON + j]
        mpos[j] = (enc[j] - ctrl[C_OFF + j]) / counts_per_rad
    if ctrl[C_READY] == 0.0:
        for j in range(7):
            ctrl[C_PREV + j] = mpos[j]
        ctrl[C_READY] = 1.0
    for j in range(7):
        mvel[j] = (mpos[j] - ctrl[C_PREV + j]) / dt
        ctrl[C_PREV + j] = mpos[j]


@njit(cache=True, inline="always")
def read_joint_encoders(plant, table, flags, truth_out, row):
    """Read the external joint encoders into ``truth_out[row]`` (rad, rad, m).

    Draws one standard normal per positioning joint from numba's random state when ``noise`` is
    on, so the caller fixes the draw order.
    """
    for i in range(3):
        value = plant[X_Q + i]
        if flags[E_NOISE] == 1:
            value += table[R_TRUTHNOISE, i] * np.random.standard_normal()
        if flags[E_QUANT] == 1:
            res = table[R_TRUTHRES, i]
            value = np.round(value / res) * res
        truth_out[row, i] = value
