"""The comparison of a saved detector's AUC on another campaign with the training campaign's test split
(ur5fault/health/diagnostics/transfer.py): the AUC against scikit-learn's, the motion resampling on data whose
answer is known."""

import math

import numpy as np
import pytest

pytest.importorskip("sklearn")
from sklearn.metrics import roc_auc_score  # noqa: E402

from ur5fault.health.diagnostics.transfer import (  # noqa: E402
    compare,
    group_bootstrap_auc,
    lines,
    rank_auc,
    subset_spread,
)


def test_auc_is_scikit_learns_with_ties():
    rng = np.random.default_rng(3)
    for n in (7, 60, 500):
        y = rng.random(n) < 0.4
        y[0], y[1] = True, False
        s = np.round(rng.normal(size=n) + y, 1)  # rounded: many ties across the classes
        assert rank_auc(y, s) == pytest.approx(roc_auc_score(y, s), abs=1e-12)
    assert math.isnan(rank_auc(np.ones(5, bool), np.arange(5.0)))
    # labels as 0/1 integers read as labels, not as indices (a bool-only ranking once gave 1.83 here)
    assert rank_auc(np.array([0, 1, 0, 1, 1]), np.array([0.1, 0.9, 0.2, 0.8, 0.7])) == 1.0
    with pytest.raises(ValueError, match="not finite"):
        rank_auc(np.array([0, 1]), np.array([0.1, np.nan]))


def runs(n_groups, rng, group_sd, shift=1.0, per_group=20):
    """Runs of ``n_groups`` motions: half faulty, score = shift x faulty + the motion's own offset on its faulty
    runs (what it shows of a fault) + run noise."""
    g = np.repeat(np.arange(n_groups), per_group)
    y = np.tile(np.arange(per_group) % 2 == 1, n_groups)
    shows = rng.normal(0.0, group_sd, n_groups)[g]
    return y, shift * y + shows * y + rng.normal(size=g.size), g


def test_resampling_whole_motions_widens_the_interval_when_motions_differ():
    rng = np.random.default_rng(0)
    y, s, g = runs(10, rng, group_sd=1.5)
    by_motion = group_bootstrap_auc(y, s, g, 400, np.random.default_rng(1))
    by_run = group_bootstrap_auc(y, s, np.arange(y.size), 400, np.random.default_rng(1))
    assert np.nanstd(by_motion) > 1.5 * np.nanstd(by_run)
    # perfectly separated scores: every resample reads 1
    assert np.all(group_bootstrap_auc(y, y + 0.0, g, 50, rng) == 1.0)


def test_same_family_covers_zero_a_worse_family_does_not():
    rng = np.random.default_rng(5)
    ref = runs(10, rng, group_sd=0.3)
    same = runs(40, rng, group_sd=0.3)
    t = compare(ref, same, seed=0, tolerance=0.03, n_boot=500)
    lo, hi = t["difference_interval"]
    assert lo < 0 < hi and t["n_groups_training_test_split"] == 10 and t["n_groups_other"] == 40
    worse = runs(40, rng, group_sd=0.3, shift=0.2)  # the fault barely shows on these motions
    w = compare(ref, worse, seed=0, tolerance=0.03, n_boot=500)
    assert w["difference_interval"][0] > 0.1 and w["share_within_tolerance"] < 0.01
    text = "\n".join(lines(w))
    assert "interval lies above the tolerance of 0.03" in text and "| 10 |" in text
    # 10 of 40 motions drawn without replacement: the spread over new motions is about 1 / sqrt(1 - 10/40) wider
    assert "from these 40 groups, so narrower than over new motions, by about 0.87" in text


def test_subset_spread():
    rng = np.random.default_rng(2)
    y, s, g = runs(12, rng, group_sd=1.0)
    sub = subset_spread(y, s, g, 4, 200, rng)
    assert sub["sd"] > 0 and sub["range_5_95"][0] < rank_auc(y, s) < sub["range_5_95"][1]
    assert sub["n_of"] == len(np.unique(g)) == 12
    assert math.isnan(subset_spread(y, s, g, 12, 10, rng)["sd"])  # as many motions as there are: no spread


def test_one_group_gives_no_interval_and_says_so():
    rng = np.random.default_rng(4)
    ref = runs(10, rng, group_sd=0.3)
    one = runs(1, rng, group_sd=0.3, per_group=40)  # a campaign of one fixed motion
    t = compare(ref, one, seed=0, tolerance=0.03, n_boot=200)
    assert math.isfinite(t["auc_other"]) and all(math.isnan(v) for v in t["auc_other_interval"])
    assert all(math.isnan(v) for v in t["difference_interval"]) and math.isnan(t["share_within_tolerance"])
    assert "There is no interval: a side holds fewer than two groups" in "\n".join(lines(t))
