"""The event limits of a baseline, fitted on its healthy runs: per channel and joint the spread model of the
residual's transient and the tail of its normalised window maxima (:mod:`.events`), the same per motion condition
(:mod:`.conditions`), and for a robot that repeats its task, per baseline run the spread and tail of its current's
transient against the other runs and its own repeats (:mod:`.task`). :func:`.baseline.fit_baseline` keeps them in
the :class:`~.baseline.Baseline`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import N_JOINTS
from .conditions import CONDITIONS, CONSTANT_SPREAD, REVERSAL, SLOW, condition, constant, enough, rest_level
from .events import (
    CHANNELS,
    FEATURES,
    features,
    fit_scale,
    fit_tail,
    judged_rows,
    quantum_sigma,
    sigma,
    transient,
    window_maxima,
)
from .observe import Observed
from .task import paired_transient

#: a baseline run's task statistics are fitted only on at least this much of it paired with the other runs or its
#: own repeats [s] (40 windows of WINDOW_S: 4 above the tail's 90 % quantile); with less, no log is judged
#: against that run
MIN_TASK_S = 10.0


def segment(obs: Observed, slow_rad_s: float) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """A log part's transients ``h`` ``(2, n, 6)`` (current [A], position [rad]: :data:`~.events.CHANNELS`; at rest
    against the rest stretch's own level, :mod:`.conditions`), spread features ``(n, 6, 4)``, judged samples
    ``(n,)`` and motion condition ``(n, 6)`` (``slow_rad_s``: the overlay's Stribeck speed)."""
    cond = condition(obs.moving, obs.speed_rad_s, obs.target_rad, obs.period_s, slow_rad_s)
    h = [rest_level(r, cond, obs.period_s, transient(r, obs.period_s))
         for r in (obs.residual_A, obs.position_residual_rad)]
    feats = features(obs.moving, obs.speed_rad_s, obs.accel_rad_s2, obs.period_s)
    # a slow or reversing joint moves, also where its target creeps under the rest speed: moving for the spread
    # model on all motions too (which judges it where its condition has no statistics)
    feats[..., 1] = np.maximum(feats[..., 1], (cond == SLOW) | (cond == REVERSAL))
    return np.stack(h), feats, judged_rows(obs.logged, obs.period_s), cond


def fit_events(segs: list[tuple[NDArray, NDArray, NDArray, NDArray]], period_s: float, quantum_rad: NDArray
               ) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Per channel, spread coefficients ``(6, 4)`` on all segments and the tail ``(6, 3)`` of the normalised
    window maxima, stacked ``(2, 6, 4)``, ``(2, 6, 3)``; and the same per motion condition on its samples alone,
    ``(2, 5, 6, 4)``, ``(2, 5, 6, 3)``, NaN for a joint with under :data:`~.conditions.MIN_CONDITION_S` of the
    condition (:mod:`.conditions`). With two or more segments each segment is normalised by the spread fitted on
    the others (leave one out), so the tail holds how far a healthy run the model was not fitted on strays, not
    how well it fits its own."""
    have = enough(np.concatenate([c for *_, c in segs]), np.concatenate([ok for _, _, ok, _ in segs]), period_s)
    coefs, tails, c_coefs, c_tails = [], [], [], []
    for i in range(len(CHANNELS)):
        floor = quantum_sigma(quantum_rad) if CHANNELS[i] == "position" else 0.0
        coef, tail = fit_channel([(h[i], f, ok) for h, f, ok, _ in segs], period_s, floor)
        coefs.append(coef)
        tails.append(tail)
        cc, ct = np.full((len(CONDITIONS), *coef.shape), np.nan), np.full((len(CONDITIONS), *tail.shape), np.nan)
        for k in range(len(CONDITIONS)):
            if have[k].any():
                cc[k], ct[k] = fit_channel([(h[i], constant(f) if k in CONSTANT_SPREAD else f, ok[:, None] & (c == k))
                                            for h, f, ok, c in segs], period_s, floor)
                cc[k][~have[k]] = np.nan
                ct[k][~have[k]] = np.nan
        c_coefs.append(cc)
        c_tails.append(ct)
    return np.stack(coefs), np.stack(tails), np.stack(c_coefs), np.stack(c_tails)


def fit_channel(one: list[tuple[NDArray, NDArray, NDArray]], period_s: float, floor: NDArray | float = 0.0
                ) -> tuple[NDArray, NDArray]:
    """One channel's spread coefficients ``(6, 4)`` and tail ``(6, 3)`` from segments ``(h, features, judged)``
    (:func:`fit_events`; a segment without judged samples only adds nothing)."""
    one = [s for s in one if s[2].any()]
    coef = fit_scale(one)
    maxima = []
    for k, (h, f, ok) in enumerate(one):
        c = fit_scale(one[:k] + one[k + 1 :]) if len(one) >= 2 else coef
        maxima.append(window_maxima(np.abs(h) / sigma(f, c, floor), ok, period_s))
    return coef, fit_tail(np.concatenate(maxima))


def task_residual(obs: Observed) -> NDArray:
    """A baseline run's current residual as a reference ``(n, 6)``: NaN where the tick was not logged."""
    return np.where(obs.logged[:, None], obs.residual_A, np.nan)


def fit_task(healthy: Sequence[Observed], segs: list[tuple[NDArray, NDArray, NDArray]], period_s: float
             ) -> tuple[NDArray, NDArray]:
    """Per baseline run, its current transient's spread ``(k, 6, 4)`` and tail ``(k, 6, 3)`` against the other
    runs and its own repeats (never its own samples) where they repeat its task; NaN for a run paired over less
    than :data:`MIN_TASK_S`. Per run, not pooled: a log paired with a run is judged by the spread of that run's
    task (a fast task's repeats differ more than a slow one's). A single run's tail is fitted on the spread
    fitted on itself (no run left out)."""
    refs = [(o.target_rad, task_residual(o)) for o in healthy]
    scale = np.full((len(healthy), N_JOINTS, len(FEATURES)), np.nan)
    tail = np.full((len(healthy), N_JOINTS, 3), np.nan)
    for k, (o, (_, f, ok, _)) in enumerate(zip(healthy, segs)):
        h, paired, _ = paired_transient(o.target_rad, o.residual_A, refs, period_s, self_index=k)
        if int((ok & paired).sum()) * period_s >= MIN_TASK_S:
            scale[k], tail[k] = fit_channel([(h, f, ok & paired)], period_s)
    return scale, tail
