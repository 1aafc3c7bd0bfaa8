"""The paired change test's prediction interval on simulated healthy logs: how often a log with no change falls
outside it (ur5fault/health/monitoring/paired.py, "Why the false-alarm rate holds" and "The log's noise counted
once"; effective.py).

Each trial draws a baseline of ``R`` healthy runs of ``m`` block estimates and a new healthy log of ``n`` blocks
from one process: an AR(1) sequence of unit variance per run (the sensors' noise and the task's repeatability,
correlated over neighbouring 0.5 s blocks) plus, per run, an offset of spread ``tau`` (a difference between
healthy runs that holds over a whole run). The baseline's mean, variance, design effect and effective blocks go
through the monitor's own code (:func:`~ur5fault.health.monitoring.effective.run_design_effect`,
:func:`~ur5fault.health.monitoring.effective.effective`, :func:`~ur5fault.health.monitoring.paired.for_log`);
the log's estimate is its blocks' mean and its standard error the block jackknife over the workflow's
:data:`~ur5fault.discrepancy.statistics.JACKKNIFE_BLOCKS` groups, as the workflow's ``judge`` gives it. The
share of logs whose ``|theta - mean| / sqrt(prediction variance)`` exceeds Student's two-sided 5 % quantile at
the reference's ``k_eff - 1`` degrees of freedom is compared with 5 % (the monitor's own tail, z = 4, is too far
out to count by simulation; the level tested is where a too narrow or too wide interval shows in 2000 trials:
the share's standard error is 0.5 %).
"""

import numpy as np
import pytest
from scipy import stats

from ur5fault.discrepancy.statistics import JACKKNIFE_BLOCKS
from ur5fault.health.monitoring.components import components
from ur5fault.health.monitoring.effective import effective, run_design_effect
from ur5fault.health.monitoring.paired import MIN_LAG, PAIRED_BLOCK_S, for_log

LEVEL = 0.05
TRIALS = 2000
#: the largest share outside the interval that is consistent with the level: 3 standard errors of the share
HOLDS = LEVEL + 3.0 * np.sqrt(LEVEL * (1.0 - LEVEL) / TRIALS)


def ar1(rng: np.random.Generator, m: int, rho: float) -> np.ndarray:
    """An AR(1) sequence of ``m`` values, coefficient ``rho``, unit variance (started stationary)."""
    x = np.empty(m)
    x[0] = rng.normal()
    e = rng.normal(size=m) * np.sqrt(1.0 - rho**2)
    for i in range(1, m):
        x[i] = rho * x[i - 1] + e[i]
    return x


def _jackknife_se(log: np.ndarray) -> float:
    """The log's estimate's (its blocks' mean's) standard error by the block jackknife over the workflow's groups."""
    groups = np.array_split(log, JACKKNIFE_BLOCKS)
    loo = np.array([(log.sum() - g.sum()) / (log.size - g.size) for g in groups])
    return float(np.sqrt((len(groups) - 1) / len(groups) * np.sum((loo - loo.mean()) ** 2)))


