"""The measured (or simulated) robot log every reader returns: SI units, batch-free arrays."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError, ParameterError
from ..sim.trajectories import Trajectory

#: why a command other than ``ur5fault discrepancy`` and ``ur5fault identify`` refuses a log without its payload. A
#: payload on the flange and the robot's torque constants both scale the gravity current of the shoulder and elbow,
#: so fitting it needs a per-log fit (:mod:`ur5fault.discrepancy.payload`, :mod:`ur5fault.identify.payload`) that
#: reports how well the log separates them (the NIST log, 0.726 kg, declared unknown at its tool offset: 0.64 kg,
#: 95 % -0.07..1.34 by discrepancy; docs/validation.md).
UNKNOWN_PAYLOAD = ("this command needs the payload stated: give --payload-kg and --tcp-offset-m (0 and 0 0 0 for a "
                   "bare flange); `ur5fault discrepancy` and `ur5fault identify` fit an unknown payload and report it "
                   "(summary.json / the --json file, \"payload\")")


#: a log whose every joint's target spans less than this [rad] stands throughout (a CB2's target at rest follows the
#: reading, by quanta, and follows a push: Movement_No10_Standstill_WDist spans 1.4 mrad; the moving runs of data/
#: span 1.4-6.9 rad)
STANDING_SPAN_RAD = 0.01
#: two sample periods closer than this [s] are one rate (a median of timestamp differences; the real logs' rates, 8 ms
#: and 2 ms, differ by millions of it)
PERIOD_TOL_S = 1e-9


@dataclasses.dataclass(frozen=True)
class MeasuredLog:
    """A measured (or simulated) robot log, SI units, batch-free ``(n_samples, 6)`` arrays.

    ``current_A`` is in joint-positive sense; optional arrays are ``None`` when absent. The rows are on the
    controller's tick grid; ``logged`` marks the ticks the robot wrote whole (``None``: all of them; a tick
    missing from the file, or a row of it with a required value NaN, is not: see :mod:`.regular`).
    ``payload_kg`` / ``tcp_offset_m`` are ``None`` when the log does not say them and the caller did not either:
    unknown, never a silent default (``ur5fault discrepancy`` fits it and says so; the other workflows refuse such
    a log with one line, :meth:`require_payload`).
    ``notes``: what the reader assumed or left out, one line each, for the user and the records.
    """

    source: str
    t_s: NDArray
    q_target_rad: NDArray
    q_actual_rad: NDArray
    current_A: NDArray
    target_current_A: NDArray | None = None
    temperature_C: NDArray | None = None
    tcp_m: NDArray | None = None
    q_motor_rad: NDArray | None = None
    payload_kg: float | None = None
    tcp_offset_m: tuple[float, float, float] | None = None
    #: UR's own inverse-dynamics joint torque of the target motion [N*m] (NIST ROBOT_TARGET_JOINT_TORQUES,
    #: RTDE target_moment), used as a cross-check by ``ur5fault identify``
    target_torque_Nm: NDArray | None = None
    logged: NDArray | None = None
    notes: tuple[str, ...] = ()
    #: ``(n_samples,)`` bool: whether the gripper holds the payload at each sample (ur5fault's own logs record
    #: it); ``None``: the log does not say, and the payload is taken as held throughout
    payload_held: NDArray | None = None
    #: what the log's target is while the arm stands (:func:`.rest_target.rest_target_style`): ``"reading"`` (the
    #: previous measured position, as a CB2 controller logs it), ``"setpoint"`` (a fixed pose, as a CB3), ``None``
    #: (not seen); logs of one robot's controller share it
    rest_target: str | None = None
    #: written by ur5fault's simulator (``read_sim``), not recorded by a robot
    simulated: bool = False

    @property
    def payload_known(self) -> bool:
        return self.payload_kg is not None and self.tcp_offset_m is not None

    def require_payload(self) -> MeasuredLog:
        """``self`` when its payload and tool offset are known; else one line saying what to give."""
        if not self.payload_known:
            missing = " and ".join(k for k, v in (("payload", self.payload_kg), ("tool offset", self.tcp_offset_m))
                                   if v is None)
            raise ParameterError(f"{self.source}: {missing} unknown: {UNKNOWN_PAYLOAD}")
        return self

    def assumptions(self, joint_temperature_C) -> list[str]:
        """What a run on this log assumes beyond its data: the reader's notes, and the joint temperatures of the
        model (``joint_temperature_C``, per joint) where the log has none."""
        out = list(self.notes)
        if self.temperature_C is None:
            temps = ", ".join(f"{float(v):g}" for v in np.atleast_1d(joint_temperature_C))
            out.append(f"{self.source}: no joint temperatures in the log; the model's {temps} degC assumed")
        span = np.ptp(self.q_target_rad, axis=0) if self.t_s.size else np.zeros(0)
        if span.size and float(span.max()) < STANDING_SPAN_RAD:
            out.append(f"{self.source}: the arm stands throughout (no joint's target moves {STANDING_SPAN_RAD:g} "
                       "rad): what shows only in motion (friction, inertia, delays, backlash) is not in it, and at one "
                       "pose a current gain, a torque constant and a current offset are hard to tell apart")
        return out

    def content_sha256(self) -> str:
        """SHA-256 of the log's measured samples (times, targets, positions, currents): the same recording under
        two file names is one log, two recordings under one file name in two folders are two."""
        import hashlib

        h = hashlib.sha256()
        for a in (self.t_s, self.q_target_rad, self.q_actual_rad, self.current_A):
            h.update(np.ascontiguousarray(a, dtype=np.float64).tobytes())
        return h.hexdigest()

    def logged_rows(self) -> NDArray:
        """``(n,)`` bool: the rows the robot wrote (all but the ticks filled in by :mod:`.regular`)."""
        return np.ones(self.t_s.size, dtype=bool) if self.logged is None else self.logged

    @property
    def period_s(self) -> float:
        return float(np.median(np.diff(self.t_s)))

    def to_trajectory(self, name: str | None = None) -> Trajectory:
        """The log's target positions as a setpoint stream, the payload held where :attr:`payload_held` says
        (a grip or release between two samples placed half-way between them), else throughout.

        The grip schedule is the log's, the mass the replay's: a log stated at 0 kg is held throughout too (the
        gripped mass is 0 kg, so its replay is unchanged), so that a replay with a payload effect (the
        discrepancy library's ``payload`` and ``payload_com`` candidates: a tool the log's statement left out)
        carries that mass; before, a 0 kg log held nothing and those candidates changed nothing."""
        self.require_payload()
        if self.payload_held is None:
            return Trajectory(name or self.source, self.period_s, self.q_target_rad, (), True, self.payload_kg)
        held = np.asarray(self.payload_held, bool)
        t = self.t_s - self.t_s[0]
        change = np.flatnonzero(held[1:] != held[:-1]) + 1
        events = tuple((float(0.5 * (t[k - 1] + t[k])), bool(held[k])) for k in change)
        return Trajectory(name or self.source, self.period_s, self.q_target_rad, events, bool(held[0]),
                          self.payload_kg)

    def window(self, t0_s: float, t1_s: float) -> MeasuredLog:
        """The part of the log with ``t0 <= t < t1`` (times relative to the log start), time re-zeroed."""
        t = self.t_s - self.t_s[0]
        sel = (t >= t0_s) & (t < t1_s)
        if sel.sum() < 2:
            raise LogFormatError(f"{self.source}: window [{t0_s}, {t1_s}) s holds fewer than 2 samples")
        kw = self._rows(sel)
        kw["t_s"] = kw["t_s"] - kw["t_s"][0]
        return MeasuredLog(**kw)

    def every(self, k: int, note: str = "") -> MeasuredLog:
        """Every ``k``-th sample, from the ``k``-th: what a logger ``k`` times slower on the same clock would have
        written (the samples are instantaneous readings, not averages; a log whose first sample is one tick after
        its clock's zero, as the simulator writes them, then gives exactly the slower logger's samples), ``note``
        added to :attr:`notes`."""
        if k < 1:
            raise ValueError(f"every({k}): k must be at least 1")
        kw = self._rows(slice(k - 1, None, k))
        if note:
            kw["notes"] = (*self.notes, note)
        return MeasuredLog(**kw)

    def _rows(self, rows) -> dict:
        """The log's fields as keyword arguments, every per-sample array cut to ``rows`` (a mask or a slice)."""
        kw = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for key, v in kw.items():
            if isinstance(v, np.ndarray) and v.shape[:1] == self.t_s.shape:
                kw[key] = v[rows]
        return kw


