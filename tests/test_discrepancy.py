"""The model-discrepancy workflow: hidden effects are found, nothing is invented, gaps shrink.

Each hidden-effect test generates "measured" data with the virtual RAVEN-II (the starting structure
plus the hidden effect), writes it to a file and analyses that file blind: the one starting
structure identified from the data itself and the one library of candidates, whatever is hidden.
The thresholds are the workflow's goal: the hidden effect named first and at least half of the
held-out gap closed. Short records (120 s, one minute where :data:`RUN_OF` says) keep the suite's
time down; effects whose default size is below what two minutes resolve are generated at a stated
multiple of it (:data:`SIZE_FACTORS`). The 5-seed sweep over every candidate at the default sizes is a study
(``python studies/discrepancy.py --sweep``).
"""

from __future__ import annotations

import inspect
import json
import shutil
from types import SimpleNamespace

import numpy as np
import pytest

from simulation.discrepancy import (
    LIBRARY_NAMES,
    MeasuredSignals,
    NominalModel,
    Split,
    WorkflowSettings,
    localize,
    strongest_dependence,
)
from simulation.discrepancy.replay import play_series
from simulation.discrepancy.signals import pooled_rmse
from simulation.discrepancy.workflow import CandidateScore, naming_shortfalls
from studies.common.discrepancy_runs import (
    HIDDEN_CHOICES,
    LIBRARY,
    STARTING_STRUCTURE,
    analyse_measured,
    run_hidden_effect,
    run_on_generic,
)
from studies.common.plant_scoring import score_with_plant

pytestmark = pytest.mark.xdist_group("discrepancy")
"""One worker runs the tests of this group, so the memoised command-line runs (a module fixture)
they share are computed once; each hidden-effect analysis that shares nothing is its own group
(:func:`alone`), so that the workers can balance them."""


def alone(effect, seed):
    """The seed parameter of an ``effect`` test that forms its own xdist group (a test's own mark
    overrides the module's)."""
    return pytest.param(seed, marks=pytest.mark.xdist_group(f"discrepancy-{effect}-{seed}"))

DURATION = 120.0
SIZE_FACTORS = {"backlash": 3.0, "capstan_runout": 12.5}
"""Hidden effects generated above their default size in these tests, because two minutes of data
do not resolve the default: backlash at its default half-width (0.02 deg on the shoulder) leaves a
held-out gap that even its true structure closes by under a fifth, and the default capstan runout
is at the replay's own accuracy. 12.5 times the default runout is a 60 um eccentric capstan."""
RUN_OF = {"capstan_runout": (1, 60.0), "none": (0, 60.0)}
"""Seed and record length (s) of the command-line runs that differ from seed 0 and DURATION: one
minute of a 60 um eccentric capstan leaves a residual far above the floor, at half the cost; with
nothing hidden, one minute is the shortest record the workflow vouches for (``SHORT_RECORD_S``),
where noise is likeliest to pass for an effect (``python studies/discrepancy.py --sweep --effects
none --seeds 5 --duration 60`` named nothing on any seed)."""


SEEDS = {"backlash": (1, 6), "hysteresis": (2, 3)}
"""The two seeds of each look-alike's test: seeds whose two-minute result does not move with the
rounding, so that the test passes or fails alike on every machine. Each record was analysed with
six copies changed in the last bit (``python studies/discrepancy_rounding.py --hidden-effect NAME
--seed S --duration 120 --backfit-rounds 6 --copies 6``, ``--size-factor 3`` for backlash): a
hidden hysteresis on seed 2 closes 65.0 % to 67.3 % of the held-out gap and on seed 3 71.3 % to
72.3 %, named first every time, while on seed 0 it closes 48.9 % to 63.8 % and on seed 1 58.9 % to
72.8 % (the README's rounding table): on two-minute records some seeds leave the hysteresis fit
between minima that the last bit chooses among, and a threshold of half the gap would be decided
by the machine. Backlash at three times its default on seeds 1 and 6 moves by under a hundredth of
a point (81.4 % and 79.2 %, named alone; seed 6: ``python studies/discrepancy_rounding.py
--hidden-effect backlash --seed 6 --duration 120 --size-factor 3 --backfit-rounds 6 --copies 6``,
2026-12-02). Seeds on which it is named alone keep the suite's time down, since a second name
costs a second backfit: of seeds 0 to 7 (``python studies/discrepancy.py --hidden-effect backlash
--seed S --duration 120 --size-factor 3 --backfit-rounds 6``), backlash is named first on every
one, alone on seeds 1, 3, 5 and 6 (81.4 %, 69.3 %, 48.6 %, 79.2 %) and with capstan friction
second on seeds 0, 2, 4 and 7 (79.5 %, 75.7 %, 78.0 %, 83.4 %); in the suite seed 0's test took
31.6 s and seed 1's 15.2 s. Seed 5 closes under half: two minutes do not resolve backlash on every seed
even at three times its size."""


PLANT_SCORED_SEED = 6
"""The backlash seed whose analysis is also scored with the plant replay, as the command's report
scores it (:func:`~studies.common.plant_scoring.score_with_plant`): 76.9 % against the
quasi-static replay's 79.2 % (``python studies/discrepancy.py --hidden-effect backlash --seed 6
--duration 120 --size-factor 3 --backfit-rounds 6``, 2026-12-03; 77.0 % before the registration
offsets entered the plant on the motor side). The other analyses of this module
are scored by the workflow's quasi-static replay, to keep the suite's time."""

BACKFIT_ROUNDS = {"backlash": 6, "hysteresis": 6, "hysteresis,payload": 3}
"""Backfit rounds of the five hidden-effect analyses below (backlash and hysteresis on two seeds,
two effects at once), by the hidden effects, fewer than the workflow's default of thirty to keep
the suite's time. Each passes with room, and no copy of its record changed in the last bit moves
it near the threshold (``python studies/discrepancy_rounding.py --hidden-effect NAME --seed S
--duration 120 --backfit-rounds R --copies 6``, ``--size-factor 3`` for backlash): backlash and
hysteresis keep six, checked so in :data:`SEEDS`; the two effects take three, checked on
2026-12-06, as were the three-round figures below. Hysteresis with a
payload closes 83.9 % to 84.9 % on the record and all six copies, naming both every time (89.6 %
at six), in 20.8 s of CPU against 33.4 s at six (``max_effects`` as below, one analysis per
process after a warm-up, two processes side by side). Three rounds were measured for the others
and not taken: backlash on seeds 1 and 6 closes 76.6 % and 71.6 % on the record and every copy,
but costs what six do (13.7 s and 10.5 s of CPU against 12.2 s and 12.0 s, one process at a
time): its backfit is cheap once named; hysteresis on seed 2 closes 57.4 % to 61.4 % over the
copies, which the rounding study calls moving with the rounding. The eccentric capstan's
command-line run takes two (:data:`CLI_BACKFIT_ROUNDS`); nothing hidden runs at the default, and
so does the blind analysis of its file again in the round trip."""

MAX_EFFECTS = 1
"""Effects each hidden-effect analysis below names per effect hidden before it stops
(``max_effects``): once they are named, the full workflow spends a last iteration, about two
fifths of its analysis, fitting the library again to find nothing more. On these records it finds
nothing more, and the capped analysis names, fits and closes exactly what the full one does, to the
last bit (backlash seeds 1 and 6: 81.4 % and 79.2 %, hysteresis seeds 2 and 3: 65.3 % and 70.9 %,
hysteresis with a payload: 89.6 %, the same held-out gaps, each run with and without the cap on
2026-12-03; 78.5 s of CPU for the five capped analyses against 126.5 s for the full ones, one
after another in one process). At three rounds too: hysteresis with a payload closes 84.5 %
capped (one analysis per process) and uncapped (the rounding study's record, :data:`BACKFIT_ROUNDS`),
the same to the last bit, 2026-12-06, as do backlash on seeds 1 and 6 (76.6 % and 71.6 %). That
nothing more is named where nothing more is hidden is what
:func:`test_nothing_hidden_names_nothing` (the full workflow) and the sweep check."""

CLI_BACKFIT_ROUNDS = {"capstan_runout": 2}
"""``--backfit-rounds`` of the command-line runs that do not run at the default. The eccentric
capstan's blind analysis names nothing at six rounds or thirty (14.5 s and 14.4 s), but its oracle,
the generator's structure fitted by the workflow's steps, runs every round it is allowed: the run
took 53 s of CPU at thirty against 30 s at six (``python studies/discrepancy.py --hidden-effect
capstan_runout --seed 1 --duration 60 --size-factor 12.5 --backfit-rounds 30``, then ``6``). The
oracle leaves no repeating residual at either (largest share -0.94 and -0.92), which is what the
test asks of it. At two rounds (2026-12-03, ``--backfit-rounds 2``, then ``6`` and ``1`` in the same
process after a warm-up: 13.5 s, 17.1 s and 10.4 s) the blind analysis is the same to the last digit
of its residual's shares (named nothing, unexplained, the same signature) and the oracle still
leaves none that repeats (largest share -0.37; -0.95 at six, -0.76 at one) and closes less than
the floor allows (42.9 % against a bound of 97.4 %; 57.9 % at six)."""


