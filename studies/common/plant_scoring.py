"""Scoring a RAVEN-II analysis with the plant replay: the links' swing on their cables followed.

The workflow fits and chooses with the quasi-static replay (:meth:`RavenModel.replay`), which
balances each cable's tension against the links' loads sample by sample and keeps no state of the
links' vibration on their cables. On a record with nothing hidden that replay leaves a held-out
residual about 1.7 times the encoders' own error (0.0034 against 0.0020, pooled deg and mm, seeds
30-34, twenty minutes), and that floor caps the share of a small effect's gap any model replayed
this way can show closed (backlash at its default size: 38 % to 58 %). The simulator's own plant
driven by the logged motor coordinates (:func:`simulation.engine.plant_replay.replay_links`)
leaves 0.0023 with the identified starting model (``python studies/discrepancy_floor.py
--dynamic``), and 0.0019 to 0.0020 once its Coulomb forces are refitted as :func:`score_with_plant`
refits them (:func:`plant_floor_gap`, seeds 20-29 and 32-44): the encoders' own error.

:func:`score_with_plant` is the blind analysis's last step: the starting model and the final one,
both as the workflow left them, are each replayed with the plant after their Coulomb forces are
refitted to the plant on the fit part (:func:`with_plant_friction`: open loop, a link sticks
wherever its dry friction holds it, so a force a few per cent off, which the quasi-static replay
hardly shows, costs the plant much), and scored on the held-out part. Nothing of it depends on
what generated the record: it applies when the record and the final model are ones the plant can
replay (:func:`plant_score_reason`), and then the report's gaps and shrink are the plant's, the
quasi-static ones kept beside them.

The quasi-static replay, where a hysteresis is fitted, has no lag of the hysteresis behind the
stretch; the plant does. The score fits that lag to the plant on the fit part, together with the
Coulomb forces (:func:`with_plant_friction_and_lag`, from a round 0.1 s), and so do the oracle's
score and :func:`refit_with_plant`. With ``fit_lag=False`` (``--fixed-plant-lag``) it takes the
candidate's constant instead (``candidates.HYSTERESIS_RESPONSE_TIME``, a round 0.1 s; until
2026-12-06 it was 0.05 s, the simulator's default, and every plant-scored hysteresis figure
measured before the lag was fitted by default was scored with that).

This module sits in the studies layer because it joins the discrepancy package, which imports
nothing of the simulator's engine, to the engine's plant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.engine.plant_replay import FOLLOWED_EFFECTS, replay_links
from simulation.discrepancy.signals import RAVEN_UNITS, report_scale
from studies.common.discrepancy_runs import LIBRARY, PER_HOMING_EFFECTS, raven_library

PLANT_SCORED_EFFECTS = tuple(name for name in LIBRARY if name in FOLLOWED_EFFECTS or name in PER_HOMING_EFFECTS)
"""Candidates of the library a model may name and still be scored with the plant replay: those
whose every change is to what the plant integrates (backlash, hysteresis, drift, the transmission
error, capstan friction) or to the registration of the motor coordinates that drive it (the
per-homing offsets, which :func:`plant_joints` enters on the motor side). The others act on the
motors, whose positions the plant takes as logged (motor friction, the controller's gravity model),
or on the links' load through the identification (an undeclared payload): the quasi-static replay
scores a model that names one of them."""

PLANT_FRICTION_EVALUATIONS = 200
"""Plant replays of the fit part allowed for each model's Coulomb-force refit (Powell's method over
one factor per joint; on twenty-minute records the refits took 116 to 142 replays for the two
models together, ``python studies/discrepancy_floor.py --effects backlash --rescore``)."""

FRICTION_FACTOR_RANGE = (0.0, 3.0)
"""Range of each joint's factor on the Coulomb force the identification gave (the refit's bounds)."""

HYSTERESIS_LAG_RANGE = (0.0, 0.5)
"""Range (s) of the lag of a fitted hysteresis behind the cable's stretch that a lag-fitting plant
score searches (:func:`with_plant_friction_and_lag`): from none to half a second, the range of the
shape study's ``--response-time``. The lag is something only the plant replay sees (the quasi-static
replay, where the candidate is fitted, has none)."""

HYSTERESIS_LAG_START = 0.1
"""Where the lag's search starts (s), and the lag under which its weights are taken
(:func:`plant_fit`): a round tenth of a second, the value of the candidate's constant
(``candidates.HYSTERESIS_RESPONSE_TIME``) and not the simulator's default of 0.05 s. The search's
first pass runs along the lag over all of :data:`HYSTERESIS_LAG_RANGE`."""

def lag_fit_evaluations(friction_evaluations: int) -> int:
    """Plant replays allowed for a model's lag and Coulomb forces fitted together
    (:func:`with_plant_friction_and_lag`): the friction refit's ``friction_evaluations`` and half as
    many again for the fourth coordinate."""
    return friction_evaluations + friction_evaluations // 2

PLANT_REFIT_EFFECTS = {
    "backlash": lambda e: {"half_width": e.half_width},
    "hysteresis": lambda e: {"stiffness": e.stiffness, "width": 1.0 / e.beta, "shape": e.gamma / e.beta},
    "drift": lambda e: {"creep_rate": e.creep_rate, "stiffness_loss": e.stiffness_loss},
}
"""Named effects :func:`refit_with_plant` refits with the plant replay, each with how its
candidate's values (the library's parameter blocks) are read back from a fitted model's effect:
those the plant integrates whose quasi-static fit leaves their plant-scored shrink short of the
floor's bound (hysteresis by 5 to 9 points, drift by 2 to 6, seeds 30-34, twenty minutes). The
transmission error and capstan friction close their bound as fitted; a per-homing offset is a
registration, which the plant takes as given."""

PLANT_REFIT_EVALUATIONS = 600
"""Plant replays of the fit part allowed for :func:`refit_with_plant` (on twenty-minute records a
replay of the fit part takes about a second; the refits of hysteresis and drift on seeds 30-33 used
the whole budget)."""


def plant_joints(model, signals, robot) -> np.ndarray:
    """(N, 3) joints (SI) of the plant replay of ``model`` (a
    :class:`~simulation.discrepancy.replay.RavenModel`) along RAVEN-II ``signals``: the links of
    its parameters, started at rest from the measured joints at the first sample and each
    re-homing, under the declared payload plus the model's undeclared one. The model's registration
    offsets (and per-homing offsets) enter on the motor side (``registration`` of
    :func:`~simulation.engine.plant_replay.replay_links`), where RAVEN-II registers: its joints are
    those :meth:`RavenModel.replay` predicts, with the links' gravity taken where they are."""
    payload = np.asarray(signals.payload_kg, dtype=float)
    if np.ptp(payload) > 0:
        raise ValueError("the plant replay builds the links' gravity for one payload; this record's declared payload "
                         f"changes from {payload.min():g} kg to {payload.max():g} kg")
    offsets = np.tile(np.asarray(model.offsets, dtype=float), (len(signals), 1))
    for count, extra in (model.homing_offsets or {}).items():
        offsets[signals.homing == count] += extra
    return replay_links(model.params, robot, signals.time, signals.drive, signals.truth, signals.restarts,
                        float(payload[0]) + float(model.payload_kg), registration=offsets)


