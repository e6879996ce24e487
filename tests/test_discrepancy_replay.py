"""The RAVEN-II replay of the discrepancy workflow: the loads, torques and restarts new candidates rely on.

A short simulated record (the starting structure only) is replayed with and without one candidate
at a time, and what the candidate adds is checked against an independent computation: the
kinematics model's loads, the friction law written out, the replay of the whole record.
"""

from __future__ import annotations

import numpy as np
import pytest

from kinematics import RavenII
from simulation.discrepancy import MeasuredSignals
from simulation.discrepancy.candidates import RAVEN_LIBRARY, library
from simulation.discrepancy.replay import MOTOR_STICTION_SPEED, RavenModel
from simulation.model.effects import Hysteresis, MotorFriction, TransmissionError
from studies.common.discrepancy_runs import generate_measured, generator_parameters, raven_library


@pytest.fixture(scope="module")
def dataset():
    """20 s of random motion of the starting structure, re-homed once (a hidden per-homing offset)."""
    return generate_measured(("homing_offset",), seed=5, duration=20.0)[0]


@pytest.fixture(scope="module")
def record(dataset):
    """The signals of :func:`dataset`, the starting structure at the generator's values and the arm."""
    signals = MeasuredSignals.from_dataset(dataset)
    model = RavenModel(generator_parameters(()), np.zeros(3))
    return signals, model, RavenII(signals.arm, check_limits=False)


def test_payload_loads_are_the_kinematics_loads_of_one_more_kilogram(record):
    signals, _, robot = record
    per_kg, _ = signals.payload_loads(robot)
    q6 = np.column_stack([signals.truth, signals.tool_joints])
    expected = robot.gravity_torques(q6, payload_kg=0.7) - robot.gravity_torques(q6, payload_kg=0.0)
    np.testing.assert_allclose(0.7 * per_kg, expected, rtol=1e-9, atol=1e-12)
    # a hanging mass loads the shoulder and the insertion axis
    assert np.all(np.sqrt(np.mean(per_kg ** 2, axis=0))[[0, 2]] > 0.1)


def test_an_undeclared_payload_stretches_the_cables_and_loads_the_motors(record):
    signals, model, robot = record
    without, heavier = model.replay(signals, robot), model.with_payload(0.5).replay(signals, robot)
    assert model.with_payload(0.5).enabled_effects[-1] == "payload"
    # more tension: the motors hold more torque and the links sag further along the load
    gravity_per_kg, _ = signals.payload_loads(robot)
    tension_change = heavier.tension - without.tension
    moving = np.abs(gravity_per_kg) > 0.05
    assert np.all(np.sign(tension_change[moving]) == np.sign(gravity_per_kg[moving]))
    assert np.max(np.abs(heavier.joints - without.joints)) > 1e-4


def test_a_transmission_error_scales_each_motors_column_of_the_coupling_as_the_simulator_does(record):
    # with a rigid cable the joints are the cable ends and the motors carry the links' tension:
    # both go through the simulator's own coupling of the arm (the engine's table), whose column j
    # is the nominal one over 1 + ratio_error[j]
    from simulation.engine.tables import build_tables

    signals, model, robot = record
    error = TransmissionError(ratio_error=[0.004, -0.003, 0.005])
    rigid = RavenModel(model.params.without("cable_stretch").with_effect(error), np.array([0.01, -0.02, 0.003]))
    state = rigid.replay(signals, robot)
    coupling = build_tables(rigid.params, robot).coupling_true
    np.testing.assert_allclose(state.joints - rigid.offsets, signals.drive @ coupling.T, rtol=0, atol=1e-12)
    c = rigid.params.constants
    ratio, gear = c.transmission_ratio[:3], c.gearbox[:3]
    motor_side = (state.tension @ coupling + c.motor_inertia[:3] * ratio ** 2 * signals.drive_acceleration
                  + c.motor_damping[:3] * ratio ** 2 * signals.drive_velocity)
    np.testing.assert_allclose(state.torque, motor_side * gear / ratio, rtol=1e-12, atol=1e-12)
    # the shoulder motor's error moves the elbow too: the elbow's cable end follows the shoulder motor
    shoulder_only = RavenModel(rigid.params.with_effect(TransmissionError(ratio_error=[0.004, 0.0, 0.0])),
                               rigid.offsets).replay(signals, robot)
    nominal = RavenModel(rigid.params.without("transmission_error"), rigid.offsets).replay(signals, robot)
    moved = np.max(np.abs(shoulder_only.joints - nominal.joints), axis=0)
    assert moved[0] > 1e-5 and moved[1] > 1e-5, moved


