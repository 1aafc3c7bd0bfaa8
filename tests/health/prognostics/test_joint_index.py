"""The per-joint health index against hand-built fleets whose answer is known."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ur5fault.health.prognostics.joint_index import JOINTS, JointHealthIndex
from ur5fault.health.prognostics.rul import WienerRUL

TRUTH = [f"backlash_deg_j{j}" for j in JOINTS] + ["tcp_dev_max_mm", "rul_cycles", "eol_cycles"]


def _fleet(rates: dict[str, tuple[float, float]], lever=(3.0, 5.0), n_insp=6, step=1000.0) -> pd.DataFrame:
    """Units whose joints 2 and 3 grow clearance linearly (deg per cycle); the feature of a joint is
    twice its clearance, every other joint reads nothing; criterion = 0.1 + 3 b2 + 5 b3 [mm / 0.5]."""
    rows = []
    for uid, (r2, r3) in rates.items():
        for k in range(n_insp):
            n = k * step
            row = {"unit_id": uid, "inspection": k, "cycles": n, "trajectory": "task"}
            for j in JOINTS:
                b = {2: r2 * n, 3: r3 * n}.get(j, 0.0)
                row[f"backlash_deg_j{j}"] = b
                row[f"enc_mismatch_hyst_rad_j{j}"] = 2.0 * b
            row["tcp_dev_max_mm"] = 0.5 * (0.1 + lever[0] * row["backlash_deg_j2"] + lever[1] * row["backlash_deg_j3"])
            row["eol_cycles"] = row["rul_cycles"] = np.nan  # truth a real fleet carries; never read here
            rows.append(row)
    return pd.DataFrame(rows)


def test_a_unit_led_by_the_other_joint_is_tracked_exactly():
    # training units: shoulder-led and elbow-led mixed; held-out unit: elbow only
    train = _fleet({"a": (1e-5, 2e-6), "b": (2e-6, 1e-5), "c": (5e-6, 5e-6)})
    test = _fleet({"t": (0.0, 1.5e-5)})
    hi = JointHealthIndex(ridge=1e-12).fit(train)
    # lever arms 3 and 5 per degree, by hand
    assert np.allclose(hi.lever_["task"][[1, 2]], [3.0, 5.0], rtol=1e-6)
    expect = 0.1 + 5.0 * 1.5e-5 * test["cycles"].to_numpy()
    assert np.allclose(hi.transform(test), expect, rtol=1e-6, atol=1e-9)


def test_transform_reads_no_truth_column():
    train = _fleet({"a": (1e-5, 2e-6), "b": (2e-6, 1e-5), "c": (5e-6, 5e-6)})
    test = _fleet({"t": (3e-6, 9e-6)})
    hi = JointHealthIndex(ridge=1e-12).fit(train)
    blind = test.drop(columns=TRUTH)  # by construction: nothing true left to read
    assert np.array_equal(hi.transform(blind), hi.transform(test))
    assert not set(hi.features_) & set(TRUTH)


def test_noiseless_linear_index_gives_the_exact_rul():
    # criterion crosses 1 at 0.1 + 5 * 1.4e-5 N = 1 -> N = 12,857 cycles; at 5,000 that is 7,857 cycles
    # ahead, found at the inspection 8,000 cycles on (1,000-cycle grid)
    train = _fleet({"a": (1e-5, 2e-6), "b": (2e-6, 1e-5), "c": (5e-6, 5e-6)}, n_insp=30)
    test = _fleet({"t": (0.0, 1.4e-5)})
    hi = JointHealthIndex(ridge=1e-12).fit(train)
    h = hi.transform(test)
    n = test["cycles"].to_numpy()
    # a Wiener model fitted with (almost) no diffusion and the unit's own drift: the median is the line
    w = WienerRUL().fit([n], [h])
    w.sigma2_, w.theta_mean_, w.theta_sd_ = 1e-20, 5.0 * 1.4e-5, 1e-12
    med, lo, hi_ = w.predict(n, h)
    assert med == lo == hi_ == 8000.0
