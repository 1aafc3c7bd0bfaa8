"""One log (or a part of one) replayed under the baseline's model overlay: the current residual the events are
found in, and the screened library columns the change test fits (:mod:`.changes`).

The replay is :class:`ur5fault.twin.LogReplay` (the one path from a log to the model); the screening is the
discrepancy workflow's own (:func:`ur5fault.discrepancy.library.screen`), on at most
:data:`~ur5fault.discrepancy.model.SCREEN_S` of the part, as that workflow screens.

Shapes: ``(n, 6)`` per sample and joint; the screened columns ``(p, m, n_channels)`` and the weighted residual
``(m, n_channels)`` on the part's first ``m`` samples (channels = the replay's signals x joints).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...discrepancy.candidates import LibraryCandidate
from ...discrepancy.library import candidates, screen
from ...discrepancy.model import SCREEN_S, WORKFLOW_SEED
from ...discrepancy.statistics import weighted
from ...errors import ParameterError
from ...identify.sensors import position_quantum
from ...logs import MeasuredLog
from ...sim.effects import EffectSpec
from ...twin.replay import LogReplay, refuse_log_owned
from ...twin.residuals import CONDITION_REST_SPEED_RAD_S
from .conditions import stribeck_speed

#: the library effects a monitor tests for a persistent change: wear of the drive train (Coulomb and viscous
#: friction, gear clearance and stiffness) and drift of the motor and its current sensor (torque constant,
#: current-sensor gain and offset). Left out: what a running robot does not acquire by itself (payload,
#: tool, where friction sits, cogging, delays, resolver offsets) - a job change, not a health change.
MONITOR_KINDS = ("coulomb_friction", "viscous_friction", "backlash", "gear_stiffness", "torque_constant",
                 "current_sensor_gain", "current_sensor_offset")

#: how much of a baseline run is screened [s]: all of it (``None``). The paired change test's reference is made
#: per 2 s of the baseline runs' paired samples (:mod:`.paired`), and the library columns exist only where a run
#: is screened: with the monitored log's :data:`~ur5fault.discrepancy.model.SCREEN_S` alone, part of a repeated
#: task's paired seconds gave no block (the bench's NIST baseline: 6 of its 9.6 paired s; docs/monitoring.md).
#: The block test still uses the
#: first :data:`~ur5fault.discrepancy.model.SCREEN_S` of each run (:func:`.changes.block_estimates`), as the
#: monitored log is screened.
BASELINE_SCREEN_S: float | None = None


@dataclasses.dataclass(frozen=True)
class Observed:
    """A log part replayed under the baseline.

    Attributes:
        name: the log's name (its file name; ``NAME[t0-t1 s]`` for a part).
        t_s: log time of each sample ``(n,)`` [s].
        residual_A: measured - simulated motor current ``(n, 6)`` [A].
        moving: the joint's target moves (target speed above the twin's rest speed) ``(n, 6)``.
        logged: the robot wrote the tick (not filled in a gap) ``(n,)``.
        cands, X, e: the screened library candidates, their weighted columns ``(p, m, n_channels)`` and the
            weighted residual ``(m, n_channels)`` on the part's first ``m`` samples.
        speed_rad_s, accel_rad_s2: the joint target's absolute speed and acceleration ``(n, 6)`` (the motion the
            event threshold scales with, :mod:`.events`).
        position_residual_rad: measured joint position reading - the twin's joint angle ``(n, 6)`` [rad]: the
            measured tracking error (actual - target) minus the twin's, from the same commands. The twin's
            angle, not its simulated reading: the reading carries the model's simulated sensor noise (about
            20 urad, ``sensors.resolver_noise_rad``), far above the measured readings' own at rest (one quantum
            of 2-16 urad on the Kufieta robot), which would hide a push on a standing arm.
        position_quantum_rad: the quantisation step of each joint's measured position ``(6,)`` [rad]
            (:func:`ur5fault.identify.sensors.position_quantum`, per joint; NaN where the joint never moves).
        target_rad: the commanded joint positions ``(n, 6)`` [rad] (the task: :mod:`.task` pairs a log with a
            baseline run that repeats it).
        current_sigma_A: the current residual's weight per joint ``(6,)`` [A] (the replay's sensor sigma, ``e``'s
            divisor on the current channels): the paired change test (:mod:`.paired`) weighs its difference
            with it. ``None`` only on a part replayed before it was kept (fill it with ``dataclasses.replace``).
        stribeck_speed_rad_s: the replay model's friction Stribeck speed [rad/s], where the events' slow condition
            ends (:func:`.conditions.stribeck_speed`; ``None``: not known, e.g. a part replayed before it was kept,
            refused as a baseline).
        rest_target: what the log's target is while the arm stands (:attr:`ur5fault.logs.MeasuredLog.rest_target`:
            ``"reading"`` as a CB2 logs it, ``"setpoint"`` as a CB3, ``None`` not seen); a baseline records its
            runs' (:attr:`.baseline.Baseline.rest_targets`), so that a log of another controller is told with
            ``--baseline-stats`` too.
        payload_kg: the log's stated payload [kg] (``None``: not stated); a baseline records its runs'
            (:attr:`.baseline.Baseline.payloads_kg`, :mod:`.coverage`).
        samples_sha256: the SHA-256 of the whole log's samples (:meth:`ur5fault.logs.MeasuredLog.content_sha256`;
            ``None`` for a part); a baseline records its runs', so that a log that is one of them is refused
            before its replay (:func:`.verdict.refuse_baseline_runs`).
        current_peak_A: the largest measured current of each joint over the part's logged samples ``(6,)`` [A]
            (``None``: not kept, e.g. a part observed before it was): an event limit above it is called out
            (:func:`.verdict.blind_joints`).
    """

    name: str
    period_s: float
    t_s: NDArray
    residual_A: NDArray
    moving: NDArray
    logged: NDArray
    cands: tuple[LibraryCandidate, ...]
    X: NDArray
    e: NDArray
    speed_rad_s: NDArray
    accel_rad_s2: NDArray
    position_residual_rad: NDArray
    position_quantum_rad: NDArray
    target_rad: NDArray
    current_sigma_A: NDArray | None = None
    stribeck_speed_rad_s: float | None = None
    rest_target: str | None = None
    payload_kg: float | None = None
    samples_sha256: str | None = None
    current_peak_A: NDArray | None = None

    @property
    def n(self) -> int:
        return self.t_s.size


def observe(log: MeasuredLog, params_overrides: dict | None = None, effects: Sequence[EffectSpec] = (), *,
            part_s: tuple[float, float] | None = None, kinds: Sequence[str] = MONITOR_KINDS,
            screen_s: float | None = SCREEN_S, jobs: int = 1) -> Observed:
    """Replay ``log`` under the overlay (``params_overrides``, ``effects``) and screen ``kinds`` on it.

    ``part_s``: keep only the samples with ``t0 <= t < t1`` of log time (the replay still starts at the log's
    start, so a part is simulated from the robot's real initial state). ``screen_s``: the length of the part's
    first stretch the library is screened on [s]; ``None``: the whole part (a baseline run's, so that the paired
    statistics hold every paired block of it, :data:`BASELINE_SCREEN_S`)."""
    if screen_s is not None and not screen_s > 0:
        raise ParameterError(f"screen_s = {screen_s} must be a positive number of seconds (or None: the whole part)")
    refuse_log_owned(params_overrides, effects, [log])
    rp = LogReplay(log, params_overrides, effects, seed=WORKFLOW_SEED, jobs=jobs)
    n_all = rp.n_samples
    t = log.t_s[1 : n_all + 1] - log.t_s[0]
    if part_s is None:
        lo, hi, name = 0, n_all, log.source
    else:
        t0, t1 = part_s
        idx = np.flatnonzero((t >= t0) & (t < t1))
        if idx.size < 2:
            raise ParameterError(f"{log.source}: the part [{t0:g}, {t1:g}) s holds fewer than 2 samples")
        lo, hi, name = int(idx[0]), int(idx[-1]) + 1, f"{log.source}[{t0:g}-{min(t1, t[-1]):g} s]"
    m = hi - lo if screen_s is None else min(hi - lo, max(2, round(screen_s / log.period_s)))
    cands = candidates(log.payload_kg, kinds=kinds, params=rp.params)
    # the screen simulates samples 1..lo+m; its baseline run is the replay itself there
    base, X, kept = screen(rp, lo + m, cands)
    if not base.ok:
        raise ParameterError(f"{log.source}: the replay under the baseline model failed ({base.failure})")
    if hi > lo + m:
        base = rp.run([()], hi)[0]
        if not base.ok:
            raise ParameterError(f"{log.source}: the replay under the baseline model failed ({base.failure})")
    meas = rp.measured(hi)
    e = weighted(meas[lo : lo + m], base.y[lo : lo + m], rp.sigma)
    qd_all = np.gradient(log.q_target_rad, log.period_s, axis=0)
    qdd = np.abs(np.gradient(qd_all, log.period_s, axis=0)[1 : n_all + 1][lo:hi])
    qd = np.abs(qd_all[1 : n_all + 1][lo:hi])
    return Observed(name, log.period_s, t[lo:hi], (meas[:, 0] - base.current_A[:hi])[lo:hi],
                    qd > CONDITION_REST_SPEED_RAD_S, log.logged_rows()[1 : n_all + 1][lo:hi],
                    tuple(kept), X[:, lo : lo + m] if kept else np.zeros((0, *e.shape)), e, qd, qdd,
                    (meas[:, 1] - base.q_rad[:hi])[lo:hi],
                    quanta(log.q_actual_rad), log.q_target_rad[1 : n_all + 1][lo:hi].copy(),
                    rp.sigma[0].copy(), stribeck_speed(rp.params), log.rest_target, log.payload_kg,
                    log.content_sha256() if part_s is None else None, peak_current(meas[lo:hi, 0],
                                                                             log.logged_rows()[1 : n_all + 1][lo:hi]))


def peak_current(current_A: NDArray, logged: NDArray) -> NDArray:
    """``(6,)``: each joint's largest absolute measured current over the logged samples [A] (NaN: none logged)."""
    a = np.abs(np.asarray(current_A, float)[np.asarray(logged, bool)])
    return np.nanmax(a, axis=0) if a.size and np.isfinite(a).any() else np.full(np.shape(current_A)[1], np.nan)


def quanta(q_rad: NDArray) -> NDArray:
    """``(6,)``: each joint's position quantum [rad] (identify's estimate on that joint alone), NaN where its
    reading never changes."""
    out = np.full(q_rad.shape[1], np.nan)
    for j in range(q_rad.shape[1]):
        col = q_rad[:, j : j + 1]
        if np.isfinite(col).all() and np.ptp(col) > 0:
            out[j] = position_quantum(col)[0]
    return out
