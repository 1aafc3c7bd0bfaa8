"""Transient events: where a log's current (or position) residual leaves its own recent level by more than the
baseline's model error does at the same motion.

*Transient, not drift.* The residual (measured - simulated current under the baseline model) is smoothed by a
centred moving average of :data:`SMOOTH_S` (sensor noise averages out; a push keeps its peak) and its own recent
level is removed: a centred running median over :data:`LEVEL_S`. A median ignores a bump that fills less than
half its window, so a push by hand or a collision (assumption: under :data:`PUSH_MAX_S` = 1 s) stays whole in
the *transient* ``h = smoothed - level``; a drift slower than the window (the wrist currents that move by
0.3-0.5 A over seconds while the arm stands, a warming motor's offset) is followed by the level and does not.

*Threshold scaled with the motion.* The model's own error is larger when a joint accelerates and moves fast.
The transient's spread is modelled per joint as ``sigma^2 = c . [1, moving, |qd|, |qdd|]`` (target speed and
acceleration of the joint, smoothed over :data:`SMOOTH_S`; ``moving`` its target moving or stopped less than
:data:`SETTLE_S` ago), ``c >= 0`` fitted by least squares to ``h^2`` on the baseline runs.

Per motion condition (the arm at rest, slow, reversing, moving: :mod:`.conditions`) the spread and tail are
fitted on that condition's samples alone; at rest the level is the rest stretch's own.

*Multiplier from the baseline's own extremes.* The normalised transient ``|h| / sigma`` is cut into independent
windows of :data:`WINDOW_S`; the largest value of each baseline window is kept, and the upper tail of those
window maxima (above their :data:`TAIL_QUANTILE` quantile) is fitted by an exponential (peaks over threshold;
scale = mean excess). For a log of ``n_w`` windows the multiplier is the level that the maxima of all its
``n_w x 6`` joint-windows exceed with probability :data:`FALSE_ALARM_PER_LOG` together: a longer log gets a
higher bar, not more false alarms. Nothing is set on the runs being monitored.

*Channels.* The same is done for the position residual (measured joint position - the twin's joint angle: the
measured tracking error less the twin's), with its own spread, tail and limit (:data:`CHANNELS`); its spread is
never below the readings' rounding error (:func:`quantum_sigma`) and its limit never below
:data:`QUANTUM_FLOOR` quanta. The channels judged (:data:`DEFAULT_CHANNELS` unless asked) share the
false-alarm probability evenly.

An event is a stretch where some joint's ``|h|`` exceeds ``multiplier x sigma`` on a judged channel; stretches
closer than :data:`MERGE_S` (on any joints and channels) are one event, ``peak_A`` / ``peak_rad`` the largest
``|h|`` of each channel on its joints. *Which joints* (:func:`name_joints`): once an event is found, a joint is
named in it where its ``|h|`` exceeds the multiplier for the event's own windows (its joints x windows the
chances of naming a joint the disturbance did not reach, at the same probability), not the log's: a push by hand
loads several joints at once, and the log's bar, made for finding the event anywhere in the log, names only the
one it loads most. The first :data:`SETTLE_S` of a replay is not judged (it starts from the
log's first sample with the model's own friction state).
Shapes: ``(n, 6)`` per sample and joint; scale coefficients ``(6, 4)``; tail ``(6, 3)`` ``(u0, beta, p0)`` per
channel.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import JOINT_NAMES, N_JOINTS
from ...twin.residuals import REVERSAL_WINDOW_S
from ..features import moving_average

#: centred moving-average window of the residual [s] (12 samples of sensor noise at 125 Hz; a push lasts longer)
SMOOTH_S = 0.1
#: the longest push or collision an event is built for [s] (assumption: a push by hand, a bump: < 1 s)
PUSH_MAX_S = 1.0
#: the running-median window of the residual's own level [s]: twice :data:`PUSH_MAX_S`, so a push fills at most
#: half of it and the median passes it over, while a drift over seconds is followed
LEVEL_S = 2.0 * PUSH_MAX_S
#: stretches above threshold closer than this are one event [s] (a push's residual crosses back and forth)
MERGE_S = 0.25
#: the length of the independent windows the multiplier counts [s]: exceedances closer are one event anyway
WINDOW_S = MERGE_S
#: the window maxima above this quantile form the fitted tail
TAIL_QUANTILE = 0.9
#: the probability that an undisturbed log of the baseline's robot raises an event anywhere (all joints)
FALSE_ALARM_PER_LOG = 0.01
#: a joint counts as moving this long after its target stops, and a replay's first samples this long are not
#: judged [s]: the twin's window around a velocity reversal, in which the drive settles
SETTLE_S = REVERSAL_WINDOW_S
#: the features of the spread model, in order
FEATURES = ("1", "moving", "|qd| [rad/s]", "|qdd| [rad/s^2]")
#: the residuals events are judged on (measured - simulated): the motor current and the joint position reading
#: (the measured tracking error minus the twin's); each has its own spread model, tail and limit
CHANNELS = ("current", "position")
#: the unit of each channel
UNITS = {"current": "A", "position": "rad"}
#: the channels judged unless asked otherwise: the current alone. On the Kufieta robot the position channel does
#: not separate pushes from the twin's own position error (docs/monitoring.md): undisturbed runs' transients
#: (shoulder_lift near rest, 0.1-0.16 mrad) cross its limit on 3 of 8 undisturbed runs, while the pushes stay below
#: it but one (6.3 mrad on shoulder_pan)
DEFAULT_CHANNELS = ("current",)
#: a position limit is never below this many quanta of the joint's reading: quantisation alone moves the
#: transient by up to one quantum (a smoothed reading between two adjacent levels, less a median on one of them),
#: and a baseline that happened to hold still on one level has no spread to show it
QUANTUM_FLOOR = 2.0


def smooth(x: NDArray, period_s: float, window_s: float = SMOOTH_S) -> NDArray:
    """Centred moving average of ``x`` ``(n, k)`` over ``window_s`` (shorter at the ends)."""
    return moving_average(x, max(1, int(round(window_s / period_s)) | 1))


def transient(residual_A: NDArray, period_s: float) -> NDArray:
    """``h`` ``(n, 6)``: the smoothed residual minus its running median over :data:`LEVEL_S`."""
    w = max(1, int(round(LEVEL_S / period_s)) | 1)
    from scipy.ndimage import median_filter  # imported here: every command builds the CLI, few monitor

    level = np.stack([median_filter(residual_A[:, j], size=w, mode="nearest") for j in range(residual_A.shape[1])],
                     axis=1)  # per column: far faster than one 2-D filter
    return smooth(residual_A, period_s) - level


def settled_moving(moving: NDArray, period_s: float) -> NDArray:
    """``moving`` ``(n, 6)`` extended by :data:`SETTLE_S` after each motion of the joint ends, and by half the
    smoothing window before it starts."""
    after = int(round(SETTLE_S / period_s))
    before = int(round(SMOOTH_S / period_s)) // 2 + 1
    out = moving.copy()
    for j in range(moving.shape[1]):
        idx = np.flatnonzero(moving[:, j])
        for k in range(-before, after + 1):
            out[np.clip(idx + k, 0, moving.shape[0] - 1), j] = True
    return out


def features(moving: NDArray, speed_rad_s: NDArray, accel_rad_s2: NDArray, period_s: float) -> NDArray:
    """``(n, 6, 4)``: the spread model's :data:`FEATURES` per sample and joint."""
    mv = settled_moving(moving, period_s).astype(float)
    return np.stack([np.ones_like(mv), mv, smooth(speed_rad_s, period_s), smooth(accel_rad_s2, period_s)], axis=2)


