"""What bounds the shrink: the held-out residual the starting model leaves with nothing hidden.

A diagnostic that knows the generator, never part of an analysis. For each seed it generates the
record of ``python studies/discrepancy.py --hidden-effect none --seed S`` (twenty minutes unless
``--duration`` says otherwise), writes and reads it as the blind analysis does, identifies the
starting structure on the first half, replays it and prints the held-out residual (the last
quarter) per joint (deg, deg, mm) and pooled: the workflow's ``gap_before`` with nothing hidden.
A hidden effect adds to this floor, and a model of the right structure takes at best the effect's
part of the gap, so the floor is what no analysis of this motion closes. The study takes it apart:

- the ground-truth encoders' own error, from the resolution and noise the generator gives them
  (uniform quantization error and white noise, independent): what no model can remove;
- the residual's RMS in frequency bands (0-2 Hz, 2-10 Hz, 10 Hz to half the log rate) beside the
  share of the encoders' white error in each: where the rest of the floor lies;
- the replay's inertial loads (the links' mass matrix times a causal estimate of their
  acceleration from the measured joints, late by about a tenth of a second): the same identified
  model replayed without them, with them from the motors' acceleration (causal too, from other
  encoders), and from two estimates that look ahead, which the replay does not allow itself: a
  centred second difference of the measured joints that skips the sample it is for, and one that
  weighs it (a diagnostic of what the present sample's own encoder error does through the load, not
  a replay to use);
- the replay's viscous and inertial loads both from the derivatives the identification fits with
  (centred Savitzky-Golay fits of a cubic over 0.6 s, which look 0.3 s ahead): how much of the floor is the
  noise and lag of the causal derivatives in the loads;
- with ``--dynamic``, the links' swing on their cables followed
  (:mod:`simulation.engine.plant_replay`: the simulator's two-mass plant driven by the
  measured motor positions), with the identified starting model's parameters (damping at its
  nominal value, as the identification holds it) and, since the diagnostic knows the generator,
  with the generator's own: how much of the floor the quasi-static replay's missing dynamics are.

With ``--effects``, for each effect hidden on the same seed (at its default size, or
``--size-factor`` times it), the starting model's held-out gap on that record and ``1 - floor /
gap``, pooled: the most a model replayed this way could close if the effect left the rest of the
residual as it is (the effect changes the motion a little, so an analysis may exceed it by a few
points).
With ``--analyse`` as well, each effect's record is analysed blind twice, with the workflow's
replay and with the links' inertial loads from the motors' acceleration
(:func:`motor_side_acceleration`), and the study prints what each names and closes beside the
bound each replay's floor sets: what a lower floor would change (about four minutes of CPU per
analysis of a twenty-minute record).

With ``--dynamic`` as well, the same gap and bound with the dynamic replay (its floor over its gap):
the most a model replayed that way could close; the effect's record replayed with the generator's
own parameters beside the floor they leave (``generator``): how close a model of the right structure
with the right values comes to that floor, which tells a fit that falls short from a structure that
cannot reach it (not for a per-homing offset, which the generator draws anew at each homing and
holds no value of: :func:`generator_model`); and for an effect the plant carries
(:data:`DYNAMIC_FITS`), the effect's parameters fitted with the dynamic replay on the fit part
together with the starting model's Coulomb forces (:func:`dynamic_oracle`), and the share of the
dynamic replay's held-out gap that closes: whether a lower floor lets a model of the right
structure close more (about six minutes of CPU per twenty-minute record).

With ``--rescore``, each effect's record is analysed blind (the workflow as it is) and its
starting and final models are scored with the plant replay on the held-out part, as fitted and
with their Coulomb forces refitted with the plant replay (:func:`plant_rescored`): whether the
workflow's own fit, replayed with the links' swing, closes more of the lower floor's gap. The
refitted figures are what the blind analysis's last step reports
(:func:`studies.common.plant_scoring.score_with_plant`) where it applies.

With ``--refine``, each effect's record is analysed blind and scored as its report scores it, and
a named backlash, hysteresis or drift is then refitted with the plant replay, from the analysis's own
values, together with the Coulomb forces (:func:`plant_refined`, the refit of ``python
studies/discrepancy.py --plant-refit``): whether a plant-scored shrink short of its floor's bound
is the quasi-static fit's values or a structure that cannot reach it (about fifteen minutes of CPU
per twenty-minute record). With ``--refine-rebase`` as well, one backfit round follows: the
starting structure re-identified around the refitted values and the effects refitted again with
the plant replay (:func:`rebased_refit`, half the budget). With ``--refine-stiffness`` as well, an
output-error step on the base follows the refit: the cable stiffness refitted with the plant replay,
then the effects again (:func:`stiffened_refit`; on seeds 30 and 32 it gained 0.4 and 1.0 points,
its factors within 0.1 % of 1: no remedy).

With ``--decompose``, each effect's record is analysed blind and its final model is scored as its
report scores it, beside the same model with its base (the starting structure as the backfit
re-identified it) or its named effect swapped for the generator's, the starting model of the same
seed's record with nothing hidden given the generator's effect, and the generator's own
(:func:`plant_decomposed`): which part keeps a plant-scored shrink short of its floor's bound.

With ``--rebase``, no analysis runs: each effect's record has its starting structure re-identified
around the generator's effect's share, as a backfit round re-identifies it around a named effect,
with that share computed from the generator's model or from the record's starting model given the
generator's effect, by the quasi-static or the plant replay, and each base is given the generator's
effect and scored as a report scores a model, beside the nothing-hidden record's starting model
given the same effect and the floor's bound (:func:`plant_rebased`): what re-identifying the base
on a record where the effect acts costs, given the effect exactly (about ten minutes per
twenty-minute record, two records at a time on 2 cores). With ``--output-error`` as well, two of
those bases are also scored with their cable stiffness refitted with the plant replay
(:func:`with_plant_stiffness`; about twenty minutes per record in all).

Run: ``python studies/discrepancy_floor.py --effects backlash,registration_offset`` (seeds 30-34,
the seeds of the README's thirty-round table; fifteen twenty-minute records, under 3 minutes on one
core); ``--seed 31 --seeds 2 --effects backlash --analyse`` (four analyses, 18 minutes);
``--effects backlash --dynamic`` (five fits with the plant replay besides, 19 minutes on 2 cores run
as two commands, ``--seed 30 --seeds 3`` and ``--seed 33 --seeds 2``).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np

from studies.common.discrepancy_runs import DEFAULT_RECORD_S, motor_side_acceleration, record_length
from studies.common.plant_scoring import (PLANT_FRICTION_EVALUATIONS, PLANT_REFIT_EVALUATIONS, plant_fit,
                                         plant_held_out_gap, with_plant_friction)
from studies.common.reporting import write_json
from studies.common.runner import non_negative_int, positive_float, positive_int, script_parser

STUDY = "discrepancy_floor"

BANDS_HZ = ((0.0, 2.0), (2.0, 10.0), (10.0, np.inf))
"""Frequency bands (Hz) of the floor's breakdown; the last ends at half the log rate. The links
swing on their cables at about 3 Hz (the replay's docstring), inside the second band."""

TO_REPORT = np.array([np.degrees(1.0), np.degrees(1.0), 1e3])
"""rad, rad, m to deg, deg, mm."""


def sensor_floor(generator) -> np.ndarray:
    """RMS error per joint of the ground-truth encoders the ``generator`` (a
    :class:`~simulation.model.parameters.RavenParameters`) simulates (rad, rad, m): quantization to
    its resolution (uniform, ``q / sqrt(12)``) and its white noise, independent. Zero for a part
    the generator switches off."""
    variance = np.zeros(3)
    if generator.is_enabled("quantization"):
        variance += np.square(generator.effect("quantization").truth_resolution) / 12.0
    if generator.is_enabled("noise"):
        variance += np.square(generator.effect("noise").truth_noise)
    return np.sqrt(variance)


def _band_edges(rate: float, bands) -> list[tuple[float, float]]:
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"the sample rate must be a positive number of Hz, got {rate!r}")
    nyquist = rate / 2.0
    edges = []
    for low, high in bands:
        if not (0.0 <= low < high):
            raise ValueError(f"a frequency band needs 0 <= low < high, got ({low}, {high})")
        edges.append((float(low), float(min(high, nyquist))))
    return edges


