"""Joint names, joint limits and validation of joint vectors.

Joint vectors follow the RAVEN-II controller's ``J``: index 0..5 are shoulder (rad),
elbow (rad), insertion (m), tool roll (rad), wrist (rad) and grasp
``(grasp2 - grasp1) / 2`` (rad). The paper's "joints 1, 2, 3" are indices 0, 1, 2.
Every public kinematics function validates its joint input here, so that a wrong
shape, a non-finite value or a joint outside its range is reported by name instead
of producing a silently wrong pose. The payload mass is checked here too
(:func:`check_payload`), and both refuse what numpy would quietly convert: text
("0.5"), complex numbers (imaginary part dropped) and booleans.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np

JOINT_NAMES = ("shoulder", "elbow", "z_ins", "tool_rot", "wrist", "grasp")
"""Names of the controller's joints J0..J5."""

JOINT_UNITS = ("rad", "rad", "m", "rad", "rad", "rad")
"""SI unit of each joint coordinate."""

N_JOINTS = len(JOINT_NAMES)


@dataclass(frozen=True)
class JointLimits:
    """Lower and upper bounds of the six joints, SI units (rad, m).

    Attributes
    ----------
    lower, upper : tuple of float, length 6
        Bounds of J0..J5; a value equal to a bound is inside the range.
    """

    lower: tuple[float, ...]
    upper: tuple[float, ...]

    def __post_init__(self) -> None:
        lower = np.asarray(self.lower, dtype=float)
        upper = np.asarray(self.upper, dtype=float)
        if lower.shape != (N_JOINTS,) or upper.shape != (N_JOINTS,):
            raise ValueError(f"joint limits need {N_JOINTS} lower and {N_JOINTS} upper bounds")
        if np.any(np.isnan(lower)) or np.any(np.isnan(upper)) or np.any(lower >= upper):
            raise ValueError(f"each lower bound must be below its upper bound: {lower} vs {upper}")
        object.__setattr__(self, "lower", tuple(float(v) for v in lower))
        object.__setattr__(self, "upper", tuple(float(v) for v in upper))

    @property
    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(lower, upper)`` as new float arrays of shape (6,)."""
        return np.array(self.lower), np.array(self.upper)


def _rad(deg: float) -> float:
    return float(np.deg2rad(deg))


CONTROLLER_JOINT_LIMITS = JointLimits(
    lower=(_rad(0.0), _rad(45.0), 0.23, _rad(-182.0), _rad(-75.0), _rad(-89.0)),
    upper=(_rad(90.0), _rad(135.0), 0.56, _rad(182.0), _rad(75.0), _rad(89.0)),
)
"""The controller's limits: ``include/raven/defines.h`` (shoulder, elbow, insertion)
and ``include/raven/tool.h`` (tool roll, wrist, grasp)."""


HOME_POSE = (_rad(30.0), _rad(90.0), 0.4, 0.0, 0.0, 0.0)
"""The controller's home pose as a joint vector J (rad, rad, m, rad, rad, rad): SHOULDER, ELBOW and
Z_INS home values of ``include/raven/defines.h`` (30 deg, 90 deg, 0.4 m), TOOL_ROT_HOME_ANGLE and
WRIST_HOME_ANGLE (0), and both grasp jaws at GRASP1/GRASP2_HOME_ANGLE (45 deg), whose
``(grasp2 - grasp1) / 2`` is 0. Inside :data:`CONTROLLER_JOINT_LIMITS`."""


def describe_joint(index: int) -> str:
    """``"elbow (J1)"``-style label of joint ``index`` for messages."""
    return f"{JOINT_NAMES[index]} (J{index})"


def _format_value(value: float, index: int) -> str:
    if JOINT_UNITS[index] == "m":
        return f"{value:.6g} m"
    return f"{value:.6g} rad ({np.rad2deg(value):.4g} deg)"


def _describe_entry(entry) -> str:
    """What an entry that is not a real number is, for messages."""
    if isinstance(entry, (str, bytes)):
        return f"text {entry!r}"
    if isinstance(entry, bool):
        return f"a boolean ({entry!r})"
    if isinstance(entry, complex):
        return f"a complex number ({entry!r})"
    if entry is None:
        return "None"
    return f"{type(entry).__name__} {entry!r}"


def as_real_array(value, name: str, unit: str) -> np.ndarray:
    """Return `value` as a float64 array if it holds real numbers only, else raise.

    ``np.asarray(value, dtype=float)`` alone would read the text "0.5" as 0.5, drop the
    imaginary part of a complex number with only a warning and read True as 1.0; a joint
    coordinate or a mass given that way is a mistake and is reported instead.

    Parameters
    ----------
    value : array_like
        Numbers (Python or numpy integers and floats), of any shape.
    name : str
        Name of the argument, used in error messages.
    unit : str
        Units expected, used in error messages (e.g. "rad, m" or "kg").

    Raises
    ------
    ValueError
        Naming the argument, the kind of the first entry that is not a real number (text,
        complex number, boolean, None...), its value and its index.
    """
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nesting
        raise ValueError(f"{name} must hold real numeric values ({unit}): {exc}") from None
    if raw.dtype.kind in "iuf":
        return raw.astype(np.float64, copy=False)
    flat = raw.reshape(-1)
    if raw.dtype.kind == "O":
        is_real = [isinstance(entry, numbers.Real) and not isinstance(entry, (bool, np.bool_))
                   for entry in flat]
        if all(is_real):
            return raw.astype(np.float64)
        position = is_real.index(False)
    elif raw.dtype.kind == "c" and np.any(flat.imag != 0):
        position = int(np.flatnonzero(flat.imag != 0)[0])
    elif flat.size:
        position = 0
    else:
        raise ValueError(f"{name} must hold real numeric values ({unit}); got an empty array "
                         f"of {raw.dtype}")
    entry = flat[position]
    entry = entry.item() if isinstance(entry, np.generic) else entry
    where = ""
    if raw.ndim:
        where = f" at index {tuple(int(i) for i in np.unravel_index(position, raw.shape))}"
    raise ValueError(f"{name} must hold real numeric values ({unit}); got "
                     f"{_describe_entry(entry)}{where}")


def check_payload(payload_kg, name: str = "payload_kg") -> float:
    """Return a payload mass as a float if it is one finite real number >= 0 (kg), else raise.

    Raises
    ------
    ValueError
        If the payload is not a single real number (text, complex, boolean, None, an array),
        is NaN or infinite, or is negative.
    """
    value = as_real_array(payload_kg, name, "kg")
    if value.ndim != 0:
        raise ValueError(f"{name} must be one number (a mass in kg), got an array of shape "
                         f"{value.shape}: {payload_kg!r}")
    mass = float(value)
    if not np.isfinite(mass) or mass < 0.0:
        raise ValueError(f"{name} must be finite and >= 0 kg, got {mass!r}")
    return mass


def as_joint_array(q, n_joints: int = N_JOINTS, name: str = "q") -> tuple[np.ndarray, bool]:
    """Validate joint coordinates and return them as a 2-D float array.

    Parameters
    ----------
    q : array_like, shape (n_joints,) or (N, n_joints)
        One configuration or a batch, SI units.
    n_joints : int
        Expected number of joint coordinates per configuration.
    name : str
        Name of the argument, used in error messages.

    Returns
    -------
    q2d : numpy.ndarray, shape (N, n_joints)
        A float64 copy-free view when possible.
    single : bool
        True if the input was one configuration (1-D), so that callers can
        return results without the batch axis.

    Raises
    ------
    ValueError
        If ``q`` holds anything but real numbers (text, complex numbers, booleans,
        None), has the wrong shape, or holds NaN or inf; the message names the
        first offending joint.
    """
    arr = as_real_array(q, name, "rad, m")
    single = arr.ndim == 1
    if arr.ndim not in (1, 2) or arr.shape[-1] != n_joints:
        raise ValueError(
            f"{name} must have shape ({n_joints},) or (N, {n_joints}), got {arr.shape}"
        )
    q2d = arr.reshape(1, n_joints) if single else arr
    if not np.isfinite(q2d).all():
        row, col = np.argwhere(~np.isfinite(q2d))[0]
        where = "" if single else f" in row {row}"
        raise ValueError(
            f"{name} holds a non-finite value ({q2d[row, col]}) for joint "
            f"{describe_joint(int(col))}{where}"
        )
    return q2d, single


def check_joint_limits(q, limits: JointLimits = CONTROLLER_JOINT_LIMITS, name: str = "q") -> None:
    """Raise if any joint coordinate is outside its range.

    Parameters
    ----------
    q : array_like, shape (k,) or (N, k), 1 <= k <= 6
        Joint coordinates J0..J(k-1), SI units.
    limits : JointLimits
        The bounds to check against (default: the controller's).
    name : str
        Name of the argument, used in error messages.

    Raises
    ------
    ValueError
        If ``q`` is malformed, or naming the first joint outside its range (name
        and index), its value, the violated bound and, for a batch, the row.
    """
    k = np.shape(q)[-1] if np.ndim(q) in (1, 2) else 0
    if not 1 <= k <= N_JOINTS:
        raise ValueError(
            f"{name} must have shape (k,) or (N, k) with 1 <= k <= {N_JOINTS}, got {np.shape(q)}"
        )
    q2d, single = as_joint_array(q, n_joints=k, name=name)
    lower, upper = (arr[:k] for arr in limits.arrays)
    check_within(q2d, single, lower, upper, name)


def check_within(
    q2d: np.ndarray, single: bool, lower: np.ndarray, upper: np.ndarray, name: str = "q"
) -> None:
    """Raise if a row of validated joint coordinates ``q2d`` (N, k) leaves [lower, upper].

    The fast path of :func:`check_joint_limits` for callers that already hold
    validated input (from :func:`as_joint_array`) and the bounds as arrays (k,).
    """
    outside = (q2d < lower) | (q2d > upper)
    if not outside.any():
        return
    row, col = (int(v) for v in np.argwhere(outside)[0])
    value = q2d[row, col]
    side, bound = ("lower", lower[col]) if value < lower[col] else ("upper", upper[col])
    where = "" if single else f" in row {row}"
    raise ValueError(
        f"{name}: joint {describe_joint(col)}{where} = {_format_value(value, col)} is beyond "
        f"its {side} limit {_format_value(bound, col)}; allowed range "
        f"[{_format_value(lower[col], col)}, {_format_value(upper[col], col)}]. "
        "Pass check_limits=False to evaluate configurations outside the controller's range."
    )
