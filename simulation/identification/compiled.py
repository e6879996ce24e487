"""The per-sample functions of an identification, compiled to machine code when a C compiler is present.

IPOPT evaluates the cost, its gradient and the Gauss-Newton Hessian over every sample at each
iteration; in casadi's virtual machine these evaluations are most of an identification's time.
Compiled with the system C compiler (casadi's ``shell`` JIT, ``cc -O1``) they run about four times
faster and give the same numbers. A compilation takes under a second and is kept for the life of
the process, keyed by the residual function itself, so the repeated identifications of one
structure (the UKF's tuning, the discrepancy workflow's re-identifications) compile once.

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
from dataclasses import dataclass

import casadi as ca

COMPILE_ENV = "RAVEN_CALIBRATION_COMPILE"
"""Set to ``0`` to evaluate the identification's functions in casadi's virtual machine."""
_COMPILER_FLAGS = ["-O1"]


@dataclass(frozen=True)
class SampleFunctions:
    """Functions of the residual's inputs (unknowns, one sample's data, ...): the sample's half
    squared residual norm, its residuals, their Jacobian with respect to the unknowns, and ``J^T J``."""

    cost: ca.Function
    residual: ca.Function
    jacobian: ca.Function
    gauss_newton: ca.Function
    compiled: bool


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
    destroyed, which a cached function never is before the interpreter ends)."""
    folder = tempfile.mkdtemp(prefix="raven_identification_")
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    return folder


def _build(residual: ca.Function, compiler: str | None) -> SampleFunctions:
    options = {} if compiler is None else {
        "jit": True, "compiler": "shell", "jit_name": "sample", "jit_cleanup": False,
        "jit_options": {"compiler": compiler, "flags": _COMPILER_FLAGS, "directory": _source_folder() + os.sep,
                        "cleanup": False}}
    inputs = [ca.SX.sym(residual.name_in(i), residual.size1_in(i)) for i in range(residual.n_in())]
    r = residual(*inputs)
    jac = ca.jacobian(r, inputs[0])
    return SampleFunctions(
        cost=ca.Function("sample_cost", inputs, [0.5 * ca.sumsqr(r)], options),
        residual=ca.Function("sample_residual", inputs, [r], options),
        jacobian=ca.Function("sample_jacobian", inputs, [jac], options),
        gauss_newton=ca.Function("sample_gauss_newton", inputs, [jac.T @ jac], options),
        compiled=compiler is not None,
    )


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
