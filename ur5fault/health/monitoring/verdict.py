"""The verdict on one log part against a baseline: its events, its changes, and the word for both."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...discrepancy.model import SCREEN_S
from ...discrepancy.statistics import MIN_Z
from ...errors import ParameterError
from ...logs.measured import MeasuredLog, same_period
from ...sim.axes import JOINT_NAMES, N_JOINTS
from . import paired
from .baseline import Baseline
from .changes import (
    BLOCK_S,
    NEEDS_OWN_MOTION,
    bar,
    block_reference,
    estimates,
    find_changes,
    keep_mask,
    moved_s,
    still_joints,
    strongest,
)
from .conditions import motion_limit
from .coverage import MIN_BEYOND_S, motion_notes, payload_notes
from .event_fit import segment
from .events import (
    CHANNELS,
    DEFAULT_CHANNELS,
    FALSE_ALARM_PER_LOG,
    QUANTUM_FLOOR,
    UNITS,
    find_events,
    multiplier,
    n_windows,
    name_joints,
    quantum_sigma,
    sigma,
)
from .observe import Observed
from .task import CONTEXT_S, paired_transient, reference

VERDICTS = ("consistent", "changed", "anomaly")


def limits(baseline: Baseline, obs: Observed, feats: NDArray, judged: NDArray, cond: NDArray,
           channels: Sequence[str] = CHANNELS, chances_share: float = 1.0) -> dict[str, NDArray]:
    """The event limit ``(n, 6)`` of a log part per judged channel ([A], [rad]): the baseline's spread at its
    motion times the multiplier for its length at the channel's share of :data:`~.events.FALSE_ALARM_PER_LOG`
    (split evenly: the probability that either channel raises a false alarm is at most the sum, whatever their
    dependence); the position spread never below the rounding error of the baseline's or the log's own readings'
    quantum, the limit never below :data:`~.events.QUANTUM_FLOOR` quanta (:mod:`.events`). The spread and tail
    are those of each sample's motion condition ``cond`` ``(n, 6)`` (:mod:`.conditions`). ``chances_share``: the
    multiplier counts that share of the log's chances of a false alarm (:func:`.conditions.motion_limit`)."""
    out = {}
    for c in channels:
        i = CHANNELS.index(c)
        q = np.fmax(baseline.quantum_rad, obs.position_quantum_rad)
        floor = quantum_sigma(q) if c == "position" else 0.0
        lim = motion_limit(feats, cond, judged, baseline.scale[i], baseline.tail[i], baseline.cond_scale[i],
                           baseline.cond_tail[i], baseline.period_s, FALSE_ALARM_PER_LOG / len(channels), floor,
                           chances_share)
        if c == "position":
            lim = np.maximum(lim, QUANTUM_FLOOR * np.nan_to_num(q, nan=0.0))
        out[c] = lim
    return out


def transients_and_limits(baseline: Baseline, obs: Observed, channels: Sequence[str] = DEFAULT_CHANNELS
                          ) -> tuple[dict[str, NDArray], Callable[[float], dict[str, NDArray]], NDArray, NDArray]:
    """:func:`judged_transients`, with its limits as a function of the share of the log's chances of a false
    alarm the multiplier counts (``1``: the log's events; an event's own share: the joints named within it,
    :func:`.events.name_joints`). The transients are made once."""
    h, feats, judged, cond = segment(obs, baseline.slow_rad_s)
    hs = dict(zip(CHANNELS, h))
    paired = np.zeros(judged.shape, bool)
    runs, matched = (), ()
    if baseline.pairs and "current" in channels:
        runs = baseline.task_runs
        refs = [(baseline.task_target_rad[i], baseline.task_residual_A[i]) for i in runs]
        h_task, paired, matched = paired_transient(obs.target_rad, obs.residual_A, refs, obs.period_s)
        hs["current"] = np.where(paired[:, None], h_task, hs["current"])
    nw = n_windows(judged, baseline.period_s)

    def limits_at(share: float) -> dict[str, NDArray]:
        lims = limits(baseline, obs, feats, judged, cond, channels, share)
        if runs:
            lim_task = np.zeros(hs["current"].shape)
            for k, i in enumerate(runs):  # the widest limit of the runs paired with each sample
                mult = multiplier(baseline.task_tail[i], nw * share, FALSE_ALARM_PER_LOG / len(channels))
                lim_task = np.where(matched[k][:, None],
                                    np.maximum(lim_task, sigma(feats, baseline.task_scale[i]) * mult), lim_task)
            lims["current"] = np.where(paired[:, None], lim_task, lims["current"])
        return lims

    return hs, limits_at, judged, paired


