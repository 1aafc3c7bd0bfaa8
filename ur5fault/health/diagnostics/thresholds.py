"""Backlash: the smallest clearance the detector finds on each joint, and the TCP deviation it
corresponds to, beside the seed paper's acceptability threshold (alpha = 0.1 deg keeps the TCP
within 0.5 mm on its pick-and-place).

Per joint, the test runs with backlash on that joint give (alpha, flagged at 5 % false alarms).
The detection probability is modelled as logistic in log alpha (maximum likelihood);
``alpha_90`` is where it reaches 90 %, with a bootstrap interval over those runs; it is not
extrapolated: outside the tested alphas only the bound is given (``alpha_90_bound``).  The empirical
figure beside it is the smallest tested alpha above which at least 90 % of the runs are flagged.

The TCP deviation at ``alpha_90`` comes from the backlash runs that have a simulated healthy twin
(train and test alike: physics, not learning): a power law ``tcp_dev_max_mm = c * alpha^s`` fitted
in log-log per joint (``s`` near 1 means proportional), evaluated at ``alpha_90`` with the 10 %,
50 % and 90 % quantiles of the residuals (the spread over the random motions and conditions).
``alpha_at_threshold_deg`` is the alpha whose median deviation reaches the campaign's threshold
(0.5 mm unless set).  Neither is extrapolated beyond 1.5x the simulated alpha range (NaN instead).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from ...seed_paper import PAPER_BACKLASH_DEG, PAPER_TCP_MM

DETECTION_PROBABILITY = 0.90
N_BOOTSTRAP = 200
MIN_RUNS = 6  # fewer runs on a joint: no fit
CROSSING_MIN_ALPHA_DEG = 0.2  # alpha/2 = 1.75 mrad: above the healthy span (95th percentile 0.43-1.08 mrad
#                               per joint in the diagnostics dataset), so a crossing is not mistaken for noise
EXTRAPOLATION = 1.5  # the TCP power law is evaluated at most this factor beyond the simulated alphas


def fit_logistic(log_alpha: np.ndarray, hit: np.ndarray, ridge: float = 1e-4) -> tuple[float, float] | None:
    """Maximum-likelihood ``(a, b)`` of P(hit) = 1 / (1 + exp(-(a + b log alpha))); None if every run or no
    run is a hit.  Newton-Raphson on the standardised input; a tiny ridge on the slope keeps perfectly
    separated runs finite (their fit is then a steep step between the two classes)."""
    if hit.all() or not hit.any():
        return None
    x = np.asarray(log_alpha, float)
    mu, sd = x.mean(), x.std() or 1.0
    z, y = (x - mu) / sd, hit.astype(float)
    w = np.zeros(2)
    design = np.stack([np.ones_like(z), z], axis=1)
    for _ in range(100):
        with np.errstate(over="ignore"):
            p = 1.0 / (1.0 + np.exp(-(design @ w)))
        grad = design.T @ (y - p) - np.array([0.0, ridge * w[1]])
        hess = design.T @ (design * (p * (1 - p))[:, None]) + np.diag([1e-12, ridge])
        step = np.linalg.solve(hess, grad)
        w += step
        if np.max(np.abs(step)) < 1e-10:
            break
    return float(w[0] - w[1] * mu / sd), float(w[1] / sd)


def alpha_at(p: float, ab: tuple[float, float] | None) -> float:
    """Alpha where the fitted probability reaches ``p`` (NaN if it never rises with alpha)."""
    if ab is None or ab[1] <= 0:
        return math.nan
    x = (math.log(p / (1 - p)) - ab[0]) / ab[1]
    return math.exp(min(x, 700.0)) if x < 700.0 else math.inf  # a nearly flat fit: never reached


def empirical_alpha(alpha: np.ndarray, hit: np.ndarray, p: float = DETECTION_PROBABILITY) -> float:
    """Smallest tested alpha such that at least ``p`` of the runs at or above it are flagged."""
    order = np.argsort(alpha)
    a, h = alpha[order], hit[order].astype(float)
    tail = np.cumsum(h[::-1])[::-1] / np.arange(len(h), 0, -1)
    ok = np.flatnonzero(tail >= p)
    return float(a[ok[0]]) if ok.size else math.nan


def backlash_thresholds(test: pd.DataFrame, detected: np.ndarray, everything: pd.DataFrame,
                        threshold_mm: float = PAPER_TCP_MM, seed: int = 0) -> dict[str, Any]:
    """Per joint: ``alpha_90`` (fit, bootstrap interval, empirical), the TCP deviation there, and the
    alpha at the TCP threshold.  ``everything``: all rows (for the TCP relation)."""
    rng = np.random.default_rng(seed)
    out: dict[str, Any] = {}
    bl = (test["fault"] == "backlash").to_numpy()
    for j in range(1, 7):
        on = bl & (test["fault_joint"] == j).to_numpy()
        alpha, hit = test.loc[on, "fault_size"].to_numpy(float), detected[on]
        res: dict[str, Any] = {"n_test": int(on.sum()), "alpha_tested_deg": [float(alpha.min()), float(alpha.max())]
                               if on.any() else [math.nan, math.nan], "detected": int(hit.sum())}
        a90 = lo = hi = math.nan
        if on.sum() >= MIN_RUNS:
            ab = fit_logistic(np.log(alpha), hit)
            a90 = alpha_at(DETECTION_PROBABILITY, ab)
            if (ab is None and hit.all()) or a90 < alpha.min():
                res["note"], res["alpha_90_bound"] = "below the smallest tested alpha", f"< {alpha.min():.3g}"
            elif ab is None or a90 > alpha.max() or not math.isfinite(a90):
                res["note"], res["alpha_90_bound"] = "not reached in the tested range", f"> {alpha.max():.3g}"
            if "alpha_90_bound" in res:
                a90 = math.nan  # not extrapolated beyond the simulated alphas
            boots = []
            for _ in range(N_BOOTSTRAP):
                k = rng.integers(0, len(alpha), len(alpha))
                boots.append(alpha_at(DETECTION_PROBABILITY, fit_logistic(np.log(alpha[k]), hit[k])))
            boots = np.array(boots)
            if np.isfinite(boots).mean() > 0.5:
                lo, hi = (float(v) for v in np.nanquantile(boots, [0.05, 0.95]))
                if lo > alpha.max():  # not extrapolated either: all of it above the tested alphas
                    lo, res["alpha_90_ci90_open_below"] = math.nan, f"> {alpha.max():.3g}"
                if hi > alpha.max():  # open above
                    hi, res["alpha_90_ci90_open_above"] = math.nan, f"> {alpha.max():.3g}"
                if lo < alpha.min():
                    lo, res["alpha_90_ci90_open_below"] = math.nan, f"< {alpha.min():.3g}"
        res.update({"alpha_90_deg": a90, "alpha_90_ci90_deg": [lo, hi],
                    "alpha_90_empirical_deg": empirical_alpha(alpha, hit) if on.any() else math.nan})
        res.update(_tcp_relation(everything, j, a90, threshold_mm))
        res.update(_crossing(test, everything, detected, j))
        out[str(j)] = res
    return {"detection_probability": DETECTION_PROBABILITY, "threshold_mm": threshold_mm,
            "paper": {"alpha_deg": PAPER_BACKLASH_DEG, "tcp_mm": PAPER_TCP_MM}, "per_joint": out}


def _crossing(test: pd.DataFrame, df: pd.DataFrame, detected: np.ndarray, joint: int) -> dict[str, Any]:
    """How often a large clearance is crossed at all, and how often the detector flags those runs.

    Crossing the gap moves the motor against the link by alpha (eq. (1)), so a run whose encoder mismatch
    spans less than half of alpha never crossed it (gravity kept one flank loaded).  Judged for
    alpha >= :data:`CROSSING_MIN_ALPHA_DEG`, where alpha/2 is well above the healthy mismatch span."""
    col = f"enc_mismatch_p2p_rad_j{joint}"
    if col not in df:
        return {}

    def crossed(rows: pd.DataFrame) -> np.ndarray:
        return (rows[col] >= 0.5 * np.radians(rows["fault_size"])).to_numpy()

    big = (df["fault"] == "backlash") & (df["fault_joint"] == joint) & (df["fault_size"] >= CROSSING_MIN_ALPHA_DEG)
    tb = ((test["fault"] == "backlash") & (test["fault_joint"] == joint)
          & (test["fault_size"] >= CROSSING_MIN_ALPHA_DEG)).to_numpy()
    cross_test = np.zeros(len(test), bool)
    cross_test[tb] = crossed(test[tb])
    return {
        "n_runs_alpha_ge_min": int(big.sum()),
        "share_crossed": float(crossed(df[big]).mean()) if big.any() else math.nan,
        "detection_rate_crossed_test": float(detected[cross_test].mean()) if cross_test.any() else math.nan,
        "n_test_crossed": int(cross_test.sum()),
    }


def _tcp_relation(df: pd.DataFrame, joint: int, a90: float, threshold_mm: float) -> dict[str, Any]:
    if "tcp_dev_max_mm" not in df:
        return {}
    sel = ((df["fault"] == "backlash") & (df["fault_joint"] == joint) & (df["status"] == "ok")
           & np.isfinite(df["tcp_dev_max_mm"]))
    alpha, dev = df.loc[sel, "fault_size"].to_numpy(float), df.loc[sel, "tcp_dev_max_mm"].to_numpy(float)
    if len(alpha) < MIN_RUNS or alpha.max() < 3 * alpha.min():
        return {"n_tcp_runs": int(len(alpha)), "tcp_note": "too few twin runs or too narrow an alpha range for a fit"}
    log_a, log_d = np.log(alpha), np.log(np.maximum(dev, 1e-9))
    slope, icpt = (float(v) for v in np.polyfit(log_a, log_d, 1))
    r10, r50, r90 = (float(v) for v in np.quantile(log_d - (icpt + slope * log_a), [0.1, 0.5, 0.9]))

    lo, hi = alpha.min() / EXTRAPOLATION, alpha.max() * EXTRAPOLATION

    def dev_at(a: float, r: float) -> float:
        return math.exp(icpt + slope * math.log(a) + r) if lo <= a <= hi else math.nan

    a_thr = math.exp(min((math.log(threshold_mm) - icpt - r50) / slope, 700.0)) if slope > 0 else math.nan
    bound = {"alpha_at_threshold_bound": f"> {hi:.3g}"} if not a_thr <= hi else {}
    return {
        **bound,
        "n_tcp_runs": int(len(alpha)),
        "tcp_power_law": {"mm_at_1deg": math.exp(icpt), "exponent": slope},
        "tcp_at_alpha_90_mm": {"p10": dev_at(a90, r10), "median": dev_at(a90, r50), "p90": dev_at(a90, r90)},
        "alpha_at_threshold_deg": a_thr if lo <= a_thr <= hi else math.nan,
        "alpha_twin_range_deg": [float(alpha.min()), float(alpha.max())],
    }