def plant_held_out_gap(model, signals, split, robot) -> np.ndarray:
    """Held-out residual RMS per joint (SI) of :func:`plant_joints`, its constant offsets fitted on
    the fit part as the workflow fits them."""
    residual = signals.truth - plant_joints(model, signals, robot)
    held_out = residual[split.held_out] - residual[split.fit].mean(axis=0)
    return np.sqrt(np.mean(np.square(held_out), axis=0))


def plant_fit(model, build, start, bounds, signals, split, robot, max_evaluations: int) -> tuple[np.ndarray, int]:
    """Powell's method on ``build(x)`` (a model of the vector ``x``, from ``start`` within ``bounds``),
    at most ``max_evaluations`` plant replays of the fit part, minimising its joint residual, each
    joint over its spread under ``model`` (the weights: the model the search starts from, so that
    no joint's larger residual drowns the others), the constant offsets profiled out. Returns the
    best ``x`` and the replays it took."""
    from scipy.optimize import minimize

    head = signals.head(int(np.flatnonzero(split.fit)[-1]) + 1)
    fit = split.fit[:len(head)]

    def fit_residual(m):
        r = (head.truth - plant_joints(m, head, robot))[fit]
        return r - r.mean(axis=0)

    spread = np.maximum(np.std(fit_residual(model), axis=0), 1e-12)
    replays = 0

    def objective(x):
        nonlocal replays
        replays += 1
        return float(np.sum(np.square(fit_residual(build(np.asarray(x, dtype=float))) / spread)))

    solution = minimize(objective, start, method="Powell", bounds=bounds,
                        options={"maxfev": int(max_evaluations), "xtol": 1e-3, "ftol": 1e-7})
    return np.asarray(solution.x, dtype=float), replays


