"""Noise models of the UKF: process noise as white accelerations, measurement noise as encoder counts.

Process noise stands for the torques the model misses: on the motors, mostly the difference between
the held torque sample of the log and the torque the motor felt over the interval (the controller
recomputes its command every millisecond from unfiltered encoder differences); on the links,
unmodelled cable and joint effects. Each enters as a white acceleration of spectral density
``sigma^2`` on a position-velocity pair, whose discrete covariance over ``dt`` is

    sigma^2 [[dt^3 / 3, dt^2 / 2], [dt^2 / 2, dt]].

The motor encoder reading is quantized to one count, a uniform error of variance
``resolution^2 / 12``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinematics.gravity_closed_form import mass_matrix_fast

from simulation.model.layout import MOTOR_INERTIA, STIFFNESS

from estimators.ukf.model import N_STATE, CableModel

HOME_JOINTS = np.array([np.pi / 6, np.pi / 2, 0.4])
"""The RAVEN-II home pose of joints 1-3 (rad, rad, m), where the starting link inertia is taken."""


def _positive3(value, name: str) -> np.ndarray:
    array = np.array(np.broadcast_to(np.asarray(value, dtype=float), (3,)))
    if not np.all(np.isfinite(array) & (array > 0)):
        raise ValueError(f"{name} must be 3 positive finite values, got {value!r}")
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class ProcessNoise:
    """White-acceleration process noise per positioning joint.

    Attributes
    ----------
    motor : (3,) density of the motor-coordinate acceleration noise (rad s^-1.5, rad s^-1.5, m s^-1.5).
    joint : (3,) density of the joint acceleration noise (same units).
    """

    motor: np.ndarray
    joint: np.ndarray

    def __post_init__(self) -> None:
        object.__setattr__(self, "motor", _positive3(self.motor, "motor"))
        object.__setattr__(self, "joint", _positive3(self.joint, "joint"))

    def covariance(self, dt: float) -> np.ndarray:
        """(12, 12) discrete process covariance over ``dt`` seconds for the state [u, u', q, q']."""
        positions, rates, cross = self._patterns()
        return (dt ** 3 / 3.0) * positions + (dt ** 2 / 2.0) * cross + dt * rates

    def _patterns(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Densities squared on the position, rate and cross entries (cached: called every step)."""
        cached = self.__dict__.get("_cached_patterns")
        if cached is None:
            density = np.concatenate([self.motor, self.joint]) ** 2
            position = np.array([0, 1, 2, 6, 7, 8])
            rate = position + 3
            positions, rates, cross = (np.zeros((N_STATE, N_STATE)) for _ in range(3))
            positions[position, position] = density
            rates[rate, rate] = density
            cross[position, rate] = density
            cross[rate, position] = density
            cached = (positions, rates, cross)
            object.__setattr__(self, "_cached_patterns", cached)
        return cached

    def as_vector(self) -> np.ndarray:
        """log10 of the six densities: the coordinates the tuning searches."""
        return np.log10(np.concatenate([self.motor, self.joint]))

    @classmethod
    def from_vector(cls, vector) -> "ProcessNoise":
        values = 10.0 ** np.asarray(vector, dtype=float)
        return cls(motor=values[:3], joint=values[3:])


def encoder_noise(model: CableModel) -> np.ndarray:
    """(3, 3) measurement covariance of one-count quantization, in motor coordinates."""
    return np.diag(model.encoder_resolution ** 2 / 12.0)


def physical_process_noise(model: CableModel, torque_rmse, joint_rmse, log_period: float) -> ProcessNoise:
    """A starting process noise from the identification's residuals (the tuning refines it).

    A torque error ``e`` held over one log period ``dt`` changes the motor velocity by ``e dt / J``:
    a white acceleration of density ``e sqrt(dt) / J``. On the links, the joint residual of the
    identification times the cable stiffness is the tension the model misses, over the link
    inertia ``M_ii`` at the home pose.
    """
    torque_rmse = _positive3(np.maximum(np.asarray(torque_rmse, dtype=float), 1e-9), "torque_rmse")
    joint_rmse = _positive3(np.maximum(np.asarray(joint_rmse, dtype=float), 1e-12), "joint_rmse")
    root = np.sqrt(log_period)
    motor = torque_rmse * root / model.table[MOTOR_INERTIA]
    inertia = np.diag(mass_matrix_fast(HOME_JOINTS.copy(), model.gravity_coefficients))
    joint = joint_rmse * model.table[STIFFNESS] * root / inertia
    return ProcessNoise(motor=motor, joint=joint)
