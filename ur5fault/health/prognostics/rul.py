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
* :class:`LinearRUL`: the same index as a linear trend measured with error plus a Wiener term, the
  trend's intercept and slope with a population prior updated by the unit's history; the RUL is the
  first passage from the fitted trend, not from the last (noisy) index value.
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


#: fewest training units of a task for the index to be fitted on that task alone (assumption: fewer
#: cannot pin a slope per feature; such a task's units take the index fitted on the whole fleet)
MIN_TASK_UNITS = 3


@dataclasses.dataclass
class TaskHealthIndex:
    """One :class:`HealthIndex` per duty task (the ``trajectory`` column: a robot knows the program it
    runs): the features' sensitivity to the clearance depends on the motion, so one linear map across
    tasks errs per unit by how its task differs from the fleet's average (on the 100-unit fleet: the
    held-out units' index slope / criterion slope scatters by 12 % pooled, 7 % per task).  Tasks with
    fewer than :data:`MIN_TASK_UNITS` training units use the pooled index."""

    criterion: str = "tcp_dev_max_mm"
    threshold: float = 0.5

    def fit(self, df: pd.DataFrame) -> TaskHealthIndex:
        self.pooled_ = HealthIndex(self.criterion, self.threshold).fit(df)
        self.by_task_: dict[str, HealthIndex] = {}
        if "trajectory" in df.columns:
            for task, g in df.groupby("trajectory"):
                if g["unit_id"].nunique() >= MIN_TASK_UNITS:
                    self.by_task_[str(task)] = HealthIndex(self.criterion, self.threshold).fit(g)
        self.features_ = self.pooled_.features_
        self.coef_ = self.pooled_.coef_
        self.failure_level_ = 1.0
        y = df[self.criterion].to_numpy(float) / self.threshold
        ok = np.isfinite(y)
        self.residual_sd_ = float(np.std(self.transform(df)[ok] - y[ok]))  # in-sample
        return self

    def transform(self, df: pd.DataFrame) -> NDArray:
        out = self.pooled_.transform(df)
        if "trajectory" in df.columns:
            for task, g in df.groupby("trajectory"):
                if str(task) in self.by_task_:
                    out[df.index.get_indexer(g.index)] = self.by_task_[str(task)].transform(g)
        return out


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
        theta = mean + sd * rng.standard_normal(N_DRAWS)
        theta = np.maximum(theta, 1e-3 * abs(self.theta_mean_))  # a wear index does not heal: drift > 0
        t = np.zeros(N_DRAWS)
        ahead = gap > 0
        t[ahead] = rng.wald(gap[ahead] / theta[ahead], gap[ahead] ** 2 / self.sigma2_)
        # found failed at the first inspection on or after the crossing, at the earliest the next one
        t = grid_rul(t, n[-1] - n[-2] if len(n) > 1 else 0.0)
        lo, med, hi = np.quantile(t, [Q_LO, 0.5, Q_HI])
        return float(med), float(lo), float(hi)


def grid_rul(t: NDArray, step: float) -> NDArray:
    """Crossing times ``t`` [cycles from now] as the unit's RUL on its inspection grid: the end of life is
    the first inspection on or after the crossing, and at least the next one (the unit is sound now)."""
    if step <= 0:
        return np.maximum(t, 0.0)
    return np.maximum(np.ceil(t / step), 1.0) * step


