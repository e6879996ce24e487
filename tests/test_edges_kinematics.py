"""Edges of the kinematics' inputs: what numpy would quietly convert is refused by name.

``np.asarray(x, dtype=float)`` reads the text "0.5" as 0.5, drops the imaginary part of a
complex number with a warning only, and reads True as 1.0. A joint coordinate or a payload
given that way is a mistake; every entry point reports it with a one-line ValueError that
names the argument and the offending entry, and never returns a pose.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from kinematics import RavenII, check_joint_limits, tool_tip_covariance, tool_tip_error

INSIDE = np.array([0.5, 1.5, 0.4, 0.1, 0.2, 0.3])
METHODS = ["forward_kinematics", "tool_position", "jacobian", "gravity_torques", "mass_matrix"]


@pytest.fixture(scope="module")
def robot():
    return RavenII()


def _complex(q):
    return np.asarray(q, dtype=complex) + np.array([0, 0, 0, 0, 1e-3j, 0])


def _batch_with_text():
    batch = np.array([INSIDE, INSIDE], dtype=object)
    batch[1, 2] = "0.4"
    return batch


BAD_JOINTS = {
    "complex array": (lambda: _complex(INSIDE), r"complex number .* at index \(4,\)"),
    "complex with zero imaginary part": (lambda: INSIDE.astype(complex),
                                         r"complex number .* at index \(0,\)"),
    "complex in a list": (lambda: [0.5 + 0.1j, 1.5, 0.4, 0.1, 0.2, 0.3],
                          r"complex number \(\(0\.5\+0\.1j\)\) at index \(0,\)"),
    "numeric text": (lambda: [str(v) for v in INSIDE], r"text '0\.5' at index \(0,\)"),
    "text in a batch": (_batch_with_text, r"text '0\.4' at index \(1, 2\)"),
    "booleans": (lambda: [True, True, False, False, False, False], r"boolean \(True\)"),
    "None in a list": (lambda: [0.5, 1.5, 0.4, 0.1, None, 0.3], r"None at index \(4,\)"),
    "a single string": (lambda: "0.5 1.5 0.4 0 0 0", "text"),
}


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("case", sorted(BAD_JOINTS))
def test_joint_angles_that_are_not_real_numbers_are_refused(robot, method, case):
    make, pattern = BAD_JOINTS[case]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no ComplexWarning on the way: refused before
        with pytest.raises(ValueError, match=r"^q must hold real numeric values \(rad, m\); "
                           r"got .*" + pattern):
            getattr(robot, method)(make(), check_limits=False)


def test_the_refusal_is_one_line(robot):
    with pytest.raises(ValueError) as info:
        robot.forward_kinematics(_complex(INSIDE))
    assert "\n" not in str(info.value)


def test_the_same_joints_as_real_numbers_are_accepted(robot):
    # Lists, object arrays of Python or numpy reals and integers are numbers like float64.
    reference = robot.tool_position(INSIDE)
    as_objects = np.array([float(v) for v in INSIDE[:3]] + list(INSIDE[3:]), dtype=object)
    for q in (list(INSIDE), as_objects):
        np.testing.assert_array_equal(robot.tool_position(q), reference)
    integers = np.array([0, 1, 0, 0, 0, 0])
    np.testing.assert_array_equal(robot.tool_position(integers, check_limits=False),
                                  robot.tool_position(integers.astype(float), check_limits=False))


@pytest.mark.parametrize("case", ["complex", "text"])
def test_the_other_joint_entry_points_refuse_them_too(robot, case):
    bad = _complex(INSIDE) if case == "complex" else [str(v) for v in INSIDE]
    pattern = "complex number" if case == "complex" else "text"
    with pytest.raises(ValueError, match=pattern):
        check_joint_limits(bad[:3])
    with pytest.raises(ValueError, match=pattern):
        robot.check_joint_limits(bad)
    with pytest.raises(ValueError, match=r"^q_true must hold real numeric values.*" + pattern):
        tool_tip_error(robot, bad, INSIDE)
    covariance = (np.eye(3) * (1e-6 + 1e-9j) if case == "complex"
                  else [["1e-6", "0", "0"], ["0", "1e-6", "0"], ["0", "0", "1e-6"]])
    with pytest.raises(ValueError, match=r"^joint_covariance must hold real numeric.*" + pattern):
        tool_tip_covariance(robot, INSIDE, covariance)


BAD_PAYLOADS = [
    (-0.1, r"payload_kg must be finite and >= 0 kg, got -0\.1"),
    (np.nan, r"payload_kg must be finite and >= 0 kg, got nan"),
    (np.inf, r"payload_kg must be finite and >= 0 kg, got inf"),
    (-np.inf, r"payload_kg must be finite and >= 0 kg, got -inf"),
    ([0.1, 0.2], r"payload_kg must be one number \(a mass in kg\), got an array of shape \(2,\)"),
    (np.array([0.1]), r"payload_kg must be one number .* shape \(1,\)"),
    (np.zeros((1, 1)), r"payload_kg must be one number .* shape \(1, 1\)"),
    ("0.1", r"payload_kg must hold real numeric values \(kg\); got text '0\.1'"),
    ("heavy", r"got text 'heavy'"),
    (None, r"payload_kg must hold real numeric values \(kg\); got None"),
    (0.1 + 0j, r"got a complex number"),
    (True, r"got a boolean \(True\)"),
]


@pytest.mark.parametrize("payload, pattern", BAD_PAYLOADS,
                         ids=[repr(p) for p, _ in BAD_PAYLOADS])
@pytest.mark.parametrize("method", ["gravity_torques", "mass_matrix", "gravity_coefficients"])
def test_payload_mistakes_are_named(robot, method, payload, pattern):
    call = getattr(robot, method)
    with pytest.raises(ValueError, match=pattern):
        if method == "gravity_coefficients":
            call(payload_kg=payload)
        else:
            call(INSIDE, payload_kg=payload)


def test_valid_payloads_of_every_numeric_type_agree(robot):
    reference = robot.gravity_torques(INSIDE, payload_kg=0.25)
    for payload in (np.float32(0.25), np.float64(0.25), np.array(0.25)):
        np.testing.assert_allclose(robot.gravity_torques(INSIDE, payload_kg=payload), reference,
                                   rtol=1e-7)
    # an integer payload is a mass too, and zero is the unloaded arm
    np.testing.assert_array_equal(robot.gravity_torques(INSIDE, payload_kg=0),
                                  robot.gravity_torques(INSIDE))


def test_a_payload_pulls_the_arm_down_more_the_heavier_it_is(robot):
    # Behaviour behind the check: the load grows linearly with the mass (J_v^T m g).
    unloaded = robot.gravity_torques(INSIDE)
    one = robot.gravity_torques(INSIDE, payload_kg=0.2) - unloaded
    two = robot.gravity_torques(INSIDE, payload_kg=0.4) - unloaded
    np.testing.assert_allclose(two, 2 * one, rtol=1e-9, atol=1e-12)
    assert np.linalg.norm(one) > 0


@pytest.mark.parametrize("tool_joints, pattern", [
    (("0", "0", "0"), r"tool_joints must hold real numeric values \(rad\); got text '0'"),
    ((0.0, 0.1j, 0.0), r"got a complex number \(0?\.?1j\) at index \(1,\)"),
    ((0.0, 0.0), r"tool_joints must be 3 finite numbers"),
])
def test_tool_joint_mistakes_in_the_gravity_coefficients_are_named(robot, tool_joints, pattern):
    with pytest.raises(ValueError, match=pattern):
        robot.gravity_coefficients(payload_kg=0.1, tool_joints=tool_joints)
