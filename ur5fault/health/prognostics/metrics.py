"""Prognostic metrics on held-out units (Saxena et al. 2010, "Metrics for offline evaluation of
prognostic performance", Int. J. PHM 1(1)), computed from a table of predictions.

The table has one row per (unit, inspection) before failure: ``unit_id``, ``cycles``, ``eol_cycles``,
``rul_true`` and ``rul_est`` [cycles].  ``life_fraction = cycles / eol_cycles``.

* RMSE at life fraction p: per unit, the inspection whose life fraction is closest to p (the earlier
  on a tie); the root mean square of ``rul_est - rul_true`` over units.
* alpha-lambda accuracy: the share of units whose estimate at lambda (closest inspection) lies within
  ``(1 +- alpha) rul_true``.
* prognostic horizon: per unit, ``eol - cycles`` of the earliest inspection from which every later
  estimate lies within ``rul_true +- alpha * eol`` (0 when the last one does not).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

ALPHA = 0.2
LIFE_FRACTIONS = (0.25, 0.5, 0.75)
LAMBDA = 0.5


def at_fraction(pred: pd.DataFrame, p: float) -> pd.DataFrame:
    """Per unit, the row whose life fraction is closest to ``p`` (the earlier on a tie)."""
    d = pred.assign(_gap=(pred["cycles"] / pred["eol_cycles"] - p).abs()).sort_values(["unit_id", "_gap", "cycles"])
    return d.groupby("unit_id", sort=True).head(1).drop(columns="_gap")


def rmse_at(pred: pd.DataFrame, p: float) -> float:
    d = at_fraction(pred, p)
    return float(np.sqrt(np.mean((d["rul_est"] - d["rul_true"]) ** 2)))


def alpha_lambda_accuracy(pred: pd.DataFrame, alpha: float = ALPHA, lam: float = LAMBDA) -> float:
    d = at_fraction(pred, lam)
    return float(np.mean(np.abs(d["rul_est"] - d["rul_true"]) <= alpha * d["rul_true"]))


def prognostic_horizons(pred: pd.DataFrame, alpha: float = ALPHA) -> pd.Series:
    """Per unit, its prognostic horizon [cycles]."""
    out = {}
    for uid, d in pred.sort_values("cycles").groupby("unit_id"):
        inside = (np.abs(d["rul_est"] - d["rul_true"]) <= alpha * d["eol_cycles"]).to_numpy()
        ph = 0.0
        for k in range(len(d) - 1, -1, -1):
            if not inside[k]:
                break
            ph = float(d["eol_cycles"].iloc[k] - d["cycles"].iloc[k])
        out[uid] = ph
    return pd.Series(out, name="prognostic_horizon_cycles", dtype=float)


def summary(pred: pd.DataFrame, alpha: float = ALPHA) -> dict:
    ph = prognostic_horizons(pred, alpha)
    inside = (pred["rul_true"] >= pred["rul_lo"]) & (pred["rul_true"] <= pred["rul_hi"]) if "rul_lo" in pred else None
    return {
        "rmse_cycles": {f"{p:g}": rmse_at(pred, p) for p in LIFE_FRACTIONS},
        "alpha_lambda_accuracy": alpha_lambda_accuracy(pred, alpha),
        "prognostic_horizon_cycles_median": float(ph.median()) if len(ph) else float("nan"),
        "prognostic_horizon_fraction_median": float((ph / pred.groupby("unit_id")["eol_cycles"].first()).median())
        if len(ph) else float("nan"),
        "interval_coverage_90": float(inside.mean()) if inside is not None else float("nan"),
        "n_units": int(pred["unit_id"].nunique()),
    }
