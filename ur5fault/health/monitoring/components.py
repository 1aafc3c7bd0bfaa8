"""Variance components of a baseline's block estimates: a difference between healthy runs that holds over a run
(between runs) and the blocks' noise about their run's level (within runs), each with its own degrees of freedom.

A baseline's paired change statistics (:mod:`.paired`) are estimates of one candidate on consecutive short blocks
of ``R`` healthy runs. Modelled as one-way random effects (runs and blocks), block ``i`` of run ``r`` is ``x_ri =
mu + a_r + e_ri``: ``a_r`` the run's offset (variance ``tau^2``: one run warmer, a sensor's offset a little off),
``e_ri`` the blocks' noise (variance ``sigma^2``, correlated between neighbouring blocks of a run by the design
effect ``DE_w``, :func:`.effective.design_effect` on each run's blocks about *its own* mean, so that the run's
offset is not counted as correlation). Estimated by the method of moments:

* *within*: each run's sum of squares about its mean has expectation ``sigma^2 (m_r - DE_r)`` (``DE_r = min(DE_w,
  m_r)``: the variance of a run's mean, ``sigma^2 DE_w / m_r``, is at most one block's), so ``sigma^2 = SS_w /
  sum_r (m_r - DE_r)``, with ``nu_w = sum_r max(m_r / DE_w - 1, 0)`` degrees of freedom (the blocks' effective
  count less one per run mean);
* *between*: the runs' means (each run one number) have ``E[S_b] = tau^2 + sigma^2 DE_w mean_r(1 / m_r)`` about
  their unweighted mean, ``S_b`` their sample variance with ``R - 1`` degrees of freedom (none with one run:
  ``tau^2`` is then unseen, taken as 0), so ``tau^2 = S_b - sigma^2 DE_w mean_r(1 / m_r)``.

A new healthy log's estimate over ``n`` blocks, against the baseline's pooled mean (weights ``w_r = m_r / k``), has
the variance ``a tau^2 + sigma^2 (min(1, DE_w / n) + DE_w / k)``, ``a = 1 + sum w_r^2`` (its own run's offset and the
mean's share of the runs'; its blocks' noise and the mean's). Written in the two mean squares it is estimated
from, ``P = a S_b + b sigma^2`` with ``b = min(1, DE_w / n) + DE_w / k - a DE_w mean_r(1 / m_r)`` (:meth:`Components.
parts`), and Student's bar counts Welch-Satterthwaite's degrees of freedom from the two parts' own (``nu = P^2 /
((a S_b)^2 / (R - 1) + (b sigma^2)^2 / nu_w)``; Satterthwaite 1946, *Biometrics Bulletin* 2: 110-114): where the
runs sit apart it counts about the ``R - 1`` of the runs' means, where they do not more, smoothly, with no switch.
``tau^2`` is not truncated at 0 in ``P``: truncated (``P = a max(0, tau^2) + ...``, the between part's weight
taken from the estimate), a baseline whose few runs' means happen to lie close gets both a small variance and the
within part's many degrees of freedom, and with three runs apart by half a block's noise 9.25 % of healthy logs
fell outside a 5 % interval (30 % of those whose ``tau^2`` estimate was under a fifth of the true one); in the
mean squares the between part always counts its ``R - 1`` (6.35 %; ``tests/health/monitoring/
test_change_coverage.py``, docs/monitoring.md). ``b < 0`` (a log longer than the runs are apart, few runs) is
taken as 0: the prediction is then ``a S_b`` alone, somewhat wide.

*Status: measured, not the default.* The monitor's paired test keeps one design effect (:mod:`.effective`,
:func:`.paired.for_log`). On simulated equal-length runs this model holds the level better where three runs sit
apart (6.35 % outside a 5 % interval against 9.8 %); on the real Kufieta baseline only two runs hold one-way
paired blocks (5 and 24), ``b`` is below 0 for a 20 s log, and the bar counts the two runs' means' single degree
of freedom: the paired test's smallest separable change rose to tens to thousands of amperes and its faults found
from 8 of 20 to 0 (docs/monitoring.md, "Variance components").

What it assumes: the runs' offsets are independent draws of one spread (a drift over the baseline's sessions is
not such a spread), the blocks' noise has one autocorrelation in every run, and the log's offset from the healthy
runs is one more draw of ``tau^2``.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from .changes import Reference
from .effective import design_effect


@dataclasses.dataclass(frozen=True)
class Components:
    """The variance components of one candidate's block estimates (module docstring): ``mean`` the reference's
    mean; ``within_var`` ``sigma^2`` (one block's noise about its run's level), ``within_de`` ``DE_w`` (its design
    effect within runs), ``within_df`` ``nu_w``; ``between_var`` ``tau^2`` (the runs' offsets), ``between_df``
    ``R - 1``; ``n_blocks`` ``k`` (the blocks of the runs), ``mean_weight2`` ``sum_r w_r^2`` (the pooled mean's
    share of the runs' offsets); ``between_ms`` ``S_b`` (the runs' means' sample variance, 0 with one run),
    ``mean_inv_m`` ``mean_r(1 / m_r)``. ``between_var`` is ``tau^2``, the runs' offsets' variance (not truncated:
    it may read below 0 by chance)."""

    mean: float
    within_var: float
    within_de: float
    within_df: float
    between_ms: float
    between_df: float
    n_blocks: int
    mean_weight2: float
    mean_inv_m: float

    def __post_init__(self) -> None:
        if not (np.isfinite(self.mean) and self.within_var >= 0.0 and self.between_ms >= 0.0
                and self.within_de >= 1.0 and self.within_df >= 1.0 and self.between_df >= 0.0
                and self.n_blocks >= 2 and 0.0 < self.mean_weight2 <= 1.0 and 0.0 < self.mean_inv_m <= 1.0):
            raise ValueError(f"variance components {self}: need a finite mean, variances >= 0, a design effect "
                             f">= 1, at least 1 within degree of freedom and 2 blocks")

    @property
    def effective_blocks(self) -> float:
        """``k / DE_w``: the independent blocks the runs' blocks are worth within runs."""
        return self.n_blocks / self.within_de

    @property
    def between_var(self) -> float:
        """``tau^2 = S_b - sigma^2 DE_w mean_r(1 / m_r)`` (module docstring; 0 with one run)."""
        return self.between_ms - self.within_var * self.within_de * self.mean_inv_m if self.between_df else 0.0

    def parts(self, n: float) -> tuple[float, float]:
        """``(a S_b, b sigma^2)``: the prediction variance's parts in the between-run and within-run mean squares
        for a log of ``n`` blocks (module docstring; ``b`` at least 0)."""
        a = 1.0 + self.mean_weight2
        b = min(1.0, self.within_de / max(n, 1.0)) + self.within_de / self.n_blocks
        if self.between_df:
            b -= a * self.within_de * self.mean_inv_m
        return a * self.between_ms, self.within_var * max(b, 0.0)

    def df(self, n: float) -> float:
        """Welch-Satterthwaite's degrees of freedom of the prediction variance for a log of ``n`` blocks."""
        p_b, p_w = self.parts(n)
        if p_b + p_w <= 0.0:
            return self.within_df
        den = p_w**2 / self.within_df + (p_b**2 / self.between_df if self.between_df else 0.0)
        return float((p_b + p_w) ** 2 / den)

    def reference(self, n: float) -> Reference:
        """The :class:`.changes.Reference` of a log's estimate over ``n`` blocks: its own blocks' noise
        ``sigma^2 min(1, DE_w / n)`` (``log_var``, which the log's own SE replaces where larger), the mean's share of
        the blocks' noise ``sigma^2 DE_w / k`` (``mean_var``), the rest of the prediction variance the runs'
        offsets, the log's and the mean's share (``run_var``, ``a tau^2``, which the log's SE does not see; the
        unbiased estimate, below 0 where the runs' means lie closer than their blocks' noise puts them, but never
        below ``-mean_var``: the prediction is at least ``log_var``), and ``k = nu + 1`` (Student's bar at ``nu``
        degrees of freedom). Clipping ``run_var`` at 0 instead makes the interval wider than it needs where the
        runs do not sit apart: 1.95 % outside a 5 % interval with three offset-free runs, against 2.7 %
        (docs/monitoring.md)."""
        n = max(n, 1.0)
        log_var = self.within_var * min(1.0, self.within_de / n)
        mean_var = self.within_var * self.within_de / self.n_blocks
        run_var = max(sum(self.parts(n)) - log_var - mean_var, -mean_var)
        return Reference(self.mean, log_var, mean_var, self.df(n) + 1.0, run_var=run_var)


def components(seqs: Sequence[NDArray], mean: float, min_lag: int = 1, var: float | None = None
               ) -> Components | None:
    """The variance components of the runs' block sequences ``seqs`` (empty ones left out), about the reference's
    ``mean`` (module docstring); ``None`` when the blocks are worth under one within degree of freedom (no noise
    can be told from them). ``var``: the sample variance of the blocks whose *level* the components take (the
    paired blocks paired both ways, each run against all the others, as a monitored log is paired, where ``seqs``
    are paired one way, each run against the runs before it, to count each difference once, :mod:`.paired`): both
    mean squares are scaled by ``var`` over the sample variance of ``seqs``' blocks pooled, their shares and
    degrees of freedom kept."""
    xs = [np.asarray(s, float) for s in seqs if len(s)]
    if not xs:
        return None
    m = np.array([x.size for x in xs], float)
    k = int(m.sum())
    centred = [x - x.mean() for x in xs]
    de = design_effect(centred, 0.0, min_lag)
    denom = float(np.sum(m - np.minimum(de, m)))
    nu_w = float(np.sum(np.maximum(m / de - 1.0, 0.0)))
    if denom <= 0.0 or nu_w < 1.0:
        return None
    scale = 1.0
    if var is not None:
        pooled = float(np.concatenate(xs).var(ddof=1))
        scale = var / pooled if pooled > 0.0 else 1.0
    sigma2 = scale * float(sum(c @ c for c in centred)) / denom
    R = len(xs)
    s_b = scale * float(np.var([x.mean() for x in xs], ddof=1)) if R >= 2 else 0.0
    return Components(float(mean), sigma2, float(de), nu_w, s_b, float(R - 1), k, float(np.sum((m / k) ** 2)),
                      float(np.mean(1.0 / m)))