def judged_rows(logged: NDArray, period_s: float) -> NDArray:
    """The samples judged ``(n,)``: logged, after the first :data:`SETTLE_S`."""
    judged = logged.copy()
    judged[: int(round(SETTLE_S / period_s))] = False
    return judged


def _nnls(F: NDArray, y: NDArray) -> NDArray:
    """``argmin |F c - y|, c >= 0`` through the QR factors of ``F`` (the same minimiser, a small problem)."""
    scale = np.maximum(np.abs(F).max(axis=0), 1e-12)  # columns of one magnitude for the solver
    q, r = np.linalg.qr(F / scale)
    from scipy.optimize import nnls

    return nnls(r, q.T @ y)[0] / scale


def _rows(ok: NDArray, j: int) -> NDArray:
    """A segment's judged rows of joint ``j``: ``ok`` ``(n,)`` for every joint or ``(n, 6)`` per joint."""
    return ok[:, j] if ok.ndim == 2 else ok


def fit_scale(segments: Sequence[tuple[NDArray, NDArray, NDArray]]) -> NDArray:
    """Spread coefficients ``(6, 4)`` from baseline segments ``(h (n, 6), features (n, 6, 4), judged (n,) or
    (n, 6) per joint)``:
    ``h^2`` on the features, least squares with ``c >= 0``, then twice reweighted by the fitted variance squared
    (a squared residual's scatter grows with its variance: the efficient fit of a variance model)."""
    coef = np.zeros((N_JOINTS, segments[0][1].shape[2]))
    for j in range(N_JOINTS):
        F = np.concatenate([f[_rows(ok, j), j] for _, f, ok in segments])
        y = np.concatenate([h[_rows(ok, j), j] ** 2 for h, _, ok in segments])
        if not y.size:  # no judged sample of this joint: no statistics
            coef[j] = np.nan
            continue
        c = _nnls(F, y)
        for _ in range(2):
            pred = F @ c
            if not np.any(pred > 0):
                break
            w = 1.0 / np.maximum(pred, 1e-3 * pred.max())
            c = _nnls(F * w[:, None], y * w)
        if not np.any(F @ c > 0):
            c = np.zeros(F.shape[1])
            c[0] = float(np.mean(y)) or 1e-12
        coef[j] = c
    return coef


