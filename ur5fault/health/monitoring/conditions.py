"""Motion conditions of the events' limit: the arm at rest, a joint moving slowly (in its friction's Stribeck
regime: stops, starts, creeping reversals), a joint moving.

*Rest, judged against its own level.* While the arm stands (every joint's target within the twin's rest speed,
:data:`~ur5fault.twin.residuals.CONDITION_REST_SPEED_RAD_S`, for at least :data:`~.events.SETTLE_S` after the
last motion), a healthy drive holds a constant current: gravity and the friction it stopped against, whatever the
model's error at that pose. A push is a departure from that level. So at rest the transient is the smoothed
residual less its running median over :data:`~.events.LEVEL_S` *within the same rest stretch* (the window cut at
the stretch's ends and padded with the nearest value there, which follows a monotone drift exactly, as the
centred median does inside): the model's error of the motion before or after the rest does not enter the level.
Rest is the arm's, not one joint's: while another joint moves, a joint that holds still is *standing*.

*Slow.* A target speed below the friction law's Stribeck speed (``1 / stribeck_rate_s_per_rad`` of the model
overlay: 0.1 rad/s packaged, where the breakaway excess of ``tanh(rate |w|)`` has fallen to 24 %) is neither rest
nor motion for friction: the friction changes sign (a creeping reversal) or falls from breakaway, and the twin's
error there is its own. Such samples of a joint that moves (target above the rest speed, or moved by more than
the controller's jitter, :data:`~.task.TARGET_JITTER_RAD`, over :data:`~.task.CONTEXT_S` around the sample: a
creep at 1 mrad/s hovers about the rest speed) and is not within :data:`~.events.SETTLE_S` of faster motion get
their own spread and tail from the baseline runs' slow samples.

*Standing*: a joint whose own target holds (not moving, creeping or settling) while other joints move. Its
current carries the coupling and the pose change of the moving links (gravity and inertia through the links it
holds), which the twin does not reproduce exactly, and that error is set by the others' motion and the pose, not by
the joint's own speed and acceleration, the moving condition's features (on the seven undisturbed Kufieta runs a
standing joint's transient differs between runs by 3-40 x in RMS, and its square hardly follows the others'
largest speed or acceleration: correlations -0.09 to 0.35 per joint; docs/monitoring.md). So it gets a constant
spread and tail of its own, fitted on the baseline's standing samples of that joint, and is judged by the wider of
that and the limit a moving joint has there (the all-motions fit and the moving condition's, which judged these
samples before this condition existed): where a few baseline runs hold it, the quietest of them can set its spread
alone (a baseline of No1, No3_Acc and the quiet No5 run put shoulder_lift's limit at 0.035 A, where TEST stands
it with 0.27 A), and the leave-one-out tail cannot see that. With too few standing samples, the widest limit the
joint has (below).

*Moving*: the rest (a joint moving faster, or settling after its own motion).

*Reversal.* A slow stretch (as above) in which the joint's target moves back, against the direction of its last
motion above the Stribeck speed, by more than the controller's jitter (:data:`~.task.TARGET_JITTER_RAD`): the
joint stopped and creeps or starts back, its friction changing sign at low speed, where the real drive sticks
and breaks away while the twin's smooth sign does not (Movement_No1's wrist_2 at 33.5-34.3 s). Its own
condition: its error is not that of a joint moving slowly one way.

Every condition gets a spread and a tail fitted on the baseline samples of that condition alone (leave one run out
for the tail, :func:`~.event_fit.fit_channel`): constant per joint at rest, slow, reversing and standing, the model on
speed and acceleration (:mod:`.events`) moving. A moving joint is judged by the wider of its own and the model fitted
on all samples (fitted on the moving samples alone, the constant and moving terms are not
anchored and extrapolate to no spread at a stop). A joint whose
baseline holds fewer than :data:`MIN_CONDITION_S` of a condition has no statistics for it (NaN) and its samples
in that condition are judged by the widest limit of the statistics it has there (all motions pooled, and the
other conditions; a moving joint without moving statistics by the all-motions fit, which holds its moving samples):
widened, not narrowed to a condition the baseline did not show. Shapes: ``(n, 6)`` per sample
and joint; per condition scale ``(5, 6, 4)``, tail ``(5, 6, 3)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import N_JOINTS
from .events import LEVEL_S, SETTLE_S, WINDOW_S, multiplier, settled_moving, sigma, smooth
from .task import CONTEXT_S, TARGET_JITTER_RAD

#: the motion conditions, in code order
CONDITIONS = ("rest", "slow", "reversal", "moving", "standing")
REST, SLOW, REVERSAL, MOVING, STANDING = range(5)
#: the conditions whose spread is constant per joint (:func:`constant`): within them the features barely vary, and
#: a fit on them extrapolates to no spread where they vanish; the moving condition keeps the spread model on speed
#: and acceleration (:mod:`.events`)
CONSTANT_SPREAD = (REST, SLOW, REVERSAL, STANDING)
#: a joint's condition has statistics only when the baseline holds at least this much of it [s] (40 windows of
#: WINDOW_S, 4 above the tail's 90 % quantile: the task statistics' bar, :data:`~.event_fit.MIN_TASK_S`)
MIN_CONDITION_S = 10.0


def stribeck_speed(params) -> float:
    """The friction law's Stribeck speed [rad/s] of a model (``1 / stribeck_rate_s_per_rad``; a law without a
    Stribeck term, rate 0, has no slow band: 0)."""
    rate = float(params.friction.stribeck_rate_s_per_rad)
    return 1.0 / rate if rate > 0 else 0.0


def condition(moving: NDArray, speed_rad_s: NDArray, target_rad: NDArray, period_s: float, slow_rad_s: float
              ) -> NDArray:
    """``(n, 6)`` codes (:data:`CONDITIONS`): ``moving`` ``(n, 6)`` the targets above the rest speed,
    ``speed_rad_s`` their absolute speed, ``target_rad`` the targets, ``slow_rad_s`` the Stribeck speed (module
    docstring)."""
    arm = moving.any(axis=1, keepdims=True)
    rest = ~settled_moving(arm, period_s)[:, 0]
    speed = smooth(speed_rad_s, period_s)
    fast_now = speed >= slow_rad_s
    fast = settled_moving(fast_now, period_s)
    k = max(1, int(round(CONTEXT_S / period_s)) // 2)
    shifted = np.concatenate([np.repeat(target_rad[:1], k, axis=0), target_rad, np.repeat(target_rad[-1:], k, axis=0)])
    creeping = np.abs(shifted[2 * k :] - shifted[: -2 * k]) > TARGET_JITTER_RAD  # moved over CONTEXT_S
    out = np.where(~fast & (moving | creeping), SLOW, MOVING).astype(np.int8)
    out[(out == MOVING) & ~fast & ~settled_moving(moving, period_s)] = STANDING  # its own target holds, others move
    out[rest] = REST
    back = max(1, int(round(SETTLE_S / period_s)))
    for j in range(out.shape[1]):
        slow = (out[:, j] == SLOW).astype(int)
        d = np.diff(np.concatenate([[0], slow, [0]]))
        for a, b in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)):
            before = np.flatnonzero(fast_now[:a, j])
            if not before.size:
                continue
            last = before[-1]  # the direction of the joint's last motion above the slow band, over SETTLE_S
            came = np.sign(target_rad[last, j] - target_rad[max(last - back, 0), j])
            moved = target_rad[b - 1, j] - target_rad[a, j]
            if came != 0 and abs(moved) > TARGET_JITTER_RAD and np.sign(moved) == -came:
                out[a:b, j] = REVERSAL
    return out


def rest_stretches(cond: NDArray) -> list[tuple[int, int]]:
    """``[(a, b)]``: the row ranges where the arm is at rest (every joint's code :data:`REST`)."""
    rest = (cond == REST).all(axis=1).astype(int)
    d = np.diff(np.concatenate([[0], rest, [0]]))
    return list(zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1)))


