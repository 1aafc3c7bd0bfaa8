"""What a baseline's runs covered, and where a monitored log leaves it: its joints' speed and its payload.

Every limit and bar of a baseline is fitted on its runs' motion. The event limits grow with speed (and
acceleration: :func:`.events.sigma`, a line in them), so a log that moves a joint faster than any baseline run did
is judged by that line extrapolated; the model's own error there was never seen. A payload the baseline runs did
not carry shows a model error that grows with the load (a torque-constant or mass error) as a change. Neither is
refused (a robot's new task is exactly what a monitor is asked about), and no verdict is changed; each log's entry
says so in its notes, with the figures, so that a "changed" or "anomaly" there is read with it.

The acceleration is not compared: on a log with ticks missing (Kufieta's Movement_No1-No3 miss every third or so)
the target is filled on the grid in a straight line, and its second difference next to a filled tick is the
filling's kink, not the motion (1.3-1.5 x the acceleration of the gap-free repeat of the same motion, No3_Acc
against No4_Acc); leaving those samples out leaves almost none of such a run (measured: the baseline's largest
speeds then came from the gap-free runs alone and two undisturbed runs were called beyond it). The speed is the
filling's secant there, the robot's mean speed over the gap.

Shapes: ``(1, 6)`` per quantity (:data:`QUANTITIES`) and joint.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import JOINT_NAMES
from .observe import Observed

#: the motion quantities compared: the joint target's absolute speed (module docstring: not its acceleration)
QUANTITIES = ("speed_rad_s",)
UNITS = {"speed_rad_s": "rad/s"}
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
    """``obs``'s :data:`QUANTITIES` ``(n, 6)`` each, 0 where the robot did not log the tick."""
    return (np.where(obs.logged[:, None], obs.speed_rad_s, 0.0),)


def envelope(runs: Sequence[Observed]) -> NDArray:
    """``(1, 6)``: the largest absolute target speed [rad/s] per joint over the logged samples of ``runs``."""
    out = np.zeros((len(QUANTITIES), len(JOINT_NAMES)))
    for o in runs:
        for i, x in enumerate(measured(o)):
            if x.size:
                out[i] = np.fmax(out[i], np.nanmax(x, axis=0))
    return out


def motion_notes(limit: NDArray, obs: Observed) -> list[str]:
    """A note naming each joint and quantity where ``obs`` spends :data:`MIN_BEYOND_S` or more beyond ``limit``
    ``(1, 6)`` (the baseline's :func:`envelope`) by more than :data:`MARGIN`."""
    parts = []
    for i, (q, x) in enumerate(zip(QUANTITIES, measured(obs))):
        beyond = x > (1.0 + MARGIN) * limit[i]
        for j in np.flatnonzero(beyond.sum(axis=0) * obs.period_s >= MIN_BEYOND_S):
            parts.append(f"{JOINT_NAMES[j]} {q.split('_')[0]} up to {np.nanmax(x[:, j]):.3g} {UNITS[q]} "
                         f"({beyond[:, j].sum() * obs.period_s:.1f} s more than {MARGIN:.0%} above the baseline runs' "
                         f"largest, {limit[i, j]:.3g})")
    if not parts:
        return []
    return ["moves beyond what the baseline runs covered: " + "; ".join(parts) + ". Its limits there are "
            "extrapolated from slower motion, where the model's own error was never seen: an event or change on "
            "those joints may be the model's error at this motion; give baseline runs that move as this log does"]


def payload_notes(payloads_kg: Sequence[float | None], obs: Observed) -> list[str]:
    """A note when ``obs``'s stated payload lies outside the baseline runs' (``payloads_kg``) by more than
    :data:`PAYLOAD_TOL_KG`."""
    known = [p for p in payloads_kg if p is not None]
    if obs.payload_kg is None or not known:
        return []
    lo, hi = min(known), max(known)
    if lo - PAYLOAD_TOL_KG <= obs.payload_kg <= hi + PAYLOAD_TOL_KG:
        return []
    held = f"{lo:g} kg" if lo == hi else f"{lo:g}-{hi:g} kg"
    return [f"carries {obs.payload_kg:g} kg, the baseline runs {held}: a model error that grows with the load (a "
            "torque-constant, current-gain or mass error) shows here as a change the baseline runs could not show; "
            "check the stated payload, or give baseline runs with this payload"]
