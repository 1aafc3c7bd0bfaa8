"""The current a joint holds at rest, fitted as a nuisance beside every candidate, never named (an option).

At rest a joint's current is whatever static friction and the speed loop's integrator were left holding when
the last motion stopped: stick-slip makes it a different constant after every stop, which no deterministic
friction law predicts sample by sample (on the real logs the model's error is largest at rest: Kufieta J1-J3
0.5-0.8 A, NIST elbow's spread 0.136 A at rest against 0.101 A in motion; docs/discrepancy.md).  So each
*rest interval* of a joint (its commanded speed at or below the residual conditions' "at rest" speed,
:data:`ur5fault.twin.residuals.CONDITION_REST_SPEED_RAD_S`, over consecutive samples) gets one free constant on
that joint's current residual, projected out of the residual and of every candidate's column exactly as the
zero-mean drift is (:mod:`.drift`; Frisch-Waugh-Lovell).  What this gives up: a current offset or gain is then
seen only in motion, where it must be told from the friction law by the direction reversals (an offset keeps its
sign, Coulomb friction follows the speed's).

Only intervals at least :func:`min_hold_s` long get a constant: the held value is a constant only once the
position loop, the slowest loop that brings the joint to rest, has settled; before that the current follows
the stopping transient, which the model simulates.  A first-order loop of bandwidth f settles to 2 % in four
time constants, 4 / (2 pi f): 0.42 s at the packaged 1.5 Hz (``controller.position_bw_Hz``).  A shorter stop
(a velocity reversal, a brief pause) keeps its samples in the fit as they are.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..logs import MeasuredLog
from ..sim.axes import N_JOINTS
from ..twin.residuals import conditions

#: time constants of a first-order loop until it is within 2 % of its final value (e^-4 = 1.8 %)
SETTLING_TIME_CONSTANTS = 4.0


def min_hold_s(position_bw_Hz: float) -> float:
    """The shortest rest interval that gets a constant [s]: the position loop's 2 % settling time."""
    if not position_bw_Hz > 0:
        raise ValueError(f"position_bw_Hz = {position_bw_Hz} must be positive")
    return SETTLING_TIME_CONSTANTS / (2.0 * np.pi * position_bw_Hz)


def intervals(rest: NDArray, min_samples: int) -> list[tuple[int, int]]:
    """The runs ``[start, stop)`` of ``True`` in the boolean ``rest`` ``(n,)`` at least ``min_samples`` long."""
    r = np.concatenate([[False], np.asarray(rest, dtype=bool), [False]])
    edges = np.flatnonzero(np.diff(r.astype(np.int8)))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2]) if b - a >= max(1, min_samples)]


def indicators(rest: NDArray, min_samples: int) -> list[NDArray]:
    """Per joint of ``rest`` ``(n, n_joints)``, the orthonormal indicators ``(n, k)`` of its ``k`` rest intervals
    of at least ``min_samples`` samples (disjoint, so each divided by the square root of its length)."""
    rest = np.asarray(rest, dtype=bool)
    n = rest.shape[0]
    out = []
    for j in range(rest.shape[1]):
        iv = intervals(rest[:, j], min_samples)
        R = np.zeros((n, len(iv)))
        for k, (a, b) in enumerate(iv):
            R[a:b, k] = 1.0 / np.sqrt(b - a)
        out.append(R)
    return out


def of_log(log: MeasuredLog, n: int, position_bw_Hz) -> list[NDArray]:
    """Per joint, the orthonormal rest-interval indicators ``(n, k)`` of ``log``'s samples ``1..n`` (its commanded
    speed at rest, the residual conditions' "at rest"); ``position_bw_Hz``: the position loop's bandwidth, one
    per joint or one for all."""
    rest = conditions(log, n, np.zeros((n, N_JOINTS)))["at rest"]
    bw = np.broadcast_to(np.asarray(position_bw_Hz, dtype=float), (N_JOINTS,))
    return [indicators(rest[:, [j]], math.ceil(min_hold_s(bw[j]) / log.period_s - 1e-9))[0] for j in range(N_JOINTS)]
