"""Remaining-useful-life estimators fitted on the training units of a life campaign.

* :class:`HealthIndex`: the change of a unit's health features since its own first inspection (a
  robot knows what it measured when new), mapped linearly (ridge on standardised features) onto the
  failure criterion's value divided by its threshold, fitted on the training units; the failure level
  of the index is the median index of the training units at their failure (and their spread enters
  every RUL distribution).
* :class:`WienerRUL`: the index as a Wiener process with drift, ``HI(N) = theta N + sigma B(N)``:
  ``theta`` has a population prior (mean and spread of the training units' drifts) updated by the
  unit's own history (conjugate normal), ``sigma`` is pooled from the training units' increments.
  The RUL is the first passage of the failure level, an inverse Gaussian for a given theta and level;
  its distribution is drawn by Monte Carlo over the posterior of theta and the level's uncertainty,
  and rounded up to the unit's inspection grid, since the end of life is, by definition,
  the first inspection that finds the unit failed (median and 5-95 % interval).
* :class:`PopulationRUL`: the naive baseline: mean residual life of the training units that outlived
  the unit's current age, whatever its features say (its 5-95 % interval from the same units).

Only features a real robot can compute enter the index (no ``tcp_dev_*``, no true wear state).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..features import FEATURE_UNITS

#: ridge penalty on standardised features (assumption: a small penalty that only keeps the fit
#: well posed when features are collinear, as the per-joint mismatch features are)
RIDGE = 1e-2
#: quantiles of every interval the estimators report
Q_LO, Q_HI = 0.05, 0.95
#: Monte Carlo draws per RUL distribution (the median's sampling error is ~1 % of its spread at 2000)
N_DRAWS = 2000


def index_features(columns) -> list[str]:
    """Health features a real robot can compute: every feature but the twin-based ``tcp_dev_*`` and
    the TCP tracking error (a robot does not measure its true TCP)."""
    return [c for c in FEATURE_UNITS if c in columns and not c.startswith(("tcp_dev", "tcp_track"))]


def feature_changes(df: pd.DataFrame, cols: list[str]) -> pd.DataFrame:
    """Each inspection's features minus the same unit's inspection 0 (NaN features read as 0 change)."""
    x = df[cols].astype(float)
    first = x.groupby(df["unit_id"]).transform("first")
    return (x - first).fillna(0.0)


@dataclasses.dataclass
class HealthIndex:
    """Linear health index; ``fit`` on training inspections, ``transform`` any inspections."""

    criterion: str = "tcp_dev_max_mm"
    threshold: float = 0.5

    def fit(self, df: pd.DataFrame) -> HealthIndex:
        self.features_ = index_features(df.columns)
        x = feature_changes(df, self.features_).to_numpy()
        self.mean_, self.scale_ = x.mean(0), x.std(0)
        self.scale_[self.scale_ == 0] = 1.0
        z = (x - self.mean_) / self.scale_
        y = df[self.criterion].to_numpy(float) / self.threshold
        ok = np.isfinite(y)
        z1 = np.column_stack([z[ok], np.ones(ok.sum())])
        reg = RIDGE * np.eye(z1.shape[1])
        reg[-1, -1] = 0.0
        self.coef_ = np.linalg.solve(z1.T @ z1 + reg, z1.T @ y[ok])
        hi = self.transform(df)
        self.failure_level_ = 1.0
        self.residual_sd_ = float(np.std(hi[ok] - y[ok]))  # in-sample: a slight underestimate
        return self

    def transform(self, df: pd.DataFrame) -> NDArray:
        z = (feature_changes(df, self.features_).to_numpy() - self.mean_) / self.scale_
        return z @ self.coef_[:-1] + self.coef_[-1]


@dataclasses.dataclass
class WienerRUL:
    """Wiener-process RUL with a population prior on the drift; ``fit`` on training histories."""

    seed: int = 0

    def fit(self, cycles: list[NDArray], hi: list[NDArray], level: float = 1.0, level_sd: float = 0.0) -> WienerRUL:
        """``cycles``, ``hi``: per training unit, its inspections' cycles and health index; ``level``,
        ``level_sd``: the index's failure level and its uncertainty."""
        drifts, incr2 = [], []
        for n, h in zip(cycles, hi):
            if len(n) < 2:
                continue
            drifts.append((h[-1] - h[0]) / (n[-1] - n[0]))
            dn, dh = np.diff(n), np.diff(h)
            incr2.append((dh - drifts[-1] * dn) ** 2 / dn)
        self.level_, self.level_sd_ = float(level), float(level_sd)
        self.theta_mean_ = float(np.mean(drifts))
        self.theta_sd_ = float(np.std(drifts, ddof=1)) if len(drifts) > 1 else abs(self.theta_mean_)
        self.sigma2_ = float(np.mean(np.concatenate(incr2)))
        return self

    def posterior(self, n: NDArray, h: NDArray) -> tuple[float, float]:
        """Mean and sd of theta given a unit's history up to now (conjugate normal update)."""
        prec = 1.0 / self.theta_sd_**2 + (n[-1] - n[0]) / self.sigma2_
        mean = (self.theta_mean_ / self.theta_sd_**2 + (h[-1] - h[0]) / self.sigma2_) / prec
        return float(mean), float(prec**-0.5)

    def predict(self, n: NDArray, h: NDArray) -> tuple[float, float, float]:
        """(median, 5 %, 95 %) RUL [cycles] of a unit whose history is (n, h) up to now."""
        rng = np.random.default_rng([self.seed, len(n)])
        mean, sd = self.posterior(n, h)
        gap = self.level_ + self.level_sd_ * rng.standard_normal(N_DRAWS) - h[-1]
        if np.all(gap <= 0):
            return 0.0, 0.0, 0.0
        theta = mean + sd * rng.standard_normal(N_DRAWS)
        theta = np.maximum(theta, 1e-3 * abs(self.theta_mean_))  # a wear index does not heal: drift > 0
        gap = np.maximum(gap, 1e-12)
        t = rng.wald(gap / theta, gap**2 / self.sigma2_)
        step = n[-1] - n[-2] if len(n) > 1 else 0.0
        if step > 0:  # found failed at the first inspection on or after the crossing
            t = np.ceil(t / step) * step
        lo, med, hi = np.quantile(t, [Q_LO, 0.5, Q_HI])
        return float(med), float(lo), float(hi)


@dataclasses.dataclass
class PopulationRUL:
    """Naive baseline: residual life of the training units that outlived the current age."""

    def fit(self, eol_cycles: NDArray) -> PopulationRUL:
        self.eol_ = np.sort(np.asarray(eol_cycles, float))
        return self

    def predict(self, age: float) -> tuple[float, float, float]:
        alive = self.eol_[self.eol_ > age] - age
        if alive.size == 0:
            return 0.0, 0.0, 0.0
        lo, hi = np.quantile(alive, [Q_LO, Q_HI])
        return float(alive.mean()), float(lo), float(hi)