def with_plant_friction(model, signals, split, robot, max_evaluations: int = PLANT_FRICTION_EVALUATIONS):
    """``model`` with its positioning joints' Coulomb forces refitted with the plant replay on the
    fit part (:func:`plant_fit` over one factor per joint in :data:`FRICTION_FACTOR_RANGE`, from 1).
    Returns the model, the factors and the replays it took."""
    friction = model.params.effect("coulomb_friction")
    forces = np.asarray(friction.force, dtype=float)

    def build(x):
        return model.with_effect(friction.replace(force=np.r_[x * forces[:3], forces[3:]]))

    x, replays = plant_fit(model, build, np.ones(3), [FRICTION_FACTOR_RANGE] * 3, signals, split, robot,
                           max_evaluations)
    return build(x), x, replays


def with_plant_friction_and_lag(model, signals, split, robot,
                                max_evaluations: int = lag_fit_evaluations(PLANT_FRICTION_EVALUATIONS)):
    """``model`` (one with a hysteresis) with the lag of its hysteresis behind the stretch (one
    value, s, for the three joints) and its positioning joints' Coulomb forces fitted together with
    the plant replay on the fit part (:func:`plant_fit`: the lag from
    :data:`HYSTERESIS_LAG_START` within :data:`HYSTERESIS_LAG_RANGE`, one factor per joint from 1
    in :data:`FRICTION_FACTOR_RANGE`; each joint weighed by its spread under the model with the
    starting lag, so that nothing of the search depends on the candidate's constant). Returns the
    model, the factors, the lag (s) and the replays it took."""
    if not model.params.is_enabled("hysteresis"):
        raise ValueError("the model has no hysteresis whose lag could be fitted")
    friction = model.params.effect("coulomb_friction")
    forces = np.asarray(friction.force, dtype=float)
    unit = HYSTERESIS_LAG_START

    def build(x):
        lagged = with_lag(model, x[0] * unit)
        return lagged.with_effect(friction.replace(force=np.r_[x[1:] * forces[:3], forces[3:]]))

    low, high = HYSTERESIS_LAG_RANGE
    start = np.ones(4)  # the lag at HYSTERESIS_LAG_START, the forces as the model has them
    x, replays = plant_fit(build(start), build, start, [(low / unit, high / unit)] + [FRICTION_FACTOR_RANGE] * 3,
                           signals, split, robot, max_evaluations)
    fitted = build(x)
    return fitted, x[1:], float(fitted.params.effect("hysteresis").response_time[0]), replays


def with_plant_scoring_fit(model, signals, split, robot, max_evaluations: int, fit_lag: bool):
    """``model`` as a plant score replays it: its Coulomb forces refitted to the plant
    (:func:`with_plant_friction`), or, with ``fit_lag`` and a hysteresis switched on, its
    hysteresis's lag fitted with them (:func:`with_plant_friction_and_lag`, with
    :func:`lag_fit_evaluations` of ``max_evaluations``). Returns the model, the factors, the lag
    (s; None where not fitted) and the replays it took."""
    if fit_lag and model.params.is_enabled("hysteresis"):
        return with_plant_friction_and_lag(model, signals, split, robot, lag_fit_evaluations(max_evaluations))
    refitted, factors, replays = with_plant_friction(model, signals, split, robot, max_evaluations)
    return refitted, factors, None, replays