def rest_level(residual: NDArray, cond: NDArray, period_s: float, h: NDArray) -> NDArray:
    """``h`` ``(n, 6)`` (the transient against the running level over all samples) with its rest rows replaced by
    the smoothed residual less its running median within the same rest stretch (module docstring)."""
    from scipy.ndimage import median_filter

    w = max(1, int(round(LEVEL_S / period_s)) | 1)
    s = smooth(residual, period_s)
    out = h.copy()
    for a, b in rest_stretches(cond):
        for j in range(residual.shape[1]):
            out[a:b, j] = s[a:b, j] - median_filter(residual[a:b, j], size=min(w, (b - a) | 1), mode="nearest")
    return out


def constant(feats: NDArray) -> NDArray:
    """``feats`` ``(n, 6, 4)`` with only the constant feature kept (the others 0): a spread constant per joint."""
    out = np.zeros_like(feats)
    out[..., 0] = feats[..., 0]
    return out


def enough(cond: NDArray, ok: NDArray, period_s: float) -> NDArray:
    """``(5, 6)``: which conditions a baseline's judged samples ``ok`` ``(n,)`` (pooled over its runs: ``cond``
    and ``ok`` concatenated) hold at least :data:`MIN_CONDITION_S` of, per joint."""
    return np.array([((cond == k) & ok[:, None]).sum(axis=0) * period_s >= MIN_CONDITION_S
                     for k in range(len(CONDITIONS))])