def test_replayed_motor_friction_opposes_the_motor_motion_with_its_datasheet_torque(record):
    signals, model, robot = record
    coulomb = np.array([4e-3, 5e-3, 6e-3, 0, 0, 0, 0])
    friction = MotorFriction(coulomb=coulomb, gearbox_loss=np.zeros(7))
    added = model.with_effect(friction).replay(signals, robot).torque - model.replay(signals, robot).torque
    c = model.params.constants
    speed = signals.drive_velocity
    fast = np.abs(speed) > 5 * MOTOR_STICTION_SPEED
    # at the gearbox output: the shaft friction times the gearbox ratio, against the motor velocity
    expected = coulomb[:3] * c.gearbox[:3] * np.sign(speed)
    np.testing.assert_allclose(added[fast], expected[fast], rtol=1e-3)
    # joints are driven by the measured motor positions, so motor friction does not move them
    np.testing.assert_array_equal(model.with_effect(friction).replay(signals, robot).joints,
                                  model.replay(signals, robot).joints)


def test_the_replay_of_the_first_samples_is_the_first_samples_of_the_replay(record):
    signals, model, robot = record
    n = len(signals) // 2
    whole, head = model.replay(signals, robot), model.replay(signals.head(n), robot)
    np.testing.assert_allclose(head.joints, whole.joints[:n], rtol=0, atol=1e-12)
    np.testing.assert_allclose(head.torque, whole.torque[:n], rtol=0, atol=1e-12)


def test_a_rehoming_restarts_the_replay_as_if_the_record_began_there(record):
    signals, model, robot = record
    assert np.count_nonzero(signals.restarts) == 2
    start = np.flatnonzero(signals.restarts)[1]
    # the encoders were re-registered there: nothing before the re-homing carries over (play,
    # friction stick, derivatives across the jump of the motor positions)
    whole = model.replay(signals, robot)
    later = model.replay(signals.select(np.arange(len(signals)) >= start), robot)
    np.testing.assert_allclose(whole.joints[start:], later.joints, rtol=0, atol=1e-12)
    np.testing.assert_allclose(whole.torque[start:], later.torque, rtol=0, atol=1e-9)
    assert np.all(np.abs(signals.drive_velocity[start]) < 1e-9)


def test_the_library_holds_ten_candidates_and_says_why_one_cannot_apply(record):
    signals, model, _ = record
    candidates = {c.name: c for c in library(signals)}
    assert len(RAVEN_LIBRARY) >= 10 and set(RAVEN_LIBRARY) <= set(candidates)
    applies, reason = candidates["gravity_model_error"].applies(model, signals, "gravity_model_error")
    assert not applies and "gravity compensation" in reason
    applies, _ = candidates["payload"].applies(model, signals, "payload")
    assert applies
    already, reason = candidates["coulomb_friction"].applies(model, signals, "coulomb_friction")
    assert not already and "already in the model" in reason


def _elbow_scaled(model, effect, field, factor):
    """``model`` with one per-joint parameter of ``effect`` multiplied by ``factor`` on the elbow only."""
    from dataclasses import replace as with_values

    old = model.params.effect(effect)
    scaled = with_values(old, **{field: getattr(old, field) * np.array([1.0, factor, 1.0])})
    return with_values(model, params=model.params.with_effect(scaled))


def _replay_remembering_nothing(model, record, monkeypatch):
    """The replay of ``model`` with the cable-series memo emptied and kept empty."""
    from simulation.discrepancy import replay as replay_module

    signals, _, robot = record
    monkeypatch.setattr(replay_module, "_SERIES", replay_module._SeriesMemo(size=0))
    return model.replay(signals, robot)