@dataclass(frozen=True)
class PlantScore:
    """The plant replay's verdict on one analysis.

    ``applies`` False: ``reason`` says why (one sentence) and the other fields are None. Otherwise
    ``gap_before`` and ``gap_after`` are the held-out residual RMS per joint (rad, rad, m) of the
    starting and final models, each with its Coulomb forces refitted to the plant, ``shrink`` the
    pooled shrink (deg and mm), ``friction_factors`` the refit's factor per joint for ``"before"``
    and ``"after"``, ``replays`` the plant replays it took. ``fits_lag`` says whether the score
    fitted the lag of a model's hysteresis to the plant (the default) or took the candidate's
    constant (``--fixed-plant-lag``); ``hysteresis_lag`` is then the final model's fitted lag (s;
    None where it has no hysteresis or the lag was not fitted).
    """

    applies: bool
    reason: str | None = None
    gap_before: np.ndarray | None = None
    gap_after: np.ndarray | None = None
    shrink: float | None = None
    friction_factors: dict | None = None
    replays: int = 0
    fits_lag: bool = False
    hysteresis_lag: float | None = None

    def document(self) -> dict:
        """The score as plain JSON values (SI)."""
        def listed(v):
            return None if v is None else [float(x) for x in v]

        return {"applies": self.applies, "reason": self.reason, "gap_before": listed(self.gap_before),
                "gap_after": listed(self.gap_after), "shrink": self.shrink,
                "friction_factors": None if self.friction_factors is None else
                {k: listed(v) for k, v in self.friction_factors.items()}, "replays": self.replays,
                "fits_lag": self.fits_lag, "hysteresis_lag_s": self.hysteresis_lag}


def pooled_gap(rms) -> float:
    """Pooled RMS (deg and mm) of per-joint RMS values in SI (rad, rad, m)."""
    return float(np.sqrt(np.mean(np.square(np.asarray(rms, dtype=float) * report_scale(RAVEN_UNITS)))))


def plant_score_reason(result, signals) -> str | None:
    """None when the plant replay can score ``result`` (a workflow result on RAVEN-II ``signals``),
    else why not, in one sentence: nothing named (the two models are one), a named effect the plant
    does not integrate (:data:`PLANT_SCORED_EFFECTS`), or a declared payload that changes.

    A re-homing is no reason: the plant starts again there at rest from the measured joints, and
    what that start gets wrong (the links' speed, where dry friction held them) is gone within
    seconds, the links' swing being damped (two replays of the same model started again at two
    instants agreed to under 1e-6 deg after 3 s, ``studies/DISCREPANCY_MEASUREMENTS.md``)."""
    if not result.named_effects:
        return "nothing was named: the starting and final models are the same"
    outside = [name for name in result.named_effects if name not in PLANT_SCORED_EFFECTS]
    if outside:
        return (f"{', '.join(outside)} {'acts' if len(outside) == 1 else 'act'} outside what the plant replay "
                "integrates")
    payload = np.asarray(signals.payload_kg, dtype=float)
    if np.ptp(payload) > 0:
        return "the declared payload changes along the record: the plant replay builds the links' gravity for one"
    return None