def meets_the_goal(result, hidden):
    """The hidden effects are named first and at least half of the held-out gap closes. (Where the
    workflow names exactly the hidden effects, the oracle, which fits them by the same steps, closes
    exactly as much; the sweep reports it.) The analyses stop once they have named as many effects as
    are hidden (:data:`MAX_EFFECTS`), and say so."""
    assert result.library == LIBRARY
    assert set(result.named_effects[:len(hidden)]) == set(hidden), result.named_effects
    assert result.max_effects == len(hidden) and result.search_capped
    assert result.shrink >= 0.5, result.shrink
    assert not result.unexplained
    _check_reported_shrink(result)


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Memoised ``studies/discrepancy.py --hidden-effect NAME`` runs: their folders."""
    from studies.discrepancy import main

    cache = {}

    def run(name):
        seed, duration = RUN_OF.get(name, (0, DURATION))
        if name not in cache:
            out = tmp_path_factory.mktemp(name) / "run"
            rounds = ["--backfit-rounds", str(CLI_BACKFIT_ROUNDS[name])] if name in CLI_BACKFIT_ROUNDS else []
            assert main(["--hidden-effect", name, "--seed", str(seed), "--duration", str(duration),
                         "--size-factor", str(SIZE_FACTORS.get(name, 1.0)), *rounds, "--out", str(out)]) == 0
            cache[name] = out
        return cache[name]

    return run


def report_of(folder):
    return json.loads((folder / "report.json").read_text())


def _check_reported_shrink(result):
    # the reported shrink is the pooled held-out RMSE with rad in degrees and m in millimetres
    before = pooled_rmse(result.residual_before.joints, result.units)
    after = pooled_rmse(result.residual_after.joints, result.units)
    assert result.shrink == pytest.approx(1.0 - after / before)
    assert np.sqrt(np.mean(result.residual_before.joints ** 2, axis=0)) == pytest.approx(result.gap_before)


def _look_alike(effect, seed):
    # backlash and hysteresis both lag the joint behind reversals: the name must be right and the
    # named effect must close at least half of the held-out gap
    result, signals, split, _ = run_hidden_effect((effect,), seed=seed, duration=DURATION,
                                                  size_factor=SIZE_FACTORS.get(effect, 1.0),
                                                  backfit_rounds=BACKFIT_ROUNDS[effect], max_effects=MAX_EFFECTS)
    meets_the_goal(result, (effect,))
    return result, signals, split


@pytest.mark.parametrize("seed", [alone("backlash", seed) for seed in SEEDS["backlash"]])
def test_hidden_backlash_is_named_and_closes_half_the_gap(seed):
    result, signals, split = _look_alike("backlash", seed)
    if seed == PLANT_SCORED_SEED:
        # the blind analysis's last step: scored by the plant replay, which follows the links' swing
        # that the quasi-static replay leaves in the residual, the models close at least half too
        score = score_with_plant(result, signals, split)
        assert score.applies, score.reason
        assert score.shrink >= 0.5, score.shrink


@pytest.mark.parametrize("seed", [alone("hysteresis", seed) for seed in SEEDS["hysteresis"]])
def test_hidden_hysteresis_is_named_and_closes_half_the_gap(seed):
    _look_alike("hysteresis", seed)


@pytest.mark.xdist_group("discrepancy-two-effects")
def test_two_hidden_effects_are_both_named_and_close_half_the_gap():
    # a lag at the joints (hysteresis) and a load the base identification absorbs (an undeclared
    # 0.5 kg payload), hidden together. Seed 1: on seed 0 two minutes name the payload only (68 %
    # shrink); four minutes name both on seeds 0 and 1 (python studies/discrepancy.py
    # --hidden-effect hysteresis,payload --duration 240)
    result, *_ = run_hidden_effect(("hysteresis", "payload"), seed=1, duration=DURATION,
                                   backfit_rounds=BACKFIT_ROUNDS["hysteresis,payload"], max_effects=2 * MAX_EFFECTS)
    meets_the_goal(result, ("hysteresis", "payload"))


def test_nothing_hidden_names_nothing(cli_runs):
    report = report_of(cli_runs("none"))
    assert report["named_effects"] == []
    assert report["unexplained"] is False
    assert report["signature"] == []
    assert report["shrink"] == pytest.approx(0.0)
    # nothing named: the plant replay has nothing to score, and the report says so
    assert report["scored_by"] == "quasi-static replay" and report["plant_replay"]["applies"] is False
    assert report["plant_replay"]["reason"].startswith("nothing was named")
    assert {k: report[k] for k in ("gap_before", "gap_after", "shrink")} == {
        k: report["quasi_static"][k] for k in ("gap_before", "gap_after", "shrink")}
    # the identified nominal model already reproduces the data to the encoders' resolution
    assert np.all(np.array(report["gap_before"]) < np.array([2e-4, 2e-4, 1e-5])), report["gap_before"]
    assert report["hidden_effect"] == [] and report["oracle_shrink"] == pytest.approx(0.0)
    # nothing hidden: the starting model's gap is the floor itself, and nothing is left above it
    assert report["floor_gap"] == report["gap_before"] and report["floor_bound"] == 0.0
    # the controller replay ran on the logged commands and found the controller's own law
    assert report["controller"]["named"] is False
    assert max(abs(v) for v in report["controller"]["scale_error"]) < 0.005
    # nothing named: the residual was checked for structure that repeats, and none was found
    assert len(report["residual_structure"]) == 3
    # the starting structure's parameters, identified once (nothing named, no backfit) and beside the generator's
    starting = report["starting_parameters"]
    assert list(starting["identified"]) == list(STARTING_STRUCTURE) and starting["final"] == starting["identified"]
    assert starting["units"]["cable_stretch"]["stiffness"] == ["N m/rad", "N m/rad", "N/m"]
    # with the identification's standard errors, none for the damping it holds at its nominal value
    errors = starting["identified_standard_error"]
    assert errors["cable_stretch"]["damping"] == [None, None, None]
    assert all(e is not None and e > 0 for e in errors["cable_stretch"]["stiffness"] + errors["coupling"]["delta"])
    assert set(report["true_starting_parameters"]) == set(STARTING_STRUCTURE)
    assert "## Parameters of the starting structure" in (cli_runs("none") / "report.md").read_text()
    assert max(report["residual_structure"]) < WorkflowSettings().structure_share
    # with nothing hidden the oracle is the starting model: the same residual, the same check
    assert report["oracle_residual_structure"] == report["residual_structure"]
    text = (cli_runs("none") / "report.md").read_text()
    assert "repeatable structure of the residual the final model leaves" in text
    # every candidate fitted was refused, and the report says which naming test each one failed
    fitted = [c for it in report["iterations"] for c in it["candidates"] if c["fitted"]]
    assert fitted and all(c["shortfalls"] for c in fitted)
    assert all(c["shortfalls"] == [] for it in report["iterations"] for c in it["candidates"] if not c["fitted"])
    assert "| verdict |" in text and "; ".join(fitted[0]["shortfalls"]) in text


def _score(validation_gap, fit_gap, bic, torque_gap=1.0, fit_torque_gap=1.0):
    return CandidateScore("candidate", 0.0, True, {}, validation_gap, bic, fit_gap, torque_gap, fit_torque_gap)


def test_a_candidate_is_refused_for_each_naming_test_it_fails_and_by_how_much():
    settings = WorkflowSettings()  # 10 % on both parts, 0.001 off the validation gap
    current = dict(gap=0.00427, fit_gap=0.00406, bic=57751.0, torque_gap=1.0, fit_torque_gap=1.0)
    # a fifth off both gaps but 0.00084 in all: the absolute floor alone refuses it
    assert naming_shortfalls(_score(0.00343, 0.00355, 46568.0), **current, settings=settings) == (
        "validation gap cut 0.00084 (< 0.001)", "torque gaps cut 0.0 % and 0.0 % (not both >= 10 %)")
    assert naming_shortfalls(_score(0.00343, 0.00355, 46568.0), **current,
                             settings=WorkflowSettings(min_improvement=0.0008)) == ()
    # the fit part barely moves: refused on that part, however much the validation gap falls
    reasons = naming_shortfalls(_score(0.0020, 0.00390, 40000.0), **current, settings=settings)
    assert reasons[0] == "fit-part gap cut 3.9 % (< 10 %)" and len(reasons) == 2
    # a fit that passes every gap test but does not lower the BIC
    assert naming_shortfalls(_score(0.0020, 0.0020, 57751.0), **current, settings=settings) == (
        "BIC not below the current model's",)
    # an effect seen only in the torques: both torque gaps down a fifth, the joints' gap unchanged
    assert naming_shortfalls(_score(0.00427, 0.00406, 50000.0, 0.8, 0.8), **current, settings=settings) == ()
    # ... but not if it widens the joints' gap by the floor
    reasons = naming_shortfalls(_score(0.00527, 0.00406, 50000.0, 0.8, 0.8), **current, settings=settings)
    assert reasons[0] == "validation gap cut -23.4 % (< 10 %)"
    # without torques (generic data) no torque sentence
    reasons = naming_shortfalls(_score(0.00400, 0.00400, 50000.0, np.nan, np.nan), **{
        **current, "torque_gap": np.nan, "fit_torque_gap": np.nan}, settings=settings)
    assert reasons == ("validation gap cut 6.3 % (< 10 %)", "fit-part gap cut 1.5 % (< 10 %)",
                       "validation gap cut 0.00027 (< 0.001)")


def test_an_effect_missing_from_the_library_is_unexplained_with_a_signature(cli_runs):
    assert "capstan_runout" not in LIBRARY_NAMES
    report = report_of(cli_runs("capstan_runout"))
    assert report["unexplained"] is True
    assert report["named_effects"] == [], report["named_effects"]
    assert report["signature"], "an unexplained residual needs a signature"
    assert all(isinstance(s, str) and s for s in report["signature"])
    # and it names the form: each joint whose runout stands above the noise, periodic in its own
    # motor's angle at the capstan, once per revolution
    for joint in ("elbow", "z_ins"):
        assert any(s.startswith(f"{joint}: periodic in the {joint} motor angle at the capstan, one cycle per revolution")
                   for s in report["signature"]), report["signature"]
    # the oracle (the true structure fitted) closes what the library could not, and leaves no
    # residual that repeats: the flag was raised by the missing effect, not by the check itself
    assert report["hidden_effect"] == ["capstan_runout"]
    assert "capstan_runout" in report["oracle_fitted_parameters"]
    share = WorkflowSettings().structure_share
    assert max(report["oracle_residual_structure"]) < share <= max(report["residual_structure"])
    # the floor: the same seed's record with nothing hidden leaves less than this one, and the oracle
    # closes no more than the part above it
    assert len(report["floor_gap"]) == 3 and 0.0 < report["floor_bound"] < 1.0
    # (both replayed quasi-statically: nothing was named, so the plant scored neither)
    assert report["scored_by"] == "quasi-static replay"
    assert report["oracle_quasi_static"]["shrink"] == report["oracle_shrink"] <= report["floor_bound"]
    assert report["plant_floor_gap"] is None and report["plant_floor_bound"] is None


def test_generation_and_analysis_meet_only_through_the_file(cli_runs, tmp_path):
    from studies.discrepancy import main

    # the analysis takes a path and nothing else (besides whether to draw a progress bar, the
    # highest log rate to analyse at, the backfit's round cap, the most effects to name and the
    # backfit's patience before and after a candidate is named, all about the analysis, none about
    # what was generated)
    parameters = inspect.signature(analyse_measured).parameters
    options = ("progress", "max_rate", "backfit_rounds", "max_effects", "backfit_patience", "named_backfit_patience")
    assert list(parameters) == ["path", *options]
    assert all(parameters[name].kind is inspect.Parameter.KEYWORD_ONLY for name in options)
    # the record with nothing hidden, the cheapest of the command-line runs to analyse again
    generated = cli_runs("none")
    copy = tmp_path / "elsewhere" / "measured.parquet"
    copy.parent.mkdir()
    shutil.copy(generated / "measured.parquet", copy)
    assert main(["--measured", str(copy), "--out", str(tmp_path / "again")]) == 0
    blind, first = report_of(tmp_path / "again"), report_of(generated)
    volatile = {"created", "runtime_s", "source", "machine"}
    assert "hidden_effect" not in blind and "oracle_shrink" not in blind and "seed" not in blind
    for key in set(blind) - volatile:
        assert first[key] == blind[key], key
    assert first["source"]["sha256"] == blind["source"]["sha256"]


def test_starting_structure_and_library_are_the_same_whatever_is_hidden(cli_runs):
    # the hidden-effect analyses (backlash, drift) check their library themselves
    assert not set(STARTING_STRUCTURE) & set(LIBRARY + ("capstan_runout",))
    assert set(HIDDEN_CHOICES) == {"none", "capstan_runout", *LIBRARY}
    assert len(LIBRARY) >= 10
    reports = [report_of(cli_runs(name)) for name in ("none", "capstan_runout")]
    for report in reports:
        assert report["starting_structure"] == list(STARTING_STRUCTURE)
        assert report["library"] == list(LIBRARY)


def test_a_command_run_is_a_row_of_the_sweep_table_with_its_reports_figures(cli_runs, tmp_path, capsys):
    from studies.common.discrepancy_runs import shrink_bound
    from studies.discrepancy import main

    folder = cli_runs("capstan_runout")
    report = report_of(folder)
    assert main(["--merge-sweeps", str(folder), "--out", str(tmp_path / "table")]) == 0
    (run,) = json.loads((tmp_path / "table" / "confusion.json").read_text())["runs"]
    assert (run["hidden"], run["seed"], run["named_first"]) == ("capstan_runout", RUN_OF["capstan_runout"][0],
                                                                "unexplained")
    assert run["shrink"] == report["shrink"] and run["oracle_shrink"] == report["oracle_shrink"]
    assert run["signature"] == report["signature"] and run["scored_by"] == report["scored_by"]
    # the bound the table reads from the report's floor is the one the report states
    assert shrink_bound(run["floor"], run["gap_before"]) == pytest.approx(report["floor_bound"], rel=1e-12)
    summary = (tmp_path / "table" / "confusion.md").read_text().split("## Confusion matrix")[0]
    row = next(line for line in summary.splitlines() if line.startswith("| capstan_runout |"))
    assert row.startswith("| capstan_runout | 1 of 1 |") and row.endswith("| yes |"), row
    # the record with nothing hidden was generated at another size: the two are not one table
    capsys.readouterr()
    with pytest.raises(SystemExit):
        main(["--merge-sweeps", str(cli_runs("none")), str(folder), "--out", str(tmp_path / "mixed")])
    assert "size factors [1.0, 12.5]" in capsys.readouterr().err
    assert not (tmp_path / "mixed").exists()
    # a run replayed with the motors' inertial loads, or marked so by the study of before, is not a
    # row of the same table as one replayed with the joints'
    assert run["inertial_loads"] == report["inertial_loads"] == "joints"
    for index, mark in enumerate(({"inertial_loads": "motors"}, {"inertial_loads": None, "motor_side_loads": True})):
        other = tmp_path / f"other{index}" / "report.json"
        other.parent.mkdir()
        other.write_text(json.dumps({**report, "seed": report["seed"] + 1, **mark}))
        capsys.readouterr()
        with pytest.raises(SystemExit):
            main(["--merge-sweeps", str(folder), str(other), "--out", str(tmp_path / f"loads{index}")])
        assert "where the replay took the links' inertial loads from" in capsys.readouterr().err
    assert main(["--merge-sweeps", str(other), "--out", str(tmp_path / "motors")]) == 0
    assert "**Inertial loads from the motors:**" in (tmp_path / "motors" / "confusion.md").read_text()


@pytest.mark.parametrize("name", ["coupling", "viscous_friction", "cable_stretch"])
def test_an_effect_of_the_starting_structure_cannot_be_hidden(tmp_path, capsys, name):
    from studies.discrepancy import main

    with pytest.raises(SystemExit) as exit_info:
        main(["--hidden-effect", name, "--out", str(tmp_path / "out")])
    error = capsys.readouterr().err
    assert exit_info.value.code == 2
    assert len(error.strip().splitlines()) == 1 and "is in the starting structure" in error
    assert not (tmp_path / "out").exists()
    with pytest.raises(ValueError, match="in the starting structure"):
        run_hidden_effect((name,), duration=DURATION)
    # one name given as a string is that name, not its letters
    with pytest.raises(ValueError, match=f"^{name} is in the starting structure"):
        run_hidden_effect(name, duration=DURATION)


def test_hidden_effects_are_one_name_or_a_sequence_of_names():
    from studies.common.discrepancy_runs import check_hidden

    assert check_hidden("backlash") == ("backlash",)
    assert check_hidden(["backlash", "payload"]) == ("backlash", "payload")
    assert check_hidden(()) == ()
    with pytest.raises(ValueError, match="unknown hidden effect 'hysterisis'"):
        check_hidden("hysterisis")
    with pytest.raises(ValueError, match="an effect is hidden twice"):
        check_hidden(("drift", "drift"))
    # "none" alone is nothing hidden, as on the command line; beside an effect it is a mistake
    assert check_hidden("none") == () and check_hidden(["none"]) == ()
    with pytest.raises(ValueError, match=r"^'none' \(nothing hidden\) cannot be combined with other effects"):
        check_hidden(("none", "backlash"))


@pytest.mark.parametrize("duration, message", [
    (6 * 3600.0 + 1.0, "at most 21600 s"), (np.inf, "at most 21600 s"), (-1.0, "at least 5 s"), (4.9, "at least 5 s"),
    ("a minute", "must be a number of seconds")])
def test_a_record_length_under_five_seconds_over_six_hours_or_not_a_length_is_refused_before_generating(duration, message):
    from studies.common.discrepancy_runs import generate_measured

    # refused at once: a day of motion at the servo rate would fill the memory before failing
    with pytest.raises(ValueError, match=message):
        generate_measured(("backlash",), duration=duration)


@pytest.fixture(scope="module")
def short_hysteresis():
    """30 s with hysteresis hidden (seed 0): its signals, split, base identifier and identified starting model."""
    from studies.common.discrepancy_runs import generate_measured, raven_base_identifier

    dataset, _ = generate_measured(("hysteresis",), seed=0, duration=30.0)
    signals = MeasuredSignals.from_dataset(dataset)
    split = Split.by_time(signals)
    base = raven_base_identifier(dataset, split.fit)
    return signals, split, base, base.identify(STARTING_STRUCTURE, None)


@pytest.mark.xdist_group("discrepancy-backfit")
def test_a_re_identification_that_leaves_its_valid_range_ends_the_backfit_and_nothing_else(short_hysteresis):
    # on an unseen seed a backfit's re-identification returned a negative load scale, which the
    # parameter set refuses: the candidate keeps the fit it had, as if the backfit had no rounds
    from simulation.discrepancy import BaseIdentifier, run_workflow
    from studies.common.discrepancy_runs import raven_library

    signals, split, base, model = short_hysteresis
    calls = []

    def out_of_range(structure, correction, payload_kg=0.0):
        calls.append(structure)
        raise ValueError("load_scale must be non-negative, got [ 0.98  1.   -0.0045]")

    failing = BaseIdentifier(identify=out_of_range, fittable=base.fittable, structure=base.structure)
    candidates = raven_library(signals, ("backlash", "hysteresis"))
    one = WorkflowSettings(max_iterations=1)
    broken = run_workflow(model, signals, split, one, candidates=candidates, base=failing)
    without = run_workflow(model, signals, split, WorkflowSettings(max_iterations=1, backfit_rounds=0),
                           candidates=candidates, base=base)
    assert calls, "the backfit never asked for a re-identification"
    assert [s.fitted for s in broken.iterations[0].scores] == [True, True]
    assert broken.named_effects == without.named_effects
    np.testing.assert_array_equal(broken.gap_after, without.gap_after)
    assert [s.bic for s in broken.iterations[0].scores] == [s.bic for s in without.iterations[0].scores]
    # neither kept a round, so neither stopped at the cap
    assert all(s.backfit_rounds == 0 and not s.backfit_capped
               for r in (broken, without) for s in r.iterations[0].scores)
    assert broken.backfit_capped == () and without.backfit_capped == ()


@pytest.mark.xdist_group("discrepancy-backfit")
def test_a_backfit_cut_by_its_last_allowed_round_is_reported_and_one_that_stopped_is_not(short_hysteresis):
    # on 30 s of data every round lowers the fit part's residual, so one allowed round is kept and
    # cut short; with a tolerance no round meets, the same round is kept and ends the backfit itself
    from simulation.discrepancy import run_workflow
    from studies.common.discrepancy_runs import raven_library

    signals, split, base, model = short_hysteresis
    candidates = raven_library(signals, ("hysteresis",))
    runs = {tolerance: run_workflow(model, signals, split, WorkflowSettings(max_iterations=1, accept_all=True,
                                                                            backfit_rounds=1,
                                                                            backfit_tolerance=tolerance),
                                    candidates=candidates, base=base)
            for tolerance in (0.0, 0.9)}
    (cut,), (stopped,) = (runs[t].iterations[0].scores for t in (0.0, 0.9))
    assert (cut.backfit_rounds, cut.backfit_capped) == (1, True)
    assert (stopped.backfit_rounds, stopped.backfit_capped) == (1, False)
    assert cut.values == stopped.values  # the same round, kept by both
    assert runs[0.0].backfit_capped == ("hysteresis",) and runs[0.9].backfit_capped == ()


@pytest.mark.xdist_group("discrepancy-backfit")
@pytest.mark.parametrize("patience, named_patience, backfit_calls, scored_call, scored_rounds, final_call, refined", [
    (0, 0, 2, 1, 1, 1, None), (2, 0, 6, 3, 2, 3, None), (2, 2, 6, 3, 2, 3, None), (0, 2, 6, 1, 1, 3, 1)])
def test_patience_lets_the_backfit_go_on_past_rounds_that_do_not_lower_the_residual_and_keeps_the_best(
        short_hysteresis, monkeypatch, patience, named_patience, backfit_calls, scored_call, scored_rounds,
        final_call, refined):
    # the rounds' residuals are scripted: 9, then 9.5 (worse), 8 (best), then 8.5, 8.6, 8.7, 8.8 (all
    # worse than 8). Patience 0 stops at the first worse round. Patience 2 goes on from the 9.5
    # round, keeps the 8 round, counts the worse rounds again from there and stops at the third in
    # a row (without the new count it would stop at 8.6, the third worse round in all). A named
    # effect's patience takes the stopped backfit of the named candidate on along the same rounds:
    # the candidate is scored (and chosen) as its own patience left it, and named as refined
    import simulation.discrepancy.workflow as workflow
    from simulation.discrepancy import run_workflow
    from studies.common.discrepancy_runs import raven_library

    signals, split, base, model = short_hysteresis
    scripted = iter([1.0, 9e-6, 9.5e-6, 8e-6, 8.5e-6, 8.6e-6, 8.7e-6, 8.8e-6])  # the first: the fit before the rounds
    calls = []

    def fit(candidate, start, *args, initial=None, **options):
        if candidate.name != "hysteresis":
            return real(candidate, start, *args, initial=initial, **options)
        calls.append((np.asarray(initial, dtype=float), np.full(candidate.n_parameters, float(len(calls)))))
        return calls[-1][1], start, next(scripted)

    real = workflow.fit_candidate
    monkeypatch.setattr(workflow, "fit_candidate", fit)
    candidates = raven_library(signals, ("hysteresis",))
    settings = WorkflowSettings(max_iterations=1, accept_all=True, backfit_rounds=7, backfit_patience=patience,
                                named_backfit_patience=named_patience)
    result = run_workflow(model, signals, split, settings, candidates=candidates, base=base)
    (iteration,) = result.iterations
    (score,) = iteration.scores
    assert len(calls) == 1 + backfit_calls
    assert (score.backfit_rounds, score.backfit_capped) == (scored_rounds, False)

    def values(call):
        return {k: np.asarray(v).tolist() for k, v in candidates[0].unpack(calls[call][1]).items()}

    assert score.values == values(scored_call)
    assert result.fitted_parameters["hysteresis"] == values(final_call)
    assert (iteration.refined_rounds, iteration.refined_capped) == (refined, False)
    assert result.backfit_capped == () and result.named_backfit_patience == named_patience
    # each round starts from the round before it, kept or not
    for before, after in zip(calls[1:], calls[2:]):
        np.testing.assert_array_equal(after[0], before[1])


@pytest.mark.xdist_group("discrepancy-backfit")
def test_a_named_effects_patience_takes_its_backfit_on_to_the_cap_and_says_so(short_hysteresis, monkeypatch):
    # scripted: 9, then 9.5 (worse: patience 0 stops), then 8, 7, 6 kept up to the cap of five rounds
    import simulation.discrepancy.workflow as workflow
    from simulation.discrepancy import run_workflow
    from studies.common.discrepancy_runs import raven_library

    signals, split, base, model = short_hysteresis
    scripted = iter([1.0, 9e-6, 9.5e-6, 8e-6, 7e-6, 6e-6])
    real = workflow.fit_candidate

    def fit(candidate, start, *args, initial=None, **options):
        if candidate.name != "hysteresis":
            return real(candidate, start, *args, initial=initial, **options)
        return np.asarray(initial, dtype=float) + 1.0, start, next(scripted)

    monkeypatch.setattr(workflow, "fit_candidate", fit)
    settings = WorkflowSettings(max_iterations=1, accept_all=True, backfit_rounds=5)
    result = run_workflow(model, signals, split, settings, candidates=raven_library(signals, ("hysteresis",)),
                          base=base)
    (iteration,) = result.iterations
    assert (iteration.scores[0].backfit_rounds, iteration.scores[0].backfit_capped) == (1, False)
    # three rounds kept after the one that did not lower the residual, the last allowed among them
    assert (iteration.refined_rounds, iteration.refined_capped) == (3, True)
    assert result.backfit_capped == ("hysteresis",)


@pytest.mark.parametrize("name", ["backfit_patience", "named_backfit_patience"])
def test_backfit_patience_is_a_count_of_rounds(name):
    for bad in (-1, 1.5, True):
        with pytest.raises(ValueError, match=f"^{name} must be an integer of at least 0"):
            WorkflowSettings(**{name: bad})


def test_the_report_of_a_run_has_the_documented_keys(tmp_path):
    from studies.common.discrepancy_report import write_report

    time, reported, rng = _generic_record(seed=2)
    truth = reported + 0.01 + 0.02 * np.tanh(np.gradient(reported, time, axis=0) / 0.05)
    truth = truth + rng.normal(0, 1e-4, truth.shape)
    result, signals, split = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "m"))
    paths = write_report(result, signals, split, {"description": "test"}, tmp_path, runtime_s=1.0,
                         starting_structure=(), analysis="blind")
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["named_effects"] == list(result.named_effects) and report["named_effects"]
    assert report["analysis"] == "blind" and report["library"] == list(result.library)
    assert len(report["gap_before"]) == 2 and len(report["gap_after"]) == 2
    np.testing.assert_allclose(report["gap_before"], result.gap_before)
    assert report["shrink"] == pytest.approx(result.shrink)
    assert report["torque_gap_before"] is None and report["equivalent"] == {}
    assert report["inertial_loads"] is None  # generic data: no RAVEN-II replay of inertial loads
    assert report["rivals"] == {k: dict(v) for k, v in result.rivals.items()}
    assert all(isinstance(it["rivals"], dict) for it in report["iterations"])
    assert len(report["residual_structure"]) == 2  # checked after the named effects too
    # generic data have no base identification to backfit against
    assert report["backfit_capped"] == [] and report["backfit_rounds"] is None and report["backfit_patience"] is None
    assert all(c["backfit_rounds"] == 0 and c["backfit_capped"] is False
               for it in report["iterations"] for c in it["candidates"])
    # 30 s of generic data: the short-record warning is about the RAVEN-II starting structure only
    assert report["record_s"] == pytest.approx(29.99) and report["short_record"] is None
    assert report["drift_note"] is None
    # parameters in SI with their units, reported in degrees and millimetres
    first = report["named_effects"][0]
    assert set(report["parameter_units"][first]) == set(report["fitted_parameters"][first])
    assert report["report_units"] == ["deg", "mm"]
    # each fitted value with the range it was searched in, in SI, and the ends it stopped at
    assert set(report["parameter_bounds"]) == set(report["fitted_parameters"])
    for block, values in report["fitted_parameters"][first].items():
        lower, upper = report["parameter_bounds"][first][block]
        assert len(lower) == len(upper) == len(np.atleast_1d(values))
        assert np.all(np.array(lower) <= np.array(values)) and np.all(np.array(values) <= np.array(upper))
    assert isinstance(report["at_bound"], list)
    text = (tmp_path / "report.md").read_text()
    assert text.startswith("# Model discrepancy") and "lower BIC is better" in text and "torque gap" in text
    assert "| search range | at bound |" in text
    assert all(p.exists() and p.stat().st_size > 0 for p in paths)
    assert {p.suffix for p in paths} >= {".json", ".md", ".png"}


def test_a_fitted_value_at_an_end_of_its_search_range_is_marked_with_that_end():
    from simulation.discrepancy.workflow import values_at_bounds
    from studies.common.discrepancy_report import parameter_rows, values_at_their_bounds

    assert values_at_bounds([0.0, 0.5, 1.0, 1.0 - 1e-9, 1e-3], 0.0, 1.0) == ["lower", "", "upper", "upper", ""]
    assert values_at_bounds([-0.1, 0.0], [-0.1, -1.0], [0.1, 1.0]) == ["lower", ""]
    fitted = {"hysteresis": {"width": np.deg2rad([0.2, 0.3]), "shape": np.array([0.4, 1.0])},
              "gravity_model_error": {"scale_error": np.array([0.1, 0.2])}}
    units = {"hysteresis": {"width": ["rad", "m"], "shape": ["1", "1"]},
             "gravity_model_error": {"scale_error": ["1", "1"]}}
    bounds = {"hysteresis": {"width": ([1e-6, 1e-6], [0.05, 0.05]), "shape": ([0.0, 0.0], [1.0, 1.0])}}
    rows = parameter_rows(fitted, units, ("a", "b"), bounds=bounds)
    assert rows[0][:5] == ["hysteresis", "width", "a", pytest.approx(0.2), "deg"]
    assert rows[0][5] == f"[{np.rad2deg(1e-6):.4g}, {np.rad2deg(0.05):.4g}]" and rows[0][6] == ""
    assert rows[1][4:] == ["mm", "[0.001, 50]", ""]  # metres shown in millimetres, the range too
    assert rows[3][5:] == ["[0, 1]", "upper"]
    assert rows[4][5:] == ["-", "-"]  # fitted without bounds (the controller's least squares)
    assert all(len(row) == 5 for row in parameter_rows(fitted, units, ("a", "b")))  # no bounds asked, no columns

    class Result:
        joint_names = ("a", "b")
        fitted_parameters = fitted
        parameter_bounds = bounds

    assert values_at_their_bounds(Result()) == ["hysteresis.shape[b] (upper)"]


def _raven_like_signals(truth, time):
    n = time.size
    return MeasuredSignals(time=time, truth=truth, reported=truth, drive=truth, torque=None, payload_kg=np.zeros(n),
                           homing=np.zeros(n, int), joint_names=("a", "b"), units=("rad", "m"))


def test_a_raven_record_under_a_minute_is_reported_as_short_and_a_minute_is_not():
    from dataclasses import replace

    from studies.common.discrepancy_runs import SHORT_RECORD_S, short_record_note

    assert SHORT_RECORD_S == 60.0

    def signals(seconds, kind="raven"):
        time = np.arange(int(round(seconds * 30)) + 1) / 30.0
        truth = np.column_stack([0.3 * np.sin(0.7 * time), 0.02 * np.sin(1.3 * time)])
        return replace(_raven_like_signals(truth, time), kind=kind)

    note = short_record_note(signals(30.0))
    assert note.startswith("the record lasts 30 s, under 60 s")
    assert short_record_note(signals(60.0)) is None
    assert short_record_note(signals(30.0, kind="generic")) is None


def test_a_raven_record_under_twenty_minutes_is_noted_as_too_short_for_drift(monkeypatch, tmp_path):
    from dataclasses import replace

    import studies.discrepancy as command
    from studies.common.discrepancy_runs import AGING_RECORD_S, DEFAULT_RECORD_S, drift_record_note

    assert AGING_RECORD_S == DEFAULT_RECORD_S == 1200.0

    def signals(seconds, kind="raven"):
        time = np.arange(int(round(seconds * 2)) + 1) / 2.0
        truth = np.column_stack([0.3 * np.sin(0.07 * time), 0.02 * np.sin(0.13 * time)])
        return replace(_raven_like_signals(truth, time), kind=kind)

    assert drift_record_note(signals(240.0)).startswith("the record lasts 240 s, under 1200 s: drift")
    assert drift_record_note(signals(1199.0)) is not None
    assert drift_record_note(signals(1200.0)) is None
    assert drift_record_note(signals(240.0, kind="generic")) is None

    asked = {}

    def stop_before_generating(hidden, seed, duration, **_):
        asked["duration"] = duration
        raise RuntimeError("stopped before generating")

    monkeypatch.setattr(command, "generate_measured", stop_before_generating)
    with pytest.raises(RuntimeError, match="stopped before generating"):
        command.main(["--hidden-effect", "none", "--no-progress", "--out", str(tmp_path / "out")])
    assert asked["duration"] == DEFAULT_RECORD_S  # the command generates records long enough to show drift


def test_the_replay_velocity_is_causal_and_does_not_lag():
    time = np.arange(400) * 0.02
    truth = np.column_stack([0.3 * np.sin(0.7 * time), 0.02 * np.sin(1.3 * time + 0.4)])
    signals = _raven_like_signals(truth, time)
    # changing the motion after a sample changes no derivative at or before it
    changed = truth.copy()
    changed[200:] += np.array([0.3, 0.01])
    other = _raven_like_signals(changed, time)
    for name in ("velocity", "acceleration", "drive_velocity", "drive_acceleration"):
        np.testing.assert_array_equal(getattr(signals, name)[:200], getattr(other, name)[:200], err_msg=name)
    # and it follows a smooth motion without the lag of a trailing average: within 1 % of the exact
    # velocity's amplitude (0.09 % and 0.31 % on its eight samples of 50 Hz), where the mean slope over
    # the same samples, late by half of them, is off by 4.9 % and 9.1 %
    exact = np.column_stack([0.3 * 0.7 * np.cos(0.7 * time), 0.02 * 1.3 * np.cos(1.3 * time + 0.4)])
    assert signals.smoothing == 8
    error = np.abs(signals.velocity - exact)[10:]
    assert np.all(error < 1e-2 * np.abs(exact).max(axis=0)), error.max(axis=0)


def _generic_record(seed=0, n=3000):
    rng = np.random.default_rng(seed)
    time = np.arange(n) * 0.01
    phases = rng.uniform(0, 2 * np.pi, size=2)
    reported = np.column_stack([0.3 * np.sin(0.7 * time + phases[0]) + 0.1 * np.sin(2.3 * time),
                                0.2 * np.sin(0.5 * time + phases[1]) + 0.05 * np.sin(3.1 * time)])
    return time, reported, rng


def _dead_band_record():
    """A robot known only by reported and measured joints: the measured joint trails the reported
    one by a play of 0.5 and 0.3 deg that reverses with the motion (plus encoder noise).
    Returns time, reported, truth and the half-widths (rad)."""
    time, reported, rng = _generic_record()
    half = np.deg2rad([0.5, 0.3])
    first = np.r_[True, np.zeros(len(time) - 1, bool)]
    truth = np.column_stack([play_series(np.ascontiguousarray(reported[:, j]), half[j], first) for j in range(2)])
    return time, reported, truth + 0.01 + rng.normal(0, 1e-4, truth.shape), half


def test_generic_data_with_a_dead_band_names_backlash():
    time, reported, truth, half = _dead_band_record()
    result, _, _ = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    assert result.named_effects[:1] == ("backlash",), result.named_effects
    assert result.shrink >= 0.8
    np.testing.assert_allclose(result.fitted_parameters["backlash"]["half_width"], half, rtol=0.1)


def test_a_search_capped_at_one_effect_stops_after_naming_it_and_says_so(tmp_path):
    from studies.common.discrepancy_report import write_report

    time, reported, truth, _ = _dead_band_record()
    full, _, _ = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    capped, signals, split = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"),
                                            settings=WorkflowSettings(max_iterations=1))
    # the full search ends with an iteration that names nothing; the capped one stops at its name
    assert full.iterations[-1].named is None and not full.search_capped and full.max_effects == 4
    assert len(capped.iterations) == 1 and capped.search_capped and capped.max_effects == 1
    # its one iteration is the full search's first, to the last bit
    assert capped.named_effects == full.named_effects[:1] == ("backlash",)
    assert capped.fitted_parameters["backlash"] == full.fitted_parameters["backlash"]
    assert [s.bic for s in capped.iterations[0].scores] == [s.bic for s in full.iterations[0].scores]
    write_report(capped, signals, split, {"description": "test"}, tmp_path, runtime_s=1.0, starting_structure=(),
                 analysis="blind")
    report = json.loads((tmp_path / "report.json").read_text())
    assert report["max_effects"] == 1 and report["search_capped"] is True
    assert "did not check whether the data hold more" in (tmp_path / "report.md").read_text()
    for wrong in (-1, 1.5, True):
        with pytest.raises(ValueError, match=f"max_iterations must be an integer of at least 0, got {wrong!r}"):
            WorkflowSettings(max_iterations=wrong)


def _dragged_record():
    """Joint a is dragged by joint b's motion: it moves by half of what a play of 0.03 rad (between
    two of the candidate's widths) takes out of b, whichever way b last moved; joint b has no error.
    Returns time, reported, truth."""
    time, reported, rng = _generic_record(seed=4)
    first = np.r_[True, np.zeros(len(time) - 1, bool)]
    b = np.ascontiguousarray(reported[:, 1])
    drag = 0.5 * (b - play_series(b, 0.03, first))
    truth = reported + np.column_stack([drag, np.zeros_like(drag)]) + 0.01
    return time, reported, truth + rng.normal(0, 1e-4, truth.shape)


def test_a_hysteresis_driven_by_another_joint_is_named_coupled_hysteresis(tmp_path, monkeypatch):
    import simulation.discrepancy.workflow as workflow
    from simulation.discrepancy import fitting
    from simulation.discrepancy.generic import coupled_hysteresis_shares
    from studies.common.discrepancy_report import write_report

    linear_fits, searched = [], []

    def count_linear(candidate, *args, **kwargs):
        linear_fits.append(candidate.name)
        return fitting.fit_linear_candidate(candidate, *args, **kwargs)

    def count_searched(candidate, *args, **kwargs):
        searched.append(candidate.name)
        return fitting.fit_candidate(candidate, *args, **kwargs)

    monkeypatch.setattr(workflow, "fit_linear_candidate", count_linear)
    monkeypatch.setattr(workflow, "fit_candidate", count_searched)
    time, reported, truth = _dragged_record()
    result, signals, split = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    assert result.named_effects[:1] == ("coupled_hysteresis",), result.named_effects
    # the screen's closed-form fit is the candidate's fit: once per iteration, never searched again
    screened = sum(any(s.name == "coupled_hysteresis" for s in it.scores) for it in result.iterations)
    assert screened >= 1 and linear_fits == ["coupled_hysteresis"] * screened, linear_fits
    assert "coupled_hysteresis" not in searched
    assert result.shrink >= 0.8, result.shrink
    # the weights of joint a on joint b's plays carry the drag; joint b's own error is noise
    weight = np.array(result.fitted_parameters["coupled_hysteresis"]["weight"]).reshape(2, 2, -1)
    assert np.abs(weight[0, 1]).sum() > 10 * np.abs(weight[1]).sum()
    # and the report's table of who drags whom says so: about the drag's own RMS from b to a
    first = np.r_[True, np.zeros(len(time) - 1, bool)]
    b = np.ascontiguousarray(reported[:, 1])
    drag = 0.5 * (b - play_series(b, 0.03, first))
    shares = coupled_hysteresis_shares(result.model_after.effects["coupled_hysteresis"], signals)
    assert shares[0, 1] == pytest.approx(np.sqrt(np.mean(drag ** 2)), rel=0.1)
    assert shares[0, 0] < 0.2 * shares[0, 1] and np.all(shares[1] < 0.2 * shares[0, 1])
    # the report's table: joint a's row, in degrees, over the fit and validation parts
    write_report(result, signals, split, {"description": "a dragged joint"}, tmp_path, 1.0, starting_structure=())
    text = (tmp_path / "report.md").read_text()
    part = coupled_hysteresis_shares(result.model_after.effects["coupled_hysteresis"], signals,
                                     split.fit | split.validation)
    assert "## Which joint drags which (coupled hysteresis)" in text
    assert f"| a (deg) | {np.degrees(part[0, 0]):.3f} | {np.degrees(part[0, 1]):.3f} |" in text


def test_noise_alone_names_nothing_not_even_the_many_weights_of_coupled_hysteresis():
    # 2 x 2 x 6 weights fitted in closed form follow the noise of the fit part, which does not repeat
    time, reported, rng = _generic_record(seed=5)
    truth = reported + 0.01 + rng.normal(0, 1e-4, reported.shape)
    result, _, _ = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    assert result.named_effects == (), result.named_effects
    score = next(s for s in result.iterations[0].scores if s.name == "coupled_hysteresis")
    assert score.bic > result.iterations[0].bic_before


def _coupled_hysteresis_inputs():
    """The inputs of a coupled-hysteresis fit on the first 2000 samples of :func:`_dragged_record`:
    time, reported, truth, signals, the candidate, the nominal model, the mask, the nominal model's
    residual there and the channel weights."""
    from simulation.discrepancy.candidates import library
    from simulation.discrepancy.fitting import ChannelWeights, residual

    time, reported, truth = _dragged_record()
    signals = MeasuredSignals.generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    (candidate,) = [c for c in library(signals) if c.name == "coupled_hysteresis"]
    model = NominalModel(offsets=np.zeros(2))
    mask = np.arange(len(time)) < 2000
    start = residual(model, signals, mask=mask)
    weights = ChannelWeights.from_residual(start.joints, None, np.full(2, 1e-6))
    return time, reported, truth, signals, candidate, model, mask, start, weights


def test_a_candidate_linear_in_its_parameters_is_the_least_squares_fit_of_its_basis():
    from simulation.discrepancy.fitting import fit_linear_candidate, residual
    from simulation.discrepancy.generic import HYSTERESIS_WIDTH_FRACTIONS

    time, reported, truth, signals, candidate, model, mask, start, weights = _coupled_hysteresis_inputs()
    # without a penalty to choose from: plain least squares
    theta, fitted, chi = fit_linear_candidate(candidate, model, signals, weights, mask=mask, penalties=(0.0,))
    # the same fit built independently: plays of each joint at fractions of its range, one column
    # per (moved joint, moving joint, width), offsets profiled out, each joint over its weight
    first = np.r_[True, np.zeros(len(time) - 1, bool)]
    plays = [reported[:, k] - play_series(np.ascontiguousarray(reported[:, k]), np.ptp(reported[:, k]) * f, first)
             for k in range(2) for f in HYSTERESIS_WIDTH_FRACTIONS]
    design = np.column_stack(plays)[mask]
    design = design - design.mean(axis=0)
    error = (truth - reported)[mask]
    expected = [np.linalg.lstsq(design, error[:, j] - error[:, j].mean(), rcond=None)[0] for j in range(2)]
    np.testing.assert_allclose(theta, np.concatenate(expected), rtol=1e-6, atol=1e-9)
    left = [error[:, j] - error[:, j].mean() - design @ expected[j] for j in range(2)]
    assert chi == pytest.approx(sum(np.sum((r / w) ** 2) for r, w in zip(left, weights.joints)), rel=1e-9)
    assert chi == pytest.approx(residual(fitted, signals, mask=mask).chi_square(weights), rel=1e-12)
    broken = _with_basis(candidate, lambda s: np.zeros((len(s), 2, 3)))
    with pytest.raises(ValueError, match=r"the basis of coupled_hysteresis has shape \(3000, 2, 3\), expected"):
        fit_linear_candidate(broken, model, signals, weights, mask=mask)
    from simulation.discrepancy.candidates import generic_candidates

    for bad in ((0.5, 2.0), (), (0.5, np.nan)):
        with pytest.raises(ValueError, match="play fractions must be a non-empty list of numbers in"):
            generic_candidates(signals, bad)


def test_play_operators_driven_by_each_joints_own_motion_are_the_least_squares_fit_of_its_own_plays():
    from simulation.discrepancy.candidates import generic_candidates
    from simulation.discrepancy.fitting import fit_linear_candidate, residual
    from simulation.discrepancy.generic import HYSTERESIS_WIDTH_FRACTIONS

    time, reported, truth, signals, _, model, mask, start, weights = _coupled_hysteresis_inputs()
    (own,) = [c for c in generic_candidates(signals, play_drivers="own") if c.name == "coupled_hysteresis"]
    assert own.n_parameters == 2 * len(HYSTERESIS_WIDTH_FRACTIONS)
    theta, fitted, chi = fit_linear_candidate(own, model, signals, weights, mask=mask, penalties=(0.0,))
    # independently: each joint's error on the plays of its own reported motion only
    first = np.r_[True, np.zeros(len(time) - 1, bool)]
    error = (truth - reported)[mask]
    expected, left = [], []
    for j in range(2):
        plays = np.column_stack([reported[:, j] - play_series(np.ascontiguousarray(reported[:, j]),
                                                              np.ptp(reported[:, j]) * f, first)
                                 for f in HYSTERESIS_WIDTH_FRACTIONS])[mask]
        plays = plays - plays.mean(axis=0)
        expected.append(np.linalg.lstsq(plays, error[:, j] - error[:, j].mean(), rcond=None)[0])
        left.append(error[:, j] - error[:, j].mean() - plays @ expected[j])
    np.testing.assert_allclose(theta, np.concatenate(expected), rtol=1e-6, atol=1e-9)
    assert chi == pytest.approx(sum(np.sum((r / w) ** 2) for r, w in zip(left, weights.joints)), rel=1e-9)
    assert chi == pytest.approx(residual(fitted, signals, mask=mask).chi_square(weights), rel=1e-12)
    # the dragged joint of this record follows the other joint's motion, which its own plays cannot follow
    (every,) = [c for c in generic_candidates(signals) if c.name == "coupled_hysteresis"]
    by_every = fit_linear_candidate(every, model, signals, weights, mask=mask, penalties=(0.0,))[1]
    dragged = [np.sqrt(np.mean(residual(m, signals, mask=mask).joints[:, 0] ** 2)) for m in (fitted, by_every)]
    assert dragged[1] < 0.2 * dragged[0], dragged
    with pytest.raises(ValueError, match="unknown play drivers 'others'; choose from every, own"):
        generic_candidates(signals, play_drivers="others")


def _ridge_by_normal_equations(design, target, penalty):
    """The ridge weights of :func:`~simulation.discrepancy.fitting.ridge_penalty`'s convention from the
    normal equations, independently of its SVD: ``(D^T D + penalty s^2 diag(|d_p|^2)) w = D^T y``,
    ``s`` the largest singular value of ``D`` with unit-norm columns."""
    norms = np.linalg.norm(design, axis=0)
    top = np.linalg.svd(design / norms, compute_uv=False)[0]
    return np.linalg.solve(design.T @ design + penalty * top ** 2 * np.diag(norms ** 2), design.T @ target)


def test_the_ridge_penalty_is_chosen_by_the_prediction_error_of_blocks_held_out_in_time():
    from simulation.discrepancy.fitting import ridge_penalty

    rng = np.random.default_rng(3)
    design = rng.normal(size=(300, 2, 4))
    target = np.einsum("njp,p->nj", design, [1.0, -0.5, 0.25, 2.0]) + 0.3
    penalties = (0.0, 1e-4, 1e-2, 1.0)
    # exact data: any penalty only biases the weights
    chosen, errors = ridge_penalty(design, target, penalties, folds=3)
    assert chosen == 0.0 and errors[0] < 1e-20 < errors[1] < errors[2] < errors[3]
    # noisy data: each block in turn predicted by the others' ridge fit, offsets fitted on the others
    noisy = target + rng.normal(0, 0.5, target.shape)
    chosen, errors = ridge_penalty(design, noisy, penalties, folds=3)
    expected = np.zeros(len(penalties))
    for block in np.array_split(np.arange(300), 3):
        learn = np.setdiff1d(np.arange(300), block)
        mean_d, mean_t = design[learn].mean(axis=0), noisy[learn].mean(axis=0)
        for k, penalty in enumerate(penalties):
            w = _ridge_by_normal_equations((design[learn] - mean_d).reshape(-1, 4),
                                           (noisy[learn] - mean_t).reshape(-1), penalty)
            expected[k] += np.sum((noisy[block] - mean_t - (design[block] - mean_d) @ w) ** 2)
    np.testing.assert_allclose(errors, expected, rtol=1e-9)
    assert chosen == penalties[int(np.argmin(expected))]
    # few samples of a target the features do not explain: the fit only follows the noise, so the
    # largest penalty predicts best (5.6 % less error than none here, 6 % to 18 % on five other draws)
    chosen, errors = ridge_penalty(rng.normal(size=(30, 2, 4)), rng.normal(size=(30, 2)), penalties, folds=3)
    assert chosen == 1.0 and errors[-1] < 0.97 * errors[0], errors


@pytest.mark.parametrize("change, message", [
    (lambda d, t: (d[..., 0], t), r"needs an \(N, J, P\) design and an \(N, J\) target"),
    (lambda d, t: (d, t[:-1]), r"needs an \(N, J, P\) design and an \(N, J\) target"),
    (lambda d, t: (d, np.where(np.arange(t.size).reshape(t.shape) == 5, np.nan, t)), "hold NaN or inf"),
])
def test_the_ridge_penalty_refuses_mismatched_or_non_finite_tables(change, message):
    from simulation.discrepancy.fitting import ridge_penalty

    design, target = np.ones((20, 2, 3)), np.ones((20, 2))
    with pytest.raises(ValueError, match=message):
        ridge_penalty(*change(design, target))


@pytest.mark.parametrize("penalties, folds, message", [
    ((), 5, "non-empty list of non-negative numbers"),
    ((0.0, -1e-3), 5, "non-empty list of non-negative numbers"),
    ((0.0, np.nan), 5, "non-empty list of non-negative numbers"),
    ((0.0,), 1, "at least 2 folds and a sample per fold, got 1 folds"),
    ((0.0,), 21, "at least 2 folds and a sample per fold, got 21 folds of 20 samples"),
    ((0.0,), 2.5, "at least 2 folds"),
])
def test_the_ridge_penalty_refuses_bad_penalties_and_folds(penalties, folds, message):
    from simulation.discrepancy.fitting import ridge_penalty

    with pytest.raises(ValueError, match=message):
        ridge_penalty(np.ones((20, 2, 3)), np.ones((20, 2)), penalties, folds)


def test_a_linear_candidate_is_the_ridge_fit_at_the_penalty_its_blocks_choose():
    from simulation.discrepancy.fitting import fit_linear_candidate, residual, ridge_penalty

    *_, signals, candidate, model, mask, start, weights = _coupled_hysteresis_inputs()
    # penalties that matter here: the drag lies between two widths, so neighbouring plays trade off
    penalties = (0.0, 1e-3, 1e-1)
    theta, fitted, chi = fit_linear_candidate(candidate, model, signals, weights, mask=mask, penalties=penalties,
                                              folds=4)
    scale = weights.joints
    design = candidate.basis(signals)[mask] / scale[None, :, None]
    chosen, _ = ridge_penalty(design, start.joints / scale, penalties, folds=4)
    assert chosen > 0  # so that the penalised path is the one checked
    expected = _ridge_by_normal_equations((design - design.mean(axis=0)).reshape(-1, candidate.n_parameters),
                                          (start.joints / scale).reshape(-1), chosen)
    np.testing.assert_allclose(theta, expected, rtol=1e-6, atol=1e-9)
    assert chi == pytest.approx(residual(fitted, signals, mask=mask).chi_square(weights), rel=1e-12)
    # the penalised fit explains the fit part less well than plain least squares, never better
    _, _, plain = fit_linear_candidate(candidate, model, signals, weights, mask=mask, penalties=(0.0,))
    assert chi >= plain * (1 - 1e-12)


def _with_basis(candidate, basis):
    from dataclasses import replace

    return replace(candidate, basis=basis)


def test_candidates_within_the_bic_margin_are_reported_as_rivals():
    time, reported, truth, _ = _dead_band_record()

    def run(margin):
        return run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"),
                              settings=WorkflowSettings(bic_tie=margin))[0]

    wide = run(1e9)
    first = wide.iterations[0]
    bic = {s.name: s.bic for s in first.scores}
    rivals = dict(first.rivals)
    assert first.named == "backlash" and rivals, rivals  # the dead band's look-alikes explain it too
    assert first.named not in rivals and set(rivals) <= {s.name for s in first.scores if s.fitted}
    for name, difference in rivals.items():
        assert difference == pytest.approx(bic[name] - bic[first.named]) and difference >= 0
    assert wide.rivals["backlash"] == rivals
    # a margin below the closest rival's difference lists none of them and names the same effects
    narrow = run(0.5 * min(rivals.values()))
    assert narrow.iterations[0].rivals == () and "backlash" not in narrow.rivals
    assert narrow.named_effects == wide.named_effects
    assert WorkflowSettings().bic_tie == 2.0
    for bad in (-1.0, np.nan, np.inf):
        with pytest.raises(ValueError, match="bic_tie must be a finite number of at least 0"):
            WorkflowSettings(bic_tie=bad)


def test_the_screen_resolves_an_effect_thirty_times_below_its_typical_scale():
    # a play the starting model half hides shows its gain only well below the candidate's typical
    # scale: the coarse scan must reach down to 3 % of it (a RAVEN-II backlash of the default size,
    # 0.02 deg, against a typical 0.06 deg)
    from simulation.discrepancy.candidates import Candidate, ParameterBlock
    from simulation.discrepancy.candidates import _any, _generic
    from simulation.discrepancy.fitting import ChannelWeights, residual
    from simulation.discrepancy.workflow import _screen

    time, reported, rng = _generic_record(seed=3)
    half = np.array([3e-4, 3e-4])  # 0.03 of the typical scale below
    first = np.r_[True, np.zeros(len(time) - 1, bool)]
    truth = np.column_stack([play_series(np.ascontiguousarray(reported[:, j]), half[j], first) for j in range(2)])
    signals = MeasuredSignals.generic(time, reported, truth + rng.normal(0, 1e-5, truth.shape), ("a", "b"),
                                     ("rad", "rad"))
    candidate = Candidate("backlash", (ParameterBlock("half_width", 2, 0.0, 0.1, 1e-2, 0.0, ("rad", "rad")),),
                          _generic("backlash"), _any)
    model = NominalModel(offsets=np.zeros(2))
    mask = np.ones(len(time), bool)
    start = residual(model, signals, mask=mask)
    weights = ChannelWeights.from_residual(start.joints, None, np.full(2, 1e-6))
    chi, values = _screen(candidate, model, signals, mask, weights, robot=None)
    # a tenth of the scale (the grid's old bottom) is already worse than no play at all
    assert residual(candidate.apply(model, np.full(2, 1e-3)), signals, mask=mask).chi_square(weights) \
        > start.chi_square(weights)
    assert chi < 0.05 * start.chi_square(weights), (chi, start.chi_square(weights))
    np.testing.assert_allclose(values, half, rtol=0.01)


def test_the_fit_budget_reaches_the_candidate_fits_and_is_checked():
    # one IPOPT iteration leaves the play where the screen put it; the default budget recovers it
    from simulation.discrepancy import WorkflowSettings

    time, reported, truth, half = _dead_band_record()
    runs = {n: run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"),
                              settings=WorkflowSettings(fit_iterations=n))[0] for n in (1, 30)}
    assert WorkflowSettings().fit_iterations == 30
    # backlash's own full fit in the first iteration (with one iteration, a look-alike fitted in
    # closed form, coupled_hysteresis, beats the crippled backlash and is named instead)
    fits = {n: next(s for s in runs[n].iterations[0].scores if s.name == "backlash") for n in runs}
    assert fits[1].fitted and fits[30].fitted
    short = np.array(fits[1].values["half_width"])
    assert np.max(np.abs(short / half - 1)) > 0.3, short
    np.testing.assert_allclose(fits[30].values["half_width"], half, rtol=0.1)
    np.testing.assert_allclose(runs[30].fitted_parameters["backlash"]["half_width"], half, rtol=0.1)
    assert fits[30].bic < fits[1].bic
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="fit_iterations must be a positive integer"):
            WorkflowSettings(fit_iterations=bad)


def test_localization_finds_a_residual_that_flips_with_direction():
    time, reported, rng = _generic_record(seed=1)
    signals = MeasuredSignals.generic(time, reported, reported, ("a", "b"), ("rad", "rad"))
    residual = np.column_stack([np.deg2rad(0.2) * np.sign(signals.velocity[:, 0]), rng.normal(0, 1e-5, len(time))])
    table = localize(signals, residual)
    spread = strongest_dependence(table).set_index(["joint", "variable"])["spread of bin means"]
    assert spread["a", "direction"] == pytest.approx(0.4, rel=0.05)  # degrees, -0.2 to +0.2
    assert spread["a", "direction"] > 5 * spread["a", "position"]
    assert spread["b", "direction"] < 0.01
    means = table[(table.joint == "a") & (table.variable == "direction")].set_index("bin")["mean"]
    assert means["moving up"] == pytest.approx(0.2, rel=0.05)
    assert means["moving down"] == pytest.approx(-0.2, rel=0.05)


def test_the_nominal_generic_model_replays_reported_plus_offsets():
    time, reported, _ = _generic_record()
    signals = MeasuredSignals.generic(time, reported, reported + 0.1, ("a", "b"), ("rad", "m"))
    model = NominalModel(offsets=np.array([0.1, 0.1]))
    np.testing.assert_allclose(model.replay(signals).joints, signals.truth)


@pytest.mark.parametrize("change, message", [
    (lambda t, r, y: (t, r[:, :1], y), "reported must have shape"),
    (lambda t, r, y: (t, r, np.where(np.arange(len(t))[:, None] == 7, np.nan, y)), "truth is not finite at sample 7"),
    (lambda t, r, y: (t[::-1].copy(), r, y), "time must increase strictly"),
    (lambda t, r, y: (t[:5], r[:5], y[:5]), "at least 20 samples"),
])
def test_bad_generic_input_is_refused_with_the_problem_named(change, message):
    time, reported, _ = _generic_record(n=200)
    t, r, y = change(time, reported, reported.copy())
    with pytest.raises(ValueError, match=message):
        MeasuredSignals.generic(t, r, y, ("a", "b"), ("rad", "rad"))


def test_overlapping_split_parts_are_refused():
    n = 100
    first = np.arange(n) < 60
    with pytest.raises(ValueError, match="must not overlap"):
        Split(fit=first, validation=np.arange(n) >= 50, held_out=np.zeros(n, dtype=bool))


def test_the_command_line_refuses_an_unknown_effect_and_a_missing_path(tmp_path, capsys):
    from studies.discrepancy import main

    with pytest.raises(SystemExit):
        main(["--hidden-effect", "cable_wobble", "--out", str(tmp_path)])
    assert "unknown hidden effect 'cable_wobble'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_info:
        main(["--measured", str(tmp_path / "absent"), "--out", str(tmp_path)])
    assert exit_info.value.code == 2 and "no file or folder" in capsys.readouterr().err
    for bad in (["--hidden-effect", "backlash", "--duration", "1e9"], ["--sweep", "--duration", "nan"],
                ["--hidden-effect", "none,backlash"]):
        with pytest.raises(SystemExit) as exit_info:
            main(bad + ["--out", str(tmp_path / "out")])
        error = capsys.readouterr().err.strip()
        assert exit_info.value.code == 2 and len(error.splitlines()) == 1, error
        assert ("argument --duration: the record length must be" in error
                or "'none' (nothing hidden) cannot be combined" in error), error
    assert not (tmp_path / "out").exists()


def test_a_sweep_run_in_a_log_is_one_line_with_what_was_hidden_named_and_closed():
    from studies.common.discrepancy_sweep import sweep_line

    run = {"hidden": "backlash", "seed": 19, "named": ["backlash", "capstan_friction"], "unexplained": True,
           "shrink": 0.41234, "oracle_shrink": 0.355}
    line = sweep_line(run, 3, 60)
    assert "\n" not in line
    assert line == ("run 3 of 60: backlash, seed 19: named backlash, capstan_friction (unexplained residual), "
                    "shrink 41.2 %, oracle 35.5 %")
    assert "named nothing, shrink 0.0 %" in sweep_line({**run, "named": [], "unexplained": False, "shrink": 0.0}, 1, 1)


def test_a_small_distortion_no_candidate_models_is_unexplained_because_it_repeats():
    # the measured b bends with the square of a's excursion (a cross-joint nonlinearity): no
    # candidate has that form, and at 0.011 deg RMS its gap stays under the unexplained floor, so
    # only the repeatable structure of the residual flags it
    time, reported, rng = _generic_record(seed=3)
    square = (reported[:, 0] - reported[:, 0].mean()) ** 2
    distortion = np.deg2rad(0.011) * (square - square.mean()) / np.std(square)
    clean = reported + 0.01 + rng.normal(0, 1e-4, reported.shape)
    runs = {}
    for name, truth in (("distorted", clean + np.column_stack([np.zeros_like(distortion), distortion])),
                        ("clean", clean)):
        runs[name], _, _ = run_on_generic(time, reported, truth, ("a", "b"), ("rad", "rad"))
    distorted, clean_run = runs["distorted"], runs["clean"]
    assert distorted.named_effects == () and clean_run.named_effects == ()
    assert distorted.iterations[-1].gap_before < WorkflowSettings().unexplained_floor
    assert distorted.unexplained and distorted.residual_structure[1] >= WorkflowSettings().structure_share
    assert distorted.signature[0].startswith("b: varies smoothly with the a position"), distorted.signature
    assert not clean_run.unexplained and clean_run.signature == ()
    assert max(clean_run.residual_structure) < 0.1


def test_a_repeatable_residual_left_after_a_named_effect_is_flagged_unexplained():
    # a dead band (backlash, in the library) and a cross-joint bend of b with the square of a's
    # excursion (no candidate has that form): backlash is named and closes most of the gap, but what
    # it leaves still repeats, so the run reports the name and an unexplained residual with its signature
    time, reported, truth, _ = _dead_band_record()
    square = (reported[:, 0] - reported[:, 0].mean()) ** 2
    bend = np.deg2rad(0.011) * (square - square.mean()) / np.std(square)
    runs = {name: run_on_generic(time, reported, truth + np.column_stack([np.zeros_like(bend), k * bend]),
                                 ("a", "b"), ("rad", "rad"))[0] for name, k in (("bent", 1.0), ("dead band", 0.0))}
    bent, alone = runs["bent"], runs["dead band"]
    share = WorkflowSettings().structure_share
    assert bent.named_effects[:1] == alone.named_effects[:1] == ("backlash",), (bent.named_effects, alone.named_effects)
    assert bent.shrink >= 0.5
    assert bent.unexplained and bent.residual_structure[1] >= share, bent.residual_structure
    assert bent.signature and bent.signature[0].startswith("b: varies smoothly with the a position"), bent.signature
    # the dead band alone leaves nothing that repeats
    assert not alone.unexplained and alone.signature == () and max(alone.residual_structure) < share


@pytest.mark.parametrize("field, bad, message", [
    ("structure_share", 0.0, "structure_share must be in"), ("structure_share", float("nan"), "structure_share must be in"),
    ("structure_share", 1.5, "structure_share must be in"), ("structure_folds", 1, "structure_folds must be an integer"),
    ("structure_folds", 4.0, "structure_folds must be an integer"),
    ("backfit_rounds", -1, "backfit_rounds must be an integer"), ("backfit_rounds", 2.0, "backfit_rounds must be"),
    ("backfit_tolerance", 1.0, "backfit_tolerance must be in"),
    ("backfit_tolerance", float("nan"), "backfit_tolerance must be in")])
def test_the_structure_check_settings_are_checked(field, bad, message):
    with pytest.raises(ValueError, match=message):
        WorkflowSettings(**{field: bad})


def test_the_log_rate_of_generated_data_is_the_one_asked_for():
    from studies.common.discrepancy_runs import generate_measured, log_rate_options

    assert log_rate_options(30.0) == {}
    assert log_rate_options(300.0) == {"log_rate": 300.0, "truth_rate": 300.0}
    # the ground truth is never logged slower than the robot's own 100 Hz
    assert log_rate_options(50.0) == {"log_rate": 50.0, "truth_rate": 100.0}
    dataset, _ = generate_measured((), seed=3, duration=5.0, robot_options=log_rate_options(200.0))
    step = np.median(np.diff(dataset.time))
    assert step == pytest.approx(0.005, abs=0.0011)  # 1 kHz servo ticks: 5 ms apart, give or take a tick


def test_a_fast_log_is_thinned_to_the_highest_rate_asked_and_a_slower_one_is_kept_whole():
    from studies.common.discrepancy_runs import thinned, thinning_step

    time = np.arange(1000) * 0.001
    assert thinning_step(time, None) == 1
    assert thinning_step(time, 30.0) == 34  # 1 kHz to 29.4 Hz: the first step at or under 30 Hz
    assert thinning_step(time, 1000.0) == 1 and thinning_step(time, 2000.0) == 1
    assert thinning_step(np.arange(100) * 0.034, 30.0) == 1  # the robot's own 30 Hz log is kept whole
    for bad in (0.0, -5.0, float("nan")):
        with pytest.raises(ValueError, match="the highest log rate must be a positive number of Hz"):
            thinning_step(time, bad)

    class Log:
        def __init__(self, t):
            self.time = t

        def select(self, keep):
            return Log(self.time[keep])

    kept = thinned(Log(time), 100.0).time
    np.testing.assert_array_equal(kept, time[::10])


def test_the_extrapolated_backfit_round_lands_on_the_fixed_point_of_a_slow_linear_contraction():
    from simulation.discrepancy.workflow import BACKFIT_STEP_LIMIT, extrapolated_round

    # rounds theta_k+1 = fixed + rho (theta_k - fixed) along one slow direction, parameters of unlike scales
    fixed, scale = np.array([0.05, 2.0e-3, 12.0]), np.array([0.01, 1e-3, 10.0])
    lower, upper = np.zeros(3), np.array([1.0, 1.0, 100.0])
    direction = np.array([1.0, -0.5, 2.0]) * scale
    for rho in (0.5, 0.92):
        rounds = [fixed + 0.3 * rho ** k * direction for k in range(3)]
        np.testing.assert_allclose(extrapolated_round(*rounds, lower, upper, scale), fixed, rtol=1e-12)
    # a contraction slower than the step limit allows goes as far as the limit: (1 - limit (1 - rho))^2 of the way left
    rho = 0.99
    rounds = [fixed + 0.3 * rho ** k * direction for k in range(3)]
    left = (1 - BACKFIT_STEP_LIMIT * (1 - rho)) ** 2
    np.testing.assert_allclose(extrapolated_round(*rounds, lower, upper, scale), fixed + 0.3 * left * direction,
                               rtol=1e-9)
    # rounds that speed up (no contraction to extrapolate) give the last round; the bounds hold
    rounds = [fixed, fixed + 0.1 * direction, fixed + 0.3 * direction]
    np.testing.assert_allclose(extrapolated_round(*rounds, lower, upper, scale), rounds[2])
    rounds = [fixed + 0.3 * rho ** k * direction * -50 for k in range(3)]
    assert np.all(extrapolated_round(*rounds, lower, upper, scale) >= lower)
    np.testing.assert_array_equal(extrapolated_round(fixed, fixed, fixed, lower, upper, scale), fixed)


def test_the_backfit_cap_asked_on_the_command_line_reaches_the_blind_analysis(monkeypatch, tmp_path):
    import studies.common.discrepancy_runs as runs
    import studies.discrepancy as command

    used = []
    monkeypatch.setattr(runs, "read_measured", lambda path, arm="left", max_rate=None: path)
    monkeypatch.setattr(runs, "run_on_raven_dataset",
                        lambda dataset, progress=False, settings=None: used.append(settings) or "run")
    assert runs.analyse_measured("a.parquet", backfit_rounds=12) == "run"
    assert runs.analyse_measured("a.parquet") == "run"
    assert used == [WorkflowSettings(backfit_rounds=12), WorkflowSettings()]
    assert WorkflowSettings().backfit_rounds != 12

    class Stop(Exception):
        pass

    asked = []

    def stop(path, out, **options):
        asked.append(options)
        raise Stop

    monkeypatch.setattr(command, "read_flagged", lambda path, arm="left": type("Flagged", (), {"n_invalid": 0})())
    monkeypatch.setattr(command, "analysed_rows", lambda dataset, max_rate=None: dataset)
    monkeypatch.setattr(command, "check_analysable", lambda dataset: None)
    monkeypatch.setattr(command, "analyse", stop)
    (tmp_path / "log.parquet").write_bytes(b"")
    for extra, cap, patience in (([], None, None), (["--backfit-rounds", "12"], 12, None),
                                 (["--backfit-patience", "2"], None, 2)):
        with pytest.raises(Stop):
            command.main(["--measured", str(tmp_path / "log.parquet"), "--out", str(tmp_path / "out"), *extra])
        assert asked[-1]["backfit_rounds"] == cap and asked[-1]["backfit_patience"] == patience
    assert runs.analysis_settings(backfit_patience=2) == WorkflowSettings(backfit_patience=2)
    assert runs.analysis_settings() == WorkflowSettings()


@pytest.fixture(scope="module")
def five_second_log(tmp_path_factory):
    """Five seconds of generated RAVEN-II data (nothing hidden) as a dataset file."""
    from studies.common.discrepancy_runs import generate_measured, write_measured

    dataset, _ = generate_measured((), seed=3, duration=5.0)
    return write_measured(dataset, tmp_path_factory.mktemp("five_seconds"))


def _edited_copy(source, target, edit):
    import pyarrow.parquet as pq

    table = pq.read_table(source)
    columns = {name: table.column(name).to_numpy(zero_copy_only=False).copy() for name in table.column_names}
    edit(columns)
    pq.write_table(type(table).from_pydict(columns).replace_schema_metadata(table.schema.metadata), target)
    return target


def test_a_record_the_workflow_cannot_analyse_is_a_one_line_error_before_any_work(five_second_log, tmp_path, capsys):
    from studies.discrepancy import main

    def time_goes_back(columns):
        columns["time"][40] = columns["time"][10]

    def first_half_too_short(columns):
        # 40 rows (1.3 s): the first half is shorter than the identification's two derivative windows
        for name in columns:
            columns[name] = columns[name][:40]

    for edit, expected in ((time_goes_back, "time must increase strictly; it does not at sample 40"),
                           (first_half_too_short, "the starting structure is identified on the record's first half")):
        path = _edited_copy(five_second_log, tmp_path / f"{edit.__name__}.parquet", edit)
        with pytest.raises(SystemExit) as exit_info:
            main(["--measured", str(path), "--no-progress", "--out", str(tmp_path / "out")])
        error = capsys.readouterr().err.strip().splitlines()[-1]
        assert exit_info.value.code == 2 and error.startswith("python studies/discrepancy.py: error: "), error
        assert f"{path} cannot be analysed: " in error and expected in error, error
        assert not (tmp_path / "out").exists()


def test_rows_with_impossible_values_are_left_out_and_counted_in_the_report(five_second_log, tmp_path, monkeypatch):
    import studies.discrepancy as command

    def lose_a_truth_value(columns):
        columns["truth.elbow"][25] = np.nan

    path = _edited_copy(five_second_log, tmp_path / "nan.parquet", lose_a_truth_value)
    with pytest.warns(UserWarning, match="impossible values in 1 of .* column 'truth.elbow', sample 25"):
        flagged = command.read_flagged(path)
    assert flagged.n_invalid == 1 and not flagged.valid_mask()[25]
    assert len(command.analysed_rows(flagged)) == len(flagged) - 1
    # the report's source says so (the analysis itself left out: its input is what is checked here)
    sources = []
    stand_in = SimpleNamespace(named_effects=())
    monkeypatch.setattr(command, "analyse_measured", lambda path, **options: (stand_in, "signals", "split"))
    monkeypatch.setattr(command, "score_with_plant", lambda result, signals, split, **options: None)
    monkeypatch.setattr(command, "write_report",
                        lambda result, signals, split, source, *rest, **options: sources.append(source))
    with pytest.warns(UserWarning, match="impossible values in 1 of"):
        command.analyse(path, tmp_path)
    command.analyse(five_second_log, tmp_path)
    assert sources[0]["rows_dropped_invalid"] == 1
    assert sources[0]["description"] == "RAVEN-II data nan.parquet, 1 row with impossible values left out"
    assert "rows_dropped_invalid" not in sources[1] and sources[1]["description"] == "RAVEN-II data measured.parquet"
