"""The digital twin of a logged robot and its residual.

A measured log (``ur5fault.logs``) names a robot's motion, payload, tool and joint temperatures; the twin
replays that motion through the model under the same conditions (:mod:`.replay`) and compares what the
model predicts with what the robot measured (:mod:`.residuals`: operating conditions, RMS tables, where
the residual is largest, what stays unexplained).

Its own package because it is neither identification nor discrepancy discovery: ``ur5fault identify``
(the bandwidth sweep, the friction choices), ``ur5fault discrepancy`` (the estimator), the tests against
the real log and whatever monitors or diagnoses a robot from its logs all take this one path, so a log's
temperature, tool or payload reaches the model one way only.
"""

from .replay import LogReplay, Replayed, log_overrides, replay_params
from .residuals import FIT_FRACTION, conditions, held_out_mask, localise, masked_rms, rms_table, unexplained

__all__ = ["FIT_FRACTION", "LogReplay", "Replayed", "conditions",
           "held_out_mask", "localise", "log_overrides", "masked_rms", "replay_params", "rms_table", "unexplained"]