def score_with_plant(result, signals, split, max_evaluations: int = PLANT_FRICTION_EVALUATIONS,
                     fit_lag: bool = True) -> PlantScore:
    """The plant replay's held-out gaps and shrink of ``result`` (module docstring); a score that
    does not apply when :func:`plant_score_reason` gives a reason, nor when a model's plant replay
    does not stay finite (then the report's figures are the quasi-static replay's, as elsewhere).

    The lag of a model's hysteresis behind the stretch is fitted to the plant on the fit part
    together with the model's Coulomb forces (:func:`with_plant_scoring_fit`), from a round 0.1 s
    and weighed at it, so that nothing of the score is a value the generator shares. With
    ``fit_lag=False`` the hysteresis lags by the candidate's constant
    (``candidates.HYSTERESIS_RESPONSE_TIME``, a round 0.1 s), as every plant-scored hysteresis
    figure measured before the lag was fitted by default was scored, with that constant at 0.05 s,
    the simulator's default, until 2026-12-06."""
    from kinematics import RavenII

    reason = plant_score_reason(result, signals)
    if reason is not None:
        return PlantScore(applies=False, reason=reason, fits_lag=bool(fit_lag))
    robot = RavenII(signals.arm, check_limits=False)
    gaps, factors, lags, replays = {}, {}, {}, 0
    for key, model in (("before", result.model_before), ("after", result.model_after)):
        refitted, factors[key], lags[key], used = with_plant_scoring_fit(model, signals, split, robot,
                                                                         max_evaluations, fit_lag)
        gaps[key] = plant_held_out_gap(refitted, signals, split, robot)
        replays += used
    for key, gap in gaps.items():
        if not np.all(np.isfinite(gap)):
            return PlantScore(applies=False, replays=replays, fits_lag=bool(fit_lag),
                              reason=f"the plant replay of the {'starting' if key == 'before' else 'final'} model "
                                     "did not stay finite")
    before = pooled_gap(gaps["before"])
    shrink = 1.0 - pooled_gap(gaps["after"]) / before if before > 0 else 0.0
    return PlantScore(applies=True, gap_before=gaps["before"], gap_after=gaps["after"], shrink=float(shrink),
                      friction_factors=factors, replays=replays, fits_lag=bool(fit_lag),
                      hysteresis_lag=lags["after"])


def refine_range(value, lower, upper, scale) -> tuple[np.ndarray, np.ndarray]:
    """Search range of a refit around fitted values (arrays in the candidate's SI units): a third to
    three times each value within the candidate's own range ``lower`` to ``upper``, or from its lower
    bound to its typical ``scale`` where the fit left it at zero."""
    value = np.asarray(value, dtype=float)
    low = np.where(value > 0, np.maximum(lower, value / 3.0), lower)
    high = np.where(value > 0, np.minimum(upper, 3.0 * value), np.minimum(upper, scale))
    return low, np.maximum(high, low)


@dataclass(frozen=True)
class PlantRefit:
    """The named effects of an analysis refitted with the plant replay (:func:`refit_with_plant`).

    ``applies`` False: ``reason`` says why (one sentence) and the other fields are empty. Otherwise
    ``effects`` are the refitted effects, ``gap_after`` the refitted model's held-out residual RMS
    per joint (rad, rad, m), ``shrink`` its pooled shrink (deg and mm) over the plant score's
    starting gap, ``fitted`` and ``refitted`` the effects' values (SI, {effect: {parameter:
    list}}) before and after, ``friction_factors`` the factors on the final model's Coulomb forces,
    ``replays`` the plant replays it took, ``hysteresis_lag`` the refitted lag (s) of a hysteresis
    whose plant score fitted its lag (None otherwise: the candidate's constant).
    """

    applies: bool
    reason: str | None = None
    effects: tuple[str, ...] = ()
    gap_after: np.ndarray | None = None
    shrink: float | None = None
    fitted: dict | None = None
    refitted: dict | None = None
    friction_factors: np.ndarray | None = None
    replays: int = 0
    hysteresis_lag: float | None = None

    def document(self) -> dict:
        """The refit as plain JSON values (SI)."""
        def listed(v):
            return None if v is None else [float(x) for x in v]

        return {"applies": self.applies, "reason": self.reason, "effects": list(self.effects),
                "gap_after": listed(self.gap_after), "shrink": self.shrink, "fitted": self.fitted,
                "refitted": self.refitted, "friction_factors": listed(self.friction_factors),
                "replays": self.replays, "hysteresis_lag_s": self.hysteresis_lag}