@dataclasses.dataclass
class LinearRUL:
    """Linear degradation with a population prior, updated by the unit's history (Bayesian linear
    regression, as Gebraeel et al., IIE Trans. 37 (2005) 543-557), measured with error, and a Wiener
    term for the randomness still to come (Ye, Wang, Tsui & Pecht, IEEE Trans. Rel. 62 (2013) 772-780).

    ``HI_k = a + theta N_k + e_k`` (e: the index's measurement error, independent between inspections,
    sd ``meas_sd``) plus a Wiener process of variance ``proc_var`` per cycle: what the trend has not
    reached yet may still arrive early or late.  The prior of (a, theta) is the mean and covariance of the
    training units' least-squares lines; ``meas_sd`` is the pooled lag-1 autocovariance of their
    detrended increments (a measurement error makes consecutive increments anticorrelated by
    ``-meas_sd**2``; a Wiener process does not), ``proc_var`` the rest of the increments' variance.
    The failure level is not the criterion's 1 but what the training units' trends had reached when they
    failed (mean and spread): the criterion of some units jumps in the last interval before failure (8 of
    100 on the default fleet), where a trend extrapolated to 1 comes late.
    The RUL is the first passage of the level from the posterior's current trend value, drawn over the
    posterior of (a, theta), rounded up to the inspection grid (median and 5-95 % interval).  The
    update weighs a history's points as independent with variance ``meas_sd**2 + proc_var * interval``
    (an approximation: the Wiener part is correlated along a path).
    """

    seed: int = 0

    def fit(self, cycles: list[NDArray], hi: list[NDArray]) -> LinearRUL:
        """``cycles``, ``hi``: per failed training unit, its inspections' cycles and index, the last one the
        inspection that found it failed."""
        lines, levels, d_all, lag1, dn_all = [], [], [], [], []
        for n_all, h_all in zip(cycles, hi):
            n, h = n_all[:-1], h_all[:-1]  # the trend before failure
            if len(n) < 3:
                continue
            theta, a = np.polyfit(n, h, 1)
            lines.append((a, theta))
            # the trend's value where the unit failed: somewhere in the last interval, its middle expected
            levels.append(a + theta * (n_all[-1] - (n_all[-1] - n[-1]) / 2))
            d = np.diff(h) - theta * np.diff(n)
            d_all.append(d**2)
            dn_all.append(np.diff(n))
            lag1.append(d[1:] * d[:-1])
        if len(lines) < 2:
            raise ValueError("LinearRUL needs at least two training units with three inspections or more")
        ab = np.array(lines)
        self.level_, self.level_sd_ = float(np.mean(levels)), float(np.std(levels, ddof=1))
        self.prior_mean_ = ab.mean(0)
        self.prior_cov_ = np.cov(ab.T, ddof=1) + np.diag([1e-12, 1e-24])  # never singular (identical units)
        var_d = float(np.mean(np.concatenate(d_all)))
        self.meas_var_ = float(np.clip(-np.mean(np.concatenate(lag1)), 0.0, var_d / 2))
        self.proc_var_ = max(var_d - 2 * self.meas_var_, 0.0) / float(np.mean(np.concatenate(dn_all)))
        return self

    def posterior(self, n: NDArray, h: NDArray) -> tuple[NDArray, NDArray]:
        """Mean and covariance of (a, theta) given a unit's history (conjugate normal update)."""
        x = np.column_stack([np.ones_like(n), n])
        noise = max(self.meas_var_ + self.proc_var_ * float(np.mean(np.diff(n))) if len(n) > 1 else self.meas_var_,
                    1e-12 * max(self.level_**2, 1e-12))  # a noiseless history: the posterior is its exact line
        p0 = np.linalg.inv(self.prior_cov_)
        prec = p0 + x.T @ x / noise
        cov = np.linalg.inv(prec)
        return cov @ (p0 @ self.prior_mean_ + x.T @ h / noise), cov

    def predict(self, n: NDArray, h: NDArray) -> tuple[float, float, float]:
        """(median, 5 %, 95 %) RUL [cycles] of a unit whose history is (n, h) up to now."""
        rng = np.random.default_rng([self.seed, len(n)])
        mean, cov = self.posterior(np.asarray(n, float), np.asarray(h, float))
        ab = rng.multivariate_normal(mean, cov, N_DRAWS, method="cholesky")
        theta = np.maximum(ab[:, 1], 1e-3 * abs(self.prior_mean_[1]))  # a wear index does not heal: drift > 0
        level = self.level_ + self.level_sd_ * rng.standard_normal(N_DRAWS)
        gap = level - (ab[:, 0] + ab[:, 1] * n[-1])
        t = np.zeros(N_DRAWS)
        ahead = gap > 0
        if self.proc_var_ > 0:
            t[ahead] = rng.wald(gap[ahead] / theta[ahead], gap[ahead] ** 2 / self.proc_var_)
        else:
            t[ahead] = gap[ahead] / theta[ahead]
        t = grid_rul(t, n[-1] - n[-2] if len(n) > 1 else 0.0)
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
