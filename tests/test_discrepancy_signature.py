"""The signature of an unexplained residual: a sparse fit over a generic term library, in words."""

from __future__ import annotations

import numpy as np
import pytest

from simulation.discrepancy.signals import RAVEN_JOINTS, RAVEN_UNITS, MeasuredSignals
from simulation.discrepancy.signature import SignatureSettings, default_shaft_ratio, describe_residual

RATE = 30.0
DURATION = 60.0


def synthetic_signals(seed: int = 0) -> MeasuredSignals:
    """A minute of smooth, incommensurate motion of the three RAVEN-II positioning joints at 30 Hz.

    Each joint sweeps exactly twice its ``amplitude`` (more than a revolution of each capstan): over
    less than a revolution, a periodic error is also a smooth function of the position.
    """
    rng = np.random.default_rng(seed)
    time = np.arange(0.0, DURATION, 1.0 / RATE)
    amplitude = np.array([0.4, 0.4, 0.035])
    centre = np.array([0.5, 1.6, 0.35])
    truth = np.empty((time.size, 3))
    for k in range(3):
        freqs = rng.uniform(0.05, 0.25, 3)
        phases = rng.uniform(0, 2 * np.pi, 3)
        wave = sum(np.sin(2 * np.pi * f * time + p) for f, p in zip(freqs, phases)) / 3
        truth[:, k] = centre[k] + amplitude[k] * (2 * (wave - wave.min()) / np.ptp(wave) - 1)
    torque = 0.3 * np.cos(truth) + 0.05 * rng.standard_normal(truth.shape)
    return MeasuredSignals(time=time, truth=truth, reported=truth.copy(), drive=truth.copy(), torque=torque,
                           payload_kg=np.zeros(time.size), homing=np.zeros(time.size, int),
                           joint_names=RAVEN_JOINTS, units=RAVEN_UNITS, kind="raven")


def noise(signals, seed, scale=np.array([2e-5, 2e-5, 1e-6])):
    return scale * np.random.default_rng(seed).standard_normal(signals.truth.shape)


def capstan_angle(signals):
    return signals.drive * default_shaft_ratio(signals)


def test_runout_in_one_motor_angle_is_named_with_its_amplitude():
    s = synthetic_signals()
    residual = noise(s, 1)
    residual[:, 1] += 1e-3 * np.sin(capstan_angle(s)[:, 1] + 0.4)
    signature = describe_residual(s, residual)
    first = signature.leading()[0]
    assert (first.joint, first.kind, first.source, first.harmonic) == ("elbow", "motor harmonic", "elbow", 1)
    assert first.amplitude == pytest.approx(1e-3, rel=0.1)
    sentence = signature.sentences()[0]
    assert "elbow motor angle" in sentence and "one cycle per revolution" in sentence
    assert f", {np.rad2deg(first.amplitude):.2g} deg (" in sentence  # 1e-3 rad is 0.057 deg
    assert signature.explained[1] > 0.9


def test_sign_of_velocity_is_named():
    s = synthetic_signals(2)
    residual = noise(s, 3)
    residual[:, 0] += -5e-4 * np.sign(s.velocity[:, 0])
    signature = describe_residual(s, residual)
    first = signature.leading()[0]
    assert (first.joint, first.kind, first.source, first.direction) == ("shoulder", "sign of velocity", "shoulder", -1)
    assert first.amplitude == pytest.approx(5e-4, rel=0.1)
    assert "sign of the shoulder velocity" in signature.sentences()[0]


def test_linear_drift_in_time_is_named():
    s = synthetic_signals(4)
    residual = noise(s, 5)
    residual[:, 2] += 1e-4 * (s.time - s.time[0]) / DURATION
    signature = describe_residual(s, residual)
    first = signature.leading()[0]
    assert (first.joint, first.kind, first.direction) == ("z_ins", "time", 1)
    assert first.amplitude == pytest.approx(1e-4, rel=0.1)
    assert "grows linearly with time, 0.1 mm over the record" in signature.sentences()[0]


def test_pure_noise_gives_no_sentence():
    for seed in (6, 7, 8):
        s = synthetic_signals(seed)
        signature = describe_residual(s, noise(s, seed + 10))
        assert signature.sentences() == []
        assert max(signature.explained) < SignatureSettings().min_share