def band_rms(values: np.ndarray, rate: float, bands=BANDS_HZ) -> np.ndarray:
    """(J, B) RMS of each column of ``values`` ((N, J), sampled at ``rate`` Hz) about its mean, in
    each frequency band ``[low, high)`` (Hz; the top band includes half the rate), by the discrete
    Fourier transform: bands that cover 0 Hz to half the rate split the variance exactly (their
    squares add up to it)."""
    values = np.asarray(values, dtype=float)
    if values.ndim != 2 or values.shape[0] < 2:
        raise ValueError(f"band_rms needs an (N, J) table with N >= 2, got shape {values.shape}")
    if not np.all(np.isfinite(values)):
        raise ValueError("band_rms needs finite values; they hold NaN or inf")
    edges = _band_edges(rate, bands)
    n = values.shape[0]
    spectrum = np.fft.rfft(values - values.mean(axis=0), axis=0)
    power = np.square(np.abs(spectrum)) / n ** 2
    power[1:] *= 2.0
    if n % 2 == 0:
        power[-1] /= 2.0  # the bin at half the rate has no mirror image
    frequency = np.fft.rfftfreq(n, d=1.0 / rate)
    top = frequency[-1]
    out = np.zeros((values.shape[1], len(edges)))
    for b, (low, high) in enumerate(edges):
        inside = (frequency >= low) & ((frequency < high) | ((high >= top) & (frequency <= top)))
        out[:, b] = np.sqrt(power[inside].sum(axis=0))
    return out


def white_band_rms(rms: np.ndarray, rate: float, bands=BANDS_HZ) -> np.ndarray:
    """(J, B) the part in each band of a white error of RMS ``rms`` (J,) sampled at ``rate`` Hz:
    ``rms * sqrt(band width / half the rate)``."""
    edges = _band_edges(rate, bands)
    nyquist = rate / 2.0
    widths = np.array([high - low for low, high in edges])
    return np.asarray(rms, dtype=float)[:, None] * np.sqrt(widths / nyquist)[None, :]


def _centred(values: np.ndarray, time: np.ndarray, skip_present: bool) -> np.ndarray:
    out = np.zeros_like(values)
    if values.shape[0] >= 3:
        out = np.gradient(np.gradient(values, time, axis=0), time, axis=0)
    if skip_present and values.shape[0] >= 5:
        h = float(np.median(np.diff(time)))
        out[2:-2] = (values[4:] + values[:-4] - values[3:-1] - values[1:-3]) / (3.0 * h * h)
    return out


def centred_acceleration(signals, skip_present: bool = False) -> np.ndarray:
    """Second derivative of the measured joints by centred differences, within each homing: it looks
    ahead, which the replay's own estimate never does.

    By default ``np.gradient`` twice, ``(q[t+2] - 2 q[t] + q[t-2]) / (4 h^2)`` inside a homing of
    log period ``h``, which weighs the sample's own reading by ``-1 / (2 h^2)``. With
    ``skip_present`` the fourth-order stencil ``(q[t+2] + q[t-2] - q[t+1] - q[t-1]) / (3 h^2)``
    (``h`` the homing's median period), exact for cubics and blind to the sample itself, so that the
    sample's encoder error cannot reach its own prediction through the inertial load; the first and
    last two samples of each homing keep the first form.
    """
    from simulation.discrepancy.signals import per_homing

    return per_homing(_centred, np.asarray(signals.truth, dtype=float), np.asarray(signals.time, dtype=float),
                      signals.homing, skip_present)


def _identification_derivatives(values: np.ndarray, time: np.ndarray) -> np.ndarray:
    from simulation.identification.samples import DERIVATIVE_WINDOW, savgol_derivatives

    step = float(np.median(np.diff(time))) if values.shape[0] > 1 else 0.0
    width = max(int(round(DERIVATIVE_WINDOW / step)) | 1, 5) if step > 0 else 0
    if not width or values.shape[0] < width:
        return np.zeros((values.shape[0], 2 * values.shape[1]))
    return np.hstack(savgol_derivatives(values, width, step))


def identification_derivatives(signals) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of the measured joints as the identification takes them
    (:func:`~simulation.identification.samples.savgol_derivatives`: centred Savitzky-Golay fits of a
    cubic over :data:`~simulation.identification.samples.DERIVATIVE_WINDOW`, 0.6 s or 19 samples at
    30 Hz), within each homing. They look 0.3 s ahead and weigh the present sample's reading by
    zero in the velocity."""
    from simulation.discrepancy.signals import per_homing

    both = per_homing(_identification_derivatives, np.asarray(signals.truth, dtype=float),
                      np.asarray(signals.time, dtype=float), signals.homing)
    joints = signals.truth.shape[1]
    return both[:, :joints], both[:, joints:]


VARIANTS = ("replay", "no inertial load", "motor-side acceleration", "look-ahead acceleration, present sample skipped",
            "look-ahead acceleration, present sample included", "the identification's derivatives")
"""The replays :func:`starting_model_residuals` compares: the workflow's, then the links' inertial
loads left out, from :func:`motor_side_acceleration`, from :func:`centred_acceleration` without and
with the present sample, and the viscous and inertial loads from :func:`identification_derivatives`."""


DYNAMIC_VARIANTS = ("dynamic replay", "dynamic replay, generator's parameters")
"""The replays of ``--dynamic`` (:func:`plant_held_out_gap`): the identified starting model's
parameters, and the generator's own, in the plant that follows the links' swing."""


def generated_record(hidden, seed: int, duration: float, size_factor: float = 1.0):
    """The generated record of ``hidden`` written and read as the blind analysis reads its file, and
    the generator's parameters."""
    from studies.common.discrepancy_runs import generate_measured, read_measured, write_measured

    generated, generator = generate_measured(hidden, seed, duration, size_factor=size_factor)
    with tempfile.TemporaryDirectory() as folder:
        return read_measured(write_measured(generated, folder)), generator


