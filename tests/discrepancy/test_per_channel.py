"""Each channel its own variance (``weighting.per_channel``): a one-joint effect is judged against its own
joint's unexplained variance, not against residual energy pooled over every channel.  Synthetic linear
problems, no simulation."""

from __future__ import annotations

import numpy as np
import pytest
from stand_in_candidates import Offset

from ur5fault.discrepancy import DiscrepancyModel, joint_check
from ur5fault.discrepancy.search import columns_of, forward, judge
from ur5fault.discrepancy.statistics import BlockGram, bic, effective_n, rss_of
from ur5fault.discrepancy.weighting import channel_scale, per_channel
from ur5fault.errors import ParameterError

N = 2500  # 20 s at 125 Hz, the screened part of a log


def two_joints(error_sigma: float, offset_sigma: float, seed: int = 7):
    """Weighted residual of two joints' currents ``(N, 2)``: unit sensor noise on both; on joint 0 a smooth,
    zero-mean model error of ``error_sigma`` RMS that no candidate explains; on joint 1 a constant offset
    of ``offset_sigma`` sensor sigmas.  Columns: an offset on each joint ``(2, N, 2)``."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / 125.0
    err = sum(np.sin(2 * np.pi * f * t + ph) for f, ph in ((0.07, 0.3), (0.19, 1.1), (0.41, 2.0)))
    err -= err.mean()
    err *= error_sigma / np.sqrt(np.mean(err**2))
    e = rng.standard_normal((N, 2))
    e[:, 0] += err
    e[:, 1] += offset_sigma
    X = np.zeros((2, N, 2))
    X[0, :, 0] = X[1, :, 1] = 1.0
    return X, e, [Offset(0), Offset(1)]


def test_the_offset_beside_a_large_model_error_is_named_per_channel_not_pooled():
    """A 5-sigma offset on a quiet joint beside a 100-sigma model error on another (the Kufieta J1-J3
    currents carry 70-160 sigma): pooled, its improvement is 25/10 026 of the residual energy and its delta
    BIC about +2, so nothing is named; each channel with its own variance, the offset is named, at its size."""
    X, e, cands = two_joints(error_sigma=100.0, offset_sigma=5.0)
    cols = columns_of(cands)
    pooled = forward(BlockGram.build(X, e), e, X, cands, cols, 2)
    assert pooled.chosen == []
    v = judge(BlockGram.build(X, e), e, X, cands, cols, [], 1)
    assert v.delta_bic > -10 and v.z > 100  # z and stability pass: only the pooled likelihood fails it
    X_w, e_w, s = per_channel(X, e, own_variance=True)
    sel = forward(BlockGram.build(X_w, e_w), e_w, X_w, cands, cols, 2)
    assert sel.chosen == [1]
    assert sel.verdicts[0].theta[0] == pytest.approx(5.0, abs=0.1)
    # the workflow's joint check of the findings (joint_check.joint_check) now keeps the offset and drops nothing
    # else wrongly: the error on joint 0 is explained by no candidate, so its offset (fitting the mean of a
    # zero-mean error) is not named either
    check = joint_check.joint_check(cands, X, [0, 1], e, own_variance=True)
    assert check.found == [cands[1]]
    assert joint_check.joint_check(cands, X, [0, 1], e, own_variance=False).found == []  # the pooled form


def test_the_likelihood_is_a_validated_choice():
    assert DiscrepancyModel().likelihood == "pooled"  # measured no better on real logs (docs/discrepancy.md)
    assert DiscrepancyModel(likelihood="per_channel").likelihood == "per_channel"
    with pytest.raises(ParameterError, match="likelihood = 'channel' is not valid; choose one of: per_channel, "
                                             "per_condition, pooled"):
        DiscrepancyModel(likelihood="channel")


def test_channel_scale_is_the_long_run_standard_deviation_floored_at_the_noise():
    rng = np.random.default_rng(3)
    white = rng.standard_normal((N, 1))
    assert channel_scale(white)[0] == pytest.approx(1.0, abs=0.05)
    assert channel_scale(0.2 * white)[0] == 1.0  # never trusted beyond the sensor's noise
    assert channel_scale(10.0 * white)[0] == pytest.approx(10.0, rel=0.05)
    # AR(1), rho 0.8: variance 1, long-run variance (1 + rho) / (1 - rho) = 9
    a = np.empty(20 * N)
    w = rng.standard_normal(20 * N)
    a[0] = w[0]
    for i in range(1, len(a)):
        a[i] = 0.8 * a[i - 1] + 0.6 * w[i]
    assert channel_scale(4.0 * a[:, None])[0] == pytest.approx(12.0, rel=0.1)


def test_the_pooled_criterion_of_the_rescaled_problem_is_the_per_channel_one_to_first_order():
    """For a small improvement the delta BIC of the rescaled (pooled) problem equals the per-channel Gaussian
    likelihood's ``sum_c n_c log(RSS1_c / RSS0_c)`` (module docstring of statistics.py), computed here from
    each channel's own sums, not by the code under test."""
    rng = np.random.default_rng(5)
    e = rng.standard_normal((N, 3)) * np.array([1.0, 4.0, 30.0])
    X = rng.standard_normal((1, N, 3)) * np.array([0.02, 0.05, 0.3])
    e = e + 6.0 * X[0]
    X_w, e_w, _ = per_channel(X, e, own_variance=True)
    G, g, ee = BlockGram.build(X_w, e_w).total()
    rss1, th = rss_of(G, g, ee, [0])
    res_w = e_w - th[0] * X_w[0]
    pooled = bic(rss1, effective_n(res_w), 0) - bic(ee, effective_n(res_w), 0)
    res = e - th[0] * X[0]  # the same fit in the original channels
    n_c = np.array([effective_n(res[:, [c]]) for c in range(3)])
    exact = float(np.sum(n_c * np.log(np.sum(res**2, axis=0) / np.sum(e**2, axis=0))))
    assert exact < -20  # an improvement that matters
    assert pooled == pytest.approx(exact, rel=0.01)