def sigma(feats: NDArray, coef: NDArray, floor: NDArray | float = 0.0) -> NDArray:
    """The transient's modelled spread ``(n, 6)`` (floored at a thousandth of its largest value, and at
    ``floor`` ``(6,)``)."""
    s2 = np.einsum("njk,jk->nj", feats, coef)
    return np.maximum(np.sqrt(np.maximum(s2, 1e-6 * np.max(s2, axis=0, keepdims=True) + 1e-18)), floor)


def quantum_sigma(quantum_rad: NDArray) -> NDArray:
    """``(6,)``: the rounding error of a reading quantised by ``quantum_rad`` (``step / sqrt(12)``, uniform over
    one step; 0 where the quantum is unknown): the position channel's spread is never below it. The twin's
    residual weights take the same floor (:func:`ur5fault.twin.replay.residual_sigma`); without it the spread
    fitted where the joints barely move is a fraction of a quantum, and the tail fitted on it turns heavy."""
    return np.nan_to_num(np.asarray(quantum_rad, dtype=float), nan=0.0) / np.sqrt(12.0)


def window_maxima(z: NDArray, judged: NDArray, period_s: float) -> NDArray:
    """``(w, 6)``: the largest ``z`` of each joint in consecutive :data:`WINDOW_S` windows of judged samples
    (``judged`` ``(n,)``, or ``(n, 6)`` per joint: ``-inf`` where a joint has none in a window; windows without
    any judged sample are left out)."""
    step = max(1, int(round(WINDOW_S / period_s)))
    zz = np.where(judged if judged.ndim == 2 else judged[:, None], z, -np.inf)
    out = [zz[a : a + step].max(axis=0) for a in range(0, zz.shape[0], step)]
    out = np.array(out) if out else np.zeros((0, z.shape[1]))
    return out[np.isfinite(out).any(axis=1)]


def fit_tail(maxima: NDArray) -> NDArray:
    """``(6, 3)`` per joint ``(u0, beta, p0)``: the window maxima exceed ``u0 + x`` with probability
    ``p0 exp(-x / beta)`` (exponential tail above the :data:`TAIL_QUANTILE` quantile, beta its mean excess;
    ``-inf``: no judged sample of the joint in that window; NaN for a joint without any)."""
    out = np.zeros((maxima.shape[1], 3))
    for j in range(maxima.shape[1]):
        m = maxima[:, j][np.isfinite(maxima[:, j])]
        if not m.size:
            out[j] = np.nan
            continue
        u0 = float(np.quantile(m, TAIL_QUANTILE))
        exc = m[m > u0] - u0
        out[j] = (u0, float(exc.mean()) if exc.size else 0.0, exc.size / m.size if m.size else 1.0)
    return out


def multiplier(tail: NDArray, n_windows: int, p_log: float = FALSE_ALARM_PER_LOG) -> NDArray:
    """``(6,)``: the level of ``|h| / sigma`` the window maxima of a log of ``n_windows`` windows exceed on any
    joint with probability ``p_log`` (a channel's share of :data:`FALSE_ALARM_PER_LOG`)."""
    p = p_log / (max(n_windows, 1) * tail.shape[0])
    u0, beta, p0 = tail.T
    return u0 + beta * np.log(np.maximum(p0 / p, 1.0))


def n_windows(judged: NDArray, period_s: float) -> int:
    return int(np.ceil(judged.sum() * period_s / WINDOW_S))


