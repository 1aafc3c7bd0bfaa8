"""Joint angles that wrap: some loggers write each joint's angle folded into +-180 deg (or 0..360),
while a UR5 joint turns through +-360 deg and its controller reports the angle continuously.  A
folded angle jumps by a whole turn between two rows, which no joint can move (a UR5 joint at its
top speed of 3.2 rad/s moves 0.026 rad in the 8 ms of a 125 Hz sample, ur5-facts.md), so a jump of
more than half a turn between two rows is a wrap and is undone (``numpy.unwrap``) on the rows as
written, before anything interpolates between them; left in, it reads as a speed of hundreds of
rad/s and silently changes every fitted value.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: a row-to-row step above this is a wrap, not motion [rad] (half a turn)
WRAP_STEP_RAD = np.pi
#: ... when it is within this of a whole number of turns [rad]: a UR5 joint's top speed, 3.2 rad/s, times the
#: longest sample period a log may have (0.1 s, plausible.MIN_RATE_HZ); a step of 1.9 turns is a wrong value
#: or unit, left for the range check to name
WRAP_TOLERANCE_RAD = 0.32


def unwrap_joints(q_rad: NDArray) -> tuple[NDArray, list[int]]:
    """``q_rad`` ``(n, 6)`` with every wrapped joint made continuous, and the (0-based) joints that wrapped."""
    step = np.diff(q_rad, axis=0)
    turns = np.round(step / (2 * np.pi))
    is_wrap = (np.abs(step) > WRAP_STEP_RAD) & (np.abs(step - 2 * np.pi * turns) <= WRAP_TOLERANCE_RAD)
    wrapped = [int(j) for j in np.flatnonzero(np.any(is_wrap, axis=0))]
    if not wrapped:
        return q_rad, []
    q = np.array(q_rad, dtype=float)
    q[:, wrapped] = np.unwrap(q[:, wrapped], axis=0)
    return q, wrapped
