"""What the virtual RAVEN-II records: robot state at the log rate and ground truth.

A :class:`Recording` keeps the compiled loop's compact per-arm channels (a few dozen floats per
log sample), so hours of robot time stay small in memory; :meth:`Recording.to_state_log` expands
them into every ``ravenstate`` field only when asked (for bags, datasets with all features).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from simulation.engine import loop
from simulation.engine import tables as engine_tables
from simulation.model.constants import ARM_SERIAL, SLOT_OF_DOF, RavenConstants

RUNLEVEL_OF_MODE = {engine_tables.MODE_TRAJECTORY: 3, engine_tables.MODE_HOMING: 1}
"""``ravenstate.runlevel`` of each loop mode: RL_PEDAL_DN (3) when operating, RL_INIT (1) while homing."""
SUBLEVEL_OF_MODE = {engine_tables.MODE_TRAJECTORY: 0, engine_tables.MODE_HOMING: 3}
"""``ravenstate.sublevel``: SL_AUTO_INIT (3) while homing."""

CHANNELS: dict[str, slice] = {
    "mpos": slice(loop.LOG_MPOS, loop.LOG_MPOS + 7),
    "mvel": slice(loop.LOG_MVEL, loop.LOG_MVEL + 7),
    "jpos": slice(loop.LOG_JPOS, loop.LOG_JPOS + 7),
    "jvel": slice(loop.LOG_JVEL, loop.LOG_JVEL + 7),
    "mpos_d": slice(loop.LOG_MPOSD, loop.LOG_MPOSD + 7),
    "jpos_d": slice(loop.LOG_JPOSD, loop.LOG_JPOSD + 7),
    "tau": slice(loop.LOG_TAU, loop.LOG_TAU + 7),
    "encoffsets": slice(loop.LOG_ENCOFF, loop.LOG_ENCOFF + 7),
    "true_joints": slice(loop.LOG_Q, loop.LOG_Q + 3),
    "true_tool_joints": slice(loop.LOG_QT, loop.LOG_QT + 4),
    "cable_tension": slice(loop.LOG_TENSION, loop.LOG_TENSION + 3),
    "cable_stretch": slice(loop.LOG_STRETCH, loop.LOG_STRETCH + 3),
    "hysteresis_state": slice(loop.LOG_Z, loop.LOG_Z + 3),
    "fatigue_dose": slice(loop.LOG_DOSE, loop.LOG_DOSE + 3),
    "applied_torque": slice(loop.LOG_TAUAPPLIED, loop.LOG_TAUAPPLIED + 7),
    "gravity_torque": slice(loop.LOG_GRAVITY, loop.LOG_GRAVITY + 3),
}
"""Float channels of a recording (simulator DOF order, SI). ``tau`` is the commanded motor torque
at the gearbox output (N m), as RAVEN-II publishes it; ``cable_tension`` is in joint units."""


@dataclass(frozen=True)
class Recording:
    """Robot state at the log rate plus ground truth, for one simulated arm.

    Attributes
    ----------
    arm : "left" or "right".
    time : (N,) s, robot clock of each state sample.
    values : (N, engine.N_LOG) float channels (see :data:`CHANNELS`).
    counts : (N, engine.N_ILOG) integer channels: encoder counts (7), DAC values (7), command
        sequence number.
    mode : (N,) loop mode of each sample (operating or homing).
    truth_time : (M,) s; truth : (M, 3) external joint encoders (rad, rad, m).
    labels : per-sample scenario labels, each (N,): ``payload_kg``, ``operating_hours``,
        ``homing_count``, ``segment`` (index into ``segment_names``).
    segment_names : names of the scenario parts.
    """

    arm: str
    time: np.ndarray
    values: np.ndarray
    counts: np.ndarray
    mode: np.ndarray
    truth_time: np.ndarray
    truth: np.ndarray
    labels: Mapping[str, np.ndarray] = field(default_factory=dict)
    segment_names: tuple[str, ...] = ()

    def __len__(self) -> int:
        return self.time.shape[0]

    @property
    def duration(self) -> float:
        return float(self.time[-1] - self.time[0]) if len(self) else 0.0

    def channel(self, name: str) -> np.ndarray:
        """One float channel by name, e.g. ``recording.channel("jpos")`` -> (N, 7)."""
        try:
            return self.values[:, CHANNELS[name]]
        except KeyError:
            raise ValueError(f"unknown channel {name!r}; known: {', '.join(CHANNELS)}") from None

    @property
    def encoder_counts(self) -> np.ndarray:
        return self.counts[:, loop.ILOG_ENC:loop.ILOG_ENC + 7]

    @property
    def dac_values(self) -> np.ndarray:
        return self.counts[:, loop.ILOG_DAC:loop.ILOG_DAC + 7]

    @property
    def sequence(self) -> np.ndarray:
        return self.counts[:, loop.ILOG_SEQ]

    def select(self, mask: np.ndarray) -> "Recording":
        """State samples where ``mask`` holds, with the truth restricted to their time span."""
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != self.time.shape:
            raise ValueError(f"mask must have shape {self.time.shape}, got {mask.shape}")
        time = self.time[mask]
        if time.size:
            keep = (self.truth_time >= time[0] - 0.02) & (self.truth_time <= time[-1] + 0.02)
        else:
            keep = np.zeros(self.truth_time.shape, dtype=bool)
        return Recording(
            arm=self.arm,
            time=time,
            values=self.values[mask],
            counts=self.counts[mask],
            mode=self.mode[mask],
            truth_time=self.truth_time[keep],
            truth=self.truth[keep],
            labels={k: v[mask] for k, v in self.labels.items()},
            segment_names=self.segment_names,
        )

    def operating(self) -> "Recording":
        """Only the samples taken while operating (homing excluded)."""
        return self.select(self.mode == engine_tables.MODE_TRAJECTORY)

    def segment(self, name: str) -> "Recording":
        """Only the samples of the scenario part called ``name``."""
        if name not in self.segment_names:
            raise ValueError(f"no segment {name!r}; segments: {self.segment_names}")
        return self.select(self.labels["segment"] == self.segment_names.index(name))

    @staticmethod
    def concatenate(recordings: list["Recording"]) -> "Recording":
        """Join recordings of the same arm in time order; segment names are merged."""
        recordings = [r for r in recordings if len(r) or len(r.truth_time)]
        if not recordings:
            raise ValueError("nothing to concatenate")
        arm = recordings[0].arm
        names: list[str] = []
        for r in recordings:
            if r.arm != arm:
                raise ValueError("cannot concatenate recordings of different arms")
            for n in r.segment_names:
                if n not in names:
                    names.append(n)
        for a, b in zip(recordings, recordings[1:]):
            if len(a) and len(b) and b.time[0] <= a.time[-1]:
                raise ValueError("recordings must be in time order without overlap")
        labels = {}
        # the first recording's order: a file written from the result is then the same byte for byte
        # in every process (a set's order follows the process's string hashing)
        for key in recordings[0].labels:
            parts = []
            for r in recordings:
                value = r.labels[key]
                if key == "segment":
                    value = np.array([names.index(r.segment_names[i]) for i in value], dtype=np.int64) \
                        if value.size else value.astype(np.int64)
                parts.append(value)
            labels[key] = np.concatenate(parts)
        return Recording(
            arm=arm,
            time=np.concatenate([r.time for r in recordings]),
            values=np.concatenate([r.values for r in recordings]),
            counts=np.concatenate([r.counts for r in recordings]),
            mode=np.concatenate([r.mode for r in recordings]),
            truth_time=np.concatenate([r.truth_time for r in recordings]),
            truth=np.concatenate([r.truth for r in recordings]),
            labels=labels,
            segment_names=tuple(names),
        )

    # ---- expansion to the robot's own message ----------------------------------------------

    def ravenstate_fields(self, robot, constants: RavenConstants | None = None) -> dict[str, np.ndarray]:
        """Every ``ravenstate`` field (except the header) in SI units, 16-wide where the message is.

        The arm's own slots hold the simulated values; the other arm's slots are zero, as a
        RAVEN-II with one arm connected publishes them (``local_io.cpp`` fills the slots of the
        ``NUM_MECH`` mechanisms present). The unused NO_CONNECTION slot (3) is zero as on the robot.

        Parameters
        ----------
        robot : the arm's :class:`kinematics.RavenII` (forward kinematics, Jacobian, gravity).
        constants : the arm's hardware constants (signs, transmission ratios).
        """
        c = constants or RavenConstants(arm=self.arm)
        n = len(self)
        arm_index = 0 if self.arm == "left" else 1
        slots = SLOT_OF_DOF + 8 * arm_index

        def wide(values7: np.ndarray, dtype=float) -> np.ndarray:
            out = np.zeros((n, 16), dtype=dtype)
            out[:, slots] = values7
            return out

        fields: dict[str, np.ndarray] = {}
        fields["runlevel"] = np.vectorize(RUNLEVEL_OF_MODE.get, otypes=[np.int64])(self.mode) if n else np.zeros(0, np.int64)
        fields["sublevel"] = np.vectorize(SUBLEVEL_OF_MODE.get, otypes=[np.int64])(self.mode) if n else np.zeros(0, np.int64)
        fields["last_seq"] = self.sequence.astype(np.int64)
        arm_type = np.zeros((n, 2), dtype=np.int64)
        arm_type[:, arm_index] = ARM_SERIAL[self.arm]
        fields["type"] = arm_type

        jpos = self.channel("jpos")
        jpos_d = self.channel("jpos_d")
        jvel = self.channel("jvel")
        q6 = joint_vector(jpos)
        q6_d = joint_vector(jpos_d)
        qd6 = joint_vector(jvel)
        pose = robot.forward_kinematics(q6, check_limits=False)
        pose_d = robot.forward_kinematics(q6_d, check_limits=False)
        pos = np.zeros((n, 6))
        pos_d = np.zeros((n, 6))
        ori = np.zeros((n, 18))
        ori_d = np.zeros((n, 18))
        pos[:, 3 * arm_index:3 * arm_index + 3] = pose[:, :3, 3]
        pos_d[:, 3 * arm_index:3 * arm_index + 3] = pose_d[:, :3, 3]
        ori[:, 9 * arm_index:9 * arm_index + 9] = pose[:, :3, :3].reshape(n, 9)
        ori_d[:, 9 * arm_index:9 * arm_index + 9] = pose_d[:, :3, :3].reshape(n, 9)
        fields["pos"] = pos
        fields["ori"] = ori
        fields["ori_d"] = ori_d
        fields["pos_d"] = pos_d
        fields["dt"] = np.full(n, c.servo_period)
        fields["encVals"] = wide(self.encoder_counts * c.encoder_sign.astype(np.int64), np.int64)
        fields["dac_val"] = wide(self.dac_values * c.dac_sign.astype(np.int64), np.int64)
        tau = self.channel("tau")
        fields["tau"] = wide(tau)
        fields["mpos"] = wide(self.channel("mpos"))
        fields["jpos"] = wide(jpos)
        fields["mvel"] = wide(self.channel("mvel"))
        fields["jvel"] = wide(jvel)
        fields["mpos_d"] = wide(self.channel("mpos_d"))
        fields["jpos_d"] = wide(jpos_d)
        grasp_d = np.zeros((n, 2))
        grasp_d[:, arm_index] = jpos_d[:, 5] + jpos_d[:, 6]
        fields["grasp_d"] = grasp_d
        fields["encoffsets"] = wide(self.channel("encoffsets"))

        # local_io.cpp publishes the Jacobian velocity in both jac_vel and jac_f (it calls get_vel
        # for both), so a real robot's jac_f holds the tool velocity; the simulator does the same.
        jac = robot.jacobian(q6, check_limits=False)
        vel = np.einsum("nij,nj->ni", jac, qd6)
        jac_vel = np.zeros((n, 12))
        jac_vel[:, 6 * arm_index:6 * arm_index + 6] = vel
        jac_f = jac_vel.copy()
        fields["jac_vel"] = jac_vel
        fields["jac_f"] = jac_f
        return fields

    def to_logs(self, robot, constants: RavenConstants | None = None):
        """The recording as a :class:`~simulation.recordings.ravenstate.RavenStateLog` and a
        :class:`~simulation.recordings.ravenstate.GroundTruthLog`."""
        from simulation.recordings.ravenstate import GroundTruthLog, RavenStateLog

        state = RavenStateLog(
            time=self.time.copy(),
            fields=self.ravenstate_fields(robot, constants),
            labels={k: np.asarray(v) for k, v in self.labels.items()},
            arm=self.arm,
        )
        truth = GroundTruthLog(time=self.truth_time.copy(), joints=self.truth.copy())
        return state, truth


def joint_vector(dof7: np.ndarray) -> np.ndarray:
    """Kinematic 6-vector J of the controller from the seven DOFs (grasp as (grasp2 - grasp1)/2)."""
    dof7 = np.asarray(dof7, dtype=float)
    out = np.empty(dof7.shape[:-1] + (6,))
    out[..., :5] = dof7[..., :5]
    out[..., 5] = 0.5 * (dof7[..., 6] - dof7[..., 5])
    return out


def recording_to_dataset(recording: Recording, robot, constants: RavenConstants | None = None,
                         chunk_seconds: float = 1800.0):
    """Synchronize a recording with its ground truth into a :class:`~simulation.recordings.dataset.CalibrationDataset`.

    The recording is expanded into ``ravenstate`` fields and synchronized chunk by chunk (the
    same path a ROS bag takes), so hours of data never hold every field at once.
    """
    from simulation.recordings.dataset import CalibrationDataset, synchronize

    if len(recording) == 0:
        raise ValueError("cannot build a dataset from an empty recording")
    edges = np.arange(recording.time[0], recording.time[-1] + chunk_seconds, chunk_seconds)
    parts = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        mask = (recording.time >= lo) & (recording.time < hi)
        if mask.sum() < 2:
            continue
        state, truth = recording.select(mask).to_logs(robot, constants)
        parts.append(synchronize(state, truth))
    return parts[0] if len(parts) == 1 else CalibrationDataset.concat(parts)
