"""Joint angles that wrap: some loggers write each joint's angle folded into +-180 deg (or 0..360),
while a UR5 joint turns through +-360 deg and its controller reports the angle continuously.  A
folded angle jumps by a whole turn between two samples, which no joint can move (a UR5 joint at its
top speed of 3.2 rad/s moves 0.026 rad in the 8 ms of a 125 Hz sample, ur5-facts.md), so a jump of
more than half a turn in one sample is a wrap and is undone (``numpy.unwrap``); left in, it reads as
a speed of hundreds of rad/s and silently changes every fitted value.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np

from .measured import MeasuredLog

_log = logging.getLogger(__name__)

#: a sample-to-sample step above this is a wrap, not motion [rad] (half a turn)
WRAP_STEP_RAD = np.pi


def unwrap_angles(log: MeasuredLog) -> MeasuredLog:
    """``log`` with every wrapped joint angle (target, actual and motor positions) made continuous;
    a warning names the joints."""
    fields = [f for f in ("q_target_rad", "q_actual_rad") if getattr(log, f) is not None]
    wrapped = sorted({j for f in fields for j in np.flatnonzero(
        np.any(np.abs(np.diff(getattr(log, f), axis=0)) > WRAP_STEP_RAD, axis=0))})
    if not wrapped:
        return log
    new = {}
    for f in fields:
        q = np.array(getattr(log, f), dtype=float)
        q[:, wrapped] = np.unwrap(q[:, wrapped], axis=0)
        new[f] = q
    _log.warning("%s: the angles of joint(s) %s wrap around (a jump of a whole turn between two samples); "
                 "made continuous", log.source, ", ".join(str(j + 1) for j in wrapped))
    return dataclasses.replace(log, **new)