def judged_transients(baseline: Baseline, obs: Observed, channels: Sequence[str] = DEFAULT_CHANNELS
                      ) -> tuple[dict[str, NDArray], dict[str, NDArray], NDArray, NDArray]:
    """What a log part's events are found in: per channel the transient ``(n, 6)``, per judged channel its limit
    ``(n, 6)``, the judged samples ``(n,)`` and the samples judged against a paired baseline run ``(n,)``.

    Where the log repeats a baseline run's motion (:mod:`.task`; only when the baseline runs repeat each other,
    :attr:`Baseline.pairs`), the current's transient is that of the residual less the paired runs' residual at
    the same point of the task, and its limit the spread of the paired run's task (fitted on that run against
    the others and its own repeats) times the multiplier of that fit's tail, the widest where several runs are
    paired; elsewhere both are the motion's (:func:`limits`). Every window is judged
    once, by one of the two, each at the share of the false-alarm probability for the log's whole length: the
    probability of a false alarm anywhere stays at most that share."""
    hs, limits_at, judged, paired = transients_and_limits(baseline, obs, channels)
    return hs, limits_at(1.0), judged, paired


def judge_changes(baseline: Baseline, obs: Observed, over: NDArray) -> tuple[list[dict], str | None, float]:
    """The changes of a log part (``over`` ``(n, 6)``: its event exceedances), and how the block test judged it:
    ``(changes, "all" | "rest" | None, share)`` (the whole part, the part beside a paired run, or not at all; the
    false-alarm share it spent). Where its screened part repeats a
    baseline run's task over at least :data:`~.paired.MIN_PAIRED_S` and the baseline holds paired statistics, the
    paired samples are judged by the paired test (:mod:`.paired`) and the rest, if it holds at least
    :data:`~.changes.BLOCK_S` (the length of the blocks it is compared with), by the baseline's block estimates
    (:mod:`.changes`); elsewhere the whole part by the latter. Per joint the change furthest beyond its bar. Where
    both tests judge the log, a change is flagged when either finds one, so each spends half the false-alarm
    probability (Bonferroni: :func:`.changes.bar`'s ``share``)."""
    m = obs.e.shape[0]
    logged, keep = obs.logged[:m], keep_mask(obs, over)
    ref = paired_reference(baseline, obs)
    if ref is None:
        every = estimates(obs, logged)
        return find_changes(obs, every, estimates(obs, keep) if over.any() else every,
                            block_reference(baseline.candidates)), "all", 1.0
    on = paired.difference(obs, ref)[1]
    rest = logged & ~on
    both = rest.sum() * obs.period_s >= BLOCK_S  # shorter, its estimate holds more of the model's error than a block
    share = 0.5 if both else 1.0
    every = paired.estimates(obs, ref, logged)
    stats = paired.for_log(baseline.paired_candidates, float((keep & on).sum() * obs.period_s))
    found = find_changes(obs, every, paired.estimates(obs, ref, keep) if over.any() else every, stats, "paired",
                         share)
    if not both:
        return found, None, share
    every = estimates(obs, rest)
    found = strongest(found, find_changes(obs, every, estimates(obs, keep & ~on) if over.any() else every,
                                          block_reference(baseline.candidates), share=share))
    return found, "rest", share