def refit_with_plant(result, signals, split, score: PlantScore,
                     max_evaluations: int = PLANT_REFIT_EVALUATIONS) -> PlantRefit:
    """The named effects of :data:`PLANT_REFIT_EFFECTS` in ``result`` (a workflow result on
    RAVEN-II ``signals``) refitted with the plant replay on the fit part, together with the final
    model's Coulomb forces: :func:`plant_fit` (Powell's method, at most ``max_evaluations`` replays)
    from the analysis's own fitted values, each searched in :func:`refine_range`, the factors on the
    forces from 1 in :data:`FRICTION_FACTOR_RANGE`.

    The workflow chooses and fits with the quasi-static replay, which keeps no state of the links'
    swing; where ``score`` (the analysis's plant score) applies, this refit asks what the named
    effects close when their values are fitted with the replay that scores them. It starts only
    from the analysis's values and the candidates' own ranges and reads only ``signals``. The
    refitted model is scored as ``score`` scores the final model: held out, over ``score``'s starting
    gap. Where ``score`` fitted the lag of a named hysteresis, the refit fits that lag too, from the
    score's value within :data:`HYSTERESIS_LAG_RANGE`. Does not apply where ``score`` does not, or
    where no named effect is one it refits."""
    from kinematics import RavenII

    if not score.applies:
        return PlantRefit(applies=False, reason=f"the plant replay does not score the analysis: {score.reason}")
    names = [n for n in result.named_effects if n in PLANT_REFIT_EFFECTS]
    if not names:
        return PlantRefit(applies=False, reason=f"no named effect is one the plant refit refits "
                                                f"({', '.join(PLANT_REFIT_EFFECTS)})")
    robot = RavenII(signals.arm, check_limits=False)
    model = result.model_after
    candidates = raven_library(signals, names)
    fitted, starts, bounds, scales = {}, [], [], []
    for candidate in candidates:
        lower, upper, scale, _ = candidate.bounds()
        values = PLANT_REFIT_EFFECTS[candidate.name](model.params.effect(candidate.name))
        fitted[candidate.name] = {b.name: np.ravel(np.asarray(values[b.name], dtype=float)).tolist()
                                  for b in candidate.blocks}
        value = np.concatenate(list(fitted[candidate.name].values()))
        low, high = refine_range(value, lower, upper, scale)
        starts.append(np.clip(value, low, high) / scale)
        bounds += list(zip(low / scale, high / scale))
        scales.append(scale)
    scales = np.concatenate(scales)
    friction = model.params.effect("coulomb_friction")
    forces = np.asarray(friction.force, dtype=float)
    cuts = np.cumsum([c.n_parameters for c in candidates])
    lagged = score.fits_lag and score.hysteresis_lag is not None and "hysteresis" in names
    unit = HYSTERESIS_LAG_START
    low, high = HYSTERESIS_LAG_RANGE

    def effect_values(x):
        return zip(candidates, np.split(x[:cuts[-1]] * scales, cuts[:-1]))

    def build(x):
        with_them = model
        for candidate, theta in effect_values(x):
            with_them = candidate.apply(with_them, theta)
        if lagged:
            with_them = with_lag(with_them, x[-1] * unit)
        factors = x[cuts[-1]:cuts[-1] + 3]
        return with_them.with_effect(friction.replace(force=np.r_[factors * forces[:3], forces[3:]]))

    start = np.r_[np.concatenate(starts), np.ones(3)]
    box = bounds + [FRICTION_FACTOR_RANGE] * 3
    if lagged:
        start, box = np.r_[start, score.hysteresis_lag / unit], box + [(low / unit, high / unit)]
    weighed_by = with_lag(model, score.hysteresis_lag) if lagged else model
    x, replays = plant_fit(weighed_by, build, start, box, signals, split, robot, max_evaluations)
    gap = plant_held_out_gap(build(x), signals, split, robot)
    if not np.all(np.isfinite(gap)):
        return PlantRefit(applies=False, replays=replays, reason="the plant replay of the refitted model did not stay finite")
    before = pooled_gap(score.gap_before)
    refitted = {c.name: {k: v.tolist() for k, v in c.unpack(theta).items()} for c, theta in effect_values(x)}
    return PlantRefit(applies=True, effects=tuple(names), gap_after=gap,
                      shrink=float(1.0 - pooled_gap(gap) / before if before > 0 else 0.0), fitted=fitted,
                      refitted=refitted, friction_factors=np.asarray(x[cuts[-1]:cuts[-1] + 3], dtype=float),
                      replays=replays,
                      hysteresis_lag=float(np.clip(x[-1] * unit, low, high)) if lagged else None)


