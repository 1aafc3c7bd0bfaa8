"""The clearance-space RUL estimator on synthetic fleets whose true RUL is known in closed form."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from synthetic_wear import LEVER, STEP, linear_wear_fleet

from ur5fault.health.prognostics.clearance_rul import ClearanceRUL, line_rates
from ur5fault.health.prognostics.joint_index import JOINTS


def _at_half_life(est: ClearanceRUL, test: pd.DataFrame) -> pd.DataFrame:
    out = []
    for _, g in test.groupby("unit_id"):
        g = g.sort_values("cycles")
        k = int(np.argmin(np.abs(g["cycles"] / g["eol_cycles"] - 0.5)))
        a = est.clearances(g)
        med, lo, hi = est.predict("task", g["cycles"].to_numpy()[: k + 1], a[: k + 1])
        out.append({"true": g["rul_cycles"].iloc[k], "eol": g["eol_cycles"].iloc[0], "med": med, "lo": lo, "hi": hi})
    return pd.DataFrame(out)


def test_rul_of_a_linear_drift_with_known_noise_is_accurate_and_its_interval_covers():
    train, test = linear_wear_fleet(60, 0, "a"), linear_wear_fleet(40, 1, "t")
    est = ClearanceRUL(ridge=1e-8).fit(train)
    r = _at_half_life(est, test)
    # the boundary b2 + 5 b3 = 1 has radius 1 / (d2 + 5 d3) along a direction d: the kernel learns it
    # from 60 units (leave-one-out error of the log radius far below the spread of radii across units)
    d, logrho = est.units_["task"]
    assert est.loo_rmse_log_radius_[est.kappa_] < 0.3 * np.std(logrho)
    # at half-life the true RUL is N* - n within one inspection; the estimate errs by a few inspections
    # at most (the noise of 2e-3 deg on the features is ~5 % of the clearance at half-life)
    err = (r["med"] - r["true"]) / r["eol"]
    assert np.sqrt(np.mean(err**2)) < 0.05
    assert abs(err.mean()) < 0.02
    inside = (r["true"] >= r["lo"]) & (r["true"] <= r["hi"])
    assert 0.75 <= inside.mean() <= 1.0          # nominal 0.90 over 40 units
    assert ((r["hi"] - r["lo"]) / r["eol"]).median() < 0.3   # and not by being uninformative


def test_the_failure_radius_depends_on_the_direction_of_growth():
    # an elbow-led unit (b3 grows 2x faster) fails at a smaller clearance radius than a shoulder-led one,
    # because the elbow weighs 5 vs 1 in the boundary: 1 / (d2 + 5 d3)
    est = ClearanceRUL(ridge=1e-8).fit(linear_wear_fleet(60, 0, "a"))
    d_tr, logrho = est.units_["task"]
    for d in (np.array([0, 1, 2, 0, 0, 0]) / 5**0.5, np.array([0, 2, 1, 0, 0, 0]) / 5**0.5):
        expect = 1.0 / (LEVER[2] * d[1] + LEVER[3] * d[2])
        got = np.exp(est._log_radius(d_tr, logrho, d[None], est.kappa_)[0])
        assert got == pytest.approx(expect, rel=0.05)


def test_prediction_reads_no_truth_and_clearances_grow_from_zero():
    train, test = linear_wear_fleet(20, 0, "a"), linear_wear_fleet(3, 1, "t")
    est = ClearanceRUL(ridge=1e-8).fit(train)
    blind = test.drop(columns=[f"backlash_deg_j{j}" for j in JOINTS] + ["eol_cycles", "rul_cycles"])
    assert np.array_equal(est.clearances(blind), est.clearances(test))
    g = test[test["unit_id"] == "t000"]
    a = est.clearances(g)
    true_rate = line_rates(g["cycles"].to_numpy(), g[[f"backlash_deg_j{j}" for j in JOINTS]].to_numpy())
    assert line_rates(g["cycles"].to_numpy(), a)[1:3] == pytest.approx(true_rate[1:3], rel=0.05)


def test_a_sound_unit_past_the_boundary_fails_at_the_next_inspection_at_the_earliest():
    est = ClearanceRUL(ridge=1e-8).fit(linear_wear_fleet(20, 0, "a"))
    n = np.arange(0.0, 5 * STEP + 1, STEP)
    a = np.zeros((len(n), 6))
    a[:, 2] = n * 1e-3                   # 2.5 deg of elbow clearance at 2,500 cycles: far past 1 / 5
    assert est.predict("task", n, a) == (STEP, STEP, STEP)
