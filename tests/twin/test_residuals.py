"""The residual analysis of a replay (ur5fault/twin/residuals.py): masked RMS, the held-out part and the
operating conditions, against values worked out by hand."""

from __future__ import annotations

import numpy as np

from ur5fault.logs import MeasuredLog
from ur5fault.twin.residuals import conditions, held_out_mask, masked_rms, rms_table

PERIOD_S = 0.01


def _log(q: np.ndarray) -> MeasuredLog:
    n = q.shape[0]
    return MeasuredLog("synthetic", np.arange(n) * PERIOD_S, q, q, np.zeros((n, 6)))


def test_masked_rms_by_hand():
    x = np.zeros((4, 6))
    x[:, 0] = [3.0, 4.0, 100.0, 100.0]
    mask = np.zeros((4, 6), bool)
    mask[:2, 0] = True
    out = masked_rms(x, mask)
    assert out[0] == np.sqrt((9 + 16) / 2)
    assert np.all(np.isnan(out[1:]))  # no samples: NaN, not 0


def test_rms_table_names_signals_and_joints():
    meas = np.zeros((3, 2, 6))
    sim = np.zeros((3, 2, 6))
    sim[:, 1, 5] = [1.0, -1.0, 5.0]
    t = rms_table(("current_A", "position_rad"), meas, sim, slice(0, 2))
    assert t["position_rad"]["wrist_3_joint"] == 1.0
    assert t["current_A"]["shoulder_pan_joint"] == 0.0


def test_held_out_mask_is_the_last_part_of_the_log():
    m = held_out_mask(100, 0.6)
    assert m.shape == (100, 6)
    # 100 samples, the first 60 fitted: samples 61..100 (index 60..99) held out on every joint
    assert int(m[:, 0].sum()) == 40 and m[60:].all() and not m[:60].any()


def test_one_split_for_one_log_and_for_several():
    """The single-log workflow, the multi-log one and the held-out mask put the split at the same sample."""
    from ur5fault.twin.residuals import fit_samples

    assert fit_samples(100, 0.6) == 60 and fit_samples(7873, 0.6) == 4723 and fit_samples(1, 0.6) == 1
    assert int((~held_out_mask(7873, 0.6)[:, 0]).sum()) == fit_samples(7873, 0.6)


def test_conditions_rest_and_reversal():
    n = 200
    t = np.arange(n + 2) * PERIOD_S
    q = np.zeros((n + 2, 6))
    q[:, 0] = np.sin(2 * np.pi * t / (n * PERIOD_S))  # one period: reverses at a quarter and three quarters
    masks = conditions(_log(q), n, np.zeros((n, 6)))
    assert masks["at rest"][:, 1].all()  # joint 2 never moves
    assert not masks["at rest"][:, 0].any() or masks["at rest"][:, 0].sum() <= 2
    near = masks["near velocity reversals"][:, 0]
    # reversals at t = 0.5 s and 1.5 s: sample 50 and 150 (samples 1..n), windows of 0.25 s either side
    assert near[49] and near[149] and not near[100] and not near[5]
    assert not masks["near velocity reversals"][:, 1].any()
