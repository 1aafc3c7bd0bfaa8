"""The model's own drift as a nuisance (``discrepancy/drift.py``) and the per-joint budget of the forward search,
on synthetic linear problems (no simulation)."""

from __future__ import annotations

import numpy as np
import pytest
from stand_in_candidates import Col

from ur5fault.discrepancy.drift import Drift, bumps
from ur5fault.discrepancy.search import columns_of, forward, judge
from ur5fault.discrepancy.statistics import BlockGram

PERIOD_S = 0.008
N = 2500  # 20 s at 125 Hz, the screened part
SIGNALS = ("current_A", "position_rad")


def test_bumps_are_zero_mean_orthonormal_and_five_seconds_apart():
    B = bumps(N, PERIOD_S)
    assert B.shape == (N, 4)  # 5 bumps over 20 s, less the mean
    assert np.allclose(B.T @ B, np.eye(4), atol=1e-10)
    assert np.allclose(B.sum(axis=0), 0.0, atol=1e-10)
    assert bumps(200, PERIOD_S).shape[1] == 0  # 1.6 s: shorter than two knots, no drift


def test_a_constant_offset_survives_and_a_slow_drift_does_not():
    t = np.arange(N) * PERIOD_S
    d = Drift(N, PERIOD_S, SIGNALS)
    e = np.zeros((N, 12))
    e[:, 2] = 3.0                                        # an offset on the elbow's current
    slow = np.sin(2 * np.pi * t / 40.0)                  # a drift over the log (period twice its length) ...
    e[:, 3] = slow - slow.mean()                         # ... about its mean (the mean is an offset's)
    e[:, 8] = e[:, 3]                                    # the same on a position channel: not touched
    out = d.remove(e)
    assert np.allclose(out[:, 2], 3.0)
    # four degrees of freedom over 20 s: a half sine over the log is taken up to within 15 %
    assert np.sqrt(np.mean(out[:, 3] ** 2)) < 0.15 * np.sqrt(np.mean(e[:, 3] ** 2))
    assert np.allclose(out[:, 8], e[:, 8])


def test_a_logged_temperature_is_kept_out_of_the_drift():
    """A current that follows the joint's logged temperature is a dictionary term, not a nuisance."""
    t = np.arange(N + 1) * PERIOD_S
    temp = np.full((N + 1, 6), 30.0)
    temp[:, 4] += 2.0 * t / t[-1]  # wrist_2 warms by 2 K over the log
    d = Drift(N, PERIOD_S, SIGNALS, temp)
    e = np.zeros((N, 12))
    e[:, 4] = temp[1:, 4] - temp[1:, 4].mean()
    e[:, 5] = temp[1:, 4] - temp[1:, 4].mean()  # the same ramp on a joint whose temperature does not move
    out = d.remove(e)
    assert np.allclose(out[:, 4], e[:, 4], atol=1e-9)
    assert np.sqrt(np.mean(out[:, 5] ** 2)) < 0.1 * np.sqrt(np.mean(e[:, 5] ** 2))


def test_a_gain_is_stable_beside_the_drift_and_not_without_it():
    """A current gain (the residual goes with the current, which follows the motion at a few seconds' period)
    beside a slow drift of the model's own error: alone, its estimate varies between time blocks and fails the
    stability test; with the drift fitted beside it, it passes and its size is the injected one."""
    rng = np.random.default_rng(7)
    t = np.arange(N) * PERIOD_S
    current = 1.0 + 0.8 * np.sin(2 * np.pi * t / 2.5)         # the joint's current [A]: a motion every 2.5 s
    gain = 0.12
    drift = 0.6 * np.sin(2 * np.pi * t / 30.0 + 0.4)          # the model's own error, slower than the motion,
    drift -= drift.mean()                                      # about its mean (the mean is an offset's)
    e = np.zeros((N, 12))
    X = np.zeros((1, N, 12))
    X[0, :, 1] = current / 0.012                                 # weighted by the sensor's sigma
    e[:, 1] = (gain * current + 0.2 * drift) / 0.012 + rng.standard_normal(N)
    cands, cols = [Col("gain", 1)], columns_of([Col("gain", 1)])
    v_alone = judge(BlockGram.build(X, e), e, X, cands, cols, [], 0)
    assert not v_alone.stability.stable
    d = Drift(N, PERIOD_S, SIGNALS)
    Xd, ed = d.remove(X), d.remove(e)
    v = judge(BlockGram.build(Xd, ed), ed, Xd, cands, cols, [], 0)
    assert v.accepted, v.reason
    assert v.theta[0] == pytest.approx(gain, rel=0.05)


def test_one_joints_findings_do_not_use_up_anothers_budget():
    """Three strong offsets on joint 0 and a weaker one on joint 3: with a global budget of 3 the weak one is
    never reached; with 2 per joint it is named."""
    rng = np.random.default_rng(8)
    n = 3000
    X = rng.standard_normal((4, n, 6))
    sizes = np.array([3.0, 2.5, 2.0, 0.5])
    e = np.tensordot(sizes, X, axes=1) + rng.standard_normal((n, 6))
    cands = [Col("a", 0), Col("b", 0), Col("c", 0), Col("d", 3)]
    cols = columns_of(cands)
    bg = BlockGram.build(X, e)
    glob = forward(bg, e, X, cands, cols, 3)
    assert sorted(glob.chosen) == [0, 1, 2]
    per = forward(bg, e, X, cands, cols, 12, per_joint=2)
    assert sorted(per.chosen) == [0, 1, 3]
