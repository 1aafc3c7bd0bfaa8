"""Prognostic metrics against hand-computed values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ur5fault.health.prognostics import metrics as M
from ur5fault.health.prognostics.rul import PopulationRUL, WienerRUL


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
    assert w.predict(n, np.array([0.0, 0.5, 0.9, 1.2])) == (0.0, 0.0, 0.0)   # past the failure level