def paired_reference(baseline: Baseline, obs: Observed) -> NDArray | None:
    """The paired baseline run's residual at each sample of the log's task (:func:`.task.reference`), or None
    where the baseline holds no paired statistics or the log repeats a baseline task for less than
    :data:`~.paired.MIN_PAIRED_S`: then the block test alone judges its changes."""
    if not baseline.paired_candidates:
        return None
    refs = list(zip(baseline.task_target_rad, baseline.task_residual_A))
    ref = reference(obs.target_rad, refs, obs.period_s)[0]
    return None if paired.paired_seconds(obs, ref) < paired.MIN_PAIRED_S else ref


#: the block test's bar (in prediction standard deviations) beyond which a log's entry says that its baseline
#: holds too few blocks to see moderate changes: 2 x the workflow's MIN_Z, i.e. 8 blocks of BLOCK_S or fewer
#: (8.5; 12 blocks 6.2, 20 blocks 5.1; two 6 s runs give 2 blocks: about 10^4, where a 0.3 A offset went unseen)
WEAK_BAR_FACTOR = 2.0


def weak_change_test(baseline: Baseline, judged: str | None, share: float) -> list[str]:
    """A note when the block test judged the log (``judged``: ``"all"``, or ``"rest"``, the part beside a paired
    run; None: it did not) at false-alarm ``share`` and the baseline gives it so few blocks that its bar is
    :data:`WEAK_BAR_FACTOR` x ``MIN_Z`` or more."""
    k = max((n for _, _, n in baseline.candidates.values()), default=0)
    if judged is None or k < 1 or bar(k, share) < WEAK_BAR_FACTOR * MIN_Z:
        return []
    where = "changes" if judged == "all" else "changes on the part not repeating a baseline run's task"
    return [f"{where} are judged against {k} block(s) of {BLOCK_S:g} s of the baseline runs: a change must lie "
            f"{bar(k, share):.3g} standard deviations from them (Student's t, {k - 1} degree(s) of freedom; "
            f"{bar(1, share):.3g} with many blocks), so only a large change is seen there: give longer or more "
            f"baseline runs (each holds a block per {BLOCK_S:g} s, up to {SCREEN_S:g} s)"
            + (", or baseline runs repeating this log's task" if judged == "all" else "")]


def own_run(log: str, run: str) -> ParameterError:
    """The refusal of a monitored ``log`` that is the baseline's ``run``."""
    return ParameterError(f"{log} is one of the baseline's runs ({run}: the same samples); judged against itself it "
                          "pairs at lag 0 and can never change: monitor it against a baseline without it")


def refuse_baseline_runs(baseline: Baseline, logs: Sequence[MeasuredLog]) -> None:
    """Before any replay: a log whose samples are one of the baseline's runs' (their SHA-256,
    :attr:`.baseline.Baseline.samples_sha256`) refused with :func:`own_run`'s line. :func:`assess` still tells a
    part of a run, and a run of a ``baseline.json`` that does not record them, after the replay
    (:func:`baseline_run_of`)."""
    if baseline.samples_sha256 is None:
        return
    runs = {sha: name for name, sha in zip(baseline.segments, baseline.samples_sha256) if sha is not None}
    for log in logs:
        run = runs.get(log.content_sha256())
        if run is not None:
            raise own_run(log.source, run)


