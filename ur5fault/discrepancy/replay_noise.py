"""A finding must stand out of the scatter the model's own replays give it.

The block jackknife (``statistics.jackknife_se``) measures how a finding's estimate varies between stretches of
the one residual it was fitted on.  It does not see how the estimate would vary with the sensor noise's
realisation: the measured log holds one realisation, the workflow's replays another, and near stick, reversals
and quantisation steps the two drives do not follow each other linearly (friction at stick answers the noise's
dither; a reading a quantum apart is an error the size of the quantum).  On a log the packaged model itself
simulated - where every finding is false - the workflow kept a base breakaway friction x 1.005 at z 9 and a
shoulder_lift friction share of 0.028 at z 8.5, with jackknife SEs of 0.0006 and 0.003; the same findings'
estimates on replays of the fitted model under four other noise seeds scattered by 0.002-0.007 and 0.008-0.025
(docs/discrepancy.md, "Findings on a log of the model itself").

So the final check asks the model itself (:func:`replay_scatter`): the kept findings' model is replayed over the
fitting part under :data:`NULL_REPLAYS` other noise seeds, and each replay's difference from the workflow's own
replay - a residual the model would leave if the robot were the model, in the metric of the fit - is regressed on
the same columns as the measured residual.  The RMS of those estimates about zero (their spread and any bias
from the errors in the columns) is the estimate's replay scatter; a finding is judged by ``|theta| / sqrt(se^2 +
scatter^2)`` against the same bar (``statistics.MIN_Z``), and its interval widened by the scatter.  A finding
that then fails is dropped as within its replays' scatter, and its joint is not offered to the re-screen
(``rescreen.freed_joints``): by this test the residual it was chosen for is the model's own.  An effect the
re-screen names is checked the same way, on its own columns and the model it is named in (``rescreen.rescreen``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..sim.effects import EffectSpec
from .statistics import BlockGram, rss_of

#: replays of the kept findings' model under other noise seeds: for K = 4 the RMS of K estimates lies within
#: 0.52..1.39 of the true scatter at 80 % (chi distribution, 4 degrees of freedom); 4 runs over the fitting part
#: are about a tenth of the NIST log's simulated seconds
NULL_REPLAYS = 4
#: the null replays' seeds: the workflow's seed plus multiples of this (any fixed seeds other than it would do)
NULL_SEED_STRIDE = 104_729


def null_seeds(seed: int, k: int = NULL_REPLAYS) -> list[int]:
    return [int(seed) + NULL_SEED_STRIDE * (i + 1) for i in range(k)]


def null_residuals(rp, specs: Sequence[EffectSpec], reference_y: NDArray, n: int, progress=None) -> list[NDArray]:
    """The kept findings' model (``specs``) replayed over samples ``1..n`` under :func:`null_seeds`, each minus the
    workflow's own replay of it (``reference_y``), weighted by the sensor sigma as every residual of the fit
    ``(n, n_channels)``; replays that fail are left out."""
    sims = rp.run_seeds(tuple(specs), n, null_seeds(rp.seed), progress)
    out = [((s.y[:n] - reference_y[:n]) / rp.sigma).reshape(n, -1) for s in sims if s.ok]
    return [e for e in out if np.all(np.isfinite(e))]


def scatter_of(rp, specs: Sequence[EffectSpec], reference, n: int, X: NDArray, cols: Sequence[Sequence[int]],
               scale: NDArray, own_variance, drift=None, progress=None) -> list[NDArray | None]:
    """:func:`replay_scatter` of the findings whose model ``specs`` the workflow replayed as ``reference`` (a
    ``Replayed``), on columns ``X`` in the metric of the fit: the null residuals with the fit's ``drift`` removed and
    scaled by its channel scale ``scale`` (``weighting.per_channel``).  None for every finding when the reference
    replay is not ok (its readings would make every null residual meaningless)."""
    if not reference.ok:
        return [None] * len(cols)
    return replay_scatter(X, in_metric(null_residuals(rp, specs, reference.y, n, progress), scale, own_variance,
                                       drift), cols)


def in_metric(nulls: Sequence[NDArray], scale: NDArray, own_variance, drift=None) -> list[NDArray]:
    """Null residuals in the metric of the fit their columns belong to: its ``drift`` removed, then its channel
    scale (``weighting.per_channel``'s ``s``, and a variance group's drift again: ``weighting.rescaled``)."""
    from .weighting import rescaled

    return [rescaled(e if drift is None else drift.remove(e), scale, own_variance) for e in nulls]


def replay_scatter(X: NDArray, nulls: Sequence[NDArray], cols: Sequence[Sequence[int]]) -> list[NDArray | None]:
    """Per finding (its columns ``cols[k]`` of ``X`` ``(p, n, n_channels)``, every finding fitted jointly as the
    final check fits them), the RMS about zero of its coefficients fitted to each null residual (``nulls``, in
    the metric of ``X``); None for every finding when fewer than two null replays ran."""
    if len(nulls) < 2:
        return [None] * len(cols)
    idx = [c for cc in cols for c in cc]
    est = []
    for e in nulls:
        G, g, ee = BlockGram.build(X[idx], e).total()
        est.append(rss_of(G, g, ee, list(range(len(idx))))[1])
    rms = np.sqrt(np.mean(np.square(est), axis=0))
    out, i = [], 0
    for cc in cols:
        out.append(rms[i : i + len(cc)])
        i += len(cc)
    return out


def with_scatter(se: NDArray, scatter: NDArray | None) -> NDArray:
    """The standard error with the replay scatter added in quadrature (unchanged without a scatter)."""
    se = np.asarray(se, dtype=float)
    return se if scatter is None else np.sqrt(se**2 + np.asarray(scatter, dtype=float) ** 2)