def with_lag(model, lag: float):
    """``model`` with its hysteresis lagging the stretch by ``lag`` seconds on every joint, ``lag``
    held within :data:`HYSTERESIS_LAG_RANGE` (the bounded search steps a rounding error past its
    ends)."""
    lag = float(np.clip(lag, *HYSTERESIS_LAG_RANGE))
    return model.with_effect(model.params.effect("hysteresis").replace(response_time=np.full(3, lag)))


def with_refit(model, refit: PlantRefit, signals):
    """``model`` (the analysis's final model) with the values of ``refit`` (one that applies): its
    effects set to the refitted values (and its hysteresis's lag where the refit fitted one) and its
    positioning joints' Coulomb forces multiplied by the refit's factors, the model the refit
    scored."""
    if not refit.applies:
        raise ValueError(f"the refit does not apply: {refit.reason}")
    for candidate in raven_library(signals, refit.effects):
        values = refit.refitted[candidate.name]
        model = candidate.apply(model, np.concatenate([np.ravel(values[b.name]) for b in candidate.blocks]))
    if refit.hysteresis_lag is not None:
        model = with_lag(model, refit.hysteresis_lag)
    friction = model.params.effect("coulomb_friction")
    forces = np.asarray(friction.force, dtype=float)
    return model.with_effect(friction.replace(force=np.r_[refit.friction_factors * forces[:3], forces[3:]]))


def plant_floor_gap(record, max_evaluations: int = PLANT_FRICTION_EVALUATIONS) -> np.ndarray:
    """The floor under a plant-scored analysis: the held-out gap per joint (SI) the starting model
    leaves on a seed's record with nothing hidden (``record``: the signals, split, robot and model
    of :func:`~studies.common.discrepancy_runs.floor_record`), scored as :func:`score_with_plant`
    scores a starting model: its Coulomb forces refitted to the plant on the fit part, then the
    plant replay. Beside a plant-scored shrink, ``1 - floor / gap`` of this floor is the share of
    the gap a model replayed with the plant could close if the effect left the rest of the residual
    as it is; the quasi-static floor bounds the quasi-static shrink alone."""
    signals, split, robot, model = record
    refitted, _, _ = with_plant_friction(model, signals, split, robot, max_evaluations)
    return plant_held_out_gap(refitted, signals, split, robot)


def score_oracle_with_plant(oracle_result, blind: PlantScore, signals, split,
                            max_evaluations: int = PLANT_FRICTION_EVALUATIONS) -> tuple[np.ndarray, float] | None:
    """The oracle's held-out gap per joint (SI) and shrink scored as ``blind`` scored the blind
    analysis: its final model's Coulomb forces refitted to the plant, over the blind analysis's
    plant-scored starting gap (the two share their starting model), its hysteresis's lag fitted with
    them where ``blind`` fitted lags. None where ``blind`` does not apply; the oracle is then scored
    by the quasi-static replay, as the analysis is."""
    from kinematics import RavenII

    if not blind.applies:
        return None
    robot = RavenII(signals.arm, check_limits=False)
    refitted, _, _, _ = with_plant_scoring_fit(oracle_result.model_after, signals, split, robot, max_evaluations,
                                               blind.fits_lag)
    gap = plant_held_out_gap(refitted, signals, split, robot)
    before = pooled_gap(blind.gap_before)
    return gap, (1.0 - pooled_gap(gap) / before if before > 0 else 0.0)
