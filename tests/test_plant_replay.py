"""The plant replay: the links swing on their cables at the frequencies of their inertia and the
cables' stiffness, hang still where the quasi-static replay balances them, start again at a
re-homing, and bad input is refused with the problem named."""

import numpy as np
import pytest
from scipy.linalg import eigh

from kinematics import RavenII
from simulation.discrepancy.replay import RavenModel
from simulation.discrepancy.signals import RAVEN_JOINTS, RAVEN_UNITS, MeasuredSignals
from simulation.engine.plant_replay import replay_links
from simulation.identification import nominal_parameters
from simulation.model.laws import cable_tension_curve, coupling_matrix

POSE = np.array([np.deg2rad(50.0), np.deg2rad(95.0), 0.40])
"""A pose inside every hard stop (shoulder, elbow rad; insertion m)."""

SOFT_CABLES = np.array([40.0, 15.0, 2000.0])
"""Round cable stiffnesses (N m/rad, N m/rad, N/m) near those of the virtual RAVEN-II: the links
swing at about 3, 3 and 15 Hz on them (on the nominal set's stiffer insertion cable, 1e5 N/m, at
about 100 Hz, which half-millisecond steps do not follow to a few per cent over a second)."""

ROBOT = RavenII("left", check_limits=False)


def cables_only(damping=None):
    params = nominal_parameters("left").only("cable_stretch")
    law = params.effect("cable_stretch").replace(stiffness=SOFT_CABLES)
    if damping is not None:
        law = law.replace(damping=np.asarray(damping, dtype=float))
    return params.with_effect(law)


def motors_for(params, cable_side):
    """Motor coordinates whose cables end at ``cable_side`` (3,), with the coupling of ``params``."""
    return np.linalg.solve(coupling_matrix(*params.constants.cable_coupling), cable_side)


def still(params, rows, pose=POSE):
    """Motor coordinates held still with the cables' ends at ``pose``, for ``rows`` samples."""
    return np.tile(motors_for(params, pose), (rows, 1))


@pytest.mark.parametrize("mode", [0, 1, 2])
def test_a_link_let_go_swings_at_the_mode_of_its_inertia_and_cable(mode):
    # motors held still, no gravity, friction or damping: M x'' = -K x about the cables' ends, with
    # M from Pinocchio's CRBA and K the cable law's slope at zero stretch (an independent
    # computation of the small oscillations), started at rest along one mode
    params = cables_only(damping=np.zeros(3))
    law = params.effect("cable_stretch")
    step = 1e-7
    slope = np.array([(cable_tension_curve(step, law.stiffness[i], law.hardening[i])
                       - cable_tension_curve(-step, law.stiffness[i], law.hardening[i])) / (2 * step) for i in range(3)])
    squared, shapes = eigh(np.diag(slope), ROBOT.mass_matrix(np.r_[POSE, 0.0, 0.0, 0.0]))
    omega = np.sqrt(squared[mode])
    assert 1.0 < omega / (2 * np.pi) < 30.0  # the swing of a few hertz the quasi-static replay cannot follow
    shape = shapes[:, mode] / np.max(np.abs(shapes[:, mode])) * 1e-4
    time = np.arange(0.0, 1.0, 1e-3)
    start = np.tile(POSE - shape, (time.size, 1))
    links = replay_links(params, ROBOT, time, still(params, time.size), start)
    expected = POSE - shape[None, :] * np.cos(omega * time)[:, None]
    # semi-implicit Euler in half-millisecond steps, as the simulator integrates: its velocity lags
    # half a step and its frequency runs high by (omega h)^2 / 24, 3.8 % of the amplitude after
    # fifteen swings of the insertion axis
    assert np.max(np.abs(links - expected)) < 0.05 * np.max(np.abs(shape)), (mode, omega / (2 * np.pi))


REGISTRATION = np.array([np.deg2rad(4.0), np.deg2rad(-6.0), 8e-3])
"""Registration offsets (rad, rad, m) large enough that the links' gravity differs between the
registered pose and the unregistered one."""


@pytest.mark.parametrize("registered", [False, True])
def test_a_link_hangs_still_where_the_quasi_static_replay_balances_its_cable_and_gravity(registered):
    # the workflow's replay puts the link where the cable's tension holds the gravity load at the
    # measured joints, its registration offsets added; started there, at rest, with the motors
    # still and the same offsets as the registration, the plant must not move
    params = nominal_parameters("left").only("cable_stretch", "gravity_stretch")
    time = np.arange(0.0, 0.5, 1e-3)
    n = time.size
    drive = still(params, n)
    offsets = REGISTRATION if registered else np.zeros(3)
    hanging = POSE + offsets
    for _ in range(20):
        truth = np.tile(hanging, (n, 1))
        signals = MeasuredSignals(time=time, truth=truth, reported=truth, drive=drive, torque=np.zeros((n, 3)),
                                  payload_kg=np.zeros(n), homing=np.zeros(n, dtype=int), joint_names=RAVEN_JOINTS,
                                  units=RAVEN_UNITS, kind="raven", tool_joints=np.zeros((n, 3)))
        hanging = RavenModel(params, offsets).replay(signals, ROBOT).joints[0]
    stretch = POSE + offsets - hanging
    assert np.all(np.abs(stretch) > 1e-5), stretch  # gravity stretches every cable
    links = replay_links(params, ROBOT, time, drive, np.tile(hanging, (n, 1)), registration=np.tile(offsets, (n, 1)))
    # a gravity 5 % off would swing each link by about a tenth of its cable's stretch
    assert np.all(np.max(np.abs(links - hanging), axis=0) < 0.01 * np.abs(stretch))
    if registered:
        # the offsets added to the replayed joints instead: the links' gravity taken at the
        # unregistered pose stretches the cables otherwise, and the links move
        added = replay_links(params, ROBOT, time, drive, np.tile(hanging - offsets, (n, 1))) + offsets
        assert np.max(np.abs(added - hanging)[:, :2]) > 0.05 * np.max(np.abs(stretch[:2]))