def test_remembered_cable_series_are_those_of_a_fresh_run_and_follow_every_input(record, monkeypatch):
    from simulation.discrepancy import replay as replay_module

    signals, model, robot = record
    loops = Hysteresis(stiffness=np.array([40.0, 30.0, 400.0]), beta=np.array([400.0, 400.0, 4000.0]),
                       gamma=np.array([100.0, 100.0, 1000.0]))
    hysteretic = RavenModel(model.params.with_effect(loops), np.zeros(3))
    monkeypatch.setattr(replay_module, "_SERIES", replay_module._SeriesMemo())
    first = hysteretic.replay(signals, robot)
    again = hysteretic.replay(signals, robot)
    # a stiffer elbow cable changes the elbow only, and what is remembered follows it
    stiffer = _elbow_scaled(hysteretic, "cable_stretch", "stiffness", 1.5)
    changed = stiffer.replay(signals, robot)
    fresh_changed = _replay_remembering_nothing(stiffer, record, monkeypatch)
    for name in ("joints", "tension", "torque"):
        np.testing.assert_array_equal(getattr(first, name), getattr(again, name))
        np.testing.assert_array_equal(getattr(changed, name), getattr(fresh_changed, name))
    assert np.max(np.abs(changed.joints[:, 1] - first.joints[:, 1])) > 1e-6
    assert np.max(np.abs(changed.tension[:, 1] - first.tension[:, 1])) > 1e-6
    np.testing.assert_array_equal(changed.joints[:, [0, 2]], first.joints[:, [0, 2]])


@pytest.mark.parametrize("effects", [(), ("hysteresis",), ("drift",), ("hysteresis", "motor_friction")])
def test_replayed_tensions_and_torques_are_the_cable_law_and_the_motor_loads_of_the_whole_table(record, effects):
    from simulation.model.laws import cable_tension_curve

    signals, model, robot = record
    for name in effects:
        model = model.with_effect(generator_parameters((name,)).effect(name))
    state = model.replay(signals, robot)
    p, c = model.params, model.params.constants
    law, hysteresis = p.effect("cable_stretch"), p.effect("hysteresis")
    # the memoised joint-by-joint tensions are the cable law over the whole table, to the last bit
    tension = cable_tension_curve(state.stretch, law.stiffness, law.hardening)
    if p.is_enabled("drift"):
        d = p.effect("drift")
        dose = d.time_scale / 3600.0 * (signals.travel + d.payload_gain * signals.loaded_travel) / d.reference_speed
        tension = tension / (1.0 + d.stiffness_loss * dose)
    if hysteresis.enabled:
        # the hysteretic share: what the replay without it lacks, given the same stretch, is k_h z with |z| <= 1/(beta + gamma)
        hysteretic = state.tension - tension
        assert np.all(np.abs(hysteretic) <= hysteresis.stiffness / (hysteresis.beta + hysteresis.gamma) * (1 + 1e-9))
        assert np.max(np.abs(hysteretic)) > 0.0
    else:
        np.testing.assert_array_equal(state.tension, tension)
    if not p.is_enabled("motor_friction"):
        # and the motor torques are the tensions through the coupling plus the motors' own loads
        ratio = c.transmission_ratio[:3]
        coupling = p.effect("coupling")
        from simulation.model.laws import coupling_matrix

        a = coupling_matrix(*(np.asarray(c.cable_coupling) + coupling.delta))
        motor_side = (state.tension @ a + c.motor_inertia[:3] * ratio ** 2 * signals.drive_acceleration
                      + c.motor_damping[:3] * ratio ** 2 * signals.drive_velocity)
        np.testing.assert_array_equal(state.torque, motor_side * c.gearbox[:3] / ratio)


def test_a_fingerprint_collision_is_caught_by_the_element_wise_comparison(record, monkeypatch):
    from simulation.discrepancy import replay as replay_module

    signals, model, robot = record
    # every input set looks alike to the index: only the exact comparison tells them apart
    monkeypatch.setattr(replay_module, "_series_fingerprint", lambda *arrays: (0.0,) * 6)
    monkeypatch.setattr(replay_module, "_SERIES", replay_module._SeriesMemo())
    model.replay(signals, robot)
    # more dry friction on the elbow changes one input array of the elbow's series, no scalar
    stickier = _elbow_scaled(model, "coulomb_friction", "force", 3.0)
    remembered = stickier.replay(signals, robot)
    fresh = _replay_remembering_nothing(stickier, record, monkeypatch)
    np.testing.assert_array_equal(remembered.joints, fresh.joints)
    assert np.max(np.abs(fresh.joints[:, 1] - model.replay(signals, robot).joints[:, 1])) > 1e-6


def _bouc_wen_sub_steps(z, change, beta, gamma):
    """The replay's explicit Euler sub-steps of the Bouc-Wen state, one by one (at most a tenth of
    the width ``1 / (beta + gamma)`` each): dz/ds = 1 - beta sgn(ds) z - gamma |z|."""
    steps = 1 + int(abs(change) * (beta + gamma) * 10.0)
    ds = change / steps
    for _ in range(steps):
        z += ds * (1.0 - beta * np.sign(ds) * z - gamma * abs(z))
    return z


