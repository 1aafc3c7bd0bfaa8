"""A log sampled faster than the detector's training runs, taken at their rate.

The features that count or weigh fast changes (current spikes, kurtosis, crest factor, high-frequency energy,
residual RMS) depend on the sample rate, so a detector scores them on the scale of its training runs' logger only
(``schema.json``'s ``log_period_s``).  A log sampled a whole number ``k`` of times faster on the same clock holds
that logger's samples exactly: every ``k``-th one (a robot's logged values are instantaneous readings at its
controller's tick, as are the simulator's, not averages over the period).  ``ur5fault diagnose`` keeps those,
the diagnosed log's and its baseline logs' alike, and says so; a log at any other rate is scored as it is, with the
note that its features are off the detector's scale (:func:`ur5fault.health.diagnosis.diagnose`).
"""

from __future__ import annotations

from ...logs.measured import MeasuredLog, same_period


def at_training_rate(log: MeasuredLog, trained_period_s: float | None) -> MeasuredLog:
    """``log`` with every ``k``-th sample kept where the training runs' period ``trained_period_s`` is a whole
    ``k >= 2`` times its own (a note added); else ``log`` itself (None: the detector does not say its period)."""
    if not trained_period_s or log.period_s <= 0:
        return log
    k = round(float(trained_period_s) / log.period_s)
    if k < 2 or not same_period(k * log.period_s, float(trained_period_s)):
        return log
    return log.every(k, note=f"{log.source}: sampled every {1e3 * log.period_s:g} ms; every {_nth(k)} sample kept, "
                             f"as the detector's training runs were logged every {1e3 * float(trained_period_s):g} ms "
                             "(its rate-dependent features are on their scale at that rate only)")


def _nth(k: int) -> str:
    """``2nd``, ``3rd``, ``4th``, ``11th``, ``22nd``."""
    suffix = "th" if 10 <= k % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(k % 10, "th")
    return f"{k}{suffix}"