def baseline_run_of(baseline: Baseline, obs: Observed) -> str | None:
    """The baseline run ``obs`` is (part of), if any: its joint targets found verbatim, from its first second of
    motion (:data:`~.task.CONTEXT_S`) on, in that run's, **and** its current residual equal to that run's over the
    whole overlap. The targets alone do not tell a log from another run of the same program: a controller (or a
    simulation) commanding the same motion twice can write the same targets to the bit; what it measured differs
    (another run's noise, a push). A log that never moves is not told (its targets at rest repeat exactly)."""
    x = obs.target_rad
    L = int(round(CONTEXT_S / obs.period_s))
    if x.shape[0] < L or L < 2:
        return None
    moving = np.flatnonzero((np.diff(x, axis=0) != 0).any(axis=1))
    if moving.size == 0:
        return None
    s0 = min(int(moving[0]), x.shape[0] - L)
    window = x[s0 : s0 + L]
    r_log = np.where(obs.logged[:, None], obs.residual_A, np.nan)
    for name, t, r in zip(baseline.segments, baseline.task_target_rad, baseline.task_residual_A):
        for j in np.flatnonzero((t[: t.shape[0] - L + 1] == window[0]).all(axis=1)):
            if not np.array_equal(t[j : j + L], window):
                continue
            m = min(x.shape[0] - s0, t.shape[0] - j)
            if np.array_equal(t[j : j + m], x[s0 : s0 + m]) and np.allclose(r[j : j + m], r_log[s0 : s0 + m],
                                                                            rtol=0.0, atol=1e-9, equal_nan=True):
                return name
    return None


def assess(baseline: Baseline, obs: Observed, channels: Sequence[str] = DEFAULT_CHANNELS) -> dict[str, Any]:
    """``{"log", "verdict", "changes", "events"}`` for one log part (``monitor.json``'s entry): ``"changed"`` when
    a persistent change is found (even if events are too: a change needs maintenance, an event may not), else
    ``"anomaly"`` when an event is, else ``"consistent"``. ``channels``: the residuals events are judged on
    (:data:`~.events.DEFAULT_CHANNELS` unless given; with both, each at half the false-alarm probability)."""
    if not same_period(obs.period_s, baseline.period_s):
        raise ParameterError(f"{obs.name}: sample period {obs.period_s:g} s differs from the baseline's "
                             f"{baseline.period_s:g} s")
    unknown = sorted(set(channels) - set(CHANNELS))
    if unknown or not channels:
        raise ParameterError(f"event channels {list(channels)}: choose from {list(CHANNELS)}")
    run = baseline_run_of(baseline, obs)
    if run is not None:  # a part of a run, or a run of a baseline.json that does not record its samples' SHA-256
        raise own_run(obs.name, run)
    hs, limits_at, judged, _ = transients_and_limits(baseline, obs, channels)
    lims = limits_at(1.0)
    events, over = find_events(obs.t_s, hs, lims, judged)
    events = name_joints(events, obs.t_s, hs, limits_at, judged, baseline.period_s)
    changes, block_judged, block_share = judge_changes(baseline, obs, over)
    verdict = "changed" if changes else "anomaly" if events else "consistent"
    typical = {c: np.nanmedian(np.where(judged[:, None], lim, np.nan), axis=0) if judged.any()
               else np.full(N_JOINTS, np.nan) for c, lim in lims.items()}
    blind = _blind(typical, moved_peak(obs))  # the joints whose events are not seen: named and noted
    return {"log": obs.name, "verdict": verdict, "changes": changes, "events": events,
            "event_limit_median": {c: {JOINT_NAMES[j]: float(v[j]) for j in range(N_JOINTS)}
                                   for c, v in typical.items()},
            "events_not_seen": _unseen_names(blind),
            "notes": _blind_notes(blind) + weak_change_test(baseline, block_judged, block_share)
            + still_note(obs)
            + ([] if baseline.motion_max is None else motion_notes(baseline.motion_max, obs))
            + ([] if baseline.payloads_kg is None else payload_notes(baseline.payloads_kg, obs))}


def still_note(obs: Observed) -> list[str]:
    """A note naming the joints the change test does not judge for the effects that need their own motion
    (:func:`.changes.still_joints`), or none."""
    still = [JOINT_NAMES[j] for j in np.flatnonzero(still_joints(obs))]
    if not still:
        return []
    kinds = ", ".join(k.replace("_", " ") for k in NEEDS_OWN_MOTION)
    part_s = obs.e.shape[0] * obs.period_s
    return [f"{', '.join(still)}: held still in the part the change test reads (first {part_s:.0f} s), "
            f"so not judged for a change of {kinds}: a held joint's current is its holding torque plus the "
            "static friction it stopped against, which the log does not show (only a current-sensor offset and the "
            "gear stiffness are judged there)"]


