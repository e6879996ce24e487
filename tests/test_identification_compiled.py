"""The identification's compiled per-sample functions: the same numbers as casadi's virtual machine,
one compilation per structure, and the virtual machine when compiling is switched off or fails."""

from __future__ import annotations

import os

import casadi as ca
import numpy as np
import pytest

from simulation.identification import FITTABLE_EFFECTS, nominal_parameters
from simulation.identification import compiled
from simulation.identification.layout import DEFAULT_FIXED, build_layout
from simulation.identification.residuals import N_DATA, N_RESIDUALS, residual_function

needs_compiler = pytest.mark.skipif(compiled._compiler() is None, reason="no C compiler on this machine")


def _residual(offsets=(0.01, -0.02, 0.003)):
    params = nominal_parameters("left")
    layout = build_layout(FITTABLE_EFFECTS, DEFAULT_FIXED, params, np.asarray(offsets))
    return layout, residual_function(layout, params.constants, params.effect("coulomb_friction").velocity_scale)


def _inputs(layout, rng):
    xi = rng.normal(0, 0.3, len(layout))
    data = rng.normal(0, 1, N_DATA)
    data[-6:] = 1.0  # the residual weights
    sigma = rng.uniform(0.5, 2.0, N_RESIDUALS)
    return xi, data, sigma, layout.references()


@needs_compiler
def test_compiled_functions_give_the_virtual_machines_numbers(monkeypatch):
    layout, residual = _residual()
    monkeypatch.setattr(compiled, "_CACHE", {})
    fast = compiled.sample_functions(residual)
    monkeypatch.setenv(compiled.COMPILE_ENV, "0")
    monkeypatch.setattr(compiled, "_CACHE", {})
    slow = compiled.sample_functions(residual)
    assert fast.compiled and not slow.compiled
    rng = np.random.default_rng(3)
    for _ in range(5):
        args = _inputs(layout, rng)
        for name in ("cost", "residual", "jacobian", "gauss_newton"):
            a, b = (np.array(getattr(f, name)(*args)) for f in (fast, slow))
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(b).max()), err_msg=name)
    # the Jacobian is that of the residual: a central difference agrees
    xi, data, sigma, references = _inputs(layout, rng)
    jac = np.array(fast.jacobian(xi, data, sigma, references))
    step = 1e-6
    for k in range(len(layout)):
        e = np.zeros(len(layout))
        e[k] = step
        diff = (np.array(fast.residual(xi + e, data, sigma, references))
                - np.array(fast.residual(xi - e, data, sigma, references))).ravel() / (2 * step)
        np.testing.assert_allclose(jac[:, k], diff, rtol=1e-5, atol=1e-7)


@needs_compiler
def test_one_structure_compiles_once_whatever_its_starting_values(monkeypatch):
    monkeypatch.setattr(compiled, "_CACHE", {})
    built = []
    original = compiled._build
    monkeypatch.setattr(compiled, "_build", lambda *a: built.append(a) or original(*a))
    # other initial offsets change the references, not the function
    first = compiled.sample_functions(_residual((0.01, -0.02, 0.003))[1])
    second = compiled.sample_functions(_residual((0.2, 0.1, -0.01))[1])
    assert first is second and len(built) == 1


def test_without_compiling_the_functions_run_in_the_virtual_machine(monkeypatch):
    layout, residual = _residual()
    monkeypatch.setenv(compiled.COMPILE_ENV, "0")
    monkeypatch.setattr(compiled, "_CACHE", {})
    functions = compiled.sample_functions(residual)
    assert not functions.compiled
    args = _inputs(layout, np.random.default_rng(0))
    assert np.isfinite(float(functions.cost(*args)))


def test_a_compiler_that_fails_falls_back_with_one_warning(monkeypatch, tmp_path):
    layout, residual = _residual()
    broken = tmp_path / "cc"
    broken.write_text("#!/bin/sh\nexit 1\n")
    broken.chmod(0o755)
    monkeypatch.setattr(compiled, "_CACHE", {})
    monkeypatch.setattr(compiled, "_FAILED", [])
    monkeypatch.setattr(compiled, "_compiler", lambda: None if compiled._FAILED else str(broken))
    with pytest.warns(RuntimeWarning, match="could not compile"):
        functions = compiled.sample_functions(residual)
    assert not functions.compiled
    args = _inputs(layout, np.random.default_rng(1))
    assert np.isfinite(float(functions.cost(*args)))
    assert isinstance(functions.cost, ca.Function)


@needs_compiler
def test_compiling_writes_nothing_to_the_working_directory(monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(compiled, "_CACHE", {})
    assert compiled.sample_functions(_residual()[1]).compiled
    assert list(tmp_path.iterdir()) == []
    folder = compiled._source_folder()
    assert not folder.startswith(str(tmp_path)) and any(name.endswith(".c") for name in os.listdir(folder))


def _mapped_inputs(layout, rng, n):
    xi, _, sigma, references = _inputs(layout, rng)
    data = rng.normal(0, 1, (N_DATA, n))
    data[-6:] = rng.integers(0, 2, (6, n))  # the residual weights: some residuals left out
    return xi, data, sigma, references


@needs_compiler
def test_maps_compiled_whole_give_the_numbers_of_the_virtual_machines_maps(monkeypatch):
    layout, residual = _residual()
    monkeypatch.setattr(compiled, "_CACHE", {})
    functions = compiled.sample_functions(residual)
    n = 37
    machine, whole = compiled.mapped(functions, n), compiled.compiled_maps(functions, n)
    assert set(whole) == set(machine) == set(compiled.SAMPLE_FUNCTIONS)
    rng = np.random.default_rng(5)
    for _ in range(3):
        args = _mapped_inputs(layout, rng, n)
        for name in compiled.SAMPLE_FUNCTIONS:
            a, b = (np.array(maps[name](*args)) for maps in (whole, machine))
            assert a.shape == b.shape, name
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(b).max()), err_msg=name)
    # the cost is summed over the samples, the residuals are one column per sample
    xi, data, sigma, references = _mapped_inputs(layout, rng, n)
    per_sample = sum(float(functions.cost(xi, data[:, k], sigma, references)) for k in range(n))
    assert float(whole["cost"](xi, data, sigma, references)) == pytest.approx(per_sample, rel=1e-12)
    assert np.array(whole["residual"](xi, data, sigma, references)).shape == (N_RESIDUALS, n)


def test_without_a_compiler_there_are_no_compiled_maps(monkeypatch):
    _, residual = _residual()
    monkeypatch.setenv(compiled.COMPILE_ENV, "0")
    monkeypatch.setattr(compiled, "_CACHE", {})
    assert compiled.compiled_maps(compiled.sample_functions(residual), 12) is None


@needs_compiler
def test_maps_that_fail_to_compile_fall_back_with_one_warning(monkeypatch, tmp_path):
    layout, residual = _residual()
    monkeypatch.setattr(compiled, "_CACHE", {})
    monkeypatch.setattr(compiled, "_FAILED", [])
    functions = compiled.sample_functions(residual)
    broken = tmp_path / "cc"
    broken.write_text("#!/bin/sh\nexit 1\n")
    broken.chmod(0o755)
    monkeypatch.setattr(compiled, "_compiler", lambda: None if compiled._FAILED else str(broken))
    with pytest.warns(RuntimeWarning, match="could not compile the identification's maps"):
        assert compiled.compiled_maps(functions, 12) is None
    assert compiled.compiled_maps(functions, 12) is None  # no second attempt, no second warning
