"""The virtual RAVEN-II arm: a parameter set, a kinematic model and the state of the servo loop."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kinematics import RavenII

from simulation.engine import loop
from simulation.engine import tables as engine_tables
from simulation.model.laws import cable_stretch_curve
from simulation.model.parameters import RavenParameters
from simulation.recordings.recording import Recording

LOG_RATE = 30.0
"""Default robot-state recording rate (Hz): the paper recorded ``ravenstate`` at 30 Hz."""
TRUTH_RATE = 100.0
"""Default ground-truth rate (Hz): the paper recorded the external encoders at 100 Hz."""


@dataclass(frozen=True)
class Motion:
    """Desired DOF motion sampled uniformly: what the servo loop tracks.

    ``q`` and ``qd`` are (N, 7) positions and velocities in the simulator's DOF order
    ``[shoulder rad, elbow rad, z_ins m, tool_rot rad, wrist rad, grasp1 rad, grasp2 rad]``,
    sampled at ``rate`` Hz from t = 0. Any object with attributes ``q``, ``qd``, ``rate`` (such as a
    :class:`simulation.trajectories.JointTrajectory`) can be run.
    """

    q: np.ndarray
    qd: np.ndarray
    rate: float


def _check_motion(motion) -> tuple[np.ndarray, np.ndarray, float]:
    try:
        q = np.ascontiguousarray(motion.q, dtype=float)
        qd = np.ascontiguousarray(motion.qd, dtype=float)
        rate = float(motion.rate)
    except AttributeError as exc:
        raise TypeError("a motion needs attributes q, qd (N, 7) and rate (Hz)") from exc
    if q.ndim != 2 or q.shape[1] != 7 or q.shape[0] < 2:
        raise ValueError(f"motion.q must have shape (N >= 2, 7), got {q.shape}")
    if qd.shape != q.shape:
        raise ValueError(f"motion.qd must have the shape of motion.q {q.shape}, got {qd.shape}")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(qd))):
        bad = int(np.argmax(~(np.isfinite(q).all(1) & np.isfinite(qd).all(1))))
        raise ValueError(f"motion has a non-finite value at sample {bad}")
    if not (np.isfinite(rate) and rate > 0):
        raise ValueError(f"motion.rate must be positive, got {rate}")
    return q, qd, rate


def smooth_move(start: np.ndarray, target: np.ndarray, duration: float, rate: float = 100.0) -> Motion:
    """Raised-cosine move from ``start`` to ``target`` (7 DOFs) in ``duration`` seconds, at rest at both ends."""
    start = np.asarray(start, dtype=float)
    target = np.asarray(target, dtype=float)
    n = max(int(np.ceil(duration * rate)) + 1, 2)
    t = np.arange(n) / rate
    phase = np.clip(t / duration, 0.0, 1.0)
    shape = 0.5 * (1.0 - np.cos(np.pi * phase))
    speed = np.where(t <= duration, 0.5 * np.pi / duration * np.sin(np.pi * phase), 0.0)
    q = start + shape[:, None] * (target - start)
    qd = speed[:, None] * (target - start)
    return Motion(q=q, qd=qd, rate=rate)


class VirtualRaven:
    """One simulated RAVEN-II arm, stepped by the compiled 1 kHz servo loop.

    Parameters
    ----------
    params : the arm's parameter set (default: the virtual RAVEN-II,
        :func:`simulation.model.parameters.RavenParameters`).
    seed : seeds every random draw (power-on encoder counts, homing registration, noise).
    payload_kg : mass hanging at the tool tip (kg); change it with :meth:`set_payload`.
    log_rate, truth_rate : recording rates of the robot state and of the ground truth (Hz).
    substeps : plant integration steps per 1 ms servo tick.

    The arm powers on at rest in its home pose with unregistered encoders; call :meth:`home`
    before recording data that a calibration should use, as on the real robot.
    """

    def __init__(self, params: RavenParameters | None = None, *, seed: int = 0, payload_kg: float = 0.0,
                 log_rate: float = LOG_RATE, truth_rate: float = TRUTH_RATE, substeps: int = 2) -> None:
        self.params = params if params is not None else RavenParameters()
        if not isinstance(self.params, RavenParameters):
            raise TypeError(f"params must be RavenParameters, got {type(self.params).__name__}")
        for name, rate in (("log_rate", log_rate), ("truth_rate", truth_rate)):
            if not (np.isfinite(rate) and 0 < rate <= 1000.0):
                raise ValueError(f"{name} must be in (0, 1000] Hz, got {rate}")
        if int(substeps) < 1:
            raise ValueError(f"substeps must be >= 1, got {substeps}")
        gravity = self.params.gravity
        self.robot = RavenII(arm=self.params.arm, check_limits=False) if gravity is None else \
            RavenII(arm=self.params.arm, gravity=gravity, check_limits=False)
        self.log_rate = float(log_rate)
        self.truth_rate = float(truth_rate)
        self.substeps = int(substeps)
        self._rng = np.random.default_rng(seed)
        self._tables: dict[float, engine_tables.EngineTables] = {}
        self.payload_kg = 0.0
        self.set_payload(payload_kg)
        self.tick = 0
        self.homing_count = 0
        self._hours_origin = 0.0
        self.plant = np.zeros(engine_tables.N_PLANT)
        self.ctrl = np.zeros(engine_tables.N_CTRL)
        self._power_on()

    # ---- state ----------------------------------------------------------------------------

    @property
    def time(self) -> float:
        """Robot clock (s)."""
        return self.tick * self.params.constants.servo_period

    @property
    def dt(self) -> float:
        return self.params.constants.servo_period

    def set_payload(self, payload_kg: float) -> None:
        """Hang ``payload_kg`` at the tool tip (the controller is not told, as on the real robot)."""
        payload = float(payload_kg)
        if not (np.isfinite(payload) and payload >= 0):
            raise ValueError(f"payload_kg must be a non-negative number, got {payload_kg!r}")
        self.payload_kg = payload

    def tables(self) -> engine_tables.EngineTables:
        key = round(self.payload_kg, 9)
        if key not in self._tables:
            self._tables[key] = engine_tables.build_tables(self.params, self.robot, self.payload_kg, self.substeps)
        return self._tables[key]

    def _power_on(self) -> None:
        c = self.params.constants
        tables = self.tables()
        home = c.home_pose
        # at rest at power-on, the cables already carry the links' weight
        stretch = np.zeros(3)
        if self.params.is_enabled("cable_stretch"):
            law = self.params.effect("cable_stretch")
            load = np.zeros(3)
            if self.params.is_enabled("gravity_stretch"):
                q6 = np.r_[home[:3], 0.0, 0.0, 0.0]
                load = self.robot.gravity_torques(q6, payload_kg=self.payload_kg) \
                    * self.params.effect("gravity_stretch").load_scale
            stretch = cable_stretch_curve(load, law.stiffness, law.hardening)
        u = np.empty(7)
        u[:3] = np.linalg.solve(tables.coupling_true, home[:3] + stretch)
        m_ins = u[2] * c.transmission_ratio[2]
        signs = np.array([1.0, 1.0, -1.0, 1.0]) * c.tool_sign
        u[3:] = (c.transmission_ratio[3:] * home[3:] + signs * m_ins / c.tool_gb_ratio) / c.transmission_ratio[3:]
        self.plant[engine_tables.X_U:engine_tables.X_U + 7] = u
        self.plant[engine_tables.X_Q:engine_tables.X_Q + 3] = home[:3]
        self.plant[engine_tables.X_PB:engine_tables.X_PB + 3] = home[:3] + stretch
        self.plant[engine_tables.X_SF:engine_tables.X_SF + 3] = stretch
        self.plant[engine_tables.X_QF:engine_tables.X_QF + 3] = home[:3]
        self.plant[engine_tables.X_QT:engine_tables.X_QT + 4] = home[3:]
        power_on = self._rng.integers(-20000, 20000, size=7).astype(float)
        self.ctrl[engine_tables.C_POWERON:engine_tables.C_POWERON + 7] = power_on
        self.ctrl[engine_tables.C_OFF:engine_tables.C_OFF + 7] = power_on

    def true_joints(self) -> np.ndarray:
        """Current true positions of shoulder (rad), elbow (rad), insertion (m)."""
        return self.plant[engine_tables.X_Q:engine_tables.X_Q + 3].copy()

    def fatigue_dose(self) -> np.ndarray:
        """Accumulated cable fatigue dose of the positioning joints (equivalent hours)."""
        return self.plant[engine_tables.X_DOSE:engine_tables.X_DOSE + 3].copy()

    def start_operating_clock(self) -> None:
        """Make ``operating_hours`` labels count from now."""
        self._hours_origin = self.time

    # ---- running --------------------------------------------------------------------------

    def _record_ticks(self, start_tick: int, n_ticks: int, rate: float) -> np.ndarray:
        period = 1.0 / rate / self.dt
        first = int(np.ceil(start_tick / period - 1e-9))
        last = int(np.floor((start_tick + n_ticks - 1) / period + 1e-9))
        ticks = np.round(np.arange(first, last + 1) * period).astype(np.int64)
        return ticks[(ticks >= start_tick) & (ticks < start_tick + n_ticks)]

    def _run_loop(self, mode: int, n_ticks: int, q: np.ndarray, qd: np.ndarray, rate: float,
                  segment: str) -> Recording:
        tables = self.tables()
        log_ticks = self._record_ticks(self.tick, n_ticks, self.log_rate)
        truth_ticks = self._record_ticks(self.tick, n_ticks, self.truth_rate)
        log_f = np.zeros((log_ticks.size, loop.N_LOG))
        log_i = np.zeros((log_ticks.size, loop.N_ILOG), dtype=np.int64)
        log_mode = np.zeros(log_ticks.size, dtype=np.int64)
        truth = np.zeros((truth_ticks.size, 3))
        seed = int(self._rng.integers(0, 2**31 - 1))
        done, n_log, n_truth = loop.servo_loop(
            mode, self.tick, n_ticks, q, qd, rate, self.time,
            tables.table, tables.flags, tables.scalars, tables.coupling_nominal, tables.coupling_true,
            tables.gravity_plant, tables.gravity_controller, self.plant, self.ctrl, seed,
            log_ticks, log_f, log_i, log_mode, truth_ticks, truth,
        )
        time = log_ticks[:n_log] * self.dt
        recording = Recording(
            arm=self.params.arm,
            time=time,
            values=log_f[:n_log],
            counts=log_i[:n_log],
            mode=log_mode[:n_log],
            truth_time=truth_ticks[:n_truth] * self.dt,
            truth=truth[:n_truth],
            labels={
                "payload_kg": np.full(n_log, self.payload_kg),
                "operating_hours": (time - self._hours_origin) / 3600.0,
                "homing_count": np.full(n_log, self.homing_count, dtype=np.int64),
                "segment": np.zeros(n_log, dtype=np.int64),
            },
            segment_names=(segment,),
        )
        self.tick += int(done)
        return recording

    def run(self, motion, segment: str = "motion") -> Recording:
        """Track a desired motion from the current state and record it.

        Parameters
        ----------
        motion : object with ``q``, ``qd`` (N, 7) and ``rate`` (Hz) — e.g. a
            :class:`simulation.trajectories.JointTrajectory` or a :class:`Motion`. Its first sample
            should be near the arm's current desired pose (prepend a move otherwise).
        segment : name of this scenario part in the recording's labels.
        """
        q, qd, rate = _check_motion(motion)
        n_ticks = int(round((q.shape[0] - 1) / rate / self.dt)) + 1
        recording = self._run_loop(engine_tables.MODE_TRAJECTORY, n_ticks, q, qd, rate, segment)
        self._last_desired = q[-1].copy()
        return recording

    def hold(self, duration: float, segment: str = "idle") -> Recording:
        """Hold the current desired pose for ``duration`` seconds (idle, pedal down)."""
        if not (np.isfinite(duration) and duration > 0):
            raise ValueError(f"duration must be positive, got {duration}")
        pose = self.desired_pose()
        return self.run(Motion(q=np.vstack([pose, pose]), qd=np.zeros((2, 7)), rate=1.0 / duration), segment)

    def move_to(self, target, duration: float | None = None, segment: str = "move") -> Recording:
        """Raised-cosine move of all seven DOFs from the current desired pose to ``target``."""
        target = np.asarray(target, dtype=float)
        if target.shape != (7,) or not np.all(np.isfinite(target)):
            raise ValueError(f"target must be 7 finite DOF positions, got {target!r}")
        start = self.desired_pose()
        if duration is None:
            span = np.abs(target - start) / np.array([0.2, 0.2, 0.02, 1.0, 1.0, 1.0, 1.0])
            duration = max(1.0, float(span.max()) * 1.5)
        return self.run(smooth_move(start, target, duration), segment)

    def desired_pose(self) -> np.ndarray:
        """The pose the controller was last asked to hold (7 DOFs, SI)."""
        return self._last_desired.copy() if hasattr(self, "_last_desired") else self.params.constants.home_pose.copy()

    def home(self, max_duration: float = 30.0) -> Recording:
        """The RAVEN-II homing procedure, then a move to the home pose.

        Drives the positioning joints into their hard stops until the motor current reaches the
        controller's threshold, waits for the cables to settle, registers the encoders
        (``homing.cpp``), and moves to the home pose in 2.5 s. Returns the recording of it all.
        """
        self.ctrl[engine_tables.C_HOMESTATE:engine_tables.C_HOMESTATE + 3] = -1.0
        n_ticks = int(round(max_duration / self.dt))
        dummy = np.zeros((2, 7))
        search = self._run_loop(engine_tables.MODE_HOMING, n_ticks, dummy, dummy, 1.0, "homing")
        if self.ctrl[engine_tables.C_HOMESTATE:engine_tables.C_HOMESTATE + 3].min() < 1.0:
            raise RuntimeError(f"homing did not reach every hard stop within {max_duration} s")
        self.homing_count += 1
        c = self.params.constants
        start = self.ctrl[engine_tables.C_HOLD:engine_tables.C_HOLD + 7].copy()
        start[:3] = c.hard_stop
        move = self.run(smooth_move(start, c.home_pose, 2.5), "homing")
        self._last_desired = c.home_pose.copy()
        return Recording.concatenate([search, move])
