"""The model's laws: the numba and casadi forms agree, inverses invert, slopes are derivatives,
and the one parameter layout packs what the effects say."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from simulation.model import laws
from simulation.model import laws_casadi
from simulation.model.constants import coupling_matrix
from simulation.model.effects import Backlash, CableStretch, Hysteresis
from simulation.model.layout import (
    COULOMB,
    HARDENING,
    MOTOR_INERTIA,
    N_ROWS,
    OFFSET,
    ROW_NAMES,
    ROWS,
    STIFFNESS,
    VELOCITY_SCALE,
    joint_table,
    row_index,
)
from simulation.model.parameters import RavenParameters

N_DRAWS = 400
RTOL = 1e-12


def draws(seed: int, n: int = N_DRAWS) -> np.random.Generator:
    return np.random.default_rng(seed)


def casadi_values(law, arguments: list[np.ndarray]) -> np.ndarray:
    """``law`` built on scalar casadi symbols, then evaluated at every column of ``arguments``."""
    symbols = [ca.SX.sym(f"a{i}") for i in range(len(arguments))]
    function = ca.Function("law", symbols, [law(*symbols)]).map(arguments[0].size)
    return np.asarray(function(*[a.reshape(1, -1) for a in arguments])).ravel()


def assert_close(actual, expected, rtol, floor):
    """``|actual - expected| <= rtol |expected| + floor`` elementwise (``floor`` may be an array)."""
    error = np.abs(np.asarray(actual) - expected)
    bound = rtol * np.abs(expected) + floor
    assert np.all(error <= bound), f"worst {np.max(error / bound):.3g} times the tolerance"


def numba_values(law, arguments: list[np.ndarray]) -> np.ndarray:
    return np.array([law(*(float(a[k]) for a in arguments)) for k in range(arguments[0].size)])


def cable_states(rng: np.random.Generator):
    """Stiffness over three decades (N m/rad ... N/m), hardening from 1 mm to 0.1 rad, stretch
    within five hardening stretches either way."""
    stiffness = 10.0 ** rng.uniform(0.5, 3.5, N_DRAWS)
    hardening = 10.0 ** rng.uniform(-3.0, -1.0, N_DRAWS)
    stretch = hardening * rng.uniform(-5.0, 5.0, N_DRAWS)
    return stretch, stiffness, hardening


def friction_states(rng: np.random.Generator):
    scale = 10.0 ** rng.uniform(-5.0, -2.0, N_DRAWS)
    velocity = scale * rng.uniform(-20.0, 20.0, N_DRAWS)
    coulomb = rng.uniform(0.0, 1.0, N_DRAWS)
    viscous = rng.uniform(0.0, 10.0, N_DRAWS)
    return velocity, coulomb, scale, viscous


@pytest.mark.parametrize("name", ["stiffness_tension", "cable_stiffness"])
def test_cable_laws_agree_in_numba_and_casadi(name):
    arguments = list(cable_states(draws(1)))
    expected = numba_values(getattr(laws, name), arguments)
    np.testing.assert_allclose(casadi_values(getattr(laws_casadi, name), arguments), expected, rtol=RTOL)


def test_stretch_law_agrees_in_numba_and_casadi_and_inverts_the_tension_law():
    stretch, stiffness, hardening = cable_states(draws(2))
    tension = numba_values(laws.stiffness_tension, [stretch, stiffness, hardening])
    arguments = [tension, stiffness, hardening]
    numba_stretch = numba_values(laws.stretch_from_tension, arguments)
    np.testing.assert_allclose(casadi_values(laws_casadi.stretch_from_tension, arguments), numba_stretch, rtol=RTOL)
    assert_close(numba_stretch, stretch, 1e-12, 1e-15 * hardening)
    np.testing.assert_allclose(laws.cable_stretch_curve(tension, stiffness, hardening), numba_stretch, rtol=RTOL)
    np.testing.assert_allclose(laws.cable_tension_curve(stretch, stiffness, hardening), tension, rtol=RTOL)


def test_tangent_stiffness_is_the_derivative_of_the_tension():
    stretch, stiffness, hardening = cable_states(draws(3))
    step = 1e-6 * hardening
    numeric = (numba_values(laws.stiffness_tension, [stretch + step, stiffness, hardening])
               - numba_values(laws.stiffness_tension, [stretch - step, stiffness, hardening])) / (2.0 * step)
    np.testing.assert_allclose(numba_values(laws.cable_stiffness, [stretch, stiffness, hardening]), numeric, rtol=1e-7)


@pytest.mark.parametrize("name", ["friction_force", "coulomb_friction"])
def test_friction_laws_agree_in_numba_and_casadi(name):
    velocity, coulomb, scale, viscous = friction_states(draws(4))
    arguments = [velocity, coulomb, scale] + ([viscous] if name == "friction_force" else [])
    expected = numba_values(getattr(laws, name), arguments)
    np.testing.assert_allclose(casadi_values(getattr(laws_casadi, name), arguments), expected, rtol=RTOL,
                               atol=1e-15 * np.max(np.abs(expected)))


def test_friction_slope_is_the_derivative_of_the_friction_and_shares_its_force():
    velocity, coulomb, scale, viscous = friction_states(draws(5))
    inverse = 1.0 / scale
    pairs = np.array([laws.friction_with_slope(velocity, inverse, coulomb, viscous, k) for k in range(N_DRAWS)])
    force, slope = pairs[:, 0], pairs[:, 1]
    np.testing.assert_allclose(force, numba_values(laws.friction_force, [velocity, coulomb, scale, viscous]),
                               rtol=1e-13, atol=1e-15)
    step = 1e-6 * scale
    numeric = (numba_values(laws.friction_force, [velocity + step, coulomb, scale, viscous])
               - numba_values(laws.friction_force, [velocity - step, coulomb, scale, viscous])) / (2.0 * step)
    assert_close(slope, numeric, 1e-6, 1e-8 * coulomb / scale)


def test_motor_friction_agrees_in_numpy_and_casadi_and_grows_with_the_transmitted_load():
    velocity, coulomb, scale, _ = friction_states(draws(12))
    rng = draws(13)
    loss = rng.uniform(0.0, 0.5, N_DRAWS)
    transmitted = rng.uniform(-5.0, 5.0, N_DRAWS)
    arguments = [velocity, coulomb, loss, transmitted, scale]
    expected = laws.motor_friction(*arguments)
    np.testing.assert_allclose(casadi_values(laws_casadi.motor_friction, arguments), expected, rtol=RTOL,
                               atol=1e-15 * np.max(np.abs(expected)))
    # opposes nothing at rest, the dry bound plus the loss per unit of load once the drive slides
    assert laws.motor_friction(0.0, 1.0, 0.2, 3.0, 1e-3) == 0.0
    assert laws.motor_friction(1.0, 1.0, 0.2, -3.0, 1e-3) == pytest.approx(1.6, rel=1e-12)
    assert laws.motor_friction(-1.0, 1.0, 0.2, 3.0, 1e-3) == pytest.approx(-1.6, rel=1e-12)


def test_link_tension_and_gravity_load_agree_in_numba_and_casadi():
    rng = draws(6)
    velocity, coulomb, scale, viscous = friction_states(rng)
    inertial = rng.normal(0.0, 1.0, N_DRAWS)
    gravity = rng.normal(0.0, 3.0, N_DRAWS)
    load_scale = rng.uniform(0.5, 1.5, N_DRAWS)
    arguments = [inertial, gravity, velocity, load_scale, coulomb, scale, viscous]
    expected = numba_values(laws.link_tension, arguments)
    np.testing.assert_allclose(casadi_values(laws_casadi.link_tension, arguments), expected, rtol=RTOL,
                               atol=1e-15 * np.max(np.abs(expected)))
    np.testing.assert_allclose(casadi_values(laws_casadi.gravity_load, [gravity, load_scale]),
                               numba_values(laws.gravity_load, [gravity, load_scale]), rtol=RTOL)
    # the tension is the sum of its loads
    friction = numba_values(laws.friction_force, [velocity, coulomb, scale, viscous])
    np.testing.assert_allclose(expected, inertial + load_scale * gravity + friction, rtol=1e-12,
                               atol=1e-14 * np.max(np.abs(expected)))


def test_bouc_wen_rate_agrees_in_numba_and_casadi_and_its_slope_is_the_rate_per_stretch():
    rng = draws(7)
    z = rng.uniform(-0.01, 0.01, N_DRAWS)
    rate = rng.normal(0.0, 0.1, N_DRAWS)
    beta = rng.uniform(10.0, 5000.0, N_DRAWS)
    gamma = rng.uniform(10.0, 2000.0, N_DRAWS)
    arguments = [z, rate, beta, gamma]
    expected = numba_values(laws.bouc_wen_rate, arguments)
    np.testing.assert_allclose(casadi_values(laws_casadi.bouc_wen_rate, arguments), expected, rtol=RTOL,
                               atol=1e-15 * np.max(np.abs(expected)))
    direction = np.sign(rate)
    slope = numba_values(laws.bouc_wen_slope, [z, direction, beta, gamma])
    np.testing.assert_allclose(slope * rate, expected, rtol=1e-12, atol=1e-15 * np.max(np.abs(expected)))


def test_coupling_laws_agree_in_numba_numpy_and_casadi():
    rng = draws(8)
    for _ in range(50):
        c01, c02, c12 = rng.normal(0.0, 0.5, 3)
        a = coupling_matrix(c01, c02, c12)
        np.testing.assert_array_equal(np.asarray(ca.DM(laws_casadi.coupling_matrix(c01, c02, c12))), a)
        motor = rng.normal(0.0, 1.0, 3)
        offset = rng.normal(0.0, 0.01, 3)
        tension = rng.normal(0.0, 10.0, 3)
        ends = np.array([laws.cable_end(a, motor, offset[i], i) for i in range(3)])
        loads = np.array([laws.coupled_transpose(a, tension, i) for i in range(3)])
        np.testing.assert_allclose(ends, a @ motor + offset, rtol=RTOL, atol=1e-15)
        np.testing.assert_allclose(loads, a.T @ tension, rtol=RTOL, atol=1e-14)
        symbolic_a = laws_casadi.coupling_matrix(*(ca.SX.sym(n) for n in ("c01", "c02", "c12")))
        u, o, t = ca.SX.sym("u", 3), ca.SX.sym("o", 3), ca.SX.sym("t", 3)
        parameters = ca.symvar(symbolic_a)
        both = ca.Function("coupling", [ca.vertcat(*parameters), u, o, t],
                           [laws_casadi.cable_ends(symbolic_a, u, o), laws_casadi.motor_load(symbolic_a, t)])
        values = {"c01": c01, "c02": c02, "c12": c12}
        casadi_ends, casadi_loads = both([values[p.name()] for p in parameters], motor, offset, tension)
        np.testing.assert_allclose(np.asarray(casadi_ends).ravel(), ends, rtol=RTOL, atol=1e-15)
        np.testing.assert_allclose(np.asarray(casadi_loads).ravel(), loads, rtol=RTOL, atol=1e-14)


def test_hyperbolic_advance_follows_sinh_and_cosh_over_small_steps():
    rng = draws(9)
    a = rng.uniform(-5.0, 5.0, N_DRAWS)
    b = rng.uniform(-1e-3, 1e-3, N_DRAWS)
    advanced = np.array([laws.advance_hyperbolic(np.sinh(a[k]), np.cosh(a[k]), b[k]) for k in range(N_DRAWS)])
    np.testing.assert_allclose(advanced[:, 0], np.sinh(a + b), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(advanced[:, 1], np.cosh(a + b), rtol=1e-13)


def test_play_keeps_its_output_inside_the_band_and_follows_beyond_it():
    rng = draws(10)
    position = np.cumsum(rng.normal(0.0, 1e-4, N_DRAWS))
    half = 3e-4
    output = position[0]
    for p in position:
        new = laws.play(p, output, half)
        assert abs(p - new) <= half + 1e-15
        assert new == output or abs(p - new) == pytest.approx(half)
        output = new


def test_the_layout_packs_each_effect_field_and_zeroes_effects_that_are_off():
    params = RavenParameters().with_effect(Backlash(enabled=False)).with_effect(Hysteresis(enabled=True))
    table = joint_table(params, offsets=[0.01, -0.02, 0.003])
    assert table.shape == (N_ROWS, 3) == (len(ROW_NAMES), 3)
    for index, row in enumerate(ROWS):
        if not row.effect:
            continue
        effect = params.effect(row.effect)
        expected = getattr(effect, row.field) if effect.enabled or row.kept_when_off else np.zeros(3)
        np.testing.assert_array_equal(table[index], expected, err_msg=row.name)
    np.testing.assert_array_equal(table[row_index("backlash")], np.zeros(3))
    np.testing.assert_array_equal(table[OFFSET], [0.01, -0.02, 0.003])
    ratio = params.constants.transmission_ratio[:3]
    np.testing.assert_array_equal(table[MOTOR_INERTIA], params.constants.motor_inertia[:3] * ratio ** 2)
    # rows that divide keep their values when their effect is off
    off = joint_table(params.without("cable_stretch", "coulomb_friction"))
    assert np.all(off[HARDENING] > 0) and np.all(off[VELOCITY_SCALE] > 0)
    np.testing.assert_array_equal(off[STIFFNESS], np.zeros(3))
    np.testing.assert_array_equal(off[COULOMB], np.zeros(3))
    assert np.all(joint_table(params.with_effect(CableStretch(stiffness=[1.0, 2.0, 3.0])))[STIFFNESS] == [1, 2, 3])


def test_the_layout_rejects_bad_offsets_and_unknown_rows():
    with pytest.raises(ValueError, match="offsets must be 3 finite values"):
        joint_table(RavenParameters(), offsets=[0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="unknown row 'stifness'"):
        row_index("stifness")