def outside_share(runs: int, m: int, n: int, rho: float, tau: float, seed: int, model: str = "design") -> float:
    """The share of ``TRIALS`` healthy logs outside the interval at ``LEVEL`` (module docstring); trials whose
    baseline is worth under 2 blocks (no statistics) are left out, and must be few. ``model``: ``"design"`` the
    monitor's default (one design effect, :func:`.paired.for_log`), ``"components"`` the variance components of
    runs and blocks with Welch-Satterthwaite's degrees of freedom (:mod:`.components`, measured, not the
    default: docs/monitoring.md)."""
    rng = np.random.default_rng(seed)
    out, judged = 0, 0
    for _ in range(TRIALS):
        seqs = [ar1(rng, m, rho) + tau * rng.normal() for _ in range(runs)]
        blocks = np.concatenate(seqs)
        mean, var = float(blocks.mean()), float(blocks.var(ddof=1))
        if model == "components":
            comp = components(seqs, mean, MIN_LAG)
            if comp is None:
                continue
            ref = comp.reference(n)
            log = ar1(rng, n, rho) + tau * rng.normal()
            judged += 1
            out += ref.z(float(log.mean()), _jackknife_se(log)) > stats.t.isf(LEVEL / 2, ref.k - 1)
            continue
        de = run_design_effect(seqs, mean, var, MIN_LAG)
        got = effective(var, blocks.size, de)
        if got is None:
            continue
        ref = for_log({"x": (mean, got[0], got[1], de)}, n * PAIRED_BLOCK_S)["x"]
        log = ar1(rng, n, rho) + tau * rng.normal()
        se = _jackknife_se(log)
        judged += 1
        out += ref.z(float(log.mean()), se) > stats.t.isf(LEVEL / 2, ref.k - 1)
    assert judged > 0.9 * TRIALS, judged
    return out / judged


def test_a_healthy_log_whose_difference_is_the_sensors_noise_falls_outside_about_as_often_as_the_level():
    """Three baseline runs of 80 blocks (40 s), a 20 s log, neighbouring blocks correlated (0.3), no difference
    that holds over a run: the interval holds its level (measured 3.2 % at 5 %), and is not twice the log's noise
    wide (with the log's SE added to the baseline's prediction of the same noise, as before: 0.95 %; the bound
    2 % is between)."""
    share = outside_share(3, 80, 40, 0.3, 0.0, seed=2)
    assert 0.02 <= share <= HOLDS, share


def test_a_run_long_offset_small_against_a_blocks_noise_is_seen_by_the_runs_means():
    """Six runs of 80 blocks that each sit off by an offset of spread 0.2 (a twenty-fifth of a block's noise
    variance, but 80 x 0.04 = 3.2 over a run's mean against the blocks' 1.9): Geyer's sum of autocorrelations
    cuts the small correlation off after a few lags, and with its design effect alone 9.5 % of healthy logs fall
    outside the 5 % interval; the runs' means see the offset (measured 4.5 %; before, Geyer's sum alone with
    the log's SE counted twice: 4.4 %)."""
    assert outside_share(6, 80, 40, 0.3, 0.2, seed=2) <= HOLDS


@pytest.mark.xfail(strict=True, reason="not met: with three runs that sit apart, Student's bar counts k_eff "
                   "(about 18) degrees of freedom while the prediction variance rests on three runs' means "
                   "(measured 9.8 % outside a 5 % interval; 13.9 % before, Geyer's sum alone with the log's SE "
                   "counted twice; docs/monitoring.md)")
def test_three_runs_that_sit_apart_by_half_a_blocks_noise_hold_the_level():
    assert outside_share(3, 80, 40, 0.3, 0.5, seed=2) <= HOLDS


@pytest.mark.parametrize(("runs", "tau"), [(3, 0.0), (6, 0.2), (3, 0.5), (5, 0.0), (6, 0.0)])
def test_the_variance_components_hold_the_level_where_runs_sit_apart_and_where_they_do_not(runs, tau):
    """The measured alternative (:mod:`.components`, not the default): the between-run part counted with the
    runs' means' ``R - 1`` degrees of freedom by Welch-Satterthwaite. Measured at 5 %: 2.7 / 4.3 / 6.35 / 2.9 /
    2.8 % (seeds 3 and 4: 2.7 / 5.7 / 5.85 / 2.15 / 3.45 and 2.2 / 5.1 / 7.1 / 2.85 / 2.65 %: with three runs
    apart, 6.43 % pooled over 6000 trials, still above the level). Not twice too wide where the runs do not sit
    apart (over 2 %). What it costs at the monitor's z = 4 and why it is not the default: docs/monitoring.md."""
    share = outside_share(runs, 80, 40, 0.3, tau, seed=2, model="components")
    assert share <= HOLDS, share
    if tau == 0.0:
        assert share >= 0.02, share