#: a joint whose typical event limit is this many times the median of the six joints' is called out: a healthy
#: baseline gives the wrists smaller limits than the big joints (they draw less current), so a wrist far above the
#: rest is a spread its baseline runs could not estimate (two runs that hardly move it: wrist_2 at 29,191 x its
#: spread, a 5 A bump of 0.5 s on it judged consistent, where the same bump on the base was an event)
BLIND_FACTOR = 10.0


def moved_peak(obs: Observed) -> NDArray | None:
    """``obs.current_peak_A`` where the joint's target moves for :data:`.coverage.MIN_BEYOND_S` or more of the
    logged samples, NaN elsewhere: a joint the log holds still draws no more than its holding current and noise
    (0.05 A on the standstill run's wrists), under any limit a spread can give, which says nothing of blindness."""
    if obs.current_peak_A is None:
        return None
    moved = moved_s(obs) >= MIN_BEYOND_S
    return np.where(moved, obs.current_peak_A, np.nan)


def blind_joints(typical: dict[str, NDArray], current_peak_A: NDArray | None = None) -> list[str]:
    """A note per channel and joint whose typical (median) event limit is :data:`BLIND_FACTOR` times the joints'
    median or more (events there are judged against a limit the rest of the arm would never need), or, on the
    current channel, above the largest current the joint draws in the log (``current_peak_A``, :attr:`.observe.
    Observed.current_peak_A`): a disturbance would have to exceed everything the joint carries to be an event. The
    second holds where the first cannot: when several joints' limits are far out, their median is too (two baseline
    runs of other tasks put the base, shoulder and elbow at 9-55 A on a log drawing 2-5 A, and only the shoulder
    was named)."""
    return _blind_notes(_blind(typical, current_peak_A))


def _blind_notes(rows: list[tuple[str, int, float, str]]) -> list[str]:
    """:func:`blind_joints`' notes of the rows of :func:`_blind`."""
    return [f"{JOINT_NAMES[j]}: its {c} events are judged against a limit of {v:.3g} {UNITS[c]} at this log's "
            f"motion, {why}: the baseline runs do not tell its spread (they hardly move it, or disagree); an event "
            "smaller than that is not seen there: give baseline runs that move it as this log does"
            for c, j, v, why in rows]


def _blind(typical: dict[str, NDArray], current_peak_A: NDArray | None) -> list[tuple[str, int, float, str]]:
    """``(channel, joint, limit, why)`` of each blind joint (:func:`blind_joints`)."""
    out = []
    for c, v in typical.items():
        unit = UNITS[c]
        mid = float(np.nanmedian(v)) if np.isfinite(v).any() else np.nan
        peak = np.full(v.shape, np.nan) if c != "current" or current_peak_A is None else np.asarray(current_peak_A)
        for j in range(v.size):
            if not np.isfinite(v[j]):
                continue
            if mid > 0 and v[j] >= BLIND_FACTOR * mid:
                why = f"{v[j] / mid:.0f} x the joints' median ({mid:.3g} {unit})"
            elif np.isfinite(peak[j]) and v[j] > peak[j]:
                why = f"above the largest current it draws in this log ({peak[j]:.3g} {unit})"
            else:
                continue
            out.append((c, j, float(v[j]), why))
    return out


def unseen(typical: dict[str, NDArray], current_peak_A: NDArray | None = None) -> list[str]:
    """``"joint channel"`` of each joint whose events :func:`blind_joints` says are not seen: a verdict of
    "consistent" says nothing of them (``monitor.json``'s ``events_not_seen``, the console line)."""
    return _unseen_names(_blind(typical, current_peak_A))


def _unseen_names(rows: list[tuple[str, int, float, str]]) -> list[str]:
    return [f"{JOINT_NAMES[j]} {c}" for c, j, _, _ in rows]
