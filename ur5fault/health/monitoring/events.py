"""Transient events: where a log's smoothed current residual leaves the band the baseline runs stayed in.

The residual (measured - simulated current under the baseline model) is smoothed by a centred moving average
of :data:`SMOOTH_S` (a push by hand or a collision lasts longer; the current sensor's noise and the model's
sample-to-sample error do not). Its deviation from the baseline's median is measured per joint in two states:
the joint's target at rest, and moving (or stopped less than :data:`SETTLE_S` ago). The threshold per joint and
state is the largest deviation any baseline segment showed there: an event is what no healthy run of the robot
did. The first :data:`SETTLE_S` of a replay is not judged (the replay starts from the log's first sample with
the model's own friction state). Nothing is set on the runs being monitored.

An event is a stretch where some joint exceeds its threshold; stretches closer than :data:`MERGE_S` (on any
joints) are one event. Shapes: ``(n, 6)``; thresholds ``(6, 2)`` with states :data:`STATES`.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import JOINT_NAMES, N_JOINTS
from ...twin.residuals import REVERSAL_WINDOW_S

#: centred moving-average window of the residual [s] (assumption: a push or a collision loads a joint for
#: 0.2 s or more, so 0.1 s keeps its peak while averaging 12 samples of sensor noise at 125 Hz)
SMOOTH_S = 0.1
#: stretches above threshold closer than this are one event [s] (a push's residual crosses back and forth)
MERGE_S = 0.25
#: a joint counts as moving this long after its target stops, and a replay's first samples this long are not
#: judged [s]: the twin's window around a velocity reversal, in which the drive settles
SETTLE_S = REVERSAL_WINDOW_S
STATES = ("at rest", "moving")


def smooth(x: NDArray, period_s: float) -> NDArray:
    """Centred moving average of ``x`` ``(n, 6)`` over :data:`SMOOTH_S` (shorter at the ends)."""
    w = max(1, int(round(SMOOTH_S / period_s)) | 1)
    kernel = np.ones(w)
    num = np.stack([np.convolve(x[:, j], kernel, mode="same") for j in range(x.shape[1])], axis=1)
    den = np.convolve(np.ones(x.shape[0]), kernel, mode="same")[:, None]
    return num / den


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


def deviation(smoothed: NDArray, moving: NDArray, median: NDArray) -> NDArray:
    """Deviation ``(n, 6)`` of the smoothed residual from the baseline median ``(6, 2)`` of its state."""
    return np.abs(smoothed - median[np.arange(smoothed.shape[1])[None, :], moving.astype(int)])


def prepare(residual_A: NDArray, moving: NDArray, logged: NDArray, period_s: float
            ) -> tuple[NDArray, NDArray, NDArray]:
    """Smoothed residual, settled motion mask and the judged samples (logged, after the first :data:`SETTLE_S`)."""
    judged = logged.copy()
    judged[: int(round(SETTLE_S / period_s))] = False
    return smooth(residual_A, period_s), settled_moving(moving, period_s), judged


def deviation_stats(segments: Sequence[tuple[NDArray, NDArray, NDArray]]) -> tuple[NDArray, NDArray, NDArray]:
    """From baseline segments ``(smoothed residual (n, 6), settled moving (n, 6), judged (n,))``: the median
    ``(6, 2)`` per joint and state (0 where no segment has the state), the largest deviation per segment
    ``(k, 6, 2)`` (NaN where a segment has no judged sample in that state) and the threshold ``(6, 2)``."""
    med = np.zeros((N_JOINTS, 2))
    for j in range(N_JOINTS):
        for s in range(2):
            vals = np.concatenate([r[(m[:, j] == bool(s)) & ok, j] for r, m, ok in segments])
            med[j, s] = np.median(vals) if vals.size else 0.0
    dev = np.full((len(segments), N_JOINTS, 2), np.nan)
    for k, (r, m, ok) in enumerate(segments):
        d = deviation(r, m, med)
        for j in range(N_JOINTS):
            for s in range(2):
                sel = (m[:, j] == bool(s)) & ok
                if sel.any():
                    dev[k, j, s] = np.max(d[sel, j])
    return med, dev, thresholds(dev)


def thresholds(dev: NDArray) -> NDArray:
    """Threshold per joint and state: the largest deviation of any baseline segment. A state no baseline segment
    holds takes the joint's threshold of the other state."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN slices: handled below
        out = np.nanmax(dev, axis=0)
    for j in range(out.shape[0]):
        if np.isnan(out[j]).any():
            out[j] = np.nanmax(out[j])
    return out


def find_events(t_s: NDArray, smoothed: NDArray, moving: NDArray, judged: NDArray, median: NDArray,
                threshold: NDArray) -> tuple[list[dict], NDArray]:
    """Events of one log part: ``[{"t_start_s", "t_end_s", "joints", "peak_A"}]`` (``peak_A``: the largest
    smoothed deviation in the event) and the exceedance mask ``(n, 6)``."""
    state = moving.astype(int)
    dev = deviation(smoothed, moving, median)
    over = (dev > threshold[np.arange(N_JOINTS)[None, :], state]) & judged[:, None]
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
    events = []
    for a, b in groups:
        sl = slice(a, b + 1)
        joints = [JOINT_NAMES[j] for j in range(N_JOINTS) if over[sl, j].any()]
        peak = float(np.max(np.where(over[sl], dev[sl], 0.0)))
        events.append({"t_start_s": float(t_s[a]), "t_end_s": float(t_s[b]), "joints": joints, "peak_A": peak})
    return events, over
