"""Step 3 of the discrepancy fit (:mod:`.steps`): the findings of the library screen and the dictionary selected
afresh among themselves on the linearised problem, so that library effects that only stood in for a term
discovered later are not re-simulated, and one fault, one finding: a dictionary term on a joint that carries
another finding must explain something on data it was not fitted to."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .candidates import Candidate
from .judging import SearchStep
from .search import backward, columns_of, forward
from .search import judge as judge_one
from .statistics import MIN_DELTA_BIC, BlockGram, effective_n, rss_of
from .weighting import OwnVariance, per_channel


@dataclasses.dataclass(frozen=True)
class JointCheckRecord:
    found: list[Candidate]
    fixed: list[int]      # columns of ``found`` in the discovery's ``X``
    trace: list[SearchStep]


def joint_check(found: list[Candidate], X: NDArray, fixed: list[int], e0: NDArray,
                preferred: Sequence[Candidate] = (), own_variance: OwnVariance = False) -> JointCheckRecord:
    """The findings selected afresh among themselves (forward, then backward), then every dictionary term that
    shares its joint with another finding checked on data it was not fitted to (:func:`same_joint_check`).
    ``preferred``: library effects named in place of a term (:func:`prefer_library`), kept when they fail only
    the stability test (the held-out judgement decides)."""
    if len(found) <= 1:
        return JointCheckRecord(found, fixed, [])
    fcols = columns_of(found)
    Xf, e0, _ = per_channel(X[fixed], e0, own_variance)  # each channel its own variance (statistics.py)
    bg = BlockGram.build(Xf, e0)
    again = forward(bg, e0, Xf, found, fcols, len(found))
    keep, _, _ = backward(bg, e0, Xf, found, fcols, again.chosen)
    trace = []
    for k in range(len(found)):
        if k not in keep and found[k] in preferred:
            v = judge_one(bg, e0, Xf, found, fcols, keep, k)
            if v.accepted or v.reason.startswith("unstable across time blocks"):
                keep.append(k)
    for k in range(len(found)):
        if k not in keep:
            v = judge_one(bg, e0, Xf, found, fcols, keep, k)
            trace.append(SearchStep.of("linear joint check", dataclasses.replace(
                v, accepted=False, reason=v.reason or "explains nothing the other findings do not")))
    keep = sorted(keep)
    for k in same_joint_check(bg, e0, Xf, found, fcols, keep):
        v = judge_one(bg, e0, Xf, found, fcols, [o for o in keep if o != k], k)
        trace.append(SearchStep.of("same-joint held-out check", dataclasses.replace(
            v, accepted=False, reason="explains nothing on data it was not fitted to that the other finding on "
                                      "its joint does not")))
        keep.remove(k)
    return JointCheckRecord([found[k] for k in keep], [fixed[c] for k in keep for c in fcols[k]], trace)


def cross_validated_rss(bg: BlockGram, idx: list[int]) -> float:
    """Sum over the time blocks of the residual sum of squares of each block predicted by the fit on all the
    other blocks (leave-one-block-out)."""
    G, g, ee = bg.total()
    out = 0.0
    for b in range(bg.G.shape[0]):
        th = rss_of(G - bg.G[b], g - bg.g[b], ee - bg.ee[b], idx)[1]
        Gb = bg.G[b][np.ix_(idx, idx)]
        out += float(bg.ee[b] - 2.0 * th @ bg.g[b][idx] + th @ Gb @ th)
    return out


def same_joint_check(bg: BlockGram, e0: NDArray, X: NDArray, found: list[Candidate], cols: list[list[int]],
                     keep: list[int]) -> list[int]:
    """One fault, one finding: a dictionary term on a joint that carries another kept finding must lower the
    residual on time blocks it was not fitted to (leave-one-block-out) by more than MIN_DELTA_BIC in effective
    samples; the terms that do not (a shape that merely shares the other finding's) are returned, to be
    dropped, so that the other finding's size is estimated without them."""
    drop: list[int] = []
    for k in keep:
        c = found[k]
        if c.source != "dictionary" or c.joint is None:
            continue
        rest = [o for o in keep if o != k and o not in drop]
        if not any(found[o].joint == c.joint for o in rest):
            continue
        base = [i for o in rest for i in cols[o]]
        with_k = base + cols[k]
        G, g, ee = bg.total()
        e_res = e0 - np.tensordot(rss_of(G, g, ee, with_k)[1], X[with_k], axes=1)
        gain = (cross_validated_rss(bg, base) - cross_validated_rss(bg, with_k)) * effective_n(e_res) / e0.size
        if gain < MIN_DELTA_BIC:
            drop.append(k)
    return drop
