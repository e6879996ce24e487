"""The controller's side of a RAVEN-II log: the logged command torques against the control law.

A RAVEN-II log holds what the controller commanded (``tau``, the PD output plus the gravity
compensation, before the DAC) beside what it was given (the desired motor positions ``mpos_d``)
and what it measured (``mpos``, ``mvel``, and the joint positions ``jpos`` it derives from them).
The law that ties them is in the controller's code: PD on motor positions (``pid_control.cpp``;
the integral gains of the positioning joints are zero) plus the gravity compensation of the
controller's model of the arm (``grav_comp.cpp``) at the reported joints, scaled from joint torques
to the gearbox output. Replaying that law predicts each logged command; what is left is a
discrepancy of the controller, which the transmission replay cannot see (it drives the cables with
the measured motor positions, so a controller that holds the arm at other motor positions changes
nothing it compares).

The one controller candidate is ``gravity_model_error``: the controller's gravity model off by a
scale per joint, as when the build on the robot carries other link masses than the nominal model
(``grav_comp.cpp`` itself once changed them by 22 % to 43 %). The command is linear in that scale,
so it is fitted in closed form.

The desired motor velocity the PD law uses is not logged; it is the central difference of the
logged desired positions within each homing (the desired motion is a smooth plan, known ahead, so
this is a reconstruction of the controller's input, not a prediction from the measurements).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simulation.model.constants import POSITIONING_NAMES

def _central_derivative(values: np.ndarray, time: np.ndarray, homing: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """d(values)/dt by central differences, each homing's stretch on its own (a re-homing
    re-registers the encoders, so the positions jump there), and where it is central: False at
    the first and last row of each stretch, where only a one-sided difference exists."""
    out = np.zeros_like(values)
    central = np.zeros(values.shape[0], dtype=bool)
    starts = np.flatnonzero(np.r_[True, homing[1:] != homing[:-1]])
    for a, b in zip(starts, np.r_[starts[1:], homing.size]):
        if b - a >= 3:
            out[a:b] = np.gradient(values[a:b], time[a:b], axis=0)
            central[a + 1:b - 1] = True
    return out, central


@dataclass(frozen=True, eq=False)
class ControllerSignals:
    """What a RAVEN-II log records of its controller, positioning joints only (SI).

    Attributes
    ----------
    motor : (N, 3) measured motor positions (rad).
    desired : (N, 3) desired motor positions (rad).
    motor_velocity : (N, 3) measured motor velocities (rad/s).
    desired_velocity : (N, 3) desired motor velocities reconstructed from ``desired`` (rad/s).
    reported : (N, 3) joint positions the controller derives from its motor encoders (rad, rad, m).
    command : (N, 3) commanded torques at the gearbox output (N m).
    usable : (N,) rows whose desired velocity is a central difference (the replay is scored there).
    """

    motor: np.ndarray
    desired: np.ndarray
    motor_velocity: np.ndarray
    desired_velocity: np.ndarray
    reported: np.ndarray
    command: np.ndarray
    usable: np.ndarray

    @classmethod
    def from_dataset(cls, dataset) -> "ControllerSignals":
        """The controller signals of a :class:`~simulation.recordings.dataset.CalibrationDataset`
        (its ``mpos``, ``mpos_d``, ``mvel``, ``jpos`` and ``tau`` columns of the positioning joints,
        which every dataset holds: the ravenstate topic logs them)."""
        table = dataset.table

        def columns(kind):
            return table[[f"{kind}.{n}" for n in POSITIONING_NAMES]].to_numpy(float)

        labels = dataset.labels
        homing = labels["homing_count"].to_numpy(int) if "homing_count" in labels else np.zeros(len(table), int)
        values = dict(motor=columns("mpos"), desired=columns("mpos_d"), motor_velocity=columns("mvel"),
                      reported=columns("jpos"), command=columns("tau"))
        velocity, usable = _central_derivative(values["desired"], dataset.time.astype(float), homing)
        return cls(**values, desired_velocity=velocity, usable=usable)

    def __len__(self) -> int:
        return self.command.shape[0]


@dataclass(frozen=True, eq=False)
class ControllerLaw:
    """The positioning joints' control law of the controller's code, with its nominal constants.

    ``kp``, ``kd`` (3,) are the PD gains (N m per motor rad and per motor rad/s at the gearbox
    output), ``ratio`` and ``gearbox`` (3,) the transmission ratios and gearbox ratios, and
    ``gravity`` the packed gravity model of the arm without payload
    (:meth:`kinematics.RavenII.gravity_coefficients`).
    """

    kp: np.ndarray
    kd: np.ndarray
    ratio: np.ndarray
    gearbox: np.ndarray
    gravity: np.ndarray

    @classmethod
    def nominal(cls, arm: str = "left", constants=None) -> "ControllerLaw":
        """The law with the controller's constants (:class:`~simulation.model.constants.RavenConstants`).

        Raises ValueError when an integral gain of a positioning joint is nonzero: the integral
        state is not logged, so such a law cannot be replayed from a log.
        """
        from kinematics import RavenII
        from simulation.model.constants import RavenConstants

        c = constants or RavenConstants(arm=arm)
        if np.any(np.asarray(c.ki[:3]) != 0):
            raise ValueError("the controller integrates the positioning joints' errors (ki != 0), "
                             "a state no log records")
        return cls(kp=np.asarray(c.kp[:3], float), kd=np.asarray(c.kd[:3], float),
                   ratio=np.asarray(c.transmission_ratio[:3], float), gearbox=np.asarray(c.gearbox[:3], float),
                   gravity=RavenII(arm, check_limits=False).gravity_coefficients(0.0))

    def gravity_compensation(self, signals: ControllerSignals) -> np.ndarray:
        """(N, 3) the gravity compensation of the controller's model at the reported joints (N m at
        the gearbox output)."""
        from kinematics.gravity_closed_form import gravity_torques_fast_batch

        torques = gravity_torques_fast_batch(np.ascontiguousarray(signals.reported), self.gravity)
        return torques / self.ratio * self.gearbox

    def command(self, signals: ControllerSignals, scale_error=None, compensation=None) -> np.ndarray:
        """(N, 3) the commands the law gives, with the gravity model scaled by ``1 + scale_error``."""
        scale = 1.0 + (np.zeros(3) if scale_error is None else np.asarray(scale_error, float))
        compensation = self.gravity_compensation(signals) if compensation is None else compensation
        position_error = signals.desired - signals.motor
        velocity_error = signals.desired_velocity - signals.motor_velocity
        return self.kp * position_error + self.kd * velocity_error + scale * compensation


@dataclass(frozen=True)
class ControllerCheck:
    """The controller replay of one record: the gravity-model scale fitted on the fit part, and
    the command gaps (RMS of logged minus replayed command per joint, N m) before and after.

    ``named`` holds when the scale cuts the gap by the workflow's ``min_shrink`` on both the fit and
    the validation parts and lowers the validation BIC (chi-square of the residual over each joint's
    fit-part RMS, plus 3 log n).
    """

    scale_error: np.ndarray
    named: bool
    fit_gap_before: np.ndarray
    fit_gap_after: np.ndarray
    validation_gap_before: np.ndarray
    validation_gap_after: np.ndarray
    held_out_gap_before: np.ndarray
    held_out_gap_after: np.ndarray
    bic_before: float
    bic_after: float

    @property
    def held_out_gap_kept(self) -> np.ndarray:
        """The held-out command gap of what the workflow keeps: with the fitted scale when it was
        named, else with none (N m)."""
        return self.held_out_gap_after if self.named else self.held_out_gap_before


def _rms(values: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(np.square(values), axis=0))


def check_controller(law: ControllerLaw, signals: ControllerSignals, fit: np.ndarray, validation: np.ndarray,
                     held_out: np.ndarray, min_shrink: float, accept: bool = False) -> ControllerCheck:
    """Fit the gravity-model scale of ``law`` on the ``fit`` rows of ``signals`` by least squares,
    joint by joint, and score it on the ``validation`` rows (``accept``: name it whatever it
    scores, for an oracle). Only the ``usable`` rows of ``signals`` count in any part."""
    fit, validation, held_out = (np.asarray(part, dtype=bool) & signals.usable for part in (fit, validation, held_out))
    compensation = law.gravity_compensation(signals)
    before = signals.command - law.command(signals, compensation=compensation)
    scale = np.zeros(3)
    for j in range(3):
        x, y = compensation[fit, j], before[fit, j]
        if np.dot(x, x) > 0:
            scale[j] = float(np.dot(x, y) / np.dot(x, x))
    after = before - scale * compensation
    weights = np.maximum(_rms(before[fit]), 1e-12)
    n_validation = int(validation.sum())
    bic_before = float(np.sum(np.square(before[validation] / weights)))
    bic_after = float(np.sum(np.square(after[validation] / weights)) + 3 * np.log(n_validation))
    cut = 1.0 - min_shrink

    def pooled(r, part):
        return float(np.sqrt(np.mean(np.square(r[part] / weights))))

    helps = (pooled(after, fit) <= cut * pooled(before, fit)
             and pooled(after, validation) <= cut * pooled(before, validation) and bic_after < bic_before)
    return ControllerCheck(scale_error=scale, named=bool(accept or helps),
                           fit_gap_before=_rms(before[fit]), fit_gap_after=_rms(after[fit]),
                           validation_gap_before=_rms(before[validation]),
                           validation_gap_after=_rms(after[validation]),
                           held_out_gap_before=_rms(before[held_out]), held_out_gap_after=_rms(after[held_out]),
                           bic_before=bic_before, bic_after=bic_after)


__all__ = ["ControllerCheck", "ControllerLaw", "ControllerSignals", "check_controller"]
