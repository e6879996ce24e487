"""The RAVEN-II arm model: forward kinematics, Jacobian, gravity and inertia.

:class:`RavenII` wraps a Pinocchio model of one arm built from the controller's
modified-DH table (see :mod:`kinematics.arm_parameters`). Like Pinocchio, it keeps
the constant description (``model``) apart from the work buffers (``data``): the
methods use an internal ``data`` by default, and accept another one from
:meth:`RavenII.create_data`, e.g. one per thread.

Joint vectors are the controller's ``J`` (see :mod:`kinematics.joint_limits`): one
configuration of shape (6,) or a batch of shape (N, 6); every result keeps that
batch axis or its absence. Poses are in the controller's base frame, whose origin is
the remote centre of motion.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from kinematics.arm_parameters import (
    DEFAULT_RADIUS_OF_GYRATION,
    TOOL_LENGTH,
    WRIST_LENGTH,
    RavenArmParameters,
    raven_arm_parameters,
)
from kinematics.dh_batch import LinkConstants, tool_jacobians, tool_transforms
from kinematics.gravity_closed_form import pack_coefficients
from kinematics.joint_limits import (
    CONTROLLER_JOINT_LIMITS,
    HOME_POSE,
    JointLimits,
    as_joint_array,
    check_joint_limits,
    check_payload,
    check_within,
)
from kinematics.mounting import DEFAULT_GRAVITY
from kinematics.pinocchio_model import TOOL_FRAME, build_model
from kinematics.urdf_export import urdf_from_parameters

BACKENDS = ("auto", "pinocchio", "numpy")
"""``"auto"`` uses Pinocchio for one configuration and numpy for a batch."""


class RavenII:
    """Model of one RAVEN-II arm.

    Parameters
    ----------
    arm : {"left", "right"}
        ``"left"`` is the gold arm, ``"right"`` the green arm.
    gravity : array_like, shape (3,)
        Gravity in the base frame (m/s^2). Default ``(-9.8, 0, 0)``: the vector the
        controller derives from its start-up accelerometer reading for the usual
        mounting (base x axis up), see :mod:`kinematics.mounting`.
    tool_length, wrist_length : float
        Tool constants (m), the controller's ``-d4 = 0.47`` and ``Lw = 0.013``.
    radius_of_gyration : float or sequence of 3 floats
        Assumed isotropic radius of gyration of links 1-3 about their centres of
        mass (m); only masses and centres of mass are published.
    limits : JointLimits
        Joint ranges (default: the controller's).
    check_limits : bool
        Whether methods reject configurations outside ``limits`` by default; each
        method can override it with its own ``check_limits`` argument. Switch it
        off to evaluate estimated joints that may leave the range.

    Attributes
    ----------
    model : pinocchio.Model
        The constant model; joint frames are the controller's DH frames and the
        frame ``"tool"`` is DH frame 6.
    data : pinocchio.Data
        Default work buffer of the methods.
    parameters : RavenArmParameters
        The immutable description the model was built from.
    """

    def __init__(
        self,
        arm: str = "left",
        gravity=DEFAULT_GRAVITY,
        *,
        tool_length: float = TOOL_LENGTH,
        wrist_length: float = WRIST_LENGTH,
        radius_of_gyration=DEFAULT_RADIUS_OF_GYRATION,
        limits: JointLimits = CONTROLLER_JOINT_LIMITS,
        check_limits: bool = True,
    ) -> None:
        params = raven_arm_parameters(
            arm,
            gravity,
            tool_length=tool_length,
            wrist_length=wrist_length,
            radius_of_gyration=radius_of_gyration,
            limits=limits,
        )
        self._setup(params, check_limits)

    @classmethod
    def from_parameters(
        cls, parameters: RavenArmParameters, check_limits: bool = True
    ) -> "RavenII":
        """Model of an arm described by ``parameters``."""
        robot = cls.__new__(cls)
        robot._setup(parameters, check_limits)
        return robot

    def _setup(self, params: RavenArmParameters, check_limits: bool) -> None:
        self._params = params
        self._check_limits = bool(check_limits)
        self._model = build_model(params)
        self._data = self._model.createData()
        self._tool_id = self._model.getFrameId(TOOL_FRAME)
        self._links = LinkConstants.from_dh(params.dh)
        self._lower, self._upper = params.limits.arrays
        self._lower.setflags(write=False)
        self._upper.setflags(write=False)

    def __repr__(self) -> str:
        return (
            f"RavenII(arm={self.arm!r}, gravity={self._params.gravity}, "
            f"check_limits={self._check_limits})"
        )

    # --- description -------------------------------------------------------------
    @property
    def model(self) -> pin.Model:
        return self._model

    @property
    def data(self) -> pin.Data:
        return self._data

    @property
    def parameters(self) -> RavenArmParameters:
        return self._params

    @property
    def arm(self) -> str:
        return self._params.arm

    @property
    def gravity(self) -> np.ndarray:
        """Gravity in the base frame (m/s^2), shape (3,)."""
        return np.array(self._params.gravity)

    @property
    def check_limits(self) -> bool:
        """Default of the methods' ``check_limits`` argument."""
        return self._check_limits

    @property
    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` bounds of J0..J5 (rad, m), shape (6,) each."""
        return self._params.limits.arrays

    @staticmethod
    def home_pose() -> np.ndarray:
        """The controller's home pose, a joint vector J of shape (6,) (rad, rad, m, rad, rad, rad).

        Shoulder 30 deg, elbow 90 deg, insertion 0.4 m, tool roll, wrist and grasp 0: the home
        values of ``include/raven/defines.h`` (see :data:`kinematics.joint_limits.HOME_POSE`).
        A new array each call.
        """
        return np.array(HOME_POSE)

    def create_data(self) -> pin.Data:
        """A new Pinocchio work buffer for this model."""
        return self._model.createData()

    def check_joint_limits(self, q) -> None:
        """Raise ``ValueError`` naming the first joint of ``q`` outside its range.

        ``q`` may hold the first k <= 6 joints, shape (k,) or (N, k).
        """
        check_joint_limits(q, self._params.limits)

    def to_urdf(self) -> str:
        """URDF text of this arm (kinematics, masses, limits; see :mod:`kinematics.urdf_export`)."""
        return urdf_from_parameters(self._params)

    # --- kinematics --------------------------------------------------------------
    def _joints(self, q, check_limits: bool | None) -> tuple[np.ndarray, bool]:
        q2d, single = as_joint_array(q)
        if self._check_limits if check_limits is None else check_limits:
            check_within(q2d, single, self._lower, self._upper)
        return q2d, single

    def _use_pinocchio(self, backend: str, single: bool) -> bool:
        if backend not in BACKENDS:
            raise ValueError(f"backend must be one of {BACKENDS}, got {backend!r}")
        return backend == "pinocchio" or (backend == "auto" and single)

    def forward_kinematics(
        self, q, *, check_limits: bool | None = None, backend: str = "auto", data=None
    ) -> np.ndarray:
        """Tool pose in the base frame, as the controller's ``fwd_kin`` computes it.

        Parameters
        ----------
        q : array_like, shape (6,) or (N, 6)
            Controller joint vectors J (rad, m).
        check_limits : bool, optional
            Reject joints outside their range; default: the model's setting.
        backend : {"auto", "pinocchio", "numpy"}
            ``"auto"``: Pinocchio for one configuration, the vectorized numpy chain
            for a batch.
        data : pinocchio.Data, optional
            Work buffer for the Pinocchio path (default: ``self.data``).

        Returns
        -------
        numpy.ndarray, shape (4, 4) or (N, 4, 4)
            Homogeneous transform of DH frame 6 (translation in m).
        """
        q2d, single = self._joints(q, check_limits)
        if self._use_pinocchio(backend, single):
            data = self._data if data is None else data
            out = np.empty((q2d.shape[0], 4, 4))
            for n, qn in enumerate(q2d):
                pin.forwardKinematics(self._model, data, qn)
                out[n] = pin.updateFramePlacement(self._model, data, self._tool_id).homogeneous
        else:
            out = tool_transforms(self._links, q2d)
        return out[0] if single else out

    def tool_position(self, q, *, check_limits: bool | None = None) -> np.ndarray:
        """Tool-tip position (origin of DH frame 6) in the base frame (m).

        Returns shape (3,) for one configuration, (N, 3) for a batch.
        """
        return self.forward_kinematics(q, check_limits=check_limits)[..., :3, 3]

    def jacobian(
        self, q, *, check_limits: bool | None = None, backend: str = "auto", data=None
    ) -> np.ndarray:
        """Geometric Jacobian of the tool frame in base-frame axes.

        Parameters
        ----------
        q : array_like, shape (6,) or (N, 6)
            Controller joint vectors J (rad, m).
        check_limits, backend, data
            As in :meth:`forward_kinematics`.

        Returns
        -------
        numpy.ndarray, shape (6, 6) or (N, 6, 6)
            Rows 0-2: d(tool position)/dJ (m/rad; m/m for the insertion column).
            Rows 3-5: base-frame angular velocity of the tool per joint rate.
        """
        q2d, single = self._joints(q, check_limits)
        if self._use_pinocchio(backend, single):
            data = self._data if data is None else data
            out = np.empty((q2d.shape[0], 6, 6))
            for n, qn in enumerate(q2d):
                out[n] = pin.computeFrameJacobian(
                    self._model, data, qn, self._tool_id, pin.LOCAL_WORLD_ALIGNED
                )
        else:
            out = tool_jacobians(self._links, q2d)
        return out[0] if single else out

    # --- dynamics of the positioning joints ----------------------------------------
    def _payload_jacobian(self, qn: np.ndarray, data) -> np.ndarray:
        """d(tool position)/d(J0..J2), shape (3, 3)."""
        jac = pin.computeFrameJacobian(
            self._model, data, qn, self._tool_id, pin.LOCAL_WORLD_ALIGNED
        )
        return jac[:3, :3]

    @staticmethod
    def _checked_payload(payload_kg: float) -> float:
        return check_payload(payload_kg)

    def gravity_torques(
        self, q, payload_kg: float = 0.0, *, check_limits: bool | None = None, data=None
    ) -> np.ndarray:
        """Gravity load of the positioning joints J0..J2, from Pinocchio.

        Parameters
        ----------
        q : array_like, shape (6,) or (N, 6)
            Controller joint vectors J (rad, m); the tool joints place the payload.
        payload_kg : float
            Point mass hanging at the tool tip (kg).
        check_limits, data
            As in :meth:`forward_kinematics`.

        Returns
        -------
        numpy.ndarray, shape (3,) or (N, 3)
            Torque (N m), torque (N m) and force (N) the joints must supply to hold
            the arm at rest (the ``g(q)`` of ``M qdd + C qd + g = tau``); equal to
            the joint torques ``GZ1..GZ3`` of the controller's ``getGravityTorque``
            (before their mapping to motor torques) for the same gravity vector.
            The payload adds ``-J_v^T (m g)``, ``J_v`` the tool-position Jacobian
            (columns J0..J2) and ``g`` the gravity vector.

        Notes
        -----
        A batch is evaluated configuration by configuration through Pinocchio;
        hot loops use ``gravity_coefficients`` with ``gravity_torques_fast``.
        """
        q2d, single = self._joints(q, check_limits)
        payload = self._checked_payload(payload_kg)
        data = self._data if data is None else data
        gravity = self.gravity
        out = np.empty((q2d.shape[0], 3))
        for n, qn in enumerate(q2d):
            out[n] = pin.computeGeneralizedGravity(self._model, data, qn)[:3]
            if payload:
                out[n] -= payload * self._payload_jacobian(qn, data).T @ gravity
        return out[0] if single else out

    def mass_matrix(
        self, q, payload_kg: float = 0.0, *, check_limits: bool | None = None, data=None
    ) -> np.ndarray:
        """Joint-space inertia of the positioning joints J0..J2, from Pinocchio's CRBA.

        The tool joints are locked (their rates zero). Links carry their published
        masses at their centres of mass and the assumed isotropic rotational inertia
        (``radius_of_gyration``); the payload is a point mass at the tool tip.

        Parameters
        ----------
        q : array_like, shape (6,) or (N, 6)
        payload_kg : float
            Point mass at the tool tip (kg).
        check_limits, data
            As in :meth:`forward_kinematics`.

        Returns
        -------
        numpy.ndarray, shape (3, 3) or (N, 3, 3)
            Symmetric positive-definite inertia (kg m^2 / kg m / kg by block).
        """
        q2d, single = self._joints(q, check_limits)
        payload = self._checked_payload(payload_kg)
        data = self._data if data is None else data
        out = np.empty((q2d.shape[0], 3, 3))
        for n, qn in enumerate(q2d):
            inertia = pin.crba(self._model, data, qn)[:3, :3]
            inertia = np.triu(inertia) + np.triu(inertia, 1).T
            if payload:
                jac = self._payload_jacobian(qn, data)
                inertia = inertia + payload * jac.T @ jac
            out[n] = inertia
        return out[0] if single else out

    def gravity_coefficients(
        self, payload_kg: float = 0.0, tool_joints=(0.0, 0.0, 0.0)
    ) -> np.ndarray:
        """Coefficients for the compiled ``gravity_torques_fast`` / ``mass_matrix_fast``.

        Parameters
        ----------
        payload_kg : float
            Point mass at the tool tip (kg).
        tool_joints : array_like, shape (3,)
            J3..J5 (rad) held fixed while the coefficients are used.

        Returns
        -------
        numpy.ndarray
            Read-only float64 array; see :mod:`kinematics.gravity_closed_form`.
        """
        return pack_coefficients(self._params, self._checked_payload(payload_kg), tool_joints)