def assumption_notes(logs: Sequence[MeasuredLog], joint_temperature_C,
                     others: Sequence[tuple[str, str | None]] = ()) -> list[str]:
    """Every log's :meth:`MeasuredLog.assumptions`, a note several logs share said once with their names (nine
    runs of a robot without temperatures: one line, not nine), in the logs' order. ``others``: ``(name,
    rest_target)`` of logs judged together with these but not read here (the runs of a monitor's
    ``baseline.json``): they enter the check that all logs are of one controller's style only."""
    by_text: dict[str, list[str]] = {}
    for lg in logs:
        for line in lg.assumptions(joint_temperature_C):
            source, sep, text = line.partition(": ")
            key, name = (text, source) if sep and source == lg.source else (line, "")
            by_text.setdefault(key, []).append(name)
    out = []
    for text, names in by_text.items():
        named = [n for n in names if n]
        if not named:
            out.append(text)
        elif len(named) == 1:
            out.append(f"{named[0]}: {text}")
        else:
            out.append(f"{len(named)} logs ({', '.join(named)}): {text}")
    return out + controllers_note([*others, *((lg.source, lg.rest_target) for lg in logs)])


def controllers_note(named: Sequence[tuple[str, str | None]]) -> list[str]:
    """A note when logs ``(name, rest_target)`` are of two controllers: a CB2's target at rest is the previous
    reading, a CB3's a fixed setpoint (:attr:`MeasuredLog.rest_target`; ``None``: never at rest, not told)."""
    styles = {s: [name for name, style in named if style == s] for s in ("reading", "setpoint")}
    if not all(styles.values()):
        return []
    return [f"the target at rest is the previous reading in {', '.join(styles['reading'])} (as a CB2 controller "
            f"logs it) and a fixed setpoint in {', '.join(styles['setpoint'])} (as a CB3's): logs of two controllers, "
            "likely two robots, under one model"]


def same_period(a_s: float, b_s: float) -> bool:
    """Two sample periods [s] are one rate: within :data:`PERIOD_TOL_S` (logs of one command must share one)."""
    return abs(a_s - b_s) <= PERIOD_TOL_S
