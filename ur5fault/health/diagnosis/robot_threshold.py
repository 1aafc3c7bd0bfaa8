"""The robot's own false-alarm threshold for ``ur5fault diagnose --baseline-logs``: read off the robot's healthy
baseline windows, each scored as a diagnosed window would be against a baseline that never held it.

Why: the threshold the benchmark saves is the 5 % false-alarm point of the simulated healthy training runs (out
of fold).  The baseline maps a robot's healthy window onto those runs (:mod:`.baseline`), but the map is fitted
on a few windows and one median and spread per input cannot follow a model error that changes with the motion:
with the map alone, 21 of 36 healthy windows of the real UR5 logs were still flagged at that threshold
(docs/diagnostics.md, "Real logs with the robot's own baseline").  A threshold is a false-alarm rate only on the
data it was read from; a user's false alarms come from windows of their own robot.

How (:func:`held_out_scores`, :func:`conformal_threshold`): the baseline's windows are split into groups - its
logs, or, with one log, the first and the second half of its windows - and each group is scored with the inputs
referred to a baseline fitted on the other groups only.  With the ``n`` held-out scores sorted, the threshold at
false-alarm rate ``alpha`` is the ``k``-th smallest, ``k = ceil((1 - alpha) (n + 1))``: the split-conformal rank,
for which a new healthy window exchangeable with the held-out ones exceeds the threshold with probability at most
``alpha``.  With fewer than ``1 / alpha - 1`` held-out windows (19 at 5 %) ``k > n`` and the largest held-out score
is taken: a new healthy window then exceeds it with probability ``1 / (n + 1)`` (more than ``alpha``, and said
so).  A window of the diagnosed log is flagged where its score exceeds both this threshold and the training
runs'.  Each held-out group is referred to fewer windows than the diagnosed log's baseline, so its scores, and the
threshold, lean high (a conservative error: fewer false alarms, later detection).  Exchangeability is an
assumption: a diagnosed motion unlike every baseline log's is not covered by it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import N_JOINTS
from .baseline import Reference, RobotThreshold, fit_map
from .score import joint_scores
from .windows import Window, window_inputs

#: the false-alarm rate the robot's threshold is read at (the benchmark's operating point)
ALPHA = 0.05


def conformal_threshold(scores: Sequence[float], alpha: float = ALPHA) -> tuple[float, int]:
    """The ``k``-th smallest of ``scores``, ``k = ceil((1 - alpha)(n + 1))`` capped at ``n``, and ``k`` itself
    (uncapped: ``k > n`` says the largest score was taken)."""
    s = np.sort(np.asarray(scores, float))
    if s.size == 0 or not np.all(np.isfinite(s)):
        raise ValueError("a threshold needs at least one finite held-out score")
    k = math.ceil((1.0 - alpha) * (s.size + 1) - 1e-12)
    return float(s[min(k, s.size) - 1]), int(k)


def groups_of(windows_by_log: Sequence[tuple[str, Sequence[Window]]]) -> list[tuple[str, list[Window]]]:
    """The held-out groups: each baseline log with windows, or with one such log, its first and second half."""
    logs = [(s, list(w)) for s, w in windows_by_log if len(w)]
    if len(logs) != 1:
        return logs
    source, ws = logs[0]
    h = len(ws) // 2
    return [(f"{source} windows 1-{h}", ws[:h]), (f"{source} windows {h + 1}-{len(ws)}", ws[h:])] if h else []


def held_out_joint_scores(models, reference: Reference, windows_by_log: Sequence[tuple[str, Sequence[Window]]],
                          period_s: float) -> tuple[NDArray, tuple[str, ...]]:
    """Every baseline window's score on each joint ``(n, 6)``, its inputs referred to a baseline fitted on the
    other groups (:func:`groups_of`) only; and the groups' names.  Fewer than two groups: no scores."""
    groups = groups_of(windows_by_log)
    if len(groups) < 2:
        return np.zeros((0, N_JOINTS)), tuple(g for g, _ in groups)
    out = []
    for i, (_, ws) in enumerate(groups):
        others = [g for k, g in enumerate(groups) if k != i]
        bmap = fit_map(reference, others, period_s)
        x = bmap.apply(window_inputs(ws, reference.names))
        out.append(joint_scores(models, reference.names, x)[0])
    return np.concatenate(out), tuple(g for g, _ in groups)


def held_out_scores(models, reference: Reference, windows_by_log: Sequence[tuple[str, Sequence[Window]]],
                    period_s: float) -> tuple[NDArray, tuple[str, ...]]:
    """Every baseline window's by-joint score (its joints' largest, :func:`held_out_joint_scores`); and the
    groups' names."""
    scores, groups = held_out_joint_scores(models, reference, windows_by_log, period_s)
    return scores.max(axis=1), groups


def threshold_from_baseline(models, reference: Reference, windows_by_log: Sequence[tuple[str, Sequence[Window]]],
                            period_s: float, alpha: float = ALPHA) -> RobotThreshold | None:
    """The robot's threshold (module docstring), with each joint's largest held-out score (which joint's healthy
    windows set the threshold, and how far below it the others stay); None where the baseline gives fewer than
    two groups (one log of one window)."""
    by_joint, groups = held_out_joint_scores(models, reference, windows_by_log, period_s)
    if by_joint.shape[0] == 0:
        return None
    scores = by_joint.max(axis=1)
    value, rank = conformal_threshold(scores, alpha)
    at = int(np.flatnonzero(scores == value)[0])  # a window whose score is the threshold
    return RobotThreshold(value, scores, groups, float(alpha), rank, tuple(map(float, by_joint.max(axis=0))),
                          int(np.argmax(by_joint[at])))


__all__ = ["ALPHA", "conformal_threshold", "groups_of", "held_out_joint_scores", "held_out_scores",
           "threshold_from_baseline"]