def generator_model(generator, hidden, size_factor: float = 1.0):
    """The generator's own model of a record for the dynamic replay: its parameters, its motors
    registered where it registers them (no offsets: without a per-homing offset hidden, the
    generator's homing puts the motors' zero exactly) and, with ``payload`` hidden, the undeclared
    payload it put at the tool tip. Not the starting model's offsets: an identification without the
    payload takes its mean sag into them (0.16 deg on the shoulder on seed 3), and registered on
    the motor side they would sag the replay a second time. None when a hidden effect is a
    per-homing offset (:data:`~studies.common.discrepancy_runs.PER_HOMING_EFFECTS`): the generator
    draws those anew at each homing and holds no value of them, and its parameters replayed
    without them would leave the effect's whole gap and pass it off as the structure's."""
    from simulation.discrepancy.replay import RavenModel
    from studies.common.discrepancy_runs import HIDDEN_PAYLOAD_KG, PER_HOMING_EFFECTS

    if any(name in PER_HOMING_EFFECTS for name in hidden):
        return None
    model = RavenModel(generator, np.zeros(3))
    return model.with_payload(HIDDEN_PAYLOAD_KG * size_factor) if "payload" in hidden else model


DYNAMIC_FITS = ("backlash",)
"""Effects :func:`dynamic_oracle` fits with the dynamic replay: those of the library whose candidate
changes only what the plant integrates."""


def dynamic_oracle(effect: str, seed: int, duration: float, size_factor: float = 1.0,
                   max_evaluations: int = 600) -> dict:
    """The hidden ``effect`` fitted with the dynamic replay on the fit part of its generated record.

    The starting structure is identified as the blind analysis identifies it (quasi-statically, on
    the first half). The library's candidate of ``effect`` is then fitted together with the starting
    model's Coulomb friction forces, which an identification without the effect uses to mimic its
    lag, by Powell's method: at most ``max_evaluations`` replays of the fit part, from the
    candidate's own starting value within its search range and the identified forces (between zero
    and three times them), minimising the fit part's joint residual of the dynamic replay, each
    joint over its spread under the starting model, the constant offsets profiled out. The rest of
    the starting structure stays as identified. Returns the dynamic replay's held-out gap per joint
    (SI) before and after, the shrink (pooled, deg and mm), the fitted values (SI) and the replays
    it took.
    """
    from studies.common.discrepancy_runs import raven_library, starting_model_on

    if effect not in DYNAMIC_FITS:
        raise ValueError(f"the dynamic oracle fits {', '.join(DYNAMIC_FITS)}, not {effect!r}")
    dataset, _ = generated_record((effect,), seed, duration, size_factor)
    signals, split, robot, model = starting_model_on(dataset)
    (candidate,) = raven_library(signals, (effect,))
    lower, upper, scale, typical = candidate.bounds()
    friction = model.params.effect("coulomb_friction")
    identified = np.asarray(friction.force[:3], dtype=float)
    k = candidate.n_parameters

    def build(x):
        with_it = candidate.apply(model, np.clip(x[:k] * scale, lower, upper))
        forces = np.r_[np.maximum(x[k:], 0.0) * identified, np.asarray(friction.force, dtype=float)[3:]]
        return with_it.with_effect(with_it.params.effect("coulomb_friction").replace(force=forces))

    bounds = list(zip(lower / scale, upper / scale)) + [(0.0, 3.0)] * 3
    x, replays = plant_fit(model, build, np.r_[np.clip(typical, lower, upper) / scale, np.ones(3)], bounds,
                           signals, split, robot, max_evaluations)
    fitted = build(x)
    before = plant_held_out_gap(model, signals, split, robot)
    after = plant_held_out_gap(fitted, signals, split, robot)
    values = {name: np.asarray(v, dtype=float).tolist()
              for name, v in candidate.unpack(np.clip(x[:k] * scale, lower, upper)).items()}
    values["coulomb_force"] = (np.maximum(x[k:], 0.0) * identified).tolist()
    return {"gap_before": before.tolist(), "gap_after": after.tolist(), "shrink": 1.0 - pooled(after) / pooled(before),
            "fitted": values, "identified_coulomb_force": identified.tolist(), "replays": replays}


def plant_rescored(effect: str, seed: int, duration: float, size_factor: float = 1.0,
                   max_evaluations: int = 200) -> dict:
    """The blind analysis of ``effect``'s generated record (the workflow as it is: quasi-static
    replay, thirty backfit rounds), its starting and final models then scored with the plant replay
    on the held-out part, as they are and with their Coulomb forces refitted with it
    (:func:`with_plant_friction`, at most ``max_evaluations`` replays each). Returns the names, the workflow's shrink, and the plant
    replay's held-out gaps (pooled, deg and mm) and shrinks: the final model as fitted over the
    starting model as identified, and each refined over the starting model refined."""
    from kinematics import RavenII
    from studies.common.discrepancy_runs import run_on_raven_dataset

    dataset, _ = generated_record((effect,), seed, duration, size_factor)
    result, signals, split = run_on_raven_dataset(dataset)
    robot = RavenII(signals.arm, check_limits=False)
    gaps, replays = {}, 0
    for name, model in (("start", result.model_before), ("final", result.model_after)):
        gaps[name] = pooled(plant_held_out_gap(model, signals, split, robot))
        refined, _, used = with_plant_friction(model, signals, split, robot, max_evaluations)
        gaps[f"{name} refined"] = pooled(plant_held_out_gap(refined, signals, split, robot))
        replays += used
    return {"named_effects": list(result.named_effects), "shrink": float(result.shrink), "plant_gaps": gaps,
            "plant_shrink": 1.0 - gaps["final"] / gaps["start"],
            "plant_shrink_refined": 1.0 - gaps["final refined"] / gaps["start refined"], "replays": replays}