def test_a_restart_starts_the_plant_again_at_rest_from_the_given_positions():
    params = cables_only()
    time = np.arange(0.0, 0.4, 1e-3)
    drive = motors_for(params, POSE)[None, :] + 0.05 * np.sin(2 * np.pi * time)[:, None]
    start = np.tile(POSE + 1e-3, (time.size, 1))
    restart = np.zeros(time.size, dtype=bool)
    restart[[0, 250]] = True
    links = replay_links(params, ROBOT, time, drive, start, restart)
    fresh = replay_links(params, ROBOT, time[250:], drive[250:], start[250:])
    np.testing.assert_array_equal(links[250:], fresh)
    np.testing.assert_array_equal(links[:250], replay_links(params, ROBOT, time[:250], drive[:250], start[:250]))
    assert not np.allclose(links[250:], replay_links(params, ROBOT, time, drive, start)[250:])


def test_what_a_restart_gets_wrong_is_forgotten_within_seconds_of_motion():
    # restarted at rest 1 mrad and 0.1 mm off where the links were, while the motors move: the
    # cables' damping and the links' slipping through their dry friction bring the links back onto
    # the replay that ran through, to under a hundredth of that error three seconds later
    params = nominal_parameters("left").only("cable_stretch", "gravity_stretch", "coulomb_friction", "viscous_friction")
    params = params.with_effect(params.effect("cable_stretch").replace(stiffness=SOFT_CABLES))
    time = np.arange(0.0, 5.0, 1e-3)
    drive = motors_for(params, POSE)[None, :] + 0.05 * np.sin(np.pi * time)[:, None]
    start = np.tile(POSE, (time.size, 1))
    through = replay_links(params, ROBOT, time, drive, start)
    error = np.array([1e-3, -1e-3, 1e-4])
    restart = np.zeros(time.size, dtype=bool)
    restart[[0, 1000]] = True
    start[1000] = through[1000] + error
    again = replay_links(params, ROBOT, time, drive, start, restart)
    np.testing.assert_array_equal(again[:1000], through[:1000])
    assert np.all(np.abs(again[1001] - through[1001]) > 0.5 * np.abs(error))
    assert np.all(np.max(np.abs(again[4000:] - through[4000:]), axis=0) < 0.01 * np.abs(error))


def test_a_registration_offset_moves_the_motors_by_the_couplings_inverse():
    # the registration enters on the motor side: the same as the motor coordinates shifted by the
    # coupling's inverse times the offset (computed here from the arm's constants)
    params = cables_only()
    time = np.arange(0.0, 0.4, 1e-3)
    drive = motors_for(params, POSE)[None, :] + 0.05 * np.sin(2 * np.pi * time)[:, None]
    start = np.tile(POSE, (time.size, 1))
    offset = np.array([np.deg2rad(2.0), np.deg2rad(-3.0), 4e-3])
    registered = replay_links(params, ROBOT, time, drive, start, registration=np.tile(offset, (time.size, 1)))
    shifted = replay_links(params, ROBOT, time, drive + motors_for(params, offset), start)
    np.testing.assert_allclose(registered, shifted, rtol=0, atol=1e-12)


@pytest.mark.parametrize("change, message", [
    ("drive shape", r"drive must have shape \(100, 3\), got \(100, 2\)"),
    ("registration shape", r"registration must have shape \(100, 3\), got \(3,\)"),
    ("registration nan", "registration is not finite at sample 3"),
    ("start nan", "start is not finite at sample 7"),
    ("time order", "time must increase strictly; it does not at sample 50"),
    ("restart first", "restart must be 100 flags, the first set"),
    ("rigid", "rigid cables"),
    ("payload", "payload_kg must be a non-negative mass"),
    ("substeps", "substeps must be a positive whole number"),
])
def test_bad_input_is_refused_with_the_problem_named(change, message):
    params = cables_only()
    time = np.arange(0.0, 0.1, 1e-3)
    drive, start = still(params, time.size), np.tile(POSE, (time.size, 1))
    restart, payload, substeps, registration = None, 0.0, 2, None
    if change == "drive shape":
        drive = drive[:, :2]
    elif change == "registration shape":
        registration = np.zeros(3)
    elif change == "registration nan":
        registration = np.zeros((time.size, 3))
        registration[3, 2] = np.nan
    elif change == "start nan":
        start[7, 1] = np.nan
    elif change == "time order":
        time[50] = time[49]
    elif change == "restart first":
        restart = np.zeros(time.size, dtype=bool)
    elif change == "rigid":
        params = params.without("cable_stretch")
    elif change == "payload":
        payload = -0.5
    elif change == "substeps":
        substeps = 0
    with pytest.raises(ValueError, match=message):
        replay_links(params, ROBOT, time, drive, start, restart, payload, substeps, registration)
