"""What a baseline's runs covered, and where a monitored log leaves it: its joints' speed, a joint standing while
the others move, and its payload.

Every limit and bar of a baseline is fitted on its runs' motion. The event limits grow with speed (and
acceleration: :func:`.events.sigma`, a line in them), so a log that moves a joint faster than any baseline run did
is judged by that line extrapolated; the model's own error there was never seen. A payload the baseline runs did
not carry shows a model error that grows with the load (a torque-constant or mass error) as a change. Neither is
refused (a robot's new task is exactly what a monitor is asked about), and no verdict is changed; each log's entry
says so in its notes, with the figures, so that a "changed" or "anomaly" there is read with it.

A joint that stands while others move is judged against the spread model's constant alone (its speed and
acceleration terms are zero), times the tail multiplier: 0.16-0.29 A on wrist 2 of the Kufieta runs. Its residual
there is what the other joints' motion does to it through the arm's dynamics, which a baseline whose runs move every
joint together never shows: against every baseline of 2-5 of the seven undisturbed Kufieta runs, nearly every false
event lies on such a joint (docs/monitoring.md, "Other baselines and another overlay"). So the second quantity is,
per joint, the largest target speed of the *other* joints at the samples where the joint's own target stands; a
joint the runs never stood while the others moved has 0 there, and a log is said to leave it where the others move
faster than :data:`FLOOR` (3 deg/s, the logs' units check's "moving": far above standstill noise).

The acceleration is not compared: on a log with ticks missing (Kufieta's Movement_No1-No3 miss every third or so)
the target is filled on the grid in a straight line, and its second difference next to a filled tick is the
filling's kink, not the motion (1.3-1.5 x the acceleration of the gap-free repeat of the same motion, No3_Acc
against No4_Acc); leaving those samples out leaves almost none of such a run (measured: the baseline's largest
speeds then came from the gap-free runs alone and two undisturbed runs were called beyond it). The speed is the
filling's secant there, the robot's mean speed over the gap.

Shapes: ``(2, 6)`` per quantity (:data:`QUANTITIES`) and joint; a ``baseline.json`` written before the second
quantity has NaN there (nothing is said of it).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...logs.plausible import UNITS_CHECK_SPEED_RAD_S
from ...sim.axes import JOINT_NAMES
from .observe import Observed

#: the motion quantities compared: the joint target's absolute speed (module docstring: not its acceleration)
QUANTITIES = ("speed_rad_s", "others_speed_standing_rad_s")
#: how a note names each quantity of a joint beyond the baseline
SAID = {"speed_rad_s": "{joint} speed up to {value:.3g} rad/s",
        "others_speed_standing_rad_s": "{joint} standing while other joints move at up to {value:.3g} rad/s"}
#: below this the other joints count as standing too [rad/s] (:data:`ur5fault.logs.plausible.
#: UNITS_CHECK_SPEED_RAD_S`); the joint's own speed has no floor (a joint the runs never moved is named at any speed)
FLOOR = {"speed_rad_s": 0.0, "others_speed_standing_rad_s": UNITS_CHECK_SPEED_RAD_S}
#: a sample lies beyond the baseline when it exceeds the largest value of the baseline runs by more than this
#: share: the largest value of a run is itself a noisy extreme (the target's differences are quantised on a CB2)
MARGIN = 0.10
#: a log is said to leave the baseline when at least this long of it lies beyond [s]: two event windows
#: (:data:`.events.WINDOW_S`), so that one stray sample of a numerical derivative says nothing
MIN_BEYOND_S = 0.5
#: payloads within this of the baseline runs' range count as covered [kg] (a stated payload is a user's number;
#: 10 g is below what the model's current can tell on a UR5)
PAYLOAD_TOL_KG = 0.01


def measured(obs: Observed) -> tuple[NDArray, ...]:
    """``obs``'s :data:`QUANTITIES` ``(n, 6)`` each, 0 where the robot did not log the tick: each joint's target
    speed, and the largest of the other joints' where the joint's own target stands (``obs.moving`` false)."""
    speed = np.where(obs.logged[:, None], obs.speed_rad_s, 0.0)
    others = np.zeros_like(speed)
    for j in range(speed.shape[1]):  # (speeds are >= 0: no other joint, or no sample, is 0)
        others[:, j] = np.delete(speed, j, axis=1).max(axis=1, initial=0.0)
    return speed, np.where(obs.moving, 0.0, others)


def envelope(runs: Sequence[Observed]) -> NDArray:
    """``(2, 6)``: per joint, the largest of each of :data:`QUANTITIES` [rad/s] over the logged samples of ``runs``."""
    out = np.zeros((len(QUANTITIES), len(JOINT_NAMES)))
    for o in runs:
        for i, x in enumerate(measured(o)):
            if x.size:
                out[i] = np.fmax(out[i], np.nanmax(x, axis=0))
    return out


def motion_notes(limit: NDArray, obs: Observed) -> list[str]:
    """A note naming each joint and quantity where ``obs`` spends :data:`MIN_BEYOND_S` or more beyond ``limit``
    ``(2, 6)`` (the baseline's :func:`envelope`) by more than :data:`MARGIN` (and above the quantity's
    :data:`FLOOR`); a quantity the baseline does not record (NaN) is not compared."""
    parts = []
    for i, (q, x) in enumerate(zip(QUANTITIES, measured(obs))):
        if i >= limit.shape[0]:
            break
        with np.errstate(invalid="ignore"):
            beyond = x > np.maximum((1.0 + MARGIN) * limit[i], FLOOR[q])
        for j in np.flatnonzero(beyond.sum(axis=0) * obs.period_s >= MIN_BEYOND_S):
            floor = (f"; above {FLOOR[q]:g} rad/s, where the others count as moving"
                     if FLOOR[q] > (1.0 + MARGIN) * limit[i, j] else "")
            parts.append(SAID[q].format(joint=JOINT_NAMES[j], value=np.nanmax(x[:, j]))
                         + f" ({beyond[:, j].sum() * obs.period_s:.1f} s more than {MARGIN:.0%} above the baseline "
                         f"runs' largest, {limit[i, j]:.3g}{floor})")
    if not parts:
        return []
    return ["moves beyond what the baseline runs covered: " + "; ".join(parts) + ". Its limits there rest on motion "
            "the baseline runs did not show, where the model's own error was never seen: an event or change on "
            "those joints may be the model's error at this motion; give baseline runs that move as this log does"]


def payload_notes(payloads_kg: Sequence[float | None], obs: Observed) -> list[str]:
    """A note when ``obs``'s stated payload lies outside the baseline runs' (``payloads_kg``) by more than
    :data:`PAYLOAD_TOL_KG`."""
    return payload_kg_notes(payloads_kg, obs.payload_kg)


def payload_kg_notes(payloads_kg: Sequence[float | None], payload_kg: float | None) -> list[str]:
    """:func:`payload_notes` of a log stating ``payload_kg`` (also ``ur5fault diagnose``'s, against its baseline
    logs)."""
    known = [p for p in payloads_kg if p is not None]
    if payload_kg is None or not known:
        return []
    lo, hi = min(known), max(known)
    if lo - PAYLOAD_TOL_KG <= payload_kg <= hi + PAYLOAD_TOL_KG:
        return []
    held = f"{lo:g} kg" if lo == hi else f"{lo:g}-{hi:g} kg"
    return [f"carries {payload_kg:g} kg, the baseline runs {held}: a model error that grows with the load (a "
            "torque-constant, current-gain or mass error) shows here as a change the baseline runs could not show; "
            "check the stated payload, or give baseline runs with this payload"]