def test_a_replay_told_to_follow_the_hysteresis_lag_drives_the_state_with_the_lagged_stretch(record):
    # a diagnostic's replay (studies/discrepancy_replay_bias.py): the Bouc-Wen state follows the
    # stretch through a first-order lag of the hysteresis's response time, as in the simulator
    from simulation.model.laws import cable_tension_curve

    signals, model, robot = record
    loops = Hysteresis(stiffness=np.array([40.0, 30.0, 400.0]), beta=np.array([400.0, 400.0, 4000.0]),
                       gamma=np.array([100.0, 100.0, 1000.0]), response_time=np.array([0.05, 0.1, 0.02]))
    lagged = RavenModel(model.params.with_effect(loops), np.zeros(3), follows_hysteresis_lag=True).replay(signals,
                                                                                                        robot)
    plain = RavenModel(model.params.with_effect(loops), np.zeros(3)).replay(signals, robot)
    assert np.max(np.abs(lagged.joints - plain.joints)) > 1e-6  # the lag changes the replay
    # without a lag to follow, the flag changes nothing, to the last bit
    instant = loops.replace(response_time=np.zeros(3))
    np.testing.assert_array_equal(
        RavenModel(model.params.with_effect(instant), np.zeros(3), follows_hysteresis_lag=True).replay(signals,
                                                                                                     robot).joints,
        RavenModel(model.params.with_effect(instant), np.zeros(3)).replay(signals, robot).joints)
    law = model.params.effect("cable_stretch")
    for j in range(3):
        # the state integrated again, step by step, from the replay's own stretch through the lag; a
        # restart begins at the stretch of the measured link position, from which the link may slip
        stretch = lagged.stretch[:, j]
        z = np.zeros_like(stretch)
        state = followed = 0.0
        for k in range(len(stretch)):
            if signals.restarts[k]:
                state, followed = 0.0, stretch[k] + lagged.joints[k, j] - signals.truth[k, j]
            step = 0.0 if k == 0 else signals.time[k] - signals.time[k - 1]
            fraction = 1.0 if k == 0 else 1.0 - np.exp(-step / loops.response_time[j])
            state = _bouc_wen_sub_steps(state, fraction * (stretch[k] - followed), loops.beta[j], loops.gamma[j])
            followed += fraction * (stretch[k] - followed)
            z[k] = state
        hysteretic = lagged.tension[:, j] - cable_tension_curve(stretch, law.stiffness[j], law.hardening[j])
        np.testing.assert_allclose(hysteretic, loops.stiffness[j] * z, rtol=1e-7,
                                   atol=1e-9 * loops.stiffness[j] / (loops.beta[j] + loops.gamma[j]))


@pytest.mark.parametrize("widths", [0.01, 0.3, 2.0, 40.0, 3000.0])
@pytest.mark.parametrize("start", [-0.9, -0.2, 0.0, 0.5, 0.99])
@pytest.mark.parametrize("direction", [1.0, -1.0])
def test_the_hysteresis_state_after_a_long_stretch_change_is_its_sub_steps_summed(widths, start, direction):
    from simulation.discrepancy.replay import _bouc_wen_after

    width = 2e-5  # a fitted width near the candidate's lower bound, where a sample moves many widths
    beta, gamma = 0.3 / width, 0.7 / width
    z0 = start * width
    change = direction * widths * width
    z = _bouc_wen_after(z0, change, beta, gamma)
    assert z == pytest.approx(_bouc_wen_sub_steps(z0, change, beta, gamma), rel=1e-12, abs=1e-12 * width)
    if widths >= 40.0:
        # many widths on, the state sits at its bound on the side of the motion
        assert z == pytest.approx(direction * width, rel=1e-12)
    assert _bouc_wen_after(z0, 0.0, beta, gamma) == z0