def test_two_terms_come_out_strongest_first():
    s = synthetic_signals(9)
    residual = noise(s, 11)
    residual[:, 0] += 4e-4 * np.sign(s.velocity[:, 0])
    residual[:, 0] += 1.2e-3 * np.cos(capstan_angle(s)[:, 0])
    signature = describe_residual(s, residual)
    kinds = [(t.kind, t.source) for t in signature.leading()[:2]]
    assert kinds == [("motor harmonic", "shoulder"), ("sign of velocity", "shoulder")]
    shares = [t.share for t in signature.leading()[:2]]
    assert shares[0] > shares[1] > SignatureSettings().min_share


def test_bad_residual_is_refused():
    s = synthetic_signals()
    with pytest.raises(ValueError, match="residual must have shape"):
        describe_residual(s, np.zeros((len(s), 2)))
    bad = np.zeros((len(s), 3))
    bad[7, 1] = np.nan
    with pytest.raises(ValueError, match="not finite at sample 7"):
        describe_residual(s, bad)
    with pytest.raises(ValueError, match="shaft_ratio"):
        describe_residual(s, np.zeros((len(s), 3)), shaft_ratio=[1.0, -1.0, 1.0])


def test_generic_signals_have_no_motor_terms_unless_given_a_ratio():
    raven = synthetic_signals()
    s = MeasuredSignals.generic(raven.time, raven.reported, raven.truth, RAVEN_JOINTS, RAVEN_UNITS)
    residual = noise(s, 12)
    residual[:, 0] += 1e-3 * np.sin(2 * 20.0 * s.drive[:, 0])
    assert not any("theta" in c for c in describe_residual(s, residual).columns)
    first = describe_residual(s, residual, shaft_ratio=[20.0, 20.0, 100.0]).leading()[0]
    assert (first.kind, first.source, first.harmonic) == ("motor harmonic", "shoulder", 2)
    assert first.amplitude == pytest.approx(1e-3, rel=0.1)


@pytest.fixture(scope="module")
def raven_capstan_run():
    """A minute of random motion of the virtual RAVEN-II with the cable and an eccentric capstan only."""
    from kinematics import RavenII
    from simulation.engine.scenarios import powered_on, record_random_test
    from simulation.model.effects import CapstanRunout
    from simulation.model.parameters import RavenParameters
    from simulation.recordings.recording import recording_to_dataset

    # a 60 um eccentric capstan: 1 mrad on the rotary joints, 50 um on the insertion
    params = RavenParameters().only("cable_stretch", "capstan_runout").with_effect(
        CapstanRunout(amplitude=np.array([1e-3, 1e-3, 5e-5])))
    robot = powered_on(params, seed=3)
    recording = record_random_test(robot, 60.0, seed=4)
    return MeasuredSignals.from_dataset(recording_to_dataset(recording, RavenII(params.arm, check_limits=False)))


def test_virtual_raven_capstan_runout_reads_as_periodic_in_a_motor_angle(raven_capstan_run):
    s = raven_capstan_run
    gap = s.truth - s.reported  # nominal model: the reported joints plus their mean offset
    residual = gap - gap.mean(axis=0)
    signature = describe_residual(s, residual)
    first = signature.leading()[0]
    assert (first.kind, first.harmonic) == ("motor harmonic", 1)
    assert "motor angle at the capstan, one cycle per revolution" in signature.sentences()[0]
    rotary = [t for t in signature.leading() if t.kind == "motor harmonic" and t.joint == t.source and t.unit == "rad"]
    assert rotary and all(t.amplitude == pytest.approx(1e-3, rel=0.25) for t in rotary)


