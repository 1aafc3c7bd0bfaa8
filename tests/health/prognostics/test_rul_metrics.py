"""Prognostic metrics against hand-computed values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ur5fault.health.prognostics import metrics as M
from ur5fault.health.prognostics.rul import HealthIndex, LinearRUL, PopulationRUL, TaskHealthIndex, WienerRUL


def _pred(rows):
    return pd.DataFrame(rows, columns=["unit_id", "cycles", "eol_cycles", "rul_true", "rul_est"])


# two units, eol 100 and 200, inspected every 25 / 50 cycles
PRED = _pred([
    ("a", 0, 100, 100, 150), ("a", 25, 100, 75, 80), ("a", 50, 100, 50, 55), ("a", 75, 100, 25, 40),
    ("b", 0, 200, 200, 100), ("b", 50, 200, 150, 150), ("b", 100, 200, 100, 130), ("b", 150, 200, 50, 45),
])


def test_rmse_at_life_fractions_by_hand():
    # 25 %: a errs +5 (80 vs 75), b errs 0 (150 vs 150): sqrt((25 + 0) / 2)
    assert M.rmse_at(PRED, 0.25) == pytest.approx(np.sqrt(12.5))
    # 50 %: a +5, b +30: sqrt((25 + 900) / 2)
    assert M.rmse_at(PRED, 0.5) == pytest.approx(np.sqrt(462.5))
    # 75 %: a +15, b -5
    assert M.rmse_at(PRED, 0.75) == pytest.approx(np.sqrt(125.0))


def test_alpha_lambda_accuracy_by_hand():
    # lambda 0.5: a 55 vs 50 (within 20 % of 50 = 10: yes), b 130 vs 100 (30 > 20: no)
    assert M.alpha_lambda_accuracy(PRED, 0.2, 0.5) == 0.5
    assert M.alpha_lambda_accuracy(PRED, 0.35, 0.5) == 1.0


def test_prognostic_horizon_by_hand():
    # bounds +-0.2 eol: a +-20: errors 50, 5, 5, 15 -> inside from cycle 25: PH = 100 - 25 = 75
    # b +-40: errors -100, 0, 30, -5 -> inside from cycle 50: PH = 200 - 50 = 150
    ph = M.prognostic_horizons(PRED, 0.2)
    assert ph["a"] == 75 and ph["b"] == 150
    # a unit whose last estimate is outside has no horizon
    bad = _pred([("c", 0, 100, 100, 100), ("c", 50, 100, 50, 90)])
    assert M.prognostic_horizons(bad, 0.2)["c"] == 0.0


def test_tie_in_life_fraction_takes_the_earlier_inspection():
    p = _pred([("a", 40, 100, 60, 0), ("a", 60, 100, 40, 40)])
    assert M.at_fraction(p, 0.5)["cycles"].tolist() == [40]


def test_population_rul_is_the_mean_residual_life_of_the_survivors():
    naive = PopulationRUL().fit(np.array([100.0, 200.0, 300.0]))
    assert naive.predict(150.0)[0] == pytest.approx(100.0)   # (50 + 150) / 2
    assert naive.predict(0.0)[0] == pytest.approx(200.0)
    assert naive.predict(400.0) == (0.0, 0.0, 0.0)


def test_wiener_posterior_by_hand_and_median_near_gap_over_drift():
    w = WienerRUL(seed=0)
    w.level_, w.level_sd_, w.theta_mean_, w.theta_sd_, w.sigma2_ = 1.0, 0.0, 0.01, 0.002, 1e-4
    n, h = np.array([0.0, 10.0, 20.0, 30.0]), np.array([0.0, 0.1, 0.25, 0.36])
    # precision 1/0.002^2 + 30/1e-4 = 250000 + 300000; mean (0.01 x 250000 + 0.36 / 1e-4) / 550000
    mean, sd = w.posterior(n, h)
    assert mean == pytest.approx((0.01 * 250000 + 3600) / 550000)
    assert sd == pytest.approx(550000**-0.5)
    med, lo, hi = w.predict(n, h)
    assert lo < med < hi
    # inverse-Gaussian median ~ its mean for a small diffusion, rounded up to the 10-cycle inspection grid
    assert med == pytest.approx(np.ceil(0.64 / mean / 10) * 10, abs=10)
    # past the failure level but found sound now: it fails at the next inspection at the earliest
    assert w.predict(n, np.array([0.0, 0.5, 0.9, 1.2])) == (10.0, 10.0, 10.0)


def _noiseless_training():
    """Three failed units on a 10-cycle grid whose index is exactly n / c, c = 95, 145, 195: each crosses 1
    in the middle of its last interval (found failed at 100, 150, 200)."""
    cycles = [np.arange(0.0, eol + 1, 10.0) for eol in (100.0, 150.0, 200.0)]
    return cycles, [n / c for n, c in zip(cycles, (95.0, 145.0, 195.0))]


def test_linear_rul_of_a_noiseless_linear_index_is_exact():
    lin = LinearRUL(seed=0).fit(*_noiseless_training())
    # every training trend was at 1 in the middle of its failure interval; nothing random is left
    assert lin.level_ == pytest.approx(1.0) and lin.level_sd_ == pytest.approx(0.0, abs=1e-12)
    assert lin.meas_var_ == pytest.approx(0.0, abs=1e-20) and lin.proc_var_ == pytest.approx(0.0, abs=1e-20)
    assert lin.prior_mean_[1] == pytest.approx(np.mean([1 / 95, 1 / 145, 1 / 195]))
    # a held-out unit with index n / 125, seen to cycle 60: its trend crosses 1 at 125, 65 cycles from now,
    # found failed at the first inspection after it: 130, a RUL of 70 (whatever the prior says)
    n = np.arange(0.0, 61.0, 10.0)
    assert lin.predict(n, n / 125.0) == pytest.approx((70.0, 70.0, 70.0))
    mean, cov = lin.posterior(n, n / 125.0)
    assert mean[1] == pytest.approx(1 / 125, rel=1e-6) and cov[1, 1] ** 0.5 < 1e-3 / 125
    # the trend already at the level, the unit still sound: the next inspection
    assert lin.predict(n, n / 55.0) == pytest.approx((10.0, 10.0, 10.0))


def test_linear_rul_starts_from_the_trend_not_the_last_noisy_value():
    lin = LinearRUL(seed=0).fit(*_noiseless_training())
    lin.meas_var_ = 0.01**2                     # a measured index: the same line with an error
    n = np.arange(0.0, 61.0, 10.0)
    h = n / 125.0
    h[-1] += 0.05                                # one high reading (5 sd): the trend hardly moves
    med = lin.predict(n, h)[0]
    assert med == pytest.approx(70.0, abs=10.0)
    w = WienerRUL(seed=0)                        # from the last value: that reading takes 0.05 x 125 cycles off
    w.level_, w.level_sd_, w.theta_mean_, w.theta_sd_, w.sigma2_ = 1.0, 0.0, 1 / 125, 1e-9, 1e-12
    assert w.predict(n, h)[0] == pytest.approx(60.0)


def test_health_index_per_task_maps_each_task_onto_the_criterion():
    # two tasks whose feature grows at 2 and 0.5 x the criterion: one pooled line fits neither, one per task both
    rows = []
    for u in range(8):
        task, gain = ("A", 2.0) if u < 4 else ("B", 0.5)
        for k in range(5):
            y = 0.1 * k * (1 + 0.1 * u)
            rows.append({"unit_id": f"u{u}", "trajectory": task, "tcp_dev_max_mm": 0.5 * y,
                         "enc_mismatch_hyst_rad_j2": gain * y})
    df = pd.DataFrame(rows)
    y = df["tcp_dev_max_mm"] / 0.5
    per_task = TaskHealthIndex().fit(df)
    assert sorted(per_task.by_task_) == ["A", "B"]
    assert np.abs(per_task.transform(df) - y).max() < 0.01
    assert np.abs(HealthIndex().fit(df).transform(df) - y).max() > 0.1
    few = TaskHealthIndex().fit(df[df["unit_id"].isin(["u0", "u1", "u4", "u5", "u6"])])   # A has 2 units only
    assert sorted(few.by_task_) == ["B"]