def _replay_rms_at(log_rate: float) -> np.ndarray:
    """Joint RMS residual (rad, rad, m) of the simulator's own parameters replayed on 30 s of random
    motion logged at ``log_rate`` (Hz), offsets fitted on the first half."""
    from simulation.discrepancy.fitting import residual
    from simulation.engine.scenarios import powered_on, record_random_test
    from simulation.recordings.recording import recording_to_dataset

    params = generator_parameters(())
    robot = powered_on(params, seed=30, log_rate=log_rate, truth_rate=log_rate)
    kinematics = RavenII(params.arm, check_limits=False)
    signals = MeasuredSignals.from_dataset(recording_to_dataset(record_random_test(robot, 30.0, seed=31), kinematics))
    model = RavenModel(params, np.zeros(3))
    first_half = np.arange(len(signals)) < len(signals) // 2
    model = model.with_offsets(residual(model, signals, kinematics, mask=first_half).joint_offsets)
    joints = residual(model, signals, kinematics, offsets=np.zeros(3)).joints
    return np.sqrt(np.mean(joints ** 2, axis=0))


def test_the_replay_of_a_fast_log_is_as_close_as_that_of_a_30_hz_log_of_the_same_motion():
    # the derivatives behind the loads span the same time at any log rate: differentiated over a
    # fixed count of samples, the encoders' quantization at 300 Hz left 20 times the 30 Hz residual
    slow, fast = _replay_rms_at(30.0), _replay_rms_at(300.0)
    np.testing.assert_allclose(fast, slow, rtol=0.1)


@pytest.mark.parametrize("step, velocity, acceleration", [(0.034, 5, 7), (1 / 30, 5, 7), (1 / 300, 41, 61),
                                                          (0.001, 134, 201), (0.1, 2, 3), (1.0, 2, 2)])
def test_derivative_windows_span_the_same_time_at_any_log_rate(step, velocity, acceleration):
    n = 200
    time = np.arange(n) * step
    signals = MeasuredSignals(time=time, truth=np.zeros((n, 3)), reported=np.zeros((n, 3)), drive=np.zeros((n, 3)),
                              torque=None, payload_kg=np.zeros(n), homing=np.zeros(n, dtype=int),
                              joint_names=("a", "b", "c"), units=("rad", "rad", "m"))
    assert (signals.smoothing, signals.acceleration_window) == (velocity, acceleration)
    # a selection keeps the windows of the whole record
    part = signals.select(np.arange(n) < 50)
    assert (part.smoothing, part.acceleration_window) == (velocity, acceleration)


@pytest.mark.parametrize("window", [0, -3, 2.5, True])
def test_a_derivative_window_that_is_not_a_positive_count_of_samples_is_refused(window):
    n = 30
    with pytest.raises(ValueError, match=r"^smoothing must be a positive number of samples, got "):
        MeasuredSignals(time=np.arange(n) * 0.03, truth=np.zeros((n, 1)), reported=np.zeros((n, 1)),
                        drive=np.zeros((n, 1)), torque=None, payload_kg=np.zeros(n), homing=np.zeros(n, dtype=int),
                        joint_names=("a",), units=("rad",), smoothing=window)


def test_derivatives_given_set_the_viscous_and_inertial_loads_and_nothing_else(record):
    signals, model, robot = record
    gravity, inertial = signals.link_loads(robot)
    still = signals.with_derivatives(acceleration=np.zeros_like(signals.truth))
    still_gravity, still_inertial = still.link_loads(robot)
    np.testing.assert_array_equal(still_gravity, gravity)
    np.testing.assert_array_equal(still_inertial, 0.0)
    # the inertial loads are linear in the acceleration: M(q) (2 q'') = 2 M(q) q''
    _, doubled = signals.with_derivatives(acceleration=2.0 * signals.acceleration).link_loads(robot)
    np.testing.assert_allclose(doubled, 2.0 * inertial, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(still.velocity, signals.velocity)
    np.testing.assert_array_equal(still.restarts, signals.restarts)
    # the cables stretch under the links' inertia, so the replayed joints move with it; the
    # signals it was made from keep their own acceleration
    assert np.max(np.abs(model.replay(still, robot).joints - model.replay(signals, robot).joints)) > 1e-7
    assert np.any(signals.acceleration != 0.0) and signals.link_loads(robot)[1] is inertial
    # a velocity given moves the viscous load (coefficient times velocity) and keeps the acceleration
    faster = signals.with_derivatives(velocity=2.0 * signals.velocity)
    np.testing.assert_array_equal(faster.acceleration, signals.acceleration)
    np.testing.assert_array_equal(faster.travel, signals.travel)
    viscous = model.params.effect("viscous_friction").coefficient
    rigid = RavenModel(model.params.without("cable_stretch"), np.zeros(3))
    np.testing.assert_allclose(rigid.replay(faster, robot).tension - rigid.replay(signals, robot).tension,
                               viscous * signals.velocity, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name, change, message", [
    ("acceleration", lambda a: a[:, :2], r"acceleration must have the shape of the joints"),
    ("velocity", lambda a: np.where(np.arange(a.shape[0])[:, None] == 3, np.nan, a), "velocity is not finite at sample 3"),
    ("velocity", None, "needs a velocity, an acceleration or both"),
])
def test_derivatives_of_another_shape_or_not_finite_are_refused(record, name, change, message):
    signals, _, _ = record
    with pytest.raises(ValueError, match=message):
        signals.with_derivatives(**({} if change is None else {name: change(getattr(signals, name))}))