def test_a_repeating_runout_is_predicted_on_blocks_left_out_by_its_share():
    from simulation.discrepancy.signature import residual_structure

    s = synthetic_signals(12)
    residual = noise(s, 13)
    amplitude = 3e-5  # rad: as large as the noise
    residual[:, 1] += amplitude * np.sin(capstan_angle(s)[:, 1] + 1.0)
    check = residual_structure(s, residual)
    # what a sinusoid can explain of sinusoid plus white noise: (A^2 / 2) / (A^2 / 2 + sigma^2)
    expected = amplitude ** 2 / 2 / (amplitude ** 2 / 2 + 2e-5 ** 2)
    # a fit to 7/8 of a minute predicts a little less than the whole share, never more
    assert expected - 0.15 <= check.explained[1] <= expected + 0.05, check.explained[1]
    assert check.rms_after[1] < check.rms_before[1]
    assert check.explained[0] < 0.1 and check.explained[2] < 0.1


def test_noise_and_steps_between_blocks_have_no_repeatable_structure():
    from simulation.discrepancy.signature import residual_structure

    for seed in (14, 15, 16):
        s = synthetic_signals(seed)
        residual = noise(s, seed + 10)
        # an offset that jumps once per block: each block's mean is left out, so nothing repeats
        block = np.minimum(np.arange(len(s)) * 8 // len(s), 7)
        residual[:, 0] += 1e-4 * np.random.default_rng(seed).standard_normal(8)[block]
        check = residual_structure(s, residual, folds=8)
        assert np.all(check.explained < 0.1), check.explained
        assert check.folds == 8


@pytest.mark.parametrize("folds", [1, 0, 2.5, True])
def test_the_structure_check_refuses_a_bad_number_of_blocks(folds):
    from simulation.discrepancy.signature import residual_structure

    s = synthetic_signals()
    with pytest.raises(ValueError, match="folds must be an integer of at least 2"):
        residual_structure(s, noise(s, 1), folds=folds)


def test_the_unmodelled_encoder_error_is_one_and_two_cycles_per_revolution():
    from studies.discrepancy_unmodelled import EncoderError

    encoder = EncoderError.drawn(0.01, seed=4)
    assert encoder.amplitude == pytest.approx(np.deg2rad(0.01))
    angles = np.random.default_rng(0).uniform(-1.0, 1.0, size=(50, 2))
    error = encoder.error(angles)
    assert error.shape == (50, 2)
    # periodic over one revolution, and the sum of a first and a second harmonic of that amplitude
    np.testing.assert_allclose(encoder.error(angles + 2 * np.pi), error, atol=1e-15)
    first = encoder.amplitude * np.sin(angles + encoder.phases[0])
    second = encoder.amplitude * np.sin(2 * angles + encoder.phases[1])
    np.testing.assert_allclose(error, first + second)
    # each seed mounts its discs differently; the same seed the same way
    assert not np.allclose(EncoderError.drawn(0.01, seed=5).phases, encoder.phases)
    np.testing.assert_array_equal(EncoderError.drawn(0.01, seed=4).phases, encoder.phases)
    for bad in (0.0, -1.0, np.nan):
        with pytest.raises(ValueError, match="amplitude must be a positive number of degrees"):
            EncoderError.drawn(bad, seed=0)


def test_no_term_is_said_to_be_larger_than_the_residual_it_describes():
    # the elbow's error grows with the square of its distance from mid-range, with the sign of the
    # side (an odd, curved error no column has): the sparse fit shares it between correlated
    # columns (the position's linear and quadratic terms, the motor harmonic), one of them with a
    # contribution larger than the whole residual; its sentence gives what it adds instead
    s = synthetic_signals(4)
    residual = noise(s, 14)
    side = s.truth[:, 1] - s.truth[:, 1].mean()
    curve = np.sign(side) * side ** 2
    residual[:, 1] += 3e-4 * (curve - curve.mean()) / curve.std()
    signature = describe_residual(s, residual)
    spread = np.std(residual[:, 1])
    per_size = {"joint harmonic": np.sqrt(0.5), "motor harmonic": np.sqrt(0.5)}
    elbow = [t for t in signature.terms if t.joint == "elbow" and t.kind not in ("constant", "time", "sign of velocity")]
    position = [t for t in elbow if t.kind == "position"]
    assert position and position[0].share > 0.8, elbow
    for term in elbow:
        assert term.amplitude * per_size.get(term.kind, 1.0) <= spread * (1 + 1e-9), term
    # where it had to be replaced, the size is that of the increment its share measures
    assert position[0].amplitude == pytest.approx(np.sqrt(position[0].share) * spread, rel=1e-9)
