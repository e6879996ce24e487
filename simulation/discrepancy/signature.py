"""A signature for a residual no named effect explains: its leading terms over a generic library, in words.

When no candidate effect closes the gap between model and measurement (an eccentric capstan, or a
distortion no effect models), the workflow still owes the researcher a description of what is
left. :func:`describe_residual` fits each joint's residual by a sparse regression over a generic
library of candidate terms (the idea of PySINDy: a library of candidate functions and a sparse
selection among them) and reports the terms it keeps, strongest first, as sentences such as
"shoulder: periodic in the shoulder motor angle at the capstan, one cycle per revolution, 0.057 deg".

The term library
----------------
Every column is a function of the measured signals (:class:`~simulation.discrepancy.signals.MeasuredSignals`);
each residual joint is fitted on the columns of every joint (the cable coupling carries one
joint's error into another). Terms, in the order of the library (simplest first):

- ``constant``: the residual's mean, an offset. It takes no part in the sparse fit (which works on
  the variance about the mean) and is reported after the other terms, since a drift or any
  term that does not average to zero over the record also moves the mean.
- ``time``: linear in time (a drift over the record).
- ``position``: ``q_k`` and ``d_k**2`` of each joint position (measured joints, SI), ``d_k = q_k - mean(q_k)``.
- ``position product``: ``d_k * d_l`` for each pair of joints. With the two above, every polynomial
  of degree <= 2 in the positions; centring first keeps the quadratic columns apart from the
  linear ones when a joint moves over a small range far from zero.
- ``velocity``, ``sign of velocity``, ``speed``: ``v_k``, ``sign(v_k)`` and ``|v_k|`` of each joint's
  measured velocity (viscous and Coulomb-like friction, direction-dependent play).
- ``torque``: each commanded motor torque (load-dependent stretch), when the data have torques.
- ``payload``: the payload at the tool tip, when it varies over the record.
- ``joint harmonic``: ``sin``/``cos`` of ``h * q_k``, ``h = 1, 2``, for each rotary (rad) joint.
- ``motor harmonic``: ``sin``/``cos`` of ``h * theta_k``, ``h = 1, 2``, where ``theta_k`` is the angle of
  joint ``k``'s capstan shaft (the gearbox output), ``theta_k = drive_k * shaft_ratio_k``. For RAVEN-II
  data ``shaft_ratio = transmission_ratio / gearbox`` (:class:`~simulation.model.constants.RavenConstants`):
  the motor coordinate ``drive`` is the motor angle over the transmission ratio, and the capstan
  turns once per ``gearbox`` motor turns. Generic data (no motors) have no such terms unless a ratio
  is given. The motor rotor itself (before the gearbox) turns ``gearbox`` times faster, far beyond
  what a 30 Hz log resolves, so it has no terms.

A sine and cosine of one angle and harmonic form one term (a sinusoid of any phase), as do ``q_k``
and ``q_k**2`` (a smooth function of one position); every other column is a term of its own.

The fit
-------
Columns are standardized (zero mean, unit standard deviation over the data given) and each
joint's residual is centred and divided by its standard deviation, so a coefficient ``c`` of a
column alone explains about ``c**2`` of the residual's variance. Columns
that vary too little to standardize, or that a record cannot tell apart from simpler columns
before them (less than :attr:`SignatureSettings.min_novelty` of their variance is new), are left
out. The sparse regression is pysindy's sequentially thresholded least squares (``ps.STLSQ``, a
plain sparse regressor on the precomputed library matrix: it needs no time derivatives, so it
serves this static regression as it is), with threshold :attr:`SignatureSettings.threshold` on the
standardized coefficients and a small ridge penalty against the remaining collinearity.

What a term explains
--------------------
The share of a term is the part of the residual's variance it adds to what the stronger terms of
its joint explain: the terms the sparse fit keeps are ordered greedily (each step adds, by least
squares, the term that explains the most of what is left) and each term's share is its increment
of explained variance. Shares are never negative and add up to the fraction of the joint's variance
the fit explains, even when terms are correlated (torque and position often are), where
coefficient-based measures split one effect into large terms of opposite sign. Terms are ranked
by the variance they explain in reporting units (deg**2 for rad joints, mm**2 for m joints, the
weighting of :func:`~simulation.discrepancy.signals.pooled_rmse`), so "strongest" compares joints as
the pooled gap does. Only terms that explain at least :attr:`SignatureSettings.min_share` (default
5 %) of their joint's residual variance become sentences: below that, a term is not a description
of the residual but of its noise (white noise over a record of hundreds of samples puts well under
1 % on any one column). The offset of a joint becomes a sentence, after the terms, when the squared
mean is at least ``min_share`` of the residual's mean square.

Amplitudes, in the residual's SI unit: a sinusoid's amplitude; the half-height of a sign step; the
change over the record of a linear drift; the offset of a constant; for every other term the root
mean square of its contribution about its mean (written "RMS" in the sentence). They are the
sparse fit's, so that a term of the right form has its own size even beside correlated ones,
except where that contribution alone would be larger than the residual it describes (its root
mean square above the residual's standard deviation): correlated columns then share one effect
with large coefficients of opposite sign (over a wrist's range of under a revolution a harmonic
of its angle is nearly a quadratic in it: on the dVRK an 8.5 deg "sinusoid" in a 1.6 deg
residual), and the amplitude is instead that of what the term adds to the stronger terms, the
size of a pure term of its kind whose root mean square is ``sqrt(share) * std(residual)``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from simulation.discrepancy.signals import MeasuredSignals, report_scale

_REPORT_UNIT = {"rad": "deg", "m": "mm"}
_HARMONIC_WORDS = {1: "one cycle per revolution", 2: "two cycles per revolution"}


@dataclass(frozen=True)
class SignatureSettings:
    """Settings of :func:`describe_residual`.

    Attributes
    ----------
    threshold : STLSQ threshold on the standardized coefficients (a column alone explaining about
        ``threshold**2`` of the residual's variance is the weakest the fit keeps).
    alpha : ridge penalty of STLSQ per sample (the residual and the columns have unit variance);
        the kept terms are then refitted without it.
    min_share : the least share of its joint's residual variance a term needs for a sentence.
    min_novelty : the least fraction of a column's variance not explained by the columns before it
        in the library for the column to stay (the record cannot tell the rest apart).
    harmonics : harmonics (cycles per revolution) of the joint and motor angle terms.
    min_samples_per_column : the fit refuses records with fewer samples than this many per column.
    """

    threshold: float = 0.1
    alpha: float = 1e-3
    min_share: float = 0.05
    min_novelty: float = 0.01
    harmonics: tuple[int, ...] = (1, 2)
    min_samples_per_column: int = 4

    def __post_init__(self) -> None:
        for name in ("threshold", "alpha", "min_share", "min_novelty"):
            value = getattr(self, name)
            if not (np.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and non-negative, got {value}")
        if not self.harmonics or any(int(h) != h or h < 1 for h in self.harmonics):
            raise ValueError(f"harmonics must be positive integers, got {self.harmonics}")


@dataclass(frozen=True)
class SignatureTerm:
    """One term of a residual's signature.

    Attributes
    ----------
    name : the term's label in the library, e.g. ``"motor harmonic 1 (shoulder)"``.
    joint : the residual joint the term describes.
    kind : ``"constant"``, ``"time"``, ``"position"``, ``"position product"``, ``"velocity"``,
        ``"sign of velocity"``, ``"speed"``, ``"torque"``, ``"payload"``, ``"joint harmonic"`` or
        ``"motor harmonic"``.
    source : the joint (or joints) whose signal the term is a function of ("" for constant, time, payload).
    amplitude : size in the residual joint's SI unit (see the module notes for what it measures), >= 0.
    direction : +1 or -1, the sign of the term for one-column terms (a drift that grows or falls,
        an offset above or below zero); +1 for sinusoids and grouped terms.
    share : the part of the joint's residual variance the term adds to the stronger terms of its
        joint (greedy increments, see the module notes); for the
        offset (``"constant"``), the squared mean over the mean square.
    unit : the residual joint's SI unit.
    harmonic : cycles per revolution for harmonic terms, else 0.
    """

    name: str
    joint: str
    kind: str
    source: str
    amplitude: float
    direction: int
    share: float
    unit: str
    harmonic: int = 0

    def sentence(self) -> str:
        """The term in words, its amplitude in degrees or millimetres."""
        scale = 180.0 / np.pi if self.unit == "rad" else 1000.0
        size = f"{self.amplitude * scale:.2g} {_REPORT_UNIT.get(self.unit, self.unit)}"
        cycles = _cycles(self.harmonic)
        words = {
            "constant": f"a constant offset, {'+' if self.direction > 0 else '-'}{size}",
            "time": f"{'grows' if self.direction > 0 else 'falls'} linearly with time, {size} over the record",
            "position": f"varies smoothly with the {self.source} position (linear and quadratic), {size} RMS",
            "position product": f"varies with the product of the {self.source} positions, {size} RMS",
            "velocity": f"proportional to the {self.source} velocity, {size} RMS",
            "sign of velocity": f"proportional to the sign of the {self.source} velocity, {size}",
            "speed": f"proportional to the {self.source} speed (|velocity|), {size} RMS",
            "torque": f"proportional to the {self.source} motor torque, {size} RMS",
            "payload": f"proportional to the payload, {size} RMS",
            "joint harmonic": f"periodic in the {self.source} joint angle, {cycles}, {size}",
            "motor harmonic": f"periodic in the {self.source} motor angle at the capstan, {cycles}, {size}",
        }[self.kind]
        return f"{self.joint}: {words} ({100 * self.share:.0f} % of its residual)"


def _cycles(harmonic: int) -> str:
    return _HARMONIC_WORDS.get(harmonic, f"{harmonic} cycles per revolution")


@dataclass(frozen=True)
class Signature:
    """The sparse description of a residual, its terms strongest first.

    Attributes
    ----------
    terms : every term the sparse fit kept, strongest first (ranked by the variance explained
        in degrees and millimetres), including those below ``min_share``, then the offsets
        (``kind == "constant"``, share: squared mean over mean square) of every joint.
    explained : (J,) fraction of each joint's residual variance the sparse fit explains.
    joint_names, units : of the residual's joints.
    min_share : the share a term needs to appear in :meth:`sentences`.
    columns : the library columns the fit used (after the ones a record cannot resolve were left out).
    """

    terms: tuple[SignatureTerm, ...]
    explained: tuple[float, ...]
    joint_names: tuple[str, ...]
    units: tuple[str, ...]
    min_share: float
    columns: tuple[str, ...] = field(default=(), repr=False)

    def leading(self) -> tuple[SignatureTerm, ...]:
        """The terms that explain at least ``min_share`` of their joint's residual, strongest first."""
        return tuple(t for t in self.terms if t.share >= self.min_share)

    def sentences(self) -> list[str]:
        """The leading terms in words, strongest first (empty when nothing meaningful is found)."""
        return [t.sentence() for t in self.leading()]


# ---- the library ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Column:
    values: np.ndarray
    label: str      # column name
    group: str      # term name the column belongs to
    kind: str
    source: str
    harmonic: int = 0


def default_shaft_ratio(signals: MeasuredSignals) -> np.ndarray | None:
    """Capstan shaft radians per unit of ``drive`` for RAVEN-II signals (``transmission_ratio / gearbox``
    of :class:`~simulation.model.constants.RavenConstants` for the signals' arm), None for generic data."""
    if signals.kind != "raven":
        return None
    from simulation.model.constants import RavenConstants

    constants = RavenConstants(arm=signals.arm)
    j = signals.n_joints
    return np.asarray(constants.transmission_ratio[:j] / constants.gearbox[:j], dtype=float)


def term_library(signals: MeasuredSignals, shaft_ratio: np.ndarray | None = None,
                 harmonics=(1, 2)) -> list[_Column]:
    """The generic term library's raw columns for ``signals`` (see the module notes), simplest first."""
    names = signals.joint_names
    q, v = signals.truth, signals.velocity
    d = q - q.mean(axis=0)
    cols: list[_Column] = [_Column(signals.time - signals.time[0], "t", "time", "time", "")]
    for k, name in enumerate(names):
        group = f"position ({name})"
        cols.append(_Column(q[:, k], f"q[{name}]", group, "position", name))
    for k, name in enumerate(names):
        group = f"position ({name})"
        cols.append(_Column(d[:, k] ** 2, f"d[{name}]^2", group, "position", name))
    for k in range(len(names)):
        for m in range(k + 1, len(names)):
            pair = f"{names[k]} and {names[m]}"
            cols.append(_Column(d[:, k] * d[:, m], f"d[{names[k]}]*d[{names[m]}]", f"position product ({pair})",
                                "position product", pair))
    for kind, func, label in (("velocity", lambda x: x, "v"), ("sign of velocity", np.sign, "sign(v)"),
                              ("speed", np.abs, "|v|")):
        for k, name in enumerate(names):
            cols.append(_Column(func(v[:, k]), f"{label}[{name}]", f"{kind} ({name})", kind, name))
    if signals.torque is not None:
        for k, name in enumerate(names):
            cols.append(_Column(signals.torque[:, k], f"tau[{name}]", f"torque ({name})", "torque", name))
    cols.append(_Column(signals.payload_kg.astype(float), "payload", "payload", "payload", ""))
    for h in harmonics:
        for k, name in enumerate(names):
            if signals.units[k] != "rad":
                continue
            group = f"joint harmonic {h} ({name})"
            for func in (np.sin, np.cos):
                cols.append(_Column(func(h * q[:, k]), f"{func.__name__}({h} q[{name}])", group,
                                    "joint harmonic", name, h))
    if shaft_ratio is not None:
        angle = signals.drive * shaft_ratio
        for h in harmonics:
            for k, name in enumerate(names):
                group = f"motor harmonic {h} ({name})"
                for func in (np.sin, np.cos):
                    cols.append(_Column(func(h * angle[:, k]), f"{func.__name__}({h} theta[{name}])", group,
                                        "motor harmonic", name, h))
    return cols


def _standardized(columns: list[_Column], min_novelty: float):
    """Standardize the columns and keep those a record resolves: (matrix, kept columns, their stds)."""
    kept, matrix, stds = [], [], []
    n = columns[0].values.shape[0]
    basis = np.empty((n, 0))  # orthonormal basis of the kept, centred columns
    for col in columns:
        x = col.values
        mean, std = float(np.mean(x)), float(np.std(x))
        scale = max(float(np.max(np.abs(x))), 1e-300)
        if not np.isfinite(std) or std <= 1e-9 * scale:
            continue
        z = (x - mean) / std
        new = z - basis @ (basis.T @ z)
        novelty = float(new @ new) / n
        if novelty < min_novelty:
            continue
        basis = np.column_stack([basis, new / np.sqrt(new @ new)])
        kept.append(col)
        matrix.append(z)
        stds.append(std)
    return np.column_stack(matrix), kept, np.array(stds)


# ---- the fit -------------------------------------------------------------------------------------


def describe_residual(signals: MeasuredSignals, residual, shaft_ratio=None,
                      settings: SignatureSettings = SignatureSettings()) -> Signature:
    """The signature of ``residual`` (measured minus model) over the generic term library.

    Parameters
    ----------
    signals : the measured signals of the samples the residual belongs to (e.g. the workflow's
        held-out part, ``signals.select(mask)``).
    residual : (N, J) measured minus model, SI units (rad, m), rows matching ``signals``.
    shaft_ratio : (J,) capstan shaft radians per unit of ``signals.drive``; by default
        ``transmission_ratio / gearbox`` of :class:`~simulation.model.constants.RavenConstants`
        for RAVEN-II signals and no motor terms for generic signals.
    settings : thresholds of the fit (:class:`SignatureSettings`).

    Returns
    -------
    Signature
        Its terms strongest first; :meth:`Signature.sentences` gives the leading ones in words.
    """
    import pysindy as ps

    residual, matrix, columns, stds = _library_matrix(signals, residual, shaft_ratio, settings)
    n, j = residual.shape
    duration = float(signals.time[-1] - signals.time[0])
    to_report = report_scale(signals.units)

    terms, offsets, explained, variances = [], [], [], []
    for jj in range(j):
        r = residual[:, jj]
        mean, power = float(np.mean(r)), float(np.mean(r * r))
        offsets.append(SignatureTerm(
            name=f"offset ({signals.joint_names[jj]})", joint=signals.joint_names[jj], kind="constant", source="",
            amplitude=abs(mean), direction=1 if mean >= 0 else -1, share=mean * mean / power if power > 0 else 0.0,
            unit=signals.units[jj]))
        variance = float(np.var(r))
        variances.append(variance)
        if variance <= 1e-24 * max(power, 1e-300):
            explained.append(0.0)
            continue
        target = (r - mean) / np.sqrt(variance)
        optimizer = ps.STLSQ(threshold=settings.threshold, alpha=settings.alpha * n, unbias=True)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            optimizer.fit(matrix, target)
        coef = np.asarray(optimizer.coef_, dtype=float).reshape(-1)
        fitted = matrix @ coef
        explained.append(float(max(0.0, 1.0 - np.mean((target - fitted) ** 2))))
        raw = coef * np.sqrt(variance) / stds  # residual units per raw column unit
        groups: dict[str, list[int]] = {}
        for i in np.flatnonzero(coef):
            groups.setdefault(columns[i].group, []).append(int(i))
        shares, directions = _greedy_shares(matrix, target, groups)
        for group, idx in groups.items():
            first = columns[idx[0]]
            amplitude, direction = _amplitude(first.kind, idx, raw, matrix, stds, duration)
            spread = _root_mean_square_per_size(first.kind, stds[idx[0]], duration)
            if amplitude * spread > np.sqrt(variance):
                # larger alone than the whole residual: the size of what it adds instead
                amplitude = float(np.sqrt(shares[group] * variance) / spread)
                direction = directions[group]
            terms.append(SignatureTerm(
                name=group, joint=signals.joint_names[jj], kind=first.kind, source=first.source,
                amplitude=amplitude, direction=direction, share=shares[group],
                unit=signals.units[jj], harmonic=first.harmonic,
            ))
    order = {name: k for k, name in enumerate(signals.joint_names)}
    terms.sort(key=lambda t: -t.share * variances[order[t.joint]] * to_report[order[t.joint]] ** 2)
    offsets.sort(key=lambda t: -(t.amplitude * to_report[order[t.joint]]))
    return Signature(terms=tuple(terms) + tuple(offsets), explained=tuple(explained),
                     joint_names=tuple(signals.joint_names), units=tuple(signals.units),
                     min_share=settings.min_share, columns=tuple(c.label for c in columns))


def _library_matrix(signals: MeasuredSignals, residual, shaft_ratio, settings: SignatureSettings):
    """The checked residual (N, J) and the standardized library matrix, its columns and their stds."""
    residual = np.asarray(residual, dtype=float)
    n, j = len(signals), signals.n_joints
    if residual.ndim != 2 or residual.shape != (n, j):
        raise ValueError(f"residual must have shape {(n, j)} (samples x joints of the signals), got {residual.shape}")
    if not np.all(np.isfinite(residual)):
        bad = int(np.argmax(~np.isfinite(residual).all(axis=1)))
        raise ValueError(f"residual is not finite at sample {bad}")
    if shaft_ratio is None:
        shaft_ratio = default_shaft_ratio(signals)
    else:
        shaft_ratio = np.asarray(shaft_ratio, dtype=float)
        if shaft_ratio.shape != (j,) or not np.all(np.isfinite(shaft_ratio)) or np.any(shaft_ratio <= 0):
            raise ValueError(f"shaft_ratio must be {j} positive finite values, got {shaft_ratio}")
    matrix, columns, stds = _standardized(term_library(signals, shaft_ratio, settings.harmonics),
                                          settings.min_novelty)
    if n < settings.min_samples_per_column * len(columns):
        raise ValueError(f"a signature over {len(columns)} library columns needs at least "
                         f"{settings.min_samples_per_column * len(columns)} samples, got {n}")
    return residual, matrix, columns, stds


def enough_samples(signals: MeasuredSignals, folds: int = 1, shaft_ratio=None,
                   settings: SignatureSettings = SignatureSettings()) -> bool:
    """Whether ``signals`` are long enough for a signature (``folds=1``) or for
    :func:`residual_structure` over ``folds`` blocks: each fit needs ``min_samples_per_column``
    samples per library column."""
    if shaft_ratio is None:
        shaft_ratio = default_shaft_ratio(signals)
    _, columns, _ = _standardized(term_library(signals, shaft_ratio, settings.harmonics), settings.min_novelty)
    fitted = len(signals) * (folds - 1) // folds if folds > 1 else len(signals)
    return fitted >= settings.min_samples_per_column * len(columns)


@dataclass(frozen=True)
class StructureCheck:
    """How much of a residual the generic library predicts on data it was not fitted to.

    Attributes
    ----------
    explained : (J,) fraction of each joint's residual variance about its block means that the
        sparse fit predicts on the block left out, over every block in turn (negative when the
        fit predicts worse than the block means).
    rms_before : (J,) RMS of the residual about its block means (SI: rad or m).
    rms_after : (J,) RMS of what the predictions leave (SI).
    folds : the number of contiguous blocks.
    """

    explained: np.ndarray
    rms_before: np.ndarray
    rms_after: np.ndarray
    folds: int


def residual_structure(signals: MeasuredSignals, residual, folds: int = 8, shaft_ratio=None,
                       settings: SignatureSettings = SignatureSettings()) -> StructureCheck:
    """Cross-validate the signature's sparse fit: is there structure in ``residual`` that repeats?

    The record is cut into ``folds`` contiguous blocks in time; each block's residual is predicted
    by the sparse fit (as in :func:`describe_residual`, the same library and STLSQ settings) to the
    other blocks. The residual is taken about each block's mean, and each prediction about its own
    mean on the block it predicts (every block has its own offset, as the workflow profiles
    constant offsets out of every part), so that a wander between blocks counts as nothing. Noise,
    or a fit that only follows it, predicts nothing on a new block; an effect the model lacks (an
    eccentric capstan, a load dependence) predicts the same way on every block.

    Parameters
    ----------
    signals, residual, shaft_ratio, settings : as for :func:`describe_residual`.
    folds : number of contiguous blocks (at least 2).

    Returns
    -------
    StructureCheck
    """
    import pysindy as ps

    if isinstance(folds, bool) or int(folds) != folds or folds < 2:
        raise ValueError(f"folds must be an integer of at least 2, got {folds!r}")
    residual, matrix, _, _ = _library_matrix(signals, residual, shaft_ratio, settings)
    n, j = residual.shape
    block = np.minimum((np.arange(n) * int(folds)) // n, int(folds) - 1)
    centred = residual.copy()
    for k in range(int(folds)):
        rows = block == k
        centred[rows] -= residual[rows].mean(axis=0)
    predicted = np.zeros_like(residual)
    for k in range(int(folds)):
        test = block == k
        train = ~test
        for jj in range(j):
            y = centred[train, jj]
            std = float(np.std(y))
            if std <= 0.0:
                continue
            optimizer = ps.STLSQ(threshold=settings.threshold, alpha=settings.alpha * int(train.sum()), unbias=True)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                optimizer.fit(matrix[train], y / std)
            guess = matrix[test] @ np.asarray(optimizer.coef_, dtype=float).reshape(-1) * std
            predicted[test, jj] = guess - guess.mean()
    before = np.sqrt(np.mean(centred ** 2, axis=0))
    after = np.sqrt(np.mean((centred - predicted) ** 2, axis=0))
    with np.errstate(divide="ignore", invalid="ignore"):
        explained = np.where(before > 0, 1.0 - (after / np.where(before > 0, before, 1.0)) ** 2, 0.0)
    return StructureCheck(explained=explained, rms_before=before, rms_after=after, folds=int(folds))


def _greedy_shares(matrix: np.ndarray, target: np.ndarray,
                   groups: dict[str, list[int]]) -> tuple[dict[str, float], dict[str, int]]:
    """Each group's increment of explained variance when groups enter by greedy forward selection,
    and the direction of the increment: the sign of a one-column group's column without the part
    the groups before it explain, against the target; +1 for groups of several columns."""
    total = float(target @ target)

    def explained(idx: list[int]) -> float:
        if not idx:
            return 0.0
        x = matrix[:, idx]
        coef = np.linalg.lstsq(x, target, rcond=None)[0]
        left = target - x @ coef
        return 1.0 - float(left @ left) / total

    shares, directions, chosen, level = {}, {}, [], 0.0
    remaining = dict(groups)
    while remaining:
        trial = {g: explained(chosen + idx) for g, idx in remaining.items()}
        best = max(trial, key=trial.get)
        shares[best] = max(0.0, trial[best] - level)
        directions[best] = 1
        if len(remaining[best]) == 1:
            column = matrix[:, remaining[best][0]]
            if chosen:
                before = matrix[:, chosen]
                column = column - before @ np.linalg.lstsq(before, column, rcond=None)[0]
            directions[best] = 1 if float(column @ target) >= 0 else -1
        level = max(level, trial[best])
        chosen += remaining.pop(best)
    return shares, directions


def _root_mean_square_per_size(kind: str, column_std: float, duration: float) -> float:
    """The root mean square of a pure term of ``kind`` per unit of its amplitude (module notes):
    1/sqrt 2 for a sinusoid, the sign's (or time's) standard deviation per unit of step height (or
    of change over the ``duration``), 1 for the terms sized by their root mean square."""
    if kind in ("joint harmonic", "motor harmonic"):
        return float(np.sqrt(0.5))
    if kind == "time":
        return float(column_std / duration) if duration > 0 else 1.0
    if kind == "sign of velocity":
        return float(column_std)
    return 1.0


def _amplitude(kind, idx, raw, matrix, stds, duration) -> tuple[float, int]:
    """A term's amplitude (residual SI units, >= 0) and direction (see :class:`SignatureTerm`)."""
    if kind in ("joint harmonic", "motor harmonic"):
        return float(np.hypot.reduce(raw[idx]) if len(idx) > 1 else abs(raw[idx[0]])), 1
    if len(idx) == 1:
        c = float(raw[idx[0]])
        direction = 1 if c >= 0 else -1
        if kind == "time":
            return abs(c) * duration, direction
        if kind == "sign of velocity":
            return abs(c), direction
        return abs(c) * float(stds[idx[0]]), direction
    contribution = matrix[:, idx] @ (raw[idx] * stds[idx])
    return float(np.std(contribution)), 1
