"""How many independent blocks a sequence of block estimates is worth: its autocorrelation accounted for.

A baseline's paired change statistics (:mod:`.paired`) are estimates of one candidate on consecutive short blocks
of each baseline run's paired difference. Neighbouring blocks need not be independent: a difference between two
healthy runs that holds for seconds (one run warmer, its friction or a sensor's offset a little off) moves every
block of that run the same way. Counted as independent, such blocks would give Student's bar too many degrees
of freedom and their sample variance would be too small. So the blocks are weighed by their own autocorrelation:

* the autocovariance of the block estimates at lag ``l`` is pooled over the runs' sequences (pairs of blocks of
  the same run, ``l`` blocks apart), about the mean of the reference (:func:`design_effect`'s ``mean``), not
  each sequence's own: a run that sits off that mean throughout shows as correlation at every lag;
* the design effect ``DE = 1 + 2 sum_l rho_l`` sums the autocorrelations, each lag under ``min_lag`` counted
  (clipped at 0: a negative correlation never buys blocks), then in Geyer's initial positive sequence (pairs
  ``rho_l + rho_{l+1}`` while their sum is positive; Geyer 1992, *Practical Markov chain Monte Carlo*, Stat. Sci.
  7: the sum of a stationary sequence's autocorrelations, truncated where its estimate turns to noise);
* Geyer's sum stops where a pair of estimated autocorrelations is not positive, so a run-long offset that is
  small against one block's noise (``rho_l`` about ``tau^2 / var_b`` at every lag, under the estimates' own noise
  of about ``1 / sqrt(k)``) is cut off after a few lags though it adds ``m tau^2`` to the variance of a run's
  ``m`` blocks' mean. So the spread of the runs' own means is measured too (:func:`cluster_design_effect`, the
  design effect of runs as clusters: the variance of the pooled mean from the runs' means, over that of ``k``
  independent blocks), and the larger of the two is taken (:func:`run_design_effect`);
* ``k`` blocks are then worth ``k_eff = k / DE`` independent ones (the variance of their mean is ``DE`` times
  that of ``k`` independent blocks), and their sample variance's expectation is ``sigma^2 (k - DE) / (k - 1)``
  (the average correlation between two of them is ``(DE - 1) / (k - 1)``): :func:`effective` undoes that bias.

What this does not see: a difference shared by *every* baseline run and the monitored log alike (it is in the
mean, not the spread), and a correlation longer than the runs' paired sequences (with a single run of few blocks,
``rho_l`` at long lags is noise and Geyer's sum stops early; ``min_lag`` is the span always counted). And
``k_eff`` is the number of independent blocks the *mean* is worth, not the degrees of freedom of the variance:
where a few runs sit apart, the spread rests on their few means, and Student's bar at ``k_eff - 1`` degrees of
freedom is too low (three simulated runs apart by half a block's noise: 9.8 % of healthy logs outside a 95 %
interval, ``tests/health/monitoring/test_change_coverage.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray


def autocorrelation(seqs: Sequence[NDArray], mean: float, lags: int | None = None) -> NDArray:
    """``rho_l`` for ``l = 0 .. lags - 1`` (default: every lag of the longest sequence) of the sequences ``seqs``
    pooled: ``sum over sequences and i of (x_i - mean)(x_{i+l} - mean)``, over the same sum at lag 0 (the biased
    estimator, which divides every lag by the total count: its sequence is positive semi-definite); 0 beyond the
    longest sequence. All zero but ``rho_0 = 1`` when every block equals ``mean``."""
    xs = [np.asarray(s, float) - mean for s in seqs if len(s)]
    if not xs:
        raise ValueError("no block estimates to correlate")
    L = max(x.size for x in xs) if lags is None else lags
    c = np.array([sum(float(x[: x.size - lag] @ x[lag:]) for x in xs if x.size > lag) for lag in range(L)])
    if c[0] <= 0.0:
        return np.eye(1, L)[0]
    return c / c[0]


def design_effect(seqs: Sequence[NDArray], mean: float, min_lag: int = 1) -> float:
    """``DE >= 1`` of the pooled sequences (module docstring): ``1 + 2 sum_l rho_l``, the lags ``1 .. min_lag - 1``
    each clipped at 0, then Geyer's initial positive pairs from lag ``min_lag`` on (computed until the first
    pair that is not positive)."""
    if min_lag < 1:
        raise ValueError(f"min_lag {min_lag}: must be at least 1")
    longest = max((len(s) for s in seqs), default=0)
    lags = min_lag + 2
    rho = autocorrelation(seqs, mean, lags)
    de = 1.0 + 2.0 * float(np.clip(rho[1:min_lag], 0.0, None).sum())
    lag = min_lag
    while lag < longest:
        if lag + 2 > rho.size:  # twice the lags so far (the sums cost one pass over the blocks per lag)
            lags = min(2 * lags, longest + 1)
            rho = autocorrelation(seqs, mean, lags)
        pair = float(rho[lag] + rho[lag + 1])
        if pair <= 0.0:
            break
        de += 2.0 * pair
        lag += 2
    return max(de, 1.0)


def cluster_design_effect(seqs: Sequence[NDArray], mean: float, var: float) -> float:
    """The design effect of the runs as clusters: ``R`` sequences of ``m_r`` blocks (``k`` in all) about ``mean``,
    ``var`` the blocks' sample variance. Runs independent of each other, the pooled mean's variance is ``V =
    sum m_r^2 Var(mean_r) / k^2``, each ``Var(mean_r)`` estimated by ``(mean_r - mean)^2 R / (R - 1)`` (about a
    mean estimated from the ``R`` runs). ``DE`` is ``V`` over that of ``k`` independent blocks, ``sigma^2 / k``,
    with ``sigma^2 = var (k - 1) / (k - DE)`` (the sample variance's bias under that correlation, as
    :func:`effective` corrects it): ``DE = A k / (1 + A)``, ``A = V k / (var (k - 1))``. Blocks that are all their
    run's mean give ``k / R`` (each run one block); independent ones about 1. 1 when fewer than two runs hold
    blocks (one run's mean tells nothing of another's) or ``var`` is 0."""
    xs = [np.asarray(s, float) for s in seqs if len(s)]
    k = sum(x.size for x in xs)
    if len(xs) < 2 or not var > 0.0:
        return 1.0
    R = len(xs)
    v = sum(x.size**2 * (x.mean() - mean) ** 2 for x in xs) * R / ((R - 1) * k**2)
    a = v * k / (var * (k - 1))
    return max(1.0, float(a * k / (1.0 + a)))


def run_design_effect(seqs: Sequence[NDArray], mean: float, var: float, min_lag: int = 1) -> float:
    """The larger of the autocorrelation's design effect (:func:`design_effect`) and the runs' as clusters
    (:func:`cluster_design_effect`; module docstring): each misses what the other sees (a short correlation within
    runs; a run-long offset too small per block for Geyer's sum), and each is at least 1."""
    return max(design_effect(seqs, mean, min_lag), cluster_design_effect(seqs, mean, var))


def effective(var: float, k: int, de: float) -> tuple[float, float] | None:
    """``(variance, k_eff)``: the sample variance ``var`` of ``k`` blocks with design effect ``de`` corrected for
    its bias, ``var (k - 1) / (k - de)``, and ``k / de``; ``None`` when the blocks are worth fewer than 2
    independent ones (no variance can be told from them)."""
    if de < 1.0 or k < 1:
        raise ValueError(f"design effect {de} (must be >= 1), {k} blocks")
    k_eff = k / de
    if k_eff < 2.0:
        return None
    return var * (k - 1) / (k - de), k_eff
