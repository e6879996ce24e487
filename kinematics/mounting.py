"""Gravity direction in the RAVEN-II base frame, as the controller derives it.

The controller does not assume a mounting: it reads a gravity vector from an
accelerometer on the robot (``grav_dir``, in cm/s^2, sensor axes) and rotates it
into each arm's base frame (``getCurrentG`` in ``src/raven/grav_comp.cpp`` of the
RAVEN-II controller). At start-up the reading is initialised to ``(0, 0, 980)``
(``src/raven/init.cpp``), i.e. the robot standing in its usual mounting, which maps
to ``(-9.8, 0, 0)`` m/s^2 in the base frame of *both* arms: the base x axis points
up, against gravity. That vector is the model's default.
"""

from __future__ import annotations

import numpy as np

ARMS = ("left", "right")
"""Arm names: ``"left"`` is the gold arm, ``"right"`` the green arm."""

ACCELEROMETER_AT_REST_CM_S2 = (0.0, 0.0, 980.0)
"""Accelerometer reading the controller starts with (cm/s^2, sensor axes)."""

DEFAULT_GRAVITY = (-9.8, 0.0, 0.0)
"""Gravity in the base frame of either arm for the usual mounting (m/s^2).

The magnitude 9.8 m/s^2 is the controller's (``grav_mag``), kept so that the
model's gravity torques equal the controller's ``tau_g`` before transmission.
"""


def gravity_from_accelerometer(reading_cm_s2, arm: str) -> np.ndarray:
    """Gravity vector in an arm's base frame from an accelerometer reading.

    Parameters
    ----------
    reading_cm_s2 : array_like, shape (3,)
        The controller's ``grav_dir`` (x, y, z) in cm/s^2, sensor axes.
    arm : {"left", "right"}
        ``"left"`` is the gold arm, ``"right"`` the green arm; the sensor axes
        map differently into the two base frames.

    Returns
    -------
    numpy.ndarray, shape (3,)
        Gravity in the arm's base frame (m/s^2), as ``getCurrentG`` computes it.

    Raises
    ------
    ValueError
        If ``arm`` is unknown or the reading is not three finite numbers.
    """
    if arm not in ARMS:
        raise ValueError(f"arm must be one of {ARMS}, got {arm!r}")
    reading = np.asarray(reading_cm_s2, dtype=float)
    if reading.shape != (3,) or not np.all(np.isfinite(reading)):
        raise ValueError(
            f"accelerometer reading must be 3 finite numbers (cm/s^2), got {reading_cm_s2!r}"
        )
    x, y, z = reading / 100.0
    if arm == "left":
        return np.array([-z, x, -y])
    return np.array([-z, -x, y])
