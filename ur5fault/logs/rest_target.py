"""What a log's target is while the arm stands: the previous reading (a CB2 controller) or a fixed setpoint (a
CB3), told from the rows where every target speed is exactly 0."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from . import regular

#: a log whose target at rest follows its reading: at least this many rows at rest, and this share of them
#: (the CB2 runs of data/kufieta-ur5: 99.0-100 % of 328-1,872 rows, every one but the first of each stretch at
#: rest; NIST's CB3 log: 0 of 2,523)
REST_TARGET_MIN_ROWS, REST_TARGET_MIN_SHARE = 25, 0.9
#: positions equal to the file's precision (the CB2 files write 6 decimals of a radian)
SAME_POSITION_RAD = 1e-9


def rest_target_rows(t: NDArray, target_q: NDArray, actual_q: NDArray, target_qd: NDArray) -> tuple[NDArray, NDArray]:
    """``(rest, same)``, each ``(n - 1,)`` for rows ``1..n-1``: the row is at rest (every target speed exactly 0)
    and one tick after the previous row (the tick grid of :func:`.regular.ticks`; a row after a gap has no previous
    reading to equal), and its target equals the previous row's measured position on every joint."""
    k, _ = regular.ticks(t)
    rest = np.all(target_qd[1:] == 0.0, axis=1) & (np.diff(k) == 1)
    same = np.all(np.abs(target_q[1:] - actual_q[:-1]) < SAME_POSITION_RAD, axis=1)
    return rest, same


def rest_target_style(t: NDArray, target_q: NDArray, actual_q: NDArray, target_qd: NDArray | None) -> str | None:
    """What the log's target is where every target speed is exactly 0 (:func:`rest_target_rows`): ``"reading"``,
    the previous tick's measured position on every joint, as in the CB2 runs of data/kufieta-ur5 (there the first
    row of each stretch at rest carries the pose the move was commanded to, and every later one the previous
    reading; the controller holds the pose: docs/validation.md, "A CB2 log's target at rest"); ``"setpoint"``, a
    fixed pose, as NIST's CB3 log; ``None``: too few rows at rest to tell, or no target speeds."""
    if target_qd is None or target_q.shape[0] < 3:
        return None
    rest, same = rest_target_rows(t, target_q, actual_q, target_qd)
    if int(rest.sum()) < REST_TARGET_MIN_ROWS:
        return None
    share = float(same[rest].mean())
    return "reading" if share >= REST_TARGET_MIN_SHARE else "setpoint" if share <= 1.0 - REST_TARGET_MIN_SHARE \
        else None
