"""Export of fitted calibrators as dependency-free C for a real-time controller.

RAVEN-II's controller is C++ running at 1 kHz. `export_c` writes a fitted fixed-offset, linear,
polynomial or network calibrator as one self-contained C file and its header, declaring

    void name(const double *x, double *y);

which reads the n_features inputs of one sample (in the units the calibrator was fitted on,
columns in the order of `fit`) and writes its n_targets corrected joint positions, the same as
``calibrator.predict(x[None, :])[0]``. The weights are the ones of the numpy real-time predictor
(`to_realtime`, standardization and the raw-position skip folded in), printed in full precision
as ``static const double`` arrays. The code needs only ``<math.h>`` (``fabs``, ``copysign``;
its ``tanh`` is its own, accurate to 1e-15 and vectorizable), has no state
and no allocation (a network keeps its layers on the stack, 8 bytes per unit), so one function
may be called from several threads; ``x`` and ``y`` may even overlap. It compiles with
``cc -O2 -shared -fPIC name.c your_code.c -lm``; a C++ controller includes the header as is
(it declares the function ``extern "C"``).
"""

from __future__ import annotations

import keyword
import re
from pathlib import Path

import numpy as np
from sklearn.utils.validation import check_is_fitted

_C_KEYWORDS = frozenset((
    "auto break case char const continue default do double else enum extern float for goto if "
    "inline int long register restrict return short signed sizeof static struct switch typedef "
    "union unsigned void volatile while _Bool _Complex _Imaginary bool true false class "
    "namespace new delete template this operator private public protected virtual friend "
    "tanh exp main").split())
_NUMBERS_PER_LINE = 4


def export_c(calibrator, directory, name: str = "calibrator") -> tuple[Path, Path]:
    """Write a fitted calibrator as ``directory/name.c`` and ``directory/name.h``.

    Parameters
    ----------
    calibrator : fitted FixedOffsetCalibrator, LinearCalibrator, PolynomialCalibrator or
        DNNCalibrator (with or without ``raw_columns``).
    directory : str or Path
        Folder of the two files (created if missing); existing files of that name are replaced.
    name : str, default="calibrator"
        Name of the C function and of the files: a C identifier.

    Returns
    -------
    (c_path, h_path) : tuple of Path

    Raises
    ------
    TypeError
        The calibrator is of a class that cannot be exported (window, kernel and forest
        calibrators keep state or support points that this export does not cover).
    sklearn.exceptions.NotFittedError
        The calibrator is not fitted.
    ValueError
        `name` is not a usable C identifier, or the fitted weights are not finite.
    """
    from estimators.dnn import DNNCalibrator
    from estimators.fixed_offset import FixedOffsetCalibrator
    from estimators.linear import LinearCalibrator
    from estimators.polynomial import PolynomialCalibrator

    supported = (FixedOffsetCalibrator, LinearCalibrator, PolynomialCalibrator, DNNCalibrator)
    if type(calibrator) not in supported:
        raise TypeError(
            f"export_c supports {', '.join(c.__name__ for c in supported)}; got "
            f"{type(calibrator).__name__}.")
    if (not isinstance(name, str) or not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", name)
            or name in _C_KEYWORDS or keyword.iskeyword(name) or name.startswith("__")):
        raise ValueError(f"name must be a C identifier that is not a keyword; got {name!r}.")
    check_is_fitted(calibrator)
    predictor = calibrator.to_realtime()
    n_features, n_targets = int(calibrator.n_features_in_), int(calibrator.n_outputs_)
    if isinstance(calibrator, DNNCalibrator):
        arrays, body = _network(name, predictor, n_features, n_targets)
    elif isinstance(calibrator, PolynomialCalibrator):
        arrays, body = _polynomial(name, predictor, n_features, n_targets)
    else:
        arrays, body = _affine(name, predictor.weight, predictor.bias, n_features, n_targets)
    description = _description(calibrator, n_features, n_targets)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    c_path, h_path = directory / f"{name}.c", directory / f"{name}.h"
    h_path.write_text(_header(name, description, n_features, n_targets))
    c_path.write_text(
        f"{description}\n#include <math.h>\n\n#include \"{name}.h\"\n\n"
        + "".join(arrays)
        + f"\nvoid {name}(const double *x, double *y)\n{{\n{body}}}\n")
    return c_path, h_path