def plant_refined(effect: str, seed: int, duration: float, size_factor: float = 1.0,
                  max_evaluations: int = PLANT_REFIT_EVALUATIONS, rebase: bool = False,
                  stiffness: bool = False) -> dict:
    """The blind analysis of ``effect``'s generated record scored as its report scored it before the
    lag of a hysteresis was fitted by default (:func:`~studies.common.plant_scoring.score_with_plant`
    with the candidate's fixed lag, ``--fixed-plant-lag``: the refinements below were measured so,
    with the candidate's lag at the simulator's 0.05 s until 2026-12-06 and a round 0.1 s since),
    then its named effects refitted with the plant replay as ``--plant-refit`` refits them
    (:func:`~studies.common.plant_scoring.refit_with_plant`, at most ``max_evaluations`` replays).

    Whether a plant-scored shrink short of its floor's bound is the quasi-static fit's values or the
    structure: the refitted model's held-out gap over the same refitted starting gap the report uses.
    Returns the names, the report's gaps (SI) and shrink, the refitted gap and shrink, the fitted and
    refitted values (SI) and the replays.

    With ``rebase``, one backfit round with the refitted values follows (:func:`rebased_refit`),
    reported as ``rebased``. With ``stiffness``, an output-error step on the base follows the first
    refit (:func:`stiffened_refit`), reported as ``stiffened``."""
    from studies.common.discrepancy_runs import run_on_raven_dataset
    from studies.common.plant_scoring import refit_with_plant, score_with_plant

    dataset, _ = generated_record((effect,), seed, duration, size_factor)
    result, signals, split = run_on_raven_dataset(dataset)
    score = score_with_plant(result, signals, split, fit_lag=False)
    out = {"named_effects": list(result.named_effects), "plant_scored": bool(score.applies)}
    refit = refit_with_plant(result, signals, split, score, max_evaluations)
    if not refit.applies:
        return out
    out = {**out, "gap_before": score.gap_before.tolist(), "gap_after": score.gap_after.tolist(),
           "shrink": float(score.shrink), "refined_gap": refit.gap_after.tolist(), "refined_shrink": refit.shrink,
           "fitted": refit.fitted, "refined": refit.refitted, "replays": refit.replays + score.replays}
    if rebase:
        out["rebased"] = rebased_refit(dataset, result, signals, split, score, refit, max_evaluations // 2)
    if stiffness:
        out["stiffened"] = stiffened_refit(result, signals, split, score, refit, max_evaluations)
    return out


def stiffened_refit(result, signals, split, score, refit, max_evaluations: int) -> dict:
    """An output-error step on the base after a plant refit: the refitted model's positioning joints'
    cable stiffness and Coulomb forces refitted with the plant replay on the fit part
    (:func:`with_plant_stiffness`, at most ``max_evaluations`` replays), then its refitted effects and
    Coulomb forces refitted again from there (:func:`~studies.common.plant_scoring.refit_with_plant`,
    half the budget). It reads only the record and the analysis's own values.

    The backfit identifies the base with the quasi-static balance (equation error) around the named
    effect; given the exact hysteresis, a base so re-identified closed about three points less than
    one identified with nothing hidden, and a plant refit of its cable stiffness alone took most of
    that back (``--rebase --output-error``). Whether the same step after the blind refit, which has
    only its own hysteresis, does too: on seeds 30 and 32 (twenty minutes) it did not (factors within
    0.1 % of 1, 0.4 and 1.0 points gained). Returns the stiffened model's gap (SI), shrink, stiffness and
    force factors and replays, and the second refit's gap, shrink, values (SI) and replays."""
    from types import SimpleNamespace

    from kinematics import RavenII
    from studies.common.plant_scoring import pooled_gap, refit_with_plant, with_refit

    robot = RavenII(signals.arm, check_limits=False)
    stiffened, factors, replays = with_plant_stiffness(with_refit(result.model_after, refit, signals), signals, split,
                                                       robot, max_evaluations)
    gap = plant_held_out_gap(stiffened, signals, split, robot)
    again = refit_with_plant(SimpleNamespace(named_effects=refit.effects, model_after=stiffened), signals, split,
                             score, max_evaluations // 2)
    return {"gap_after": gap.tolist(), "shrink": 1.0 - pooled_gap(gap) / pooled_gap(score.gap_before),
            "stiffness_factors": factors[:3].tolist(), "friction_factors": factors[3:].tolist(), "replays": replays,
            "refitted_again": {"gap_after": again.gap_after.tolist(), "shrink": again.shrink,
                               "refitted": again.refitted, "replays": again.replays}}


def rebased_refit(dataset, result, signals, split, score, refit, max_evaluations: int) -> dict:
    """One backfit round after a plant refit: the starting structure re-identified on the fit part of
    ``dataset`` with the refitted effects' share taken out of the joints and torques (the
    quasi-static replay's, as the workflow's backfit takes it), the refitted effects put on it, and
    those effects and the Coulomb forces refitted with the plant again
    (:func:`~studies.common.plant_scoring.refit_with_plant`, from the refitted values, at most
    ``max_evaluations`` replays). It reads only the record and the analysis's own values.

    The backfit re-identified the base around the effect as the quasi-static fit left it; the refit
    then moved the effect. Whether the base re-identified around the refitted effect lets a second
    refit close more. Returns the re-identified model's shrink (its Coulomb forces refitted as the
    report's score refits them), the second refit's gap (SI), shrink, values (SI) and replays; where
    the analysis named an effect the identification fits, ``reason`` instead."""
    from types import SimpleNamespace

    from kinematics import RavenII
    from simulation.discrepancy.fitting import residual
    from studies.common.discrepancy_runs import STARTING_STRUCTURE, raven_base_identifier
    from studies.common.plant_scoring import pooled_gap, refit_with_plant, with_refit

    if set(result.named_effects) != set(refit.effects):
        return {"reason": "the analysis named effects the plant refit does not refit: "
                          + ", ".join(n for n in result.named_effects if n not in refit.effects)}
    robot = RavenII(signals.arm, check_limits=False)
    refitted = with_refit(result.model_after, refit, signals)
    share = effect_share(refitted, refit.effects, signals, robot, plant=False)
    identified = raven_base_identifier(dataset, split.fit).identify(STARTING_STRUCTURE, share)
    for name in refit.effects:
        identified = identified.with_effect(refitted.params.effect(name))
    model = identified.with_offsets(identified.offsets + residual(identified, signals, robot, mask=split.fit).joint_offsets)
    scored, _, _ = with_plant_friction(model, signals, split, robot)
    before = pooled_gap(score.gap_before)
    again = refit_with_plant(SimpleNamespace(named_effects=refit.effects, model_after=model), signals, split, score,
                             max_evaluations)
    return {"rebased_shrink": 1.0 - pooled_gap(plant_held_out_gap(scored, signals, split, robot)) / before,
            "gap_after": again.gap_after.tolist(), "shrink": again.shrink, "refitted": again.refitted,
            "replays": again.replays}


DECOMPOSED_MODELS = ("the workflow's", "the workflow's base, the true effect", "the true base, the workflow's effect",
                     "the nothing-hidden record's starting model, the true effect", "the generator's")
"""Models :func:`plant_decomposed` scores: the blind analysis's final model (its base, the starting
structure as the backfit re-identified it around the named effect, and the named effect as fitted),
each part of it swapped for the generator's, the starting model identified on the same seed's
record with nothing hidden (the floor's) with the generator's effect, and the generator's own."""


def plant_decomposed(effect: str, seed: int, duration: float, size_factor: float = 1.0,
                     max_evaluations: int = PLANT_FRICTION_EVALUATIONS) -> dict:
    """A diagnostic that knows the generator: which part of the blind analysis's final model keeps
    its plant-scored shrink short of the floor's bound.

    ``effect``'s generated record is analysed blind and scored as its report scored it before the
    lag of a hysteresis was fitted by default (:func:`~studies.common.plant_scoring.score_with_plant`
    with the candidate's fixed lag, at most ``max_evaluations`` replays per Coulomb-force refit): the
    swapped models are scored with the lags they carry, so that only the swapped part differs.
    Where the analysis named ``effect`` (one of
    :data:`~studies.common.plant_scoring.PLANT_REFIT_EFFECTS`, whose generator carries one effect
    object of that name), each model of :data:`DECOMPOSED_MODELS` is scored the same way: its
    Coulomb forces refitted with the plant replay on the fit part, its held-out gap over the
    report's starting gap. Nothing of it feeds an analysis. Returns the names, the report's shrink
    and each model's shrink."""
    from kinematics import RavenII
    from simulation.discrepancy.replay import RavenModel
    from studies.common.discrepancy_runs import floor_record, run_on_raven_dataset
    from studies.common.plant_scoring import PLANT_REFIT_EFFECTS, score_with_plant

    if effect not in PLANT_REFIT_EFFECTS:
        raise ValueError(f"the decomposition swaps one of {', '.join(PLANT_REFIT_EFFECTS)}, not {effect!r}")
    dataset, generator = generated_record((effect,), seed, duration, size_factor)
    result, signals, split = run_on_raven_dataset(dataset)
    score = score_with_plant(result, signals, split, max_evaluations, fit_lag=False)
    out = {"named_effects": list(result.named_effects), "plant_scored": bool(score.applies)}
    if not score.applies or effect not in result.named_effects:
        return out
    del dataset
    robot = RavenII(signals.arm, check_limits=False)
    final = result.model_after
    true_effect, fitted_effect = generator.effect(effect), final.params.effect(effect)
    floor_model = floor_record(seed, duration)[3]
    models = dict(zip(DECOMPOSED_MODELS, (
        final, final.with_effect(true_effect), RavenModel(generator.with_effect(fitted_effect), final.offsets),
        floor_model.with_effect(true_effect), RavenModel(generator, final.offsets))))
    before = pooled(score.gap_before)
    shrinks = {}
    for name, model in models.items():
        refitted, _, _ = with_plant_friction(model, signals, split, robot, max_evaluations)
        shrinks[name] = 1.0 - pooled(plant_held_out_gap(refitted, signals, split, robot)) / before
    return {**out, "shrink": float(score.shrink), "shrinks": shrinks}


REBASED_MODELS = ("the nothing-hidden record's starting model",
                  "re-identified around the generator's share, quasi-static replay",
                  "re-identified around the generator's share, plant replay",
                  "re-identified around the starting model's share, quasi-static replay",
                  "re-identified around the starting model's share, plant replay")
"""Bases :func:`plant_rebased` gives the generator's effect: the starting structure identified on the
same seed's record with nothing hidden (the floor's), and the starting structure re-identified on
the effect's record, as one backfit round re-identifies it, with the generator's effect's share
removed from the joints, that share computed with the generator's own model or with the record's
starting model given the generator's effect (what a first backfit round has at best), by the
quasi-static replay (:meth:`~simulation.discrepancy.replay.RavenModel.replay`, as the workflow
computes it) or by the plant replay (its joints; its motor torques being the logged ones, the torque
share stays the quasi-static replay's)."""


def effect_share(model, effect, signals, robot, plant: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """What ``effect`` (a name, or several) adds to ``model``'s replayed joints (N, 3, SI) and motor
    torques (N, 3, or None) along ``signals``: by the quasi-static replay, or with ``plant`` the
    joints by the plant replay (:func:`~studies.common.plant_scoring.plant_joints`) and the torques
    as before."""
    from studies.common.plant_scoring import plant_joints

    without = model.without_extras([effect] if isinstance(effect, str) else list(effect))
    with_it, without_it = model.replay(signals, robot), without.replay(signals, robot)
    torque = None if with_it.torque is None else with_it.torque - without_it.torque
    if plant:
        return plant_joints(model, signals, robot) - plant_joints(without, signals, robot), torque
    return with_it.joints - without_it.joints, torque


STIFFNESS_FACTOR_RANGE = (0.9, 1.1)
"""Range of each positioning joint's factor on its identified cable stiffness in
:func:`with_plant_stiffness` (a round ten per cent: the bases :func:`plant_rebased` compares differ
by under one)."""

OUTPUT_ERROR_BASES = (REBASED_MODELS[0], REBASED_MODELS[4])
"""Bases of :data:`REBASED_MODELS` that :func:`plant_rebased` with ``output_error`` also scores with
their cable stiffness refitted with the plant replay: the nothing-hidden record's starting model
and the base a backfit can reach without the generator (the starting model's share, plant replay)."""


def with_plant_stiffness(model, signals, split, robot, max_evaluations: int = PLANT_REFIT_EVALUATIONS):
    """``model`` with its positioning joints' cable stiffness and Coulomb forces refitted with the
    plant replay on the fit part: :func:`~studies.common.plant_scoring.plant_fit` over one factor
    per joint on each, from 1, the stiffness factors in :data:`STIFFNESS_FACTOR_RANGE`, the force
    factors in :data:`~studies.common.plant_scoring.FRICTION_FACTOR_RANGE`. An output-error step
    on the base: the identification fits the stiffness with the quasi-static balance, equation
    error. Returns the model, the six factors (stiffness first) and the replays it took."""
    from studies.common.plant_scoring import FRICTION_FACTOR_RANGE

    stretch, friction = model.params.effect("cable_stretch"), model.params.effect("coulomb_friction")
    stiffness, forces = np.asarray(stretch.stiffness, dtype=float), np.asarray(friction.force, dtype=float)

    def build(x):
        return (model.with_effect(stretch.replace(stiffness=x[:3] * stiffness))
                .with_effect(friction.replace(force=np.r_[x[3:] * forces[:3], forces[3:]])))

    x, replays = plant_fit(model, build, np.ones(6), [STIFFNESS_FACTOR_RANGE] * 3 + [FRICTION_FACTOR_RANGE] * 3,
                           signals, split, robot, max_evaluations)
    return build(x), x, replays


def plant_rebased(effect: str, seed: int, duration: float, size_factor: float = 1.0,
                  max_evaluations: int = PLANT_FRICTION_EVALUATIONS, output_error: bool = False) -> dict:
    """A diagnostic that knows the generator: how well the starting structure can be re-identified
    on a record where ``effect`` acts, given the effect exactly.

    No analysis runs. ``effect``'s generated record is read as the blind analysis reads it, its
    starting structure identified on the fit part (the report's starting model), and each base of
    :data:`REBASED_MODELS` is given the generator's effect and scored as the report scores a model
    (:func:`~studies.common.plant_scoring.score_with_plant`: the Coulomb forces refitted with the
    plant replay on the fit part, at most ``max_evaluations`` replays, the held-out gap over the
    starting model's, so scored). The floor's bound (the plant-scored starting model of the
    nothing-hidden record over this one's) is beside them. A backfit that re-identifies the base
    around its named effect can reach the bases re-identified here at best: their shrinks tell how
    much of a shortfall from the bound the re-identification on the effect's record itself costs,
    and how much the share a backfit removes, computed from a base that still holds part of the
    effect, costs beside it. With ``output_error``, the bases of :data:`OUTPUT_ERROR_BASES` are also
    scored with their cable stiffness refitted with the plant replay on the fit part beside their
    Coulomb forces (:func:`with_plant_stiffness`): whether an output-error step on the base recovers
    what the re-identification costs. Returns each base's shrink, the bound, the identified values
    of the cable stretch, frictions and gravity scale (SI) of each base, the generator's and the
    starting model's, and with ``output_error`` each refitted base's shrink, factors and replays."""
    from kinematics import RavenII
    from simulation.discrepancy.fitting import residual
    from simulation.discrepancy.replay import RavenModel
    from studies.common.discrepancy_runs import (STARTING_STRUCTURE, floor_record, raven_base_identifier,
                                                 starting_model_on)
    from studies.common.plant_scoring import PLANT_REFIT_EFFECTS, plant_floor_gap

    if effect not in PLANT_REFIT_EFFECTS:
        raise ValueError(f"the re-identification gives the generator's {', '.join(PLANT_REFIT_EFFECTS)}, "
                         f"not {effect!r}")
    dataset, generator = generated_record((effect,), seed, duration, size_factor)
    signals, split, robot, identified = starting_model_on(dataset)
    base = raven_base_identifier(dataset, split.fit)

    def with_fitted_offsets(m):
        return m.with_offsets(m.offsets + residual(m, signals, robot, mask=split.fit).joint_offsets)

    true_effect = generator.effect(effect)
    start = with_fitted_offsets(identified)
    sources = {"generator's": with_fitted_offsets(RavenModel(generator, np.zeros(3))),
               "starting model's": with_fitted_offsets(start.with_effect(true_effect))}
    floor = floor_record(seed, duration)
    bases = {REBASED_MODELS[0]: floor[3]}
    for source, model in sources.items():
        for plant in (False, True):
            share = effect_share(model, effect, signals, robot, plant)
            name = f"re-identified around the {source} share, {'plant' if plant else 'quasi-static'} replay"
            bases[name] = base.identify(STARTING_STRUCTURE, share)

    def score(model):
        refitted, _, _ = with_plant_friction(model, signals, split, robot, max_evaluations)
        return pooled(plant_held_out_gap(refitted, signals, split, robot))

    before = score(start)
    shrinks = {name: 1.0 - score(with_fitted_offsets(b.with_effect(true_effect))) / before for name, b in bases.items()}
    values = {name: base_values(m) for name, m in
              {"the generator's": generator, "the starting model": start, **bases}.items()}
    out = {"shrinks": shrinks, "bound": 1.0 - pooled(plant_floor_gap(floor, max_evaluations)) / before,
           "values": values}
    if output_error:
        out["output_error"] = {}
        for name in OUTPUT_ERROR_BASES:
            refitted, factors, replays = with_plant_stiffness(with_fitted_offsets(bases[name].with_effect(true_effect)),
                                                              signals, split, robot)
            out["output_error"][name] = {
                "shrink": 1.0 - pooled(plant_held_out_gap(refitted, signals, split, robot)) / before,
                "stiffness_factors": factors[:3].tolist(), "friction_factors": factors[3:].tolist(),
                "replays": replays}
    return out


BASE_VALUES = (("cable_stretch", "stiffness"), ("cable_stretch", "hardening"), ("coulomb_friction", "force"),
               ("viscous_friction", "coefficient"), ("gravity_stretch", "load_scale"))
"""The identified quantities :func:`plant_rebased` reports per base (the positioning joints)."""


def base_values(params) -> dict:
    """``params``' (a :class:`~simulation.model.parameters.RavenParameters` or a model holding one)
    :data:`BASE_VALUES` on the positioning joints, SI, as ``{"effect.field": [3 values]}``."""
    params = getattr(params, "params", params)
    return {f"{e}.{f}": np.asarray(getattr(params.effect(e), f), dtype=float)[:3].tolist() for e, f in BASE_VALUES}


def pooled(rms: np.ndarray) -> float:
    """Pooled RMS (deg and mm) of per-joint RMS values in SI (the workflow's pooled gap)."""
    return float(np.sqrt(np.mean(np.square(np.asarray(rms) * TO_REPORT))))


def starting_model_residuals(hidden, seed: int, duration: float, size_factor: float = 1.0,
                             variants: bool = False, dynamic: bool = False) -> dict:
    """Held-out residual RMS per joint (SI) of the starting structure identified on the first half
    of the generated record of ``hidden``, replayed as the workflow replays it (``"replay"``) and,
    with ``variants``, as the other :data:`VARIANTS` replay it, with ``dynamic`` as the
    :data:`DYNAMIC_VARIANTS` do; also the held-out residual itself, the log rate and the encoders'
    floor of the generator."""
    from simulation.model.constants import RavenConstants
    from studies.common.discrepancy_runs import held_out_gap, held_out_residual, starting_model_on

    dataset, generator = generated_record(hidden, seed, duration, size_factor)
    signals, split, robot, model = starting_model_on(dataset)
    held_out = held_out_residual(model, signals, split, robot)
    out = {"rate_hz": 1.0 / float(np.median(np.diff(signals.time))), "sensor_floor": sensor_floor(generator),
           "held_out": held_out, "replay": np.sqrt(np.mean(np.square(held_out), axis=0))}
    if variants:
        coupling = RavenConstants(arm=dataset.arm).nominal_coupling()
        accelerations = (np.zeros_like(signals.truth), motor_side_acceleration(signals, coupling),
                         centred_acceleration(signals, skip_present=True), centred_acceleration(signals))
        replays = {name: signals.with_derivatives(acceleration=a) for name, a in zip(VARIANTS[1:], accelerations)}
        velocity, acceleration = identification_derivatives(signals)
        replays[VARIANTS[-1]] = signals.with_derivatives(velocity=velocity, acceleration=acceleration)
        out.update({name: held_out_gap(model, replayed, split, robot) for name, replayed in replays.items()})
    if dynamic:
        identified, true = DYNAMIC_VARIANTS
        out[identified] = plant_held_out_gap(model, signals, split, robot)
        exact = generator_model(generator, hidden, size_factor)
        out[true] = None if exact is None else plant_held_out_gap(exact, signals, split, robot)
    return out


def analyse_both(effect: str, seed: int, duration: float, size_factor: float = 1.0) -> dict:
    """The blind analysis of the generated record of ``effect``, with the workflow's replay and with
    the links' inertial loads from :func:`motor_side_acceleration`: for each, the effects named,
    the shrink, and the floor bound that replay's floor sets (the same seed's record with nothing
    hidden, replayed alike)."""
    from simulation.discrepancy.signals import RAVEN_UNITS
    from studies.common.discrepancy_runs import (floor_bound, held_out_gap, inertial_loads_from, run_on_raven_dataset,
                                                 starting_model_on)

    dataset, _ = generated_record((effect,), seed, duration, size_factor)
    nothing, _ = generated_record((), seed, duration)
    out = {}
    for name, loads in (("the workflow's replay", "joints"), ("motor-side inertial loads", "motors")):
        with inertial_loads_from(loads):
            result, _, _ = run_on_raven_dataset(dataset)
            signals, split, robot, model = starting_model_on(nothing)
        floor = held_out_gap(model, signals, split, robot)
        out[name] = {"named_effects": list(result.named_effects), "shrink": float(result.shrink),
                     "floor_bound": floor_bound(floor, result.gap_before, RAVEN_UNITS)}
    return out


def say_blind(effect: str, named, detail: str) -> None:
    """One line on a blind analysis of ``effect``'s record: what it named, then ``detail``."""
    print(f"    {effect} analysed blind: named {', '.join(named) or 'nothing'}; {detail}", flush=True)


def _numbers(values, digits: int = 5) -> str:
    return ", ".join(f"{v:.{digits}f}" for v in np.ravel(values))


def main(argv: list[str] | None = None) -> dict:
    from simulation.discrepancy.signals import RAVEN_UNITS
    from studies.common.discrepancy_runs import floor_bound
    from studies.discrepancy import parse_effect_list

    parser = script_parser(STUDY, __doc__)
    parser.add_argument("--seed", type=non_negative_int, default=30, help="first seed (>= 0)")
    parser.add_argument("--seeds", type=positive_int, default=5, help="number of seeds from --seed")
    parser.add_argument("--duration", type=record_length, default=DEFAULT_RECORD_S,
                        help="record length (s, at most six hours)")
    parser.add_argument("--effects", type=parse_effect_list, default=(), metavar="NAMES",
                        help="effects to hide on each seed, separated by commas, for their gap beside the floor")
    parser.add_argument("--size-factor", type=positive_float, default=1.0, help="the hidden effects' size (x default)")
    parser.add_argument("--analyse", action="store_true",
                        help="analyse each effect's record with the workflow's replay and with motor-side inertial loads")
    parser.add_argument("--dynamic", action="store_true",
                        help="also replay with the links' swing on their cables followed (the simulator's plant)")
    parser.add_argument("--rescore", action="store_true",
                        help="analyse each effect's record blind and score its models with the plant replay")
    parser.add_argument("--refine", action="store_true",
                        help="analyse each effect's record blind, score it as its report does, and refit its named "
                             "backlash, hysteresis or drift with the plant replay")
    parser.add_argument("--refine-rebase", action="store_true",
                        help="with --refine: then re-identify the starting structure around the refitted effects "
                             "and refit them again with the plant replay (half the budget)")
    parser.add_argument("--refine-stiffness", action="store_true",
                        help="with --refine: then refit the cable stiffness with the plant replay (output error) and "
                             "the named effects again (half the budget)")
    parser.add_argument("--decompose", action="store_true",
                        help="analyse each effect's record blind and score its final model with its base and its "
                             "named effect each swapped for the generator's (a diagnostic that knows the generator)")
    parser.add_argument("--rebase", action="store_true",
                        help="re-identify each effect's record's starting structure around the generator's effect's "
                             "share and score it with that effect (a diagnostic that knows the generator; no analysis)")
    parser.add_argument("--output-error", action="store_true",
                        help="with --rebase: also refit two bases' cable stiffness with the plant replay")
    parser.add_argument("--out", type=Path, default=None, help="write the figures to this JSON file")
    args = parser.parse_args(argv)
    for flag in ("refine_rebase", "refine_stiffness"):
        if getattr(args, flag) and not args.refine:
            parser.error(f"--{flag.replace('_', '-')} goes with --refine")
    if args.output_error and not args.rebase:
        parser.error("--output-error goes with --rebase")

    effects = tuple(e for e in args.effects if e != "none")
    labels = [f"{low:g}-{high:g} Hz" if np.isfinite(high) else f"{low:g} Hz-half the rate" for low, high in BANDS_HZ]
    out = {"seeds": list(range(args.seed, args.seed + args.seeds)), "duration_s": args.duration,
           "size_factor": args.size_factor, "bands_hz": [list(b) for b in BANDS_HZ], "runs": {}}
    print(f"held-out residual of the identified starting model, nothing hidden, {args.duration:g} s records "
          "(deg, deg, mm; pooled in deg and mm)")
    for seed in out["seeds"]:
        floor = starting_model_residuals((), seed, args.duration, variants=True, dynamic=args.dynamic)
        sensors = floor["sensor_floor"]
        bands = band_rms(floor["held_out"], floor["rate_hz"])
        white = white_band_rms(sensors, floor["rate_hz"])
        run = {"floor": floor["replay"].tolist(), "floor_pooled": pooled(floor["replay"]),
               "sensor_floor": sensors.tolist(), "sensor_floor_pooled": pooled(sensors),
               "bands": bands.tolist(), "sensor_bands": white.tolist(),
               "variants": {name: {"floor": floor[name].tolist(), "floor_pooled": pooled(floor[name])}
                            for name in VARIANTS[1:]},
               "effects": {}}
        print(f"seed {seed}: floor {_numbers(floor['replay'] * TO_REPORT)} (pooled {run['floor_pooled']:.5f}); "
              f"encoders {_numbers(sensors * TO_REPORT)} (pooled {run['sensor_floor_pooled']:.5f})")
        for j, joint in enumerate(("shoulder", "elbow", "z_ins")):
            parts = "; ".join(f"{label} {b:.5f} (encoders {w:.5f})"
                              for label, b, w in zip(labels, bands[j] * TO_REPORT[j], white[j] * TO_REPORT[j]))
            print(f"    {joint}: {parts}")
        for name in VARIANTS[1:]:
            print(f"    replayed with {name}: {_numbers(floor[name] * TO_REPORT)} "
                  f"(pooled {run['variants'][name]['floor_pooled']:.5f})", flush=True)
        for name in DYNAMIC_VARIANTS if args.dynamic else ():
            run["variants"][name] = {"floor": floor[name].tolist(), "floor_pooled": pooled(floor[name])}
            print(f"    {name}: {_numbers(floor[name] * TO_REPORT)} (pooled {pooled(floor[name]):.5f})", flush=True)
        for effect in effects:
            residuals = starting_model_residuals((effect,), seed, args.duration, size_factor=args.size_factor,
                                                 dynamic=args.dynamic)
            gap = residuals["replay"]
            bound = floor_bound(floor["replay"], gap, RAVEN_UNITS)
            run["effects"][effect] = {"gap_before": gap.tolist(), "gap_before_pooled": pooled(gap),
                                      "bound": bound}
            print(f"    {effect} hidden: starting model's held-out gap {_numbers(gap * TO_REPORT)} (pooled "
                  f"{pooled(gap):.5f}); 1 - floor / gap = {100 * bound:.1f} %", flush=True)
            if args.dynamic:
                name = DYNAMIC_VARIANTS[0]
                dynamic_gap = residuals[name]
                dynamic_bound = floor_bound(floor[name], dynamic_gap, RAVEN_UNITS)
                run["effects"][effect]["dynamic"] = {"gap_before": dynamic_gap.tolist(),
                                                     "gap_before_pooled": pooled(dynamic_gap), "bound": dynamic_bound}
                print(f"    {effect} hidden, {name}: held-out gap {_numbers(dynamic_gap * TO_REPORT)} (pooled "
                      f"{pooled(dynamic_gap):.5f}); 1 - floor / gap = {100 * dynamic_bound:.1f} %", flush=True)
                exact, exact_floor = residuals[DYNAMIC_VARIANTS[1]], floor[DYNAMIC_VARIANTS[1]]
                if exact is None:
                    run["effects"][effect]["dynamic"]["generator"] = None
                    print(f"    {effect} hidden, {DYNAMIC_VARIANTS[1]}: not replayed (the generator draws "
                          f"{effect} anew at each homing and holds no value of it)", flush=True)
                else:
                    run["effects"][effect]["dynamic"]["generator"] = {
                        "gap": exact.tolist(), "gap_pooled": pooled(exact), "floor_pooled": pooled(exact_floor)}
                    print(f"    {effect} hidden, {DYNAMIC_VARIANTS[1]}: held-out gap {_numbers(exact * TO_REPORT)} "
                          f"(pooled {pooled(exact):.5f}, against {pooled(exact_floor):.5f} with nothing hidden)",
                          flush=True)
                if effect in DYNAMIC_FITS:
                    run["effects"][effect]["dynamic"]["oracle"] = fitted = dynamic_oracle(
                        effect, seed, args.duration, args.size_factor)
                    print(f"    {effect} fitted with the {name} with the Coulomb forces ({fitted['replays']} replays): "
                          f"{_numbers(np.asarray(fitted['fitted']['half_width']) * TO_REPORT)}; held-out gap "
                          f"{_numbers(np.asarray(fitted['gap_after']) * TO_REPORT)}; closes "
                          f"{100 * fitted['shrink']:.1f} % of the {name}'s gap", flush=True)
            if args.rescore:
                run["effects"][effect]["rescored"] = scored = plant_rescored(effect, seed, args.duration,
                                                                             args.size_factor)
                g = scored["plant_gaps"]
                print(f"    {effect} analysed blind: named {', '.join(scored['named_effects']) or 'nothing'}, shrink "
                      f"{100 * scored['shrink']:.1f} %; scored with the plant replay: gap {g['start']:.5f} to "
                      f"{g['final']:.5f} ({100 * scored['plant_shrink']:.1f} %), Coulomb forces refitted with it "
                      f"{g['start refined']:.5f} to {g['final refined']:.5f} ({100 * scored['plant_shrink_refined']:.1f} %)",
                      flush=True)
            if args.refine:
                run["effects"][effect]["refined"] = refined = plant_refined(effect, seed, args.duration,
                                                                            args.size_factor,
                                                                            rebase=args.refine_rebase,
                                                                            stiffness=args.refine_stiffness)
                say_blind(effect, refined["named_effects"], (
                    f"reported shrink (plant replay) {100 * refined['shrink']:.1f} %; its "
                    f"{', '.join(refined['refined'])} refitted with the plant replay ({refined['replays']} replays): "
                    f"{100 * refined['refined_shrink']:.1f} %") if "refined_shrink" in refined
                    else "nothing to refit with the plant replay")
                again = refined.get("rebased")
                if again is not None:
                    print(f"    {effect}: the base re-identified around the refitted values "
                          + (f"{100 * again['rebased_shrink']:.1f} %; refitted again ({again['replays']} replays): "
                             f"{100 * again['shrink']:.1f} %" if "reason" not in again else f"not tried: {again['reason']}"),
                          flush=True)
                stiffened = refined.get("stiffened")
                if stiffened is not None:
                    again = stiffened["refitted_again"]
                    print(f"    {effect}: the cable stiffness then refitted with the plant replay "
                          f"({stiffened['replays']} replays, factors "
                          + ", ".join(f"{f:.4f}" for f in stiffened["stiffness_factors"])
                          + f"): {100 * stiffened['shrink']:.1f} %; {', '.join(refined['refined'])} refitted again "
                          f"({again['replays']} replays): {100 * again['shrink']:.1f} %", flush=True)
            if args.decompose:
                run["effects"][effect]["decomposed"] = parts = plant_decomposed(effect, seed, args.duration,
                                                                                args.size_factor)
                say_blind(effect, parts["named_effects"], (
                    f"reported shrink (plant replay) {100 * parts['shrink']:.1f} %; "
                    + "; ".join(f"{name} {100 * v:.1f} %" for name, v in parts["shrinks"].items()))
                    if "shrinks" in parts else "nothing to decompose")
            if args.rebase:
                run["effects"][effect]["rebased"] = rebased = plant_rebased(effect, seed, args.duration,
                                                                            args.size_factor,
                                                                            output_error=args.output_error)
                print(f"    {effect} given exactly, scored with the plant replay (bound "
                      f"{100 * rebased['bound']:.1f} %): "
                      + "; ".join(f"{name} {100 * v:.1f} %" for name, v in rebased["shrinks"].items()), flush=True)
                for name, refit in rebased.get("output_error", {}).items():
                    print(f"    {name}, cable stiffness refitted with the plant replay ({refit['replays']} replays, "
                          "factors " + ", ".join(f"{f:.4f}" for f in refit["stiffness_factors"])
                          + f"): {100 * refit['shrink']:.1f} %", flush=True)
            if args.analyse:
                run["effects"][effect]["analyses"] = analyses = analyse_both(effect, seed, args.duration,
                                                                             args.size_factor)
                for name, a in analyses.items():
                    print(f"    {effect} analysed with {name}: named {', '.join(a['named_effects']) or 'nothing'}; "
                          f"shrink {100 * a['shrink']:.1f} % (floor bound {100 * a['floor_bound']:.1f} %)", flush=True)
        out["runs"][seed] = run
    if args.out is not None:
        write_json(args.out, out)
    return out


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