def motion_limit(feats: NDArray, cond: NDArray, judged: NDArray, coef: NDArray, tail: NDArray, cond_coef: NDArray,
                 cond_tail: NDArray, period_s: float, p_log: float, floor: NDArray | float = 0.0,
                 chances_share: float = 1.0) -> NDArray:
    """The limit ``(n, 6)`` of one channel where it is judged by the motion (not a paired baseline run): per
    sample and joint the spread and tail of its condition (``cond_coef`` ``(5, 6, 4)``, ``cond_tail``
    ``(5, 6, 3)``), a moving joint the wider of its condition's and that fitted on all samples
    (``coef`` ``(6, 4)``, ``tail`` ``(6, 3)``: anchored where the moving samples' own fit extrapolates to
    no spread, at a stop), a standing joint the wider of its condition's and a moving joint's (module docstring);
    where the baseline has none for a condition of that joint (NaN: too few samples of
    it), the widest limit of the statistics the joint has there (all motions and every condition; a moving
    sample without moving statistics: the all-motions fit, which was fitted on the moving samples among others):
    a condition the baseline did not show is judged no tighter than any it did. The multiplier: every
    (window of :data:`~.events.WINDOW_S`, joint, statistics used) a log holds is one chance of a false alarm,
    each at ``p_log`` over their number (union bound: at most ``p_log`` for the log). ``chances_share``: the
    chances counted are that share of the log's (the joints named within one event: :func:`.events.name_joints`)."""
    n = feats.shape[0]
    cond = cond.astype(int)
    have = np.isfinite(cond_coef).all(axis=2) & np.isfinite(cond_tail).all(axis=2)  # (k, 6)
    own = have[cond, np.arange(N_JOINTS)[None, :]]  # (n, 6)
    which = np.where(own, cond + 1, 0)  # 0: all motions (a moving joint, or widened)
    widen = ~own | (cond == MOVING) | (cond == STANDING)
    step = max(1, int(round(WINDOW_S / period_s)))
    chances = 0
    for a in range(0, n, step):
        w = which[a : a + step][judged[a : a + step]]
        chances += sum(np.unique(w[:, j]).size for j in range(N_JOINTS))
    per_log_windows = max(chances * chances_share, 1) / N_JOINTS  # multiplier() divides by joints x windows
    models = [(cond_coef[k], cond_tail[k]) for k in range(len(CONDITIONS))]
    lims = np.stack([sigma(feats, np.nan_to_num(c, nan=0.0), floor) * multiplier(np.nan_to_num(t, nan=0.0),
                                                                                  per_log_windows, p_log)
                     for c, t in [(coef, tail)] + models])  # (1 + k, n, 6)
    lims[1:][~np.broadcast_to(have[:, None, :], lims[1:].shape)] = 0.0
    out = np.take_along_axis(lims, which[None], axis=0)[0]
    moving = np.maximum(lims[0], lims[MOVING + 1])  # a moving joint, and a standing one never below it
    widest = np.where(cond == MOVING, moving,
                      np.where((cond == STANDING) & own, np.maximum(moving, out), lims.max(axis=0)))
    return np.where(widen, widest, out)
