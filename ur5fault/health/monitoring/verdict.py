"""The verdict on one log part against a baseline: its events, its changes, and the word for both."""

from __future__ import annotations

from typing import Any

from numpy.typing import NDArray

from ...errors import ParameterError
from .baseline import Baseline, segment
from .changes import estimates, find_changes, keep_mask
from .events import find_events, multiplier, n_windows, sigma
from .observe import Observed

VERDICTS = ("consistent", "changed", "anomaly")


def limit_A(baseline: Baseline, feats: NDArray, judged: NDArray) -> NDArray:
    """The event limit ``(n, 6)`` [A] of a log part: the baseline's spread at its motion times the multiplier
    for its length (:mod:`.events`)."""
    return sigma(feats, baseline.scale) * multiplier(baseline.tail, n_windows(judged, baseline.period_s))[None, :]


def assess(baseline: Baseline, obs: Observed) -> dict[str, Any]:
    """``{"log", "verdict", "changes", "events"}`` for one log part (``monitor.json``'s entry): ``"changed"`` when
    a persistent change is found (even if events are too: a change needs maintenance, an event may not), else
    ``"anomaly"`` when an event is, else ``"consistent"``."""
    if abs(obs.period_s - baseline.period_s) > 1e-9:
        raise ParameterError(f"{obs.name}: sample period {obs.period_s:g} s differs from the baseline's "
                             f"{baseline.period_s:g} s")
    h, feats, judged = segment(obs)
    events, over = find_events(obs.t_s, h, limit_A(baseline, feats, judged), judged)
    every = estimates(obs, obs.logged[: obs.e.shape[0]])
    outside = estimates(obs, keep_mask(obs, over)) if over.any() else every
    changes = find_changes(obs, every, outside, baseline.candidates)
    verdict = "changed" if changes else "anomaly" if events else "consistent"
    return {"log": obs.name, "verdict": verdict, "changes": changes, "events": events}
