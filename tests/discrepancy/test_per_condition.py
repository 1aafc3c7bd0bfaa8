"""Each channel its own variance at rest and in motion (``weighting.VarianceGroups``, ``group_scale``): a constant
on a joint's current is estimated where the model's own error (friction, inertia: motion) is small, not judged
against the error in motion.  Synthetic linear problems, no simulation; expected values computed by hand."""

from __future__ import annotations

import numpy as np
import pytest
from stand_in_candidates import Offset

from ur5fault.discrepancy import DiscrepancyModel
from ur5fault.discrepancy.search import columns_of, judge
from ur5fault.discrepancy.statistics import BlockGram
from ur5fault.discrepancy.weighting import VarianceGroups, group_scale, per_channel
from ur5fault.errors import ParameterError

N = 2500  # 20 s at 125 Hz, the screened part of a log


def test_group_scale_is_each_groups_own_scale_and_the_channels_for_a_small_group():
    # 200 samples of +-1 then 200 of +-3 (alternating: lag-1 autocorrelation clipped to 0, so n_c = n)
    e = np.where(np.arange(400) % 2 == 0, 1.0, -1.0)[:, None] * np.where(np.arange(400) < 200, 1.0, 3.0)[:, None]
    labels = (np.arange(400) >= 200).astype(int)[:, None]
    s = group_scale(e, labels)
    assert s.shape == (400, 1)
    assert np.allclose(s[:200], 1.0) and np.allclose(s[200:], 3.0)
    # a group of 10 samples (< 25 effective ones) takes the channel's scale: sqrt((390 x 1 + 10 x 9) / 400)
    e2 = np.where(np.arange(400) % 2 == 0, 1.0, -1.0)[:, None] * np.where(np.arange(400) < 390, 1.0, 3.0)[:, None]
    s2 = group_scale(e2, (np.arange(400) >= 390).astype(int)[:, None])
    assert np.allclose(s2[390:], np.sqrt(480.0 / 400.0)) and np.allclose(s2[:390], 1.0)
    # never below the sensor's noise
    assert np.allclose(group_scale(0.1 * e, labels), 1.0)


def test_variance_groups_are_validated():
    with pytest.raises(ValueError, match="must be"):
        VarianceGroups(np.zeros(5))
    with pytest.raises(ValueError, match="applied to"):
        VarianceGroups(np.zeros((5, 2))).of(6, 2)


def rest_and_motion(offset: float, error_sigma: float, seed: int = 11):
    """One joint's weighted current residual ``(N, 1)``: at rest (every other second) unit sensor noise, in motion
    a smooth zero-mean model error of ``error_sigma`` RMS on top; a constant ``offset`` throughout.  The offset's
    column ``(1, N, 1)`` and the rest labels."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / 125.0
    moving = (np.floor(t) % 2).astype(bool)
    err = sum(np.sin(2 * np.pi * f * t + ph) for f, ph in ((0.11, 0.4), (0.23, 1.3), (0.53, 2.2)))
    err = np.where(moving, err, 0.0)
    err *= error_sigma / np.sqrt(np.mean(err[moving] ** 2))
    err[moving] -= err[moving].mean()
    e = (rng.standard_normal(N) + err + offset)[:, None]
    return np.ones((1, N, 1)), e, (~moving).astype(int)[:, None]


def test_an_offset_beside_a_model_error_in_motion_is_named_from_the_samples_at_rest():
    """A 3-sigma offset beside a 30-sigma model error that acts in motion only (the Kufieta J1-J3 currents carry
    tens of sigma in motion): one variance per channel judges the constant against the moving samples' spread
    (block jackknife of the mean), so its z is small; with its own variance at rest, the rest samples carry it,
    and it is named at its size (to about 1/sqrt(1250) sigma)."""
    X, e, rest = rest_and_motion(offset=3.0, error_sigma=30.0)
    cands, cols = [Offset()], columns_of([Offset()])
    X1, e1, _ = per_channel(X, e, own_variance=True)
    one = judge(BlockGram.build(X1, e1), e1, X1, cands, cols, [], 0)
    assert not one.accepted and one.z < 4.0
    Xg, eg, s = per_channel(X, e, own_variance=VarianceGroups(rest))
    both = judge(BlockGram.build(Xg, eg), eg, Xg, cands, cols, [], 0)
    assert both.accepted
    assert both.theta[0] == pytest.approx(3.0, abs=0.15)
    assert s[rest[:, 0] == 1].max() < 1.2 and s[rest[:, 0] == 0].min() > 20.0


def test_the_likelihood_per_condition_is_a_choice():
    assert DiscrepancyModel(likelihood="per_condition").likelihood == "per_condition"
    with pytest.raises(ParameterError, match="choose one of: per_channel, per_condition, pooled"):
        DiscrepancyModel(likelihood="rest")


def test_the_drift_removed_in_the_weighted_metric_is_the_joint_weighted_fit_with_it():
    """Frisch-Waugh-Lovell in the weighted metric: an offset's weighted least-squares estimate beside the drift, from
    the residual and column with the drift removed unweighted and then again weighted (``Drift.remove_weighted``),
    equals the estimate of one weighted regression on the offset and the drift's basis together (numpy's lstsq)."""
    from ur5fault.discrepancy.drift import Drift

    n, period = 2500, 0.008
    d = Drift(n, period, ("current_A", "position_rad"))
    rng = np.random.default_rng(2)
    t = np.arange(n) * period
    e = rng.standard_normal((n, 12))
    e[:, 3] += 0.7 + 5.0 * np.sin(2 * np.pi * 0.05 * t)  # joint 3's current: an offset and a slow drift
    X = np.zeros((1, n, 12))
    X[0, :, 3] = 1.0
    s = np.ones((n, 12))
    s[:, 3] = np.where(np.floor(t) % 2 == 0, 1.0, 8.0)  # a scale that varies from sample to sample
    Xw = d.remove_weighted(d.remove(X) / s, s)
    ew = d.remove_weighted(d.remove(e) / s, s)
    fwl = float(np.sum(Xw[0, :, 3] * ew[:, 3]) / np.sum(Xw[0, :, 3] ** 2))
    B = d.bases[3]
    design = np.column_stack([1.0 / s[:, 3], B / s[:, 3][:, None]])
    joint = np.linalg.lstsq(design, e[:, 3] / s[:, 3], rcond=None)[0][0]
    assert B.shape[1] >= 3
    assert fwl == pytest.approx(joint, rel=1e-9)
    assert abs(joint - 0.7) < 0.2
    # without the weighted projection (drift removed unweighted, then weighted) the estimate is another one
    naive = d.remove(X) / s, d.remove(e) / s
    other = float(np.sum(naive[0][0, :, 3] * naive[1][:, 3]) / np.sum(naive[0][0, :, 3] ** 2))
    assert abs(other - joint) > 1e-3