def _header(name, description, n_features, n_targets):
    guard = f"{name.upper()}_H"
    return (f"{description}\n#ifndef {guard}\n#define {guard}\n\n"
            f"#define {name.upper()}_N_FEATURES {n_features}\n"
            f"#define {name.upper()}_N_TARGETS {n_targets}\n\n"
            "#ifdef __cplusplus\nextern \"C\" {\n#endif\n\n"
            f"/* y[0..{n_targets - 1}] = corrected joint positions for the inputs "
            f"x[0..{n_features - 1}] of one sample. */\n"
            f"void {name}(const double *x, double *y);\n\n"
            "#ifdef __cplusplus\n}\n#endif\n\n"
            f"#endif /* {guard} */\n")


def _description(calibrator, n_features, n_targets) -> str:
    lines = [f"Generated by raven-calibration from a fitted {type(calibrator).__name__}: "
             f"{n_features} inputs -> {n_targets} outputs."]
    names = getattr(calibrator, "feature_names_in_", None)
    if names is not None:
        lines.append("Inputs, in order: " + ", ".join(str(n) for n in names) + ".")
    if calibrator.raw_columns_ is not None:
        lines.append("Output j is input raw_columns[j] plus its learned correction; raw_columns "
                     f"= {[int(c) for c in calibrator.raw_columns_]}.")
    text = "\n".join(" * " + line.replace("*/", "* /") for line in lines)
    return f"/*\n{text}\n */\n"


def _array(name, values, ctype="double") -> str:
    values = np.asarray(values).reshape(-1)
    if ctype == "double":
        if not np.all(np.isfinite(values)):
            raise ValueError(f"cannot export: the fitted weights {name} are not all finite.")
        items = [format(float(v), ".17g") for v in values]
    else:
        items = [str(int(v)) for v in values]
    rows = [", ".join(items[i:i + _NUMBERS_PER_LINE])
            for i in range(0, len(items), _NUMBERS_PER_LINE)]
    return (f"static const {ctype} {name}[{len(items)}] = {{\n    "
            + ",\n    ".join(rows) + "\n};\n")


def _affine_layer(source, weight, bias, target, n_in, n_out, indent="    ") -> str:
    """C statements ``target = bias + source @ weight`` (weight row-major (n_in, n_out)).

    The loop over inputs is outermost, _BLOCK inputs at a time, so the inner loop is an
    independent multiply-add per output over contiguous weight rows, which compilers vectorize
    without reordering any sum (no -ffast-math needed), loading and storing the outputs once
    per block of inputs.
    """
    text = f"{indent}for (j = 0; j < {n_out}; ++j) {target}[j] = {bias}[j];\n"
    i = 0
    for block in _BLOCKS:
        while n_in - i >= block:
            scalars = ", ".join(f"s{k} = {source}[{i + k}]" for k in range(block))
            terms = " + ".join(f"s{k} * {weight}[{(i + k) * n_out} + j]" for k in range(block))
            text += (f"{indent}{{\n{indent}    const double {scalars};\n"
                     f"{indent}    for (j = 0; j < {n_out}; ++j)\n"
                     f"{indent}        {target}[j] = {target}[j] + {terms};\n{indent}}}\n")
            i += block
    return text


_BLOCKS = (8, 4, 2, 1)


# tanh without libm, so that the loop over a layer's units vectorizes at -O2 already (glibc's
# tanh is a scalar call unless -ffast-math): for a = min(|z|, 20) (tanh(20) rounds to 1),
# expm1(-2a) is its Taylor series at u = -2a / 128 (|u| <= 0.3125, truncation < 1e-16) doubled
# seven times with expm1(2u) = expm1(u) * (expm1(u) + 2), and tanh(a) = -m / (2 + m). Relative
# error below 1e-15 over the whole line; NaN stays NaN. The clamp is a loop of its own: a select
# inside the arithmetic loop would keep compilers from vectorizing it.
_TANH_COEFFICIENTS = ["1.0 / 479001600.0", "1.0 / 39916800.0", "1.0 / 3628800.0",
                      "1.0 / 362880.0", "1.0 / 40320.0", "1.0 / 5040.0", "1.0 / 720.0",
                      "1.0 / 120.0", "1.0 / 24.0", "1.0 / 6.0", "0.5"]


