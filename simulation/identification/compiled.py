"""The per-sample functions of an identification, compiled to machine code when a C compiler is present.

IPOPT evaluates the cost, its gradient and the Gauss-Newton Hessian over every sample at each
iteration; in casadi's virtual machine these evaluations are most of an identification's time.
Compiled with the system C compiler (casadi's ``shell`` JIT, ``cc -O1``) they run about four times
faster and give the same numbers. A compilation takes under a second and is kept for the life of
the process, keyed by the residual function itself, so the repeated identifications of one
structure (the UKF's tuning, the discrepancy workflow's re-identifications) compile once.

The same functions mapped over a record's samples run in casadi's virtual machine, which calls the
compiled per-sample code once per sample. A structure fitted to one record again and again (the
discrepancy workflow's re-identifications, two dozen per analysis) has its maps compiled too
(:func:`compiled_maps`): the loop over the samples then runs in machine code as well, and an
identification of a two-minute record takes about a third less time, to the same numbers. A map is
compiled for one record length (about a second for the four), so the identification asks for it
only once a structure and a length recur (``simulation.identification.fit``).

Without a C compiler, or with the environment variable ``RAVEN_CALIBRATION_COMPILE=0``, the same
functions run in the virtual machine.
"""

from __future__ import annotations

import atexit
import functools
import hashlib
import os
import shutil
import tempfile
import warnings
from dataclasses import dataclass, field

import casadi as ca

COMPILE_ENV = "RAVEN_CALIBRATION_COMPILE"
"""Set to ``0`` to evaluate the identification's functions in casadi's virtual machine."""
_COMPILER_FLAGS = ["-O1"]


SAMPLE_FUNCTIONS = ("cost", "residual", "jacobian", "gauss_newton")
MAP_SHARED_INPUTS = [0, 2, 3]
"""Inputs of a per-sample function that every sample shares in its map: the unknowns, the channel
scales and the references (the data matrix has one column per sample)."""
MAP_REDUCED = {"cost": [0], "gauss_newton": [0], "residual": [], "jacobian": []}
"""Outputs summed over the samples by each map (the others are one column per sample)."""


@dataclass(frozen=True)
class SampleFunctions:
    """Functions of the residual's inputs (unknowns, one sample's data, ...): the sample's half
    squared residual norm, its residuals, their Jacobian with respect to the unknowns, and ``J^T J``;
    ``plain`` holds the same four in the virtual machine (what :func:`compiled_maps` compiles)."""

    cost: ca.Function
    residual: ca.Function
    jacobian: ca.Function
    gauss_newton: ca.Function
    compiled: bool
    plain: dict = field(default_factory=dict, repr=False, compare=False)


_CACHE: dict[str, SampleFunctions] = {}
_FAILED: list[str] = []


def _compiler() -> str | None:
    if os.environ.get(COMPILE_ENV, "1").strip() in ("0", "false", "no"):
        return None
    if _FAILED:
        return None
    return shutil.which("cc") or shutil.which("gcc")


@functools.cache
def _source_folder() -> str:
    """A folder of this process for the generated C sources and libraries, removed at exit (casadi
    writes them to the working directory otherwise, and removes them only when a function is
    destroyed, which a cached function never is before the interpreter ends). Releases before
    casadi 3.8 leave a copy of each source in the working directory all the same, hence the
    project's requirement of 3.8."""
    folder = tempfile.mkdtemp(prefix="raven_identification_")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def _jit_options(compiler: str, name: str) -> dict:
    return {"jit": True, "compiler": "shell", "jit_name": name, "jit_cleanup": False,
            "jit_options": {"compiler": compiler, "flags": _COMPILER_FLAGS, "directory": _source_folder() + os.sep,
                            "cleanup": False}}


def _build(residual: ca.Function, compiler: str | None) -> SampleFunctions:
    options = {} if compiler is None else _jit_options(compiler, "sample")
    inputs = [ca.SX.sym(residual.name_in(i), residual.size1_in(i)) for i in range(residual.n_in())]
    r = residual(*inputs)
    jac = ca.jacobian(r, inputs[0])
    outputs = {"cost": 0.5 * ca.sumsqr(r), "residual": r, "jacobian": jac, "gauss_newton": jac.T @ jac}
    plain = {name: ca.Function(f"sample_{name}", inputs, [outputs[name]]) for name in SAMPLE_FUNCTIONS}
    built = plain if compiler is None else {name: ca.Function(f"sample_{name}", inputs, [outputs[name]], options)
                                            for name in SAMPLE_FUNCTIONS}
    return SampleFunctions(**built, compiled=compiler is not None, plain=plain)


def sample_functions(residual: ca.Function) -> SampleFunctions:
    """The per-sample functions of ``residual`` (a casadi function whose inputs are columns, the
    unknowns first), compiled when possible, from the process's cache when the same residual
    function was seen before."""
    key = hashlib.sha256(residual.serialize().encode()).hexdigest()
    compiler = _compiler()
    cached = _CACHE.get(key)
    if cached is not None and (cached.compiled or compiler is None):
        return cached
    try:
        functions = _build(residual, compiler)
    except RuntimeError as error:
        if compiler is None:
            raise
        _FAILED.append(str(error))
        warnings.warn(f"the C compiler {compiler!r} could not compile the identification's functions; they run in "
                      f"casadi's virtual machine instead (about 4x slower): {str(error).splitlines()[0]}",
                      RuntimeWarning, stacklevel=3)
        functions = _build(residual, None)
    _CACHE[key] = functions
    return functions


def mapped(functions: SampleFunctions, n: int) -> dict[str, ca.Function]:
    """The per-sample functions mapped over ``n`` samples, run by the virtual machine (which calls
    the compiled per-sample code where there is some), by name."""
    return {name: getattr(functions, name).map(f"{name}_map", "serial", n, MAP_SHARED_INPUTS, MAP_REDUCED[name])
            for name in SAMPLE_FUNCTIONS}


def compiled_maps(functions: SampleFunctions, n: int) -> dict[str, ca.Function] | None:
    """The per-sample functions mapped over ``n`` samples and compiled whole, loop included, by name;
    None without a compiler or when compiling fails (with one warning, as for the per-sample functions).

    Each map sums or stacks the samples in the order the virtual machine's map does, so both give
    the same numbers; derivatives that casadi takes of them (IPOPT's gradient) are compiled too.
    """
    compiler = _compiler()
    if compiler is None or not functions.compiled:
        return None
    maps = {}
    try:
        for name, plain_map in mapped(SampleFunctions(**functions.plain, compiled=False), n).items():
            inputs = [ca.MX.sym(plain_map.name_in(i), plain_map.sparsity_in(i)) for i in range(plain_map.n_in())]
            maps[name] = ca.Function(f"{name}_map", inputs, plain_map.call(inputs), _jit_options(compiler, f"{name}_map"))
    except RuntimeError as error:
        _FAILED.append(str(error))
        warnings.warn(f"the C compiler {compiler!r} could not compile the identification's maps over the samples; "
                      f"they run in casadi's virtual machine instead: {str(error).splitlines()[0]}",
                      RuntimeWarning, stacklevel=3)
        return None
    return maps
