"""The search: forward selection over the candidates' columns of the linearised problem, every step
judged by :func:`judge` (a rejected candidate does not end the search: the next one is tried), and a
backward check of every finding against all the others (:func:`backward`).  Refinement by
re-simulation is in ``refinement.py``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .candidates import Candidate
from .statistics import (
    MAX_COLLINEARITY,
    MIN_DELTA_BIC,
    MIN_Z,
    BlockGram,
    Stability,
    amplitude_z,
    below,
    bic,
    collinearity,
    effective_n,
    jackknife_se,
    rss_of,
    stability,
)

#: other candidates that achieve at least this share of the chosen one's improvement are reported with
#: it as indistinguishable in this log (e.g. a current-sensor gain g and a torque-constant change 1/g)
ALTERNATIVE_SHARE = 0.98
#: candidates judged per step at most, in order of improvement; each judgement is small linear algebra,
#: so in practice every candidate that could still lower BIC enough is tried
MAX_TRIES_PER_STEP = 1000


@dataclasses.dataclass(frozen=True)
class Verdict:
    """How one candidate fared against noise, autocorrelation and time blocks, given the others."""

    label: str
    theta: tuple[float, ...]
    se: tuple[float, ...]
    delta_bic: float
    z: float
    stability: Stability
    accepted: bool
    reason: str  # why it was rejected ("" when accepted)


def judge(bg: BlockGram, e_fit: NDArray, X: NDArray, cands: Sequence[Candidate], cols: list[list[int]],
          others: list[int], cand: int, fixed: Sequence[int] = ()) -> Verdict:
    """Judge candidate ``cand`` in the joint fit with ``others`` (candidate indices) and ``fixed`` columns.

    Args:
        bg: block statistics of ``e ~ X theta``.
        e_fit: the weighted residual ``(n, n_channels)`` the statistics were built from.
        X: all columns ``(p, n, n_channels)``.
        cands: the candidates (for their valid ranges and labels); ``cols``: column indices of each.
    """
    G, g, ee = bg.total()
    base = list(fixed) + [c for o in others for c in cols[o]]
    idx = base + cols[cand]
    rss0, th0 = rss_of(G, g, ee, base)
    rss1, th = rss_of(G, g, ee, idx)
    e_res = e_fit - np.tensordot(th, X[idx], axes=1)
    n_eff = effective_n(e_res)
    dbic = bic(rss1, n_eff, len(idx)) - bic(rss0, n_eff, len(base))
    own = list(range(len(base), len(idx)))
    se = jackknife_se(bg, idx)
    z = amplitude_z(th[own], se[own])
    stab = stability(bg, idx, own, th, rss1 / n_eff)
    reasons = []
    lo, hi = cands[cand].bounds()
    if np.any(th[own] < lo) or np.any(th[own] > hi):
        reasons.append("estimate outside the effect's valid range")
    r2 = collinearity(G, base, cols[cand])
    if r2 > MAX_COLLINEARITY:
        reasons.append(f"collinear with the findings already in (r^2 {r2:.3f})")
    if dbic > -MIN_DELTA_BIC:
        reasons.append(f"delta BIC {dbic:.1f} > -{MIN_DELTA_BIC:g}")
    if z < MIN_Z:
        reasons.append(f"z {below(z, MIN_Z)} < {MIN_Z:g}")
    if not stab.stable:
        reasons.append("unstable across time blocks (" + ", ".join(f"{r:.2f}" for r in stab.ratios) + ")")
    return Verdict(cands[cand].label, tuple(float(t) for t in th[own]), tuple(float(s) for s in se[own]),
                   float(dbic), float(z), stab, not reasons, "; ".join(reasons))


@dataclasses.dataclass
class Selection:
    """Result of a forward selection: chosen candidates (indices, in order), their joint coefficients,
    the indistinguishable alternatives of each, and the trace of every judgement."""

    chosen: list[int]
    verdicts: list[Verdict]
    alternatives: list[list[tuple[int, NDArray]]]
    trace: list[Verdict]

    def theta(self, bg: BlockGram, cols: list[list[int]], fixed: Sequence[int] = ()) -> NDArray:
        G, g, ee = bg.total()
        idx = list(fixed) + [c for k in self.chosen for c in cols[k]]
        return rss_of(G, g, ee, idx)[1][len(fixed):]


def columns_of(cands: Sequence[Candidate], start: int = 0) -> list[list[int]]:
    out, k = [], start
    for c in cands:
        out.append(list(range(k, k + c.n_coef)))
        k += c.n_coef
    return out


def forward(bg: BlockGram, e_fit: NDArray, X: NDArray, cands: Sequence[Candidate], cols: list[list[int]],
            max_n: int, fixed: Sequence[int] = (), per_joint: int | None = None) -> Selection:
    """Forward selection: at each step the candidates are tried in order of the improvement they add to the
    joint fit; the first one :func:`judge` accepts is taken.  Stops when no candidate can lower BIC enough
    or none that could is accepted.  ``per_joint``: at most this many chosen per joint (robot-wide
    candidates count as one more "joint"), so that one joint's findings cannot use up another's budget."""
    G, g, ee = bg.total()
    chosen: list[int] = []
    verdicts: list[Verdict] = []
    alts: list[list[tuple[int, NDArray]]] = []
    trace: list[Verdict] = []
    while len(chosen) < max_n:
        base = list(fixed) + [c for k in chosen for c in cols[k]]
        rss0, th0 = rss_of(G, g, ee, base)
        n_eff = effective_n(e_fit - np.tensordot(th0, X[base], axes=1)) if base else effective_n(e_fit)
        gains = []
        full = set() if per_joint is None else {
            c.joint for c in (cands[k] for k in chosen) if sum(cands[o].joint == c.joint for o in chosen) >= per_joint}
        for k in range(len(cands)):
            if k in chosen or (per_joint is not None and cands[k].joint in full):
                continue
            rss1, _ = rss_of(G, g, ee, base + cols[k])
            gains.append((rss0 - rss1, k))
        gains.sort(reverse=True)
        taken = None
        for gain, k in gains[:MAX_TRIES_PER_STEP]:
            # early rejection: even ignoring its extra parameters the gain cannot lower BIC enough
            if gain <= 0 or n_eff * math.log(max(rss0 - gain, 1e-300) / rss0) > -MIN_DELTA_BIC:
                break
            v = judge(bg, e_fit, X, cands, cols, chosen, k, fixed)
            trace.append(v)
            if v.accepted:
                taken = (k, v, gain)
                break
        if taken is None:
            break
        k, v, gain = taken
        alt = []
        for gain2, k2 in gains:  # as good in this log, and as credible on its own
            if (k2 != k and gain2 >= ALTERNATIVE_SHARE * gain
                    and judge(bg, e_fit, X, cands, cols, chosen, k2, fixed).accepted):
                alt.append((k2, rss_of(G, g, ee, base + cols[k2])[1][len(base):]))
        chosen.append(k)
        verdicts.append(v)
        alts.append(alt)
    return Selection(chosen, verdicts, alts, trace)


def backward(bg: BlockGram, e_fit: NDArray, X: NDArray, cands: Sequence[Candidate], cols: list[list[int]],
             chosen: list[int], fixed: Sequence[int] = ()) -> tuple[list[int], list[Verdict], list[Verdict]]:
    """Judge every finding against all the others; drop the weakest failing one and repeat.

    Returns:
        The kept candidates, their final verdicts, and the verdicts of the dropped ones.
    """
    kept = list(chosen)
    dropped: list[Verdict] = []
    while kept:
        vs = [judge(bg, e_fit, X, cands, cols, [o for o in kept if o != k], k, fixed) for k in kept]
        failing = [(v.delta_bic, i) for i, v in enumerate(vs) if not v.accepted]
        if not failing:
            return kept, vs, dropped
        _, i = max(failing)
        dropped.append(vs[i])
        kept.pop(i)
    return kept, [], dropped