def _tanh_layer(values, scratch, n) -> str:
    horner = "".join(f"        m = m * u + {c};\n" for c in _TANH_COEFFICIENTS[1:])
    return (f"    for (j = 0; j < {n}; ++j) {scratch}[j] = fabs({values}[j]) > 20.0 ? 20.0 : "
            f"fabs({values}[j]);\n"
            f"    for (j = 0; j < {n}; ++j) {{\n"
            f"        const double u = {scratch}[j] * (-2.0 / 128.0);\n"
            f"        double m = {_TANH_COEFFICIENTS[0]};\n"
            + horner
            + "        m = (m * u + 1.0) * u;\n"
            + "        m = m * (m + 2.0);\n" * 7
            + f"        {values}[j] = copysign(m / (-2.0 - m), {values}[j]);\n"
            "    }\n")


def _copy_out(n_targets, raw_index) -> str:
    text = ""
    if raw_index is not None:
        text += "".join(f"    out[{j}] += x[{int(c)}];\n" for j, c in enumerate(raw_index))
    return text + f"    for (j = 0; j < {n_targets}; ++j) y[j] = out[j];\n"


def _affine(name, weight, bias, n_features, n_targets):
    arrays = [_array(f"{name}_weight", weight), _array(f"{name}_bias", bias)]
    body = (f"    double out[{n_targets}];\n    int j;\n"
            + _affine_layer("x", f"{name}_weight", f"{name}_bias", "out", n_features, n_targets)
            + _copy_out(n_targets, None))
    return arrays, body


def _network(name, predictor, n_features, n_targets):
    weights, biases = predictor.layers
    arrays, declarations, statements = [], [], []
    source, n_in = "x", n_features
    for index, (weight, bias) in enumerate(zip(weights, biases)):
        arrays += [_array(f"{name}_w{index}", weight), _array(f"{name}_b{index}", bias)]
        is_output = index == len(weights) - 1
        n_out = weight.shape[1]
        target = "out" if is_output else f"h{index}"
        declarations.append(f"    double {target}[{n_out}];\n")
        statements.append(_affine_layer(source, f"{name}_w{index}", f"{name}_b{index}", target,
                                        n_in, n_out))
        if not is_output and predictor.activation == "tanh":
            declarations.append(f"    double a{index}[{n_out}];\n")
            statements.append(_tanh_layer(target, f"a{index}", n_out))
        elif not is_output:
            statements.append(f"    for (j = 0; j < {n_out}; ++j) {target}[j] = {target}[j] < 0.0"
                              f" ? 0.0 : {target}[j];\n")  # NaN stays NaN
        source, n_in = target, n_out
    body = ("".join(declarations) + "    int j;\n" + "".join(statements)
            + _copy_out(n_targets, predictor.raw_index))
    return arrays, body


def _polynomial(name, predictor, n_features, n_targets):
    weight, bias = predictor.weight, predictor.bias
    n_terms = weight.shape[0]
    arrays = [_array(f"{name}_weight", weight), _array(f"{name}_bias", bias)]
    statements = [f"    for (i = 0; i < {n_features}; ++i) m[i] = x[i];\n"]
    for degree, (parent, factor, start, stop) in enumerate(predictor.levels, start=2):
        arrays += [_array(f"{name}_parent{degree}", parent, "int"),
                   _array(f"{name}_factor{degree}", factor, "int")]
        statements.append(
            f"    for (i = 0; i < {stop - start}; ++i)\n"
            f"        m[{start} + i] = m[{name}_parent{degree}[i]]"
            f" * x[{name}_factor{degree}[i]];\n")
    body = (f"    double m[{n_terms}];\n    double out[{n_targets}];\n    int i, j;\n"
            + "".join(statements)
            + _affine_layer("m", f"{name}_weight", f"{name}_bias", "out", n_terms, n_targets)
            + _copy_out(n_targets, None))
    return arrays, body