def find_events(t_s: NDArray, h: dict[str, NDArray], limits: dict[str, NDArray], judged: NDArray
                ) -> tuple[list[dict], NDArray]:
    """Events of one log part: ``[{"t_start_s", "t_end_s", "joints", "channels", "peak_A", "peak_rad"}]`` and the
    exceedance mask ``(n, 6)`` of all channels together.

    ``h``: the transient of every channel (:data:`CHANNELS`); ``limits``: the limit of each channel judged.
    An event's ``joints`` and ``channels`` are those that crossed their limit in it; ``peak_A`` / ``peak_rad``:
    the largest ``|h|`` of the current / position channel on those joints over the event, whether or not that
    channel crossed (what the other signal did meanwhile)."""
    over_c = {c: (np.abs(h[c]) > lim) & judged[:, None] for c, lim in limits.items()}
    over = np.zeros(judged.shape + (N_JOINTS,), bool)
    for o in over_c.values():
        over |= o
    rows = np.flatnonzero(over.any(axis=1))
    if not rows.size:
        return [], over
    period = float(np.median(np.diff(t_s))) if t_s.size > 1 else 1.0
    gap = max(1, int(round(MERGE_S / period)))
    groups, start = [], rows[0]
    for a, b in zip(rows[:-1], rows[1:]):
        if b - a > gap:
            groups.append((start, a))
            start = b
    groups.append((start, rows[-1]))
    channels = [[c for c in CHANNELS if c in over_c and over_c[c][a : b + 1].any()] for a, b in groups]
    return [_event(t_s, slice(a, b + 1), ch, over, h) for (a, b), ch in zip(groups, channels)], over


def _event(t_s: NDArray, sl: slice, channels: list[str], over: NDArray, h: dict[str, NDArray]) -> dict:
    """The event over the samples ``sl``: its joints those with an exceedance in ``over`` ``(n, 6)`` there, each
    channel's peak on them."""
    js = [j for j in range(N_JOINTS) if over[sl, j].any()]
    ev = {"t_start_s": float(t_s[sl.start]), "t_end_s": float(t_s[sl.stop - 1]), "joints": [JOINT_NAMES[j] for j in js],
          "channels": channels}
    for c in CHANNELS:
        ev[f"peak_{UNITS[c]}"] = float(np.abs(h[c][sl][:, js]).max())
    return ev


def event_limits(events: list[dict], t_s: NDArray, limits_at: Callable[[float], dict[str, NDArray]],
                 judged: NDArray, period_s: float) -> list[tuple[slice, dict[str, NDArray]]]:
    """Per event its samples and the limits ``(n, 6)`` per judged channel for the event's own windows:
    ``limits_at(share)`` gives the limits when the multiplier counts that share of the log's chances of a false
    alarm (``1``: the log's, which found the event), and an event of ``k`` windows of :data:`WINDOW_S` counts ``k``
    of the log's judged windows (``period_s``: the baseline's sample period, with which the log's windows are
    counted). Events of one length share their limits (one computation each)."""
    nw = max(n_windows(judged, period_s), 1)
    by_k: dict[int, dict[str, NDArray]] = {}
    out = []
    for ev in events:
        rows = np.flatnonzero((t_s >= ev["t_start_s"]) & (t_s <= ev["t_end_s"]))
        k = max(1, int(np.ceil(rows.size * period_s / WINDOW_S)))
        if k not in by_k:
            by_k[k] = limits_at(min(1.0, k / nw))
        out.append((slice(int(rows[0]), int(rows[-1]) + 1), by_k[k]))
    return out


def name_joints(events: list[dict], t_s: NDArray, h: dict[str, NDArray],
                limits_at: Callable[[float], dict[str, NDArray]], judged: NDArray, period_s: float) -> list[dict]:
    """The events with every joint named whose ``|h|`` exceeds, within the event and on a channel that found it,
    the limit for the event's own windows (:func:`event_limits`). The joints named at the log's limit stay named;
    the channels are those that found the event."""
    out = []
    for ev, (sl, lims) in zip(events, event_limits(events, t_s, limits_at, judged, period_s)):
        over = np.zeros((sl.stop - sl.start, N_JOINTS), bool)
        for c in ev["channels"]:
            over |= (np.abs(h[c][sl]) > lims[c][sl]) & judged[sl, None]
        named = over.any(axis=0) | np.isin(np.array(JOINT_NAMES), ev["joints"])
        mask = np.zeros((t_s.size, N_JOINTS), bool)
        mask[sl] = named
        out.append(_event(t_s, sl, ev["channels"], mask, h))
    return out
