"""Monitoring: a robot's new logs against its own fitted baseline (``ur5fault monitor``).

A baseline is a model overlay fitted to the robot (``ur5fault identify`` / ``discrepancy``) plus the
residual statistics of healthy runs of that robot replayed under it (:mod:`.baseline`). A new log is
replayed under the same overlay (:mod:`.observe`, through :class:`ur5fault.twin.LogReplay`) and judged:

* *events* (:mod:`.events`): where the current residual (optionally the position residual too) leaves its own
  recent level (a running median) by more than the baseline runs' model error does at the same motion, beyond a
  bar for the log's length: a push, a collision, a transient, not a drift;
  ``{"t_start_s", "t_end_s", "joints", "channels", "peak_A", "peak_rad"}`` each;
* *changes* (:mod:`.changes`): a library effect of the discrepancy workflow whose estimate on the new log
  (outside its events) lies outside the spread of its estimates over time blocks of the baseline runs (their
  drift within a run included): a persistent change, named with size and interval; where the log repeats a
  baseline run's task, fitted to the difference of residuals at the same point of the task and judged against the
  same estimate between healthy baseline runs (:mod:`.paired`).

Verdict per log (:mod:`.verdict`): ``"changed"`` when a change is found, else ``"anomaly"`` when an event is,
else ``"consistent"``. See docs/monitoring.md.
"""

from .baseline import Baseline, fit_baseline
from .observe import Observed, observe
from .verdict import assess

__all__ = ["Baseline", "Observed", "assess", "fit_baseline", "observe"]
