"""Statistics of the discrepancy workflow: weighted residuals, the linearised least-squares problem in
time blocks, and the tests a finding must pass.

Every residual is weighted by its sensor's noise sigma (``ur5fault.twin.LogReplay.sigma``), so a weighted residual of
pure sensor noise has unit variance.  The linearised problem is ``e ~ X theta``: ``e`` the weighted
residual ``(n, n_channels)`` (channels = signals x joints), ``X`` one column per coefficient of the
candidates, same shape.  It is reduced once to sufficient statistics per contiguous time block
(:class:`BlockGram`); fits, leave-one-block-out (jackknife) errors and per-block estimates then cost
only small matrix algebra, however many candidates there are.

A finding is judged by what it explains that nothing else does (:func:`judge`):

* *significance*: it lowers the Bayesian information criterion by more than :data:`MIN_DELTA_BIC`,
  with the sample count discounted for the residual's own autocorrelation (:func:`effective_n`), and
  its coefficients stand :data:`MIN_Z` jackknife standard errors from zero (the block jackknife
  carries the residual's autocorrelation and the model's own errors into the error);
* *stability*: every time block of the fitting part that constrains it gives the same estimate within
  a factor :data:`STABILITY_RATIO` (or within :data:`STABILITY_Z` of its own error);
* *generalisation* (checked by simulation on the held-out part, :func:`generalisation`).

Each channel's own variance in these tests (an option; the default is one pooled variance): :mod:`.weighting`.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import NDArray

#: two-sided 95 % quantile of the normal distribution (intervals are estimate +- Z_95 SE)
Z_95 = 1.959963984540054
#: a finding must lower BIC by more than this ("very strong" on Kass & Raftery's scale)
MIN_DELTA_BIC = 10.0
#: |estimate| / jackknife SE a finding needs; with a few hundred candidates tried, a Bonferroni
#: correction of a 5 % test asks for about 3.9
MIN_Z = 4.0


def below(x: float, limit: float) -> str:
    """``x`` (below ``limit``) to as many decimals as it takes to read below it: "z 3.96 < 4", not "z 4.0 < 4"."""
    for digits in range(1, 17):
        text = f"{x:.{digits}f}"
        if float(text) < limit:
            return text
    return repr(float(x))

#: blocks of the block jackknife (standard errors and intervals)
JACKKNIFE_BLOCKS = 10
#: contiguous blocks of the fitting part in which a finding's estimate must be stable
STABILITY_BLOCKS = 4
#: allowed ratio of a block's estimate to the overall one ...
STABILITY_RATIO = (0.5, 2.0)
#: ... unless the block's estimate is within this many of its own standard errors of the overall one
STABILITY_Z = 3.0
#: a block constrains a finding when it holds at least this share of the finding's information
INFORMATIVE_SHARE = 0.5 / STABILITY_BLOCKS
#: a candidate whose columns the findings already in explain to this share (r^2; variance inflation 50)
#: can only fit the small differences between near-identical shapes - the model's own error, not an effect
MAX_COLLINEARITY = 0.98
#: lag-1 autocorrelation is capped below 1 so that the effective sample count stays positive
RHO_MAX = 0.999
#: on the held-out part, a finding must remove at least this share of the change it makes there ...
GENERALISATION_MIN = 0.5
#: ... when that change is large enough to be tested: (5 sigma)^2 in weighted, autocorrelation-discounted units
HELD_OUT_MIN_ENERGY = 25.0


def weighted(meas: NDArray, sim: NDArray, sigma: NDArray) -> NDArray:
    """Weighted residual ``(meas - sim) / sigma``, ``(n, n_signals, 6)`` -> ``(n, n_channels)``."""
    r = (meas - sim) / sigma
    return r.reshape(r.shape[0], -1)


def lag1(e: NDArray) -> NDArray:
    """Lag-1 autocorrelation of each channel of ``e`` ``(n, n_channels)``, clipped to ``[0, RHO_MAX]``."""
    x = e - e.mean(axis=0)
    den = np.sum(x * x, axis=0)
    rho = np.where(den > 0, np.sum(x[1:] * x[:-1], axis=0) / np.where(den > 0, den, 1.0), 0.0)
    return np.clip(rho, 0.0, RHO_MAX)


def effective_n(e: NDArray) -> float:
    """Independent samples in a residual: ``sum over channels of n (1 - rho) / (1 + rho)``."""
    rho = lag1(e)
    return float(max(np.sum(e.shape[0] * (1 - rho) / (1 + rho)), 10.0))


def bic(rss: float, n_eff: float, k: int) -> float:
    """Bayesian information criterion of a Gaussian model with ``k`` parameters."""
    return n_eff * math.log(max(rss, 1e-300) / n_eff) + k * math.log(n_eff)


def block_edges(n: int, blocks: int) -> NDArray:
    return np.linspace(0, n, blocks + 1).astype(int)


@dataclasses.dataclass(frozen=True)
class BlockGram:
    """Sufficient statistics of ``e ~ X theta`` per time block: ``G[b] = X_b X_b^T``, ``g[b] = X_b e_b``,
    ``ee[b] = e_b . e_b``, for :data:`JACKKNIFE_BLOCKS` blocks (the stability blocks are unions of them
    when the counts divide, else recomputed by :meth:`coarsen`)."""

    G: NDArray  # (blocks, p, p)
    g: NDArray  # (blocks, p)
    ee: NDArray  # (blocks,)

    @classmethod
    def build(cls, X: NDArray, e: NDArray, blocks: int = JACKKNIFE_BLOCKS) -> BlockGram:
        """``X`` ``(p, n, n_channels)``, ``e`` ``(n, n_channels)``."""
        edges = block_edges(e.shape[0], blocks)
        p = X.shape[0]
        G, g, ee = np.zeros((blocks, p, p)), np.zeros((blocks, p)), np.zeros(blocks)
        for b in range(blocks):
            Xb = X[:, edges[b] : edges[b + 1]].reshape(p, -1)
            eb = e[edges[b] : edges[b + 1]].reshape(-1)
            G[b], g[b], ee[b] = Xb @ Xb.T, Xb @ eb, eb @ eb
        return cls(G, g, ee)

    def total(self) -> tuple[NDArray, NDArray, float]:
        return self.G.sum(axis=0), self.g.sum(axis=0), float(self.ee.sum())

    def coarsen(self, blocks: int) -> BlockGram:
        """Merge neighbouring blocks into ``blocks`` groups (as even as the fine blocks allow)."""
        groups = np.array_split(np.arange(self.G.shape[0]), blocks)
        return BlockGram(np.stack([self.G[i].sum(axis=0) for i in groups]),
                         np.stack([self.g[i].sum(axis=0) for i in groups]),
                         np.array([self.ee[i].sum() for i in groups]))


def solve(G: NDArray, g: NDArray) -> NDArray:
    """Least-squares coefficients from a Gram matrix (pseudo-inverse where it is singular)."""
    try:
        return np.linalg.solve(G, g)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(G, g, rcond=None)[0]


def rss_of(G: NDArray, g: NDArray, ee: float, idx: list[int]) -> tuple[float, NDArray]:
    """Residual sum of squares and coefficients of the fit on columns ``idx``."""
    if not idx:
        return ee, np.zeros(0)
    th = solve(G[np.ix_(idx, idx)], g[idx])
    return float(ee - g[idx] @ th), th


def jackknife_se(bg: BlockGram, idx: list[int]) -> NDArray:
    """Block-jackknife standard errors of the coefficients on columns ``idx``."""
    G, g, _ = bg.total()
    B = bg.G.shape[0]
    sub = np.ix_(idx, idx)
    full = solve(G[sub], g[idx])
    thetas = []
    for b in range(B):
        Gb = G[sub] - bg.G[b][sub]
        if np.linalg.matrix_rank(Gb) < len(idx):
            continue  # the block is the only one that constrains a column
        thetas.append(solve(Gb, g[idx] - bg.g[b][idx]))
    if len(thetas) < 3:
        return np.full(len(idx), np.nan)
    t = np.array(thetas)
    m = len(t)
    return np.sqrt((m - 1) / m * np.sum((t - full) ** 2, axis=0))


def amplitude_z(theta: NDArray, se: NDArray) -> float:
    """Distance of a coefficient group from zero in its standard errors (one coefficient: ``|t|/se``;
    a sine-cosine pair: its amplitude over the error along the amplitude's direction)."""
    if not np.all(np.isfinite(se)) or np.any(se <= 0):
        return 0.0
    amp = float(np.linalg.norm(theta))
    if amp == 0.0:
        return 0.0
    u = theta / amp
    return amp / float(np.sqrt(np.sum((u * se) ** 2)))


@dataclasses.dataclass(frozen=True)
class Stability:
    """Per-block estimates of one finding (its coefficients projected on the overall estimate)."""

    ratios: tuple[float, ...]  # block estimate / overall, informative blocks; NaN where uninformative
    stable: bool


def stability(bg: BlockGram, idx: list[int], own: list[int], theta: NDArray, residual_scale: float) -> Stability:
    """Estimate the finding on columns ``own`` (positions in ``idx``) in each stability block, the other
    findings held at their overall coefficients ``theta``; compare with the overall estimate.

    Args:
        residual_scale: variance of the weighted residual per sample, times the autocorrelation
            inflation ``n / n_eff`` (for the blocks' own standard errors).
    """
    sb = bg.coarsen(STABILITY_BLOCKS)
    cols = [idx[i] for i in own]
    others = [i for i in range(len(idx)) if i not in own]
    th_own = theta[own]
    norm2 = float(th_own @ th_own)
    info = np.array([np.trace(sb.G[b][np.ix_(cols, cols)]) for b in range(STABILITY_BLOCKS)])
    ratios, ok = [], True
    for b in range(STABILITY_BLOCKS):
        if info[b] < INFORMATIVE_SHARE * info.sum() or norm2 == 0.0:
            ratios.append(float("nan"))
            continue
        Gb = sb.G[b][np.ix_(cols, cols)]
        gb = sb.g[b][cols] - sb.G[b][np.ix_(cols, [idx[i] for i in others])] @ theta[others]
        tb = solve(Gb, gb)
        ratio = float(tb @ th_own / norm2)
        ratios.append(ratio)
        if not STABILITY_RATIO[0] <= ratio <= STABILITY_RATIO[1]:
            # a block that cannot resolve the difference does not count against the finding
            se_along = math.sqrt(residual_scale * float(th_own @ solve(Gb, th_own)) / norm2)
            if abs(ratio - 1.0) * math.sqrt(norm2) > STABILITY_Z * se_along:
                ok = False
    return Stability(tuple(ratios), ok)


@dataclasses.dataclass(frozen=True)
class Generalisation:
    """What a finding does on the held-out part: the change it makes there (``energy``, weighted and
    discounted for autocorrelation) and the share of that change that moves the model towards the
    measurement (``ratio``: 1 for a perfect finding, <= 0 for one that does not generalise)."""

    energy: float
    ratio: float

    @property
    def testable(self) -> bool:
        return self.energy >= HELD_OUT_MIN_ENERGY

    @property
    def passes(self) -> bool:
        return not self.testable or self.ratio >= GENERALISATION_MIN


def generalisation(e_with: NDArray, e_without: NDArray) -> Generalisation:
    """From the weighted held-out residuals with and without the finding, ``(n, n_channels)``."""
    change = e_without - e_with
    energy = float(np.sum(change**2))
    if energy == 0.0:
        return Generalisation(0.0, 0.0)
    drop = float(np.sum(e_without**2) - np.sum(e_with**2))
    # drop / energy = 1 + 2 e_with.change / energy: its noise grows with the residual's correlation time
    discount = effective_n(e_with) / e_with.size
    return Generalisation(energy * discount, drop / energy)


def collinearity(G: NDArray, base: list[int], own: list[int]) -> float:
    """Largest squared canonical correlation between columns ``own`` and the span of columns ``base``
    (1: ``own`` lies in that span; 0: orthogonal to it)."""
    if not base:
        return 0.0
    Goo = G[np.ix_(own, own)]
    Gob = G[np.ix_(own, base)]
    schur = Goo - Gob @ solve(G[np.ix_(base, base)], Gob.T)
    lam = np.linalg.eigvals(solve(Goo, schur)).real  # 1 - r^2 along the canonical directions
    return float(np.clip(1.0 - lam.min(), 0.0, 1.0))