@pytest.mark.parametrize("layout", ["C", "rows of C", "F", "every other row"])
def test_column_means_are_numpys_to_the_last_bit_in_every_layout(layout):
    from simulation.discrepancy.fitting import column_means

    rng = np.random.default_rng(4)
    for rows in (1, 2, 7, 1000, 4801):
        # columns of very different sizes and offsets, where the order of the additions shows
        table = rng.normal(size=(rows, 3)) * np.array([1e-6, 3.0, 1e4]) + np.array([0.3, -7.0, 1e5])
        values = {"C": table, "rows of C": table[rows // 3:], "F": np.asfortranarray(table),
                  "every other row": table[::2]}[layout]
        assert np.array_equal(column_means(values), values.mean(axis=0))


@pytest.mark.parametrize("options, generator_lag, scorer_lag, fitted", [
    # the generator's lag is the simulator's 0.05 s, the candidate's a round 0.1 s: none shared by default
    ([], 0.05, 0.1, False),
    (["--response-time", "0"], 0.0, 0.0, False),
    (["--response-time", "0", "--scorer-lag", "0.1"], 0.0, 0.1, False),
    (["--scorer-lag", "0.2", "--backfit-patience", "2"], 0.05, 0.2, False),
    (["--scorer-lag", "0.05"], 0.05, 0.05, False),
    # a scorer that fits its lag leaves the candidate's constant alone, whatever the generator's
    (["--response-time", "0.2", "--fit-scorer-lag"], 0.2, 0.1, True),
    (["--fit-scorer-lag"], 0.05, 0.1, True),
    # a replay that fits its lag leaves the candidate's constant alone too
    (["--fit-replay-lag"], 0.05, 0.1, False),
    (["--fit-replay-lag", "--fit-scorer-lag", "--response-time", "0.2"], 0.2, 0.1, True),
    # the motors' inertial loads change what the records are replayed with, not a lag
    (["--motor-side-loads", "--fit-scorer-lag"], 0.05, 0.1, True),
])
def test_the_shape_study_gives_the_generator_and_the_scorer_their_lags(monkeypatch, tmp_path, options,
                                                                        generator_lag, scorer_lag, fitted):
    import studies.common.discrepancy_runs as runs
    import studies.discrepancy as command
    from simulation.discrepancy import candidates
    from studies import discrepancy_hysteresis_shape as study
    from studies.common.discrepancy_runs import inertial_loads_from, with_motor_side_loads

    class ReachedTheAnalysis(Exception):
        pass

    seen = {}

    def generate(hidden, seed, duration, params):
        seen["generated"] = (hidden, seed, params.effect("hysteresis").response_time.tolist())
        return None, params

    def analyse(path, folder, shown_path=None, backfit_patience=None, fit_plant_lag=False, inertial_loads="joints"):
        # the command's analysis replays within the block its inertial loads name
        with inertial_loads_from(inertial_loads):
            replays_motor_loads = runs.replay_transform() is with_motor_side_loads
        seen["analysed"] = (path.name, backfit_patience, candidates.HYSTERESIS_RESPONSE_TIME, fit_plant_lag,
                            replays_motor_loads, inertial_loads)
        raise ReachedTheAnalysis

    monkeypatch.setattr(runs, "generate_measured", generate)
    monkeypatch.setattr(runs, "write_measured", lambda dataset, folder: folder / "measured.parquet")
    monkeypatch.setattr(command, "analyse", analyse)
    out = tmp_path / "out"
    with pytest.raises(ReachedTheAnalysis):
        study.main(["--seed", "5", *options, "--out", str(out)])
    patience = 2 if "--backfit-patience" in options else None
    assert seen == {"generated": (("hysteresis",), 5, [generator_lag] * 3),
                    "analysed": ("measured.parquet", patience, scorer_lag, fitted, "--motor-side-loads" in options,
                                 "motors" if "--motor-side-loads" in options else "joints")}
    assert candidates.HYSTERESIS_RESPONSE_TIME == 0.1
    assert runs.replay_transform() is None
    assert not out.exists()


def test_the_shape_studys_fitted_replay_lag_is_a_parameter_the_replay_follows_joint_by_joint(record):
    from dataclasses import replace

    from studies.discrepancy_hysteresis_shape import hysteresis_candidate

    signals, model, robot = record
    theta = np.array([10.0, 4.0, 200.0, 3e-3, 4e-3, 1e-4, 0.4, 0.4, 0.4, 0.0, 0.2, 0.0])
    with hysteresis_candidate(None, None, fit_lag=True):
        (candidate,) = raven_library(signals, ("hysteresis",))
        lower, upper, _, typical = candidate.bounds()
        built = candidate.apply(model, theta)
    assert [b.name for b in candidate.blocks] == ["stiffness", "width", "shape", "response_time"]
    np.testing.assert_array_equal(lower[9:], 0.0)
    np.testing.assert_array_equal(upper[9:], 0.5)
    np.testing.assert_array_equal(typical[9:], 0.1)
    assert built.follows_hysteresis_lag
    effect = built.params.effect("hysteresis")
    np.testing.assert_array_equal(effect.response_time, [0.0, 0.2, 0.0])
    by_hand = replace(model.with_effect(Hysteresis(stiffness=theta[:3], beta=1.0 / theta[3:6],
                                                   gamma=theta[6:9] / theta[3:6], response_time=theta[9:])),
                      follows_hysteresis_lag=True)
    lagged, expected = built.replay(signals, robot), by_hand.replay(signals, robot)
    np.testing.assert_array_equal(lagged.joints, expected.joints)
    # only the elbow's state lags: the joints without a lag replay as without the option
    unlagged = replace(built, follows_hysteresis_lag=False).replay(signals, robot)
    np.testing.assert_array_equal(lagged.joints[:, [0, 2]], unlagged.joints[:, [0, 2]])
    assert np.max(np.abs(lagged.joints[:, 1] - unlagged.joints[:, 1])) > 1e-6
    # outside the block the library's candidate is its own again, and a constant lag has no place beside a fitted one
    (candidate,) = raven_library(signals, ("hysteresis",))
    assert [b.name for b in candidate.blocks] == ["stiffness", "width", "shape"]
    assert not candidate.apply(model, theta[:9]).follows_hysteresis_lag
    with pytest.raises(ValueError, match="no constant lag"):
        with hysteresis_candidate(None, 0.1, fit_lag=True):
            pass


def test_a_rebased_model_replays_its_hysteresis_as_the_model_it_was_taken_from(record):
    from dataclasses import replace

    from simulation.discrepancy.workflow import _transplant

    signals, model, robot = record
    hysteresis = Hysteresis(stiffness=np.array([10.0, 4.0, 200.0]), response_time=np.array([0.1, 0.2, 0.1]))
    source = replace(model.with_effect(hysteresis), follows_hysteresis_lag=True)
    moved = _transplant(source, model, ("hysteresis",))
    assert moved.follows_hysteresis_lag
    np.testing.assert_array_equal(moved.replay(signals, robot).joints, source.replay(signals, robot).joints)
    assert not _transplant(replace(source, follows_hysteresis_lag=False), model, ("hysteresis",)).follows_hysteresis_lag


def test_the_shape_study_holds_the_candidates_shape_and_lag_only_within_its_block(record):
    from simulation.discrepancy import candidates
    from studies.discrepancy_hysteresis_shape import hysteresis_candidate

    signals, model, _ = record
    theta = np.array([10.0, 4.0, 200.0, 3e-3, 4e-3, 1e-4, 0.9, 0.9, 0.9])

    def fitted_shape_range_and_built():
        (candidate,) = raven_library(signals, ("hysteresis",))
        lower, upper, _, _ = candidate.bounds()
        return lower[6:], upper[6:], candidate.apply(model, theta).params.effect("hysteresis")

    with hysteresis_candidate(0.4, 0.0):
        lower, upper, built = fitted_shape_range_and_built()
        np.testing.assert_array_equal(lower, 0.4)
        np.testing.assert_array_equal(upper, 0.4)
        np.testing.assert_array_equal(built.response_time, 0.0)
    lower, upper, built = fitted_shape_range_and_built()
    np.testing.assert_array_equal(lower, 0.0)
    np.testing.assert_array_equal(upper, 1.0)
    np.testing.assert_array_equal(built.response_time, candidates.HYSTERESIS_RESPONSE_TIME)
    np.testing.assert_allclose(built.gamma / built.beta, 0.9)
    with hysteresis_candidate(None, 0.2):
        lower, upper, built = fitted_shape_range_and_built()
        np.testing.assert_array_equal(lower, 0.0)
        np.testing.assert_array_equal(built.response_time, 0.2)
    assert candidates.HYSTERESIS_RESPONSE_TIME == 0.1
    _, _, built = fitted_shape_range_and_built()
    np.testing.assert_array_equal(built.response_time, 0.1)


def test_the_motors_inertial_loads_reach_every_record_the_study_helpers_read_and_only_within_the_block(dataset,
                                                                                                      record):
    import studies.common.discrepancy_runs as runs
    from simulation.model.constants import RavenConstants
    from studies.common.discrepancy_runs import inertial_loads_from, with_motor_side_loads

    signals, model, robot = record
    coupling = RavenConstants(arm=dataset.arm).nominal_coupling()
    with inertial_loads_from("joints"):
        assert runs.replay_transform() is None
    with inertial_loads_from("motors"):
        assert runs.replay_transform() is with_motor_side_loads
        inside = runs.replayed_signals(dataset)
    assert runs.replay_transform() is None
    # the links' acceleration is the motors' through the nominal coupling; the rest is the record's
    np.testing.assert_allclose(inside.acceleration, signals.drive_acceleration @ coupling.T, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(inside.acceleration - signals.acceleration)) > 1e-3
    for name in ("velocity", "truth", "time", "drive_acceleration"):
        np.testing.assert_array_equal(getattr(inside, name), getattr(signals, name))
    difference = model.replay(inside, robot).joints - model.replay(signals, robot).joints
    assert np.max(np.abs(difference)) > 1e-7
    with pytest.raises(RuntimeError, match="inside"):
        with inertial_loads_from("motors"):
            raise RuntimeError("inside")
    assert runs.replay_transform() is None
    assert np.array_equal(runs.replayed_signals(dataset).acceleration, signals.acceleration)


def test_the_command_replays_the_analysis_the_oracle_and_the_floor_with_the_inertial_loads_asked_for(
        monkeypatch, tmp_path):
    import json
    from types import SimpleNamespace

    import studies.common.discrepancy_report as report
    import studies.common.discrepancy_runs as runs
    import studies.discrepancy as command
    from studies.common.discrepancy_runs import inertial_loads_from, with_motor_side_loads

    class StopAfterTheFloor(Exception):
        pass

    seen = {}

    def analyse(path, folder, **options):
        seen["analysed"] = options["inertial_loads"]
        with inertial_loads_from(options["inertial_loads"]):
            seen["analysis replays"] = runs.replay_transform()
        # what the analysis's report says of its replay is all the oracle and the floor learn of it
        folder.mkdir(parents=True, exist_ok=True)
        (folder / "report.json").write_text(json.dumps({"inertial_loads": options["inertial_loads"]}))
        return (SimpleNamespace(backfit_rounds=None, backfit_patience=0, named_backfit_patience=None),) + (None,) * 4

    def oracle(*arguments, **options):
        seen["oracle replays"] = runs.replay_transform()

    def floor_record(*arguments):
        seen["floor replays"] = runs.replay_transform()
        raise StopAfterTheFloor

    monkeypatch.setattr(command, "generate_measured", lambda *arguments, **options: (None, None))
    monkeypatch.setattr(command, "write_measured", lambda dataset, folder: folder / "measured.parquet")
    monkeypatch.setattr(command, "analyse", analyse)
    monkeypatch.setattr(report, "oracle", oracle)
    monkeypatch.setattr(report, "floor_record", floor_record)
    for extra, loads, transform in (([], "joints", None),
                                    (["--inertial-loads", "motors"], "motors", with_motor_side_loads)):
        seen.clear()
        with pytest.raises(StopAfterTheFloor):
            command.main(["--hidden-effect", "drift", "--duration", "60", *extra, "--no-progress",
                          "--out", str(tmp_path / loads)])
        assert seen == {"analysed": loads, "analysis replays": transform, "oracle replays": transform,
                        "floor replays": transform}
        assert runs.replay_transform() is None
    with pytest.raises(ValueError, match="from one of joints, motors, not 'links'"):
        inertial_loads_from("links")
