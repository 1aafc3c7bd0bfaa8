"""The effective number of independent blocks (ur5fault/health/monitoring/effective.py) against hand-computed
values: a sequence's autocorrelation, a run offset that makes every block of a run one, an AR(1) sequence's known
design effect, and the variance's bias correction."""

import numpy as np
import pytest

from ur5fault.health.monitoring.effective import autocorrelation, design_effect, effective


def test_the_autocorrelation_of_an_alternating_sequence():
    # x = 1, -1, 1, -1 about 0: lag sums 4, -3, 2, -1 over the lag-0 sum 4
    np.testing.assert_allclose(autocorrelation([np.array([1.0, -1.0, 1.0, -1.0])], 0.0), [1.0, -0.75, 0.5, -0.25])
    # pooled over two sequences, lags only within each: (1, 1) and (2,) about 0 -> lag 0: 1 + 1 + 4, lag 1: 1
    np.testing.assert_allclose(autocorrelation([np.array([1.0, 1.0]), np.array([2.0])], 0.0), [1.0, 1 / 6])


def test_a_negative_correlation_buys_no_blocks_and_the_lags_within_a_stretch_always_count():
    alt = [np.array([1.0, -1.0, 1.0, -1.0])]
    assert design_effect(alt, 0.0) == 1.0  # rho_1 + rho_2 = -0.25: Geyer stops at once, DE floored at 1
    # min_lag 2: rho_1 clipped to 0, then the pair rho_2 + rho_3 = 0.25 counts: 1 + 2 x 0.25
    assert design_effect(alt, 0.0, min_lag=2) == pytest.approx(1.5)
    with pytest.raises(ValueError):
        design_effect(alt, 0.0, min_lag=0)


def test_runs_that_each_sit_apart_are_worth_one_block_each():
    """Two runs of 10 blocks, every block of one at +1 and of the other at -1 about the mean 0: rho_l =
    (10 - l) / 10, Geyer's pairs 1.7, 1.3, 0.9, 0.5, 0.1 sum to 4.5, DE = 1 + 9 = 10, and the 20 blocks are
    worth 2: the runs."""
    seqs = [np.ones(10), -np.ones(10)]
    de = design_effect(seqs, 0.0)
    assert de == pytest.approx(10.0)
    var = float(np.concatenate(seqs).var(ddof=1))
    got = effective(var, 20, de)
    assert got is not None
    assert got[1] == pytest.approx(2.0)
    assert got[0] == pytest.approx(var * 19 / 10)
    assert effective(var, 20, 10.5) is None  # worth under 2: no variance


def test_an_ar1_sequences_design_effect():
    """AR(1) with coefficient 0.5: the variance of its mean is (1 + 0.5) / (1 - 0.5) = 3 times that of
    independent samples."""
    rng = np.random.default_rng(3)
    x = np.zeros(20_000)
    for i in range(1, x.size):
        x[i] = 0.5 * x[i - 1] + rng.normal()
    assert design_effect([x], 0.0) == pytest.approx(3.0, rel=0.1)
    # white noise: about 1
    assert design_effect([rng.normal(size=20_000)], 0.0) == pytest.approx(1.0, abs=0.1)


def test_the_design_effect_of_runs_as_clusters():
    """Hand-computed (effective.cluster_design_effect): runs (1, 1), (-1, -1), (0, 0, 0, 0) about 0, their blocks'
    sample variance 4/7: the pooled mean's variance from the runs' means (4 + 4 + 0) x 3 / (2 x 64) = 0.1875,
    A = 0.1875 x 8 / (4/7 x 7) = 0.375, DE = 0.375 x 8 / 1.375 = 24/11. Two runs each at their mean: k / R,
    as the autocorrelation gives (above). One run tells nothing: 1. The run design effect is the larger."""
    from ur5fault.health.monitoring.effective import cluster_design_effect, run_design_effect

    seqs = [np.ones(2), -np.ones(2), np.zeros(4)]
    var = float(np.concatenate(seqs).var(ddof=1))
    assert var == pytest.approx(4 / 7)
    assert cluster_design_effect(seqs, 0.0, var) == pytest.approx(24 / 11)
    two = [np.ones(10), -np.ones(10)]
    assert cluster_design_effect(two, 0.0, float(np.concatenate(two).var(ddof=1))) == pytest.approx(10.0)
    assert cluster_design_effect([np.arange(5.0)], 2.0, 2.5) == 1.0
    assert cluster_design_effect(seqs, 0.0, 0.0) == 1.0
    assert run_design_effect(seqs, 0.0, var) == pytest.approx(max(24 / 11, design_effect(seqs, 0.0)))
