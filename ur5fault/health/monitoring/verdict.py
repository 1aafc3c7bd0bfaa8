"""The verdict on one log part against a baseline: its events, its changes, and the word for both."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from .baseline import Baseline, segment
from .changes import estimates, find_changes, keep_mask
from .events import (
    CHANNELS,
    DEFAULT_CHANNELS,
    FALSE_ALARM_PER_LOG,
    QUANTUM_FLOOR,
    find_events,
    multiplier,
    n_windows,
    quantum_sigma,
    sigma,
)
from .observe import Observed

VERDICTS = ("consistent", "changed", "anomaly")


def limits(baseline: Baseline, obs: Observed, feats: NDArray, judged: NDArray,
           channels: Sequence[str] = CHANNELS) -> dict[str, NDArray]:
    """The event limit ``(n, 6)`` of a log part per judged channel ([A], [rad]): the baseline's spread at its
    motion times the multiplier for its length at the channel's share of :data:`~.events.FALSE_ALARM_PER_LOG`
    (split evenly: the probability that either channel raises a false alarm is at most the sum, whatever their
    dependence); the position spread never below the rounding error of the baseline's or the log's own readings'
    quantum, the limit never below :data:`~.events.QUANTUM_FLOOR` quanta (:mod:`.events`)."""
    nw = n_windows(judged, baseline.period_s)
    out = {}
    for c in channels:
        i = CHANNELS.index(c)
        q = np.fmax(baseline.quantum_rad, obs.position_quantum_rad)
        floor = quantum_sigma(q) if c == "position" else 0.0
        mult = multiplier(baseline.tail[i], nw, FALSE_ALARM_PER_LOG / len(channels))
        lim = sigma(feats, baseline.scale[i], floor) * mult
        if c == "position":
            lim = np.maximum(lim, QUANTUM_FLOOR * np.nan_to_num(q, nan=0.0))
        out[c] = lim
    return out


def assess(baseline: Baseline, obs: Observed, channels: Sequence[str] = DEFAULT_CHANNELS) -> dict[str, Any]:
    """``{"log", "verdict", "changes", "events"}`` for one log part (``monitor.json``'s entry): ``"changed"`` when
    a persistent change is found (even if events are too: a change needs maintenance, an event may not), else
    ``"anomaly"`` when an event is, else ``"consistent"``. ``channels``: the residuals events are judged on
    (:data:`~.events.DEFAULT_CHANNELS` unless given; with both, each at half the false-alarm probability)."""
    if abs(obs.period_s - baseline.period_s) > 1e-9:
        raise ParameterError(f"{obs.name}: sample period {obs.period_s:g} s differs from the baseline's "
                             f"{baseline.period_s:g} s")
    unknown = sorted(set(channels) - set(CHANNELS))
    if unknown or not channels:
        raise ParameterError(f"event channels {list(channels)}: choose from {list(CHANNELS)}")
    h, feats, judged = segment(obs)
    events, over = find_events(obs.t_s, dict(zip(CHANNELS, h)), limits(baseline, obs, feats, judged, channels),
                               judged)
    every = estimates(obs, obs.logged[: obs.e.shape[0]])
    outside = estimates(obs, keep_mask(obs, over)) if over.any() else every
    changes = find_changes(obs, every, outside, baseline.candidates)
    verdict = "changed" if changes else "anomaly" if events else "consistent"
    return {"log": obs.name, "verdict": verdict, "changes": changes, "events": events}
