"""Joint angles that wrap: some loggers write each joint's angle folded into +-180 deg (or 0..360),
while a UR5 joint turns through +-360 deg and its controller reports the angle continuously.  A
folded angle jumps by a whole turn between two rows, which no joint can move (a UR5 joint at its
top speed of 3.2 rad/s moves 0.026 rad in the 8 ms of a 125 Hz sample, ur5-facts.md), so a jump of
more than half a turn between two rows, in a joint whose values span at most one turn, is a wrap and
is undone (``numpy.unwrap``) on the rows as written, before anything interpolates between them; left
in, it reads as a speed of hundreds of rad/s and silently changes every fitted value.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

#: a row-to-row step above this is a wrap, not motion [rad] (half a turn)
WRAP_STEP_RAD = np.pi
#: a folded angle spans at most one turn (+-180 deg or 0..360 deg) [rad]; a jump in a joint spanning more is not
#: a wrap but a bad value (the reader's range check names it)
FOLDED_SPAN_RAD = 2 * np.pi * (1 + 1e-9)


def unwrap_joints(q_rad: NDArray) -> tuple[NDArray, list[int]]:
    """``q_rad`` ``(n, 6)`` with every wrapped joint made continuous, and the (0-based) joints that wrapped."""
    jumps = np.any(np.abs(np.diff(q_rad, axis=0)) > WRAP_STEP_RAD, axis=0)
    folded = np.ptp(q_rad, axis=0) <= FOLDED_SPAN_RAD  # a folded angle never spans more than one turn
    wrapped = [int(j) for j in np.flatnonzero(jumps & folded)]
    if not wrapped:
        return q_rad, []
    q = np.array(q_rad, dtype=float)
    q[:, wrapped] = np.unwrap(q[:, wrapped], axis=0)
    return q, wrapped
