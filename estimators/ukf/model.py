"""The identified motor-cable-link model of the positioning joints, packed for the UKF.

The UKF's process model is the identified cable model and nothing else: the parameter set an
identification returns (:class:`simulation.identification.IdentificationResult`), its session
offsets, and the model layer's pure functions (:mod:`simulation.model.laws`) and closed-form
gravity and inertia (:mod:`kinematics.gravity_closed_form`). :class:`CableModel` holds those numbers
in joint units, immutable, with the packed arrays the compiled process model reads.

State (12, joint units): ``[u (3), u' (3), q (3), q' (3)]``: motor coordinates ``u = motor angle /
transmission ratio`` of shoulder, elbow and insertion motors and their rates, then the joints
(rad, rad, m) and their rates. Input: the commanded motor torques ``tau`` (N m at the gearbox
output) as torques ``tau * ratio / gearbox`` on the motor coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.identification.samples import arm_model
from simulation.model.laws import cable_stretch_curve, coupling_matrix
from simulation.model.layout import (
    HARDENING,
    LOAD_SCALE,
    MOTOR_INERTIA,
    N_ROWS,
    OFFSET,
    STIFFNESS,
    VELOCITY_SCALE,
    joint_table,
)
from simulation.model.parameters import RavenParameters

N_STATE = 12
U, UD, Q, QD = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
N_DISTURBANCE_STATE = 15
"""State size with a disturbance torque per positioning joint (states 12-14, N m, N m, N)."""
D = slice(12, 15)
DISTURBANCE_SPREAD = np.array([1.0, 1.0, 10.0])
"""Initial standard deviation of the disturbance torques (N m, N m, N): the order of a kilogram at
the tool tip (about 10 N on the insertion axis, a few tenths of a metre of lever on the shoulder and
elbow), round numbers."""


def _frozen(array) -> np.ndarray:
    array = np.array(array, dtype=float)
    array.setflags(write=False)
    return array


@dataclass(frozen=True)
class CableModel:
    """Numbers of the motor-cable-link model, joint units (rad, rad, m; N m, N m, N).

    Attributes
    ----------
    table : (N_ROWS, 3) per-joint parameters in the model's one layout
        (:mod:`simulation.model.layout`): cable stiffness at zero tension, hardening stretch,
        damping; gravity load scale; Coulomb force, its ``tanh`` velocity scale, viscous
        coefficient (zero for effects that are off); session offset; motor inertia and damping on
        the motor coordinates (``J ratio^2``, ``b ratio^2``); the rows of effects the UKF does not
        model are not read.
    coupling : (3, 3) true cable coupling ``A`` (cable ends at ``A u + offset``).
    gravity_coefficients : coefficients of :func:`kinematics.gravity_torques_fast` with the payload.
    torque_scale : (3,) ``ratio / gearbox``: gearbox-output torque to motor-coordinate torque.
    transmission_ratio : (3,) motor rad per joint unit.
    encoder_resolution : (3,) one motor-encoder count in motor coordinates.
    nominal_coupling : (3, 3) the controller's coupling (its ``jpos = A_nom mpos / ratio``).
    """

    table: np.ndarray
    coupling: np.ndarray
    gravity_coefficients: np.ndarray
    torque_scale: np.ndarray
    transmission_ratio: np.ndarray
    encoder_resolution: np.ndarray
    nominal_coupling: np.ndarray

    def __post_init__(self) -> None:
        for name in ("table", "coupling", "gravity_coefficients", "torque_scale", "transmission_ratio",
                     "encoder_resolution", "nominal_coupling"):
            value = _frozen(getattr(self, name))
            if not np.all(np.isfinite(value)):
                raise ValueError(f"CableModel.{name} must be finite")
            object.__setattr__(self, name, value)
        if self.table.shape != (N_ROWS, 3):
            raise ValueError(f"table must have shape ({N_ROWS}, 3), got {self.table.shape}")
        if np.any(self.table[STIFFNESS] <= 0) or np.any(self.table[HARDENING] <= 0):
            raise ValueError("the UKF needs a stretching cable: stiffness and hardening must be positive")
        if np.any(self.table[VELOCITY_SCALE] <= 0) or np.any(self.table[MOTOR_INERTIA] <= 0):
            raise ValueError("friction velocity scales and motor inertias must be positive")

    @classmethod
    def from_parameters(cls, params: RavenParameters, offsets, payload_kg: float = 0.0) -> "CableModel":
        """The model of a parameter set (effects that are off contribute nothing) and session offsets.

        Raises
        ------
        ValueError
            ``cable_stretch`` is off (a rigid cable leaves the joints no state of their own), or
            the offsets are not three finite numbers.
        """
        if not params.is_enabled("cable_stretch"):
            raise ValueError("the UKF models the cable stretch; the parameter set has cable_stretch off")
        c = params.constants
        ratio = c.transmission_ratio[:3]
        table = joint_table(params, offsets)
        coupling = params.effect("coupling")
        delta = coupling.delta if coupling.enabled else np.zeros(3)
        counts = c.encoder_counts_per_rev
        return cls(
            table=table,
            coupling=coupling_matrix(*(np.asarray(c.cable_coupling) + delta)),
            gravity_coefficients=arm_model(params).gravity_coefficients(payload_kg),
            torque_scale=ratio / c.gearbox[:3],
            transmission_ratio=ratio,
            encoder_resolution=2.0 * np.pi / counts / ratio,
            nominal_coupling=c.nominal_coupling(),
        )

    @property
    def motor_inertia(self) -> np.ndarray:
        return self.table[MOTOR_INERTIA]

    def cable_ends(self, motor: np.ndarray) -> np.ndarray:
        """Cable-end positions ``A u + offset`` (joint units) of motor coordinates (..., 3)."""
        return np.asarray(motor) @ self.coupling.T + self.table[OFFSET]

    def static_joints(self, motor: np.ndarray, gravity_torque) -> np.ndarray:
        """Joints at rest under a load: cable ends minus the stretch of the gravity tension."""
        tension = self.table[LOAD_SCALE] * np.asarray(gravity_torque)
        stretch = np.array([cable_stretch_curve(tension[..., i], self.table[STIFFNESS, i], self.table[HARDENING, i])
                            for i in range(3)])
        return self.cable_ends(motor) - np.moveaxis(stretch, 0, -1)
