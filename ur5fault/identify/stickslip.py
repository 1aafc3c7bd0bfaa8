"""Breakaway friction and presliding stiffness from the starts out of rest.

At every start the target begins to move after a rest; the joint stays stuck while the
servo raises the current from its holding value, and breaks away when the friction
torque reaches its static level.  Per start we take:

* the *holding* current and rest position: medians over the :data:`HOLD_S` before the start;
* the *break* sample: the sample of largest current in the direction of motion (friction
  residual: measured current minus model torque / K minus the joint's constant offset,
  :mod:`.friction`) from the start until the measured position has left its rest value by
  more than three position-noise sigmas (and one sample beyond);
* the breakaway current: that largest residual;
* the presliding compliance: the rest-to-break displacement over the rest-to-break torque
  change.  Whichever side of the gear the friction acts on, the link moves only by the
  friction contact's own (bristle) deflection before it slides, so this is the joint-side
  presliding stiffness sigma_0 of a LuGre law.  At 125 Hz the break is seen within 8 ms, so
  the displacement may include the first instant of sliding: the stiffness is a lower bound.

Each start is one event: the estimate is the median over starts (a start can catch a
servo transient), its interval the bootstrap over starts.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .signals import LogSignals
from .stats import Estimate, bootstrap, interval

#: rest before a start that defines the holding current and rest position [s]
HOLD_S = 0.16
#: a start counts if the joint had rested at least this long before it [s]
MIN_REST_S = 0.2
#: the joint has left rest when it moved this many position-noise sigmas
MOVED_SIGMAS = 3.0
#: the search for the break ends this long after the target started, moved or not [s]
MAX_STICK_S = 0.3
#: fewer starts than this: not identifiable
MIN_STARTS = 5


def starts(sig: LogSignals, j: int) -> NDArray:
    """Sample indices where joint ``j``'s target leaves a rest of at least :data:`MIN_REST_S`."""
    rest = sig.at_rest()[:, j]
    k = np.flatnonzero(rest[:-1] & ~rest[1:]) + 1
    need = int(round(MIN_REST_S / sig.period_s))
    keep = [s for s in k if s >= need and rest[s - need : s].all() and sig.same_log(s - need, s)]
    stick = int(round(MAX_STICK_S / sig.period_s))
    return np.array([s for s in keep if s + stick < sig.n and sig.same_log(s, s + stick)], dtype=int)


def start_events(sig: LogSignals, j: int, k_joint: float, offset_A: float, noise_rad: float) -> NDArray:
    """Per start ``(n_starts, 3)``: breakaway current [A], torque change [N*m] and displacement [rad]
    from rest to the break (all in the direction of motion)."""
    resid = sig.current_A[:, j] - sig.model_torque_Nm[:, j] / k_joint - offset_A
    q = sig.q_actual_rad[:, j]
    hold = int(round(HOLD_S / sig.period_s))
    stick = int(round(MAX_STICK_S / sig.period_s))
    out = []
    for k0 in starts(sig, j):
        direction = np.sign(sig.qd_target_rad_s[k0 + 2, j])
        if direction == 0:
            continue
        q_rest = np.median(q[k0 - hold : k0])
        i_hold = np.median(resid[k0 - hold : k0])
        moved = np.flatnonzero(direction * (q[k0 : k0 + stick] - q_rest) > MOVED_SIGMAS * noise_rad)
        end = k0 + (moved[0] + 2 if moved.size else stick)
        kb = k0 + int(np.argmax(direction * resid[k0:end]))
        dT = direction * (resid[kb] - i_hold) * k_joint
        out.append((direction * resid[kb], dT, direction * (q[kb] - q_rest)))
    return np.array(out).reshape(-1, 3)


def _median_stiffness(ev: NDArray) -> NDArray:
    """Median breakaway current and the pooled stiffness sum(dT^2) / sum(dT * dq) of the events."""
    dT, dq = ev[:, 1], ev[:, 2]
    den = np.sum(dT * dq)
    return np.array([np.median(ev[:, 0]), np.sum(dT * dT) / den if den > 0 else np.nan])


def identify_stickslip(sig: LogSignals, k_joint: NDArray, offset_A: NDArray, noise_rad: NDArray,
                       joints, n_boot: int, seed: int) -> list[Estimate]:
    """Breakaway current [A] and presliding stiffness [N*m/rad] of ``joints``."""
    out = []
    for j in joints:
        ev = start_events(sig, j, float(k_joint[j]), float(offset_A[j]), float(noise_rad[j]))
        if ev.shape[0] < MIN_STARTS:
            continue
        value = _median_stiffness(ev)
        boot = bootstrap(lambda idx, ev=ev: _median_stiffness(ev[idx]), [np.array([e]) for e in range(len(ev))],
                         n_boot, seed)
        lo, hi = interval(boot)
        n = ev.shape[0]
        out.append(Estimate("friction.breakaway_A", j, float(value[0]), float(lo[0]), float(hi[0]),
                            f"median over {n} starts from rest of the largest friction current before the joint "
                            "left rest"))
        out.append(Estimate("friction.presliding_stiffness_Nm_per_rad", j, float(value[1]), float(lo[1]),
                            float(hi[1]), f"rest-to-break torque change over joint displacement, {n} starts "
                            "(a lower bound: the 8 ms sampling may include the first instant of sliding)"))
    return out
