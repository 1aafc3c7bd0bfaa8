"""Remaining useful life in the space of the joints' clearances: each joint's clearance estimated from its
own features, its growth extrapolated per joint, and the end of life where that growth meets the failure
boundary the training units of the same duty task drew when they failed.

Why this shape (measured on the 100-unit fleet, docs/prognostics.md): the failure criterion, the maximum
TCP deviation over the duty cycle, is not one smooth function of a health index; on one task it jumps by
0.1-0.3 of the threshold within one inspection interval once the elbow clearance passes ~0.09-0.10 deg,
so an index extrapolated to its failure level is late for elbow-led units.  In clearance space the
failure set is star-shaped around the new robot (clearances only grow, the deviation grows with each of
them), so it is described by its radius along each direction of growth; this estimator learns that
radius from where the training units of the task failed and reads off where the unit's own growth
direction meets it.  The clearances grow linearly in expectation (a gamma process in the work the gear
transmits, ur5fault/health/prognostics/wear.py, at a duty cycle that repeats), so their line through the
new robot (clearance 0 at cycle 0) extrapolates the unit.

Fitted on the failed training units only (their true clearance is the fitting target of stage 1, as
:class:`~.joint_index.JointHealthIndex`; nothing true is read at prediction):

1. per duty task (fewer than :data:`~.rul.MIN_TASK_UNITS` training units: the whole fleet), per joint,
   the ridge map from the joint's feature changes onto its clearance growth
   (:func:`~.joint_index.fit_clearance_maps`);
2. the training units' clearance estimates *cross-fitted* (each unit estimated by maps fitted without it,
   :data:`FOLDS` folds by unit), so the boundary, the growth-rate prior and the noise carry the errors
   a held-out unit's estimates have;
3. per training unit: its growth rate vector ``r`` (least squares through the origin), its direction
   ``d = r / |r|`` and its failure radius ``rho = |r| * N_f`` (``N_f``: the middle of its last interval,
   where the crossing is expected); per task the prior (mean, covariance) of ``r`` and the per-joint
   scatter of the estimates about each unit's line;
4. the boundary: ``log rho(d)`` as a kernel-weighted mean over the task's training units, weight
   ``exp(kappa (cos(d, d_i) - 1))``; ``kappa`` chosen from :data:`KAPPAS` by leave-one-unit-out on the
   training units (all tasks together), whose residual sd per task is the boundary's uncertainty.

Prediction for a unit seen at cycles ``n`` with estimates ``a``: the posterior of ``r`` (conjugate normal:
the task's prior, and ``a_k = r n_k + e_k`` with the joints' scatter), Monte Carlo draws of ``r`` and of the
boundary ``rho(d) exp(s eps)``, the crossing ``N* = rho / |r|``, the RUL ``N* - n_now`` rounded up to the
inspection grid and at least one interval (median and 5-95 % interval).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .joint_index import JOINT_RIDGE, ClearanceMap, estimate_clearances, fit_clearance_maps
from .rul import MIN_TASK_UNITS, N_DRAWS, Q_HI, Q_LO, grid_rul

#: folds (by unit) of the cross-fitted training estimates (assumption: 5 keeps 80 % of a task's units in
#: every fit; a task with fewer units than folds is fitted leave-one-unit-out)
FOLDS = 5
#: candidate concentrations of the direction kernel (cos 1 - 1/kappa: from one shared radius, kappa 0, to
#: the nearest direction alone); chosen by leave-one-unit-out on the training units
KAPPAS = (0.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0)
#: the key of the maps fitted on the whole fleet (tasks with too few training units)
POOLED = ""


def _tasks(df: pd.DataFrame) -> pd.Series:
    return df["trajectory"].astype(str) if "trajectory" in df.columns else pd.Series(POOLED, index=df.index)


def line_rates(n: NDArray, a: NDArray) -> NDArray:
    """Least-squares growth rate per joint of a line through the origin: ``a_k ~ r n_k``; ``a`` (k, joints)."""
    nn = float(n @ n)
    return (n @ a) / nn if nn > 0 else np.zeros(a.shape[1])


@dataclasses.dataclass
class ClearanceRUL:
    """RUL where a unit's extrapolated clearance growth meets its task's failure boundary; ``fit`` on
    training inspections (with the true clearances), ``clearances`` and ``predict`` read features only."""

    ridge: float = JOINT_RIDGE
    seed: int = 0

    def _fit_maps(self, df: pd.DataFrame) -> dict[str, dict[int, ClearanceMap]]:
        maps = {POOLED: fit_clearance_maps(df, self.ridge)}
        tasks = _tasks(df)
        for task, g in df.groupby(tasks):
            if g["unit_id"].nunique() >= MIN_TASK_UNITS and str(task) != POOLED:
                maps[str(task)] = fit_clearance_maps(g, self.ridge)
        return maps

    @staticmethod
    def _estimate(maps: dict[str, dict[int, ClearanceMap]], df: pd.DataFrame) -> NDArray:
        out = np.zeros((len(df), 6))
        tasks = _tasks(df)
        for task, g in df.groupby(tasks):
            ii = df.index.get_indexer(g.index)
            out[ii] = estimate_clearances(maps.get(str(task), maps[POOLED]), g)
        return out

    def clearances(self, df: pd.DataFrame) -> NDArray:
        """Estimated clearance growth since inspection 0 per joint [deg], shape (rows, 6); reads features
        and the duty task only."""
        return self._estimate(self.maps_, df)

    def fit(self, df: pd.DataFrame) -> ClearanceRUL:
        """``df``: the failed training units' inspections, each unit to its failed inspection."""
        df = df.sort_values(["unit_id", "cycles"])
        self.maps_ = self._fit_maps(df)
        # 2. cross-fitted estimates: each unit by maps fitted on the others
        units = np.array(sorted(df["unit_id"].unique()))
        folds = min(FOLDS, len(units))
        a_cf = np.zeros((len(df), 6))
        for f in range(folds):
            held = units[f::folds]
            rows = df["unit_id"].isin(held).to_numpy()
            a_cf[rows] = self._estimate(self._fit_maps(df[~rows]), df[rows])
        # 3. per unit: rate, direction, failure radius; per task: prior and scatter
        tasks = _tasks(df)
        per_unit = []
        self.train_units_: dict[str, tuple[str, NDArray, float]] = {}  # unit -> (task, rate, failure cycles)
        self.train_history_: dict[str, tuple[NDArray, NDArray]] = {}  # unit -> (cycles, cross-fitted estimates)
        for uid, g in df.groupby("unit_id", sort=True):
            ii = df.index.get_indexer(g.index)
            n, a = g["cycles"].to_numpy(float), a_cf[ii]
            r = np.maximum(line_rates(n, a), 0.0)
            n_f = n[-1] - (n[-1] - n[-2]) / 2 if len(n) > 1 else n[-1]
            per_unit.append((str(tasks.loc[g.index[0]]), r, n_f, a - np.outer(n, r)))
            self.train_units_[str(uid)] = per_unit[-1][:3]
            self.train_history_[str(uid)] = (n, a)
        self.units_: dict[str, tuple[NDArray, NDArray]] = {}   # task -> (directions, log radii)
        self.prior_: dict[str, tuple[NDArray, NDArray, NDArray]] = {}  # task -> (mean r, cov r, scatter var)
        by_task: dict[str, list] = {}
        for t, r, n_f, res in per_unit:
            by_task.setdefault(t, []).append((r, n_f, res))
        everyone = [u for v in by_task.values() for u in v]
        for t, members in [(POOLED, everyone)] + [(t, m) for t, m in by_task.items()
                                                   if len(m) >= MIN_TASK_UNITS and t != POOLED]:
            r = np.array([m[0] for m in members])
            speed = np.linalg.norm(r, axis=1)
            keep = speed > 0
            d = r[keep] / speed[keep, None]
            self.units_[t] = (d, np.log(speed[keep] * np.array([m[1] for m in members])[keep]))
            cov = np.cov(r.T, ddof=1) if len(r) > 1 else np.diag(r[0] ** 2)
            cov = cov + np.diag(1e-6 * np.maximum(np.diag(cov).max(), 1e-30) * np.ones(6))  # never singular
            var_e = np.maximum(np.var(np.concatenate([m[2] for m in members]), axis=0), 1e-12)
            self.prior_[t] = (r.mean(0), cov, var_e)
        # 4. kernel width by leave-one-unit-out over every task's units; the residual sd per task
        loo = {k: [] for k in KAPPAS}
        for t, (d, logrho) in self.units_.items():
            if t == POOLED and len(self.units_) > 1:
                continue
            for k in KAPPAS:
                for i in range(len(d)):
                    others = np.arange(len(d)) != i
                    loo[k].append((t, logrho[i] - self._log_radius(d[others], logrho[others], d[i][None], k)[0]))
        score = {k: np.mean([e**2 for _, e in v]) for k, v in loo.items() if v}
        self.kappa_ = min(score, key=score.get) if score else 0.0
        self.boundary_sd_ = {}
        for t in self.units_:
            errs = [e for tt, e in loo[self.kappa_] if tt == t]
            self.boundary_sd_[t] = float(np.sqrt(np.mean(np.square(errs)))) if errs else float(
                np.std(self.units_[t][1], ddof=1) if len(self.units_[t][1]) > 1 else 0.0)
        self.loo_rmse_log_radius_ = {float(k): float(np.sqrt(v)) for k, v in score.items()}
        return self

    @staticmethod
    def _log_radius(d_train: NDArray, logrho: NDArray, d: NDArray, kappa: float) -> NDArray:
        """Kernel-weighted mean of the training log radii at directions ``d`` (m, 6)."""
        w = np.exp(kappa * (d @ d_train.T - 1.0))
        return (w @ logrho) / np.maximum(w.sum(1), 1e-300)

    def radius(self, task: str, d: NDArray) -> float:
        """The kernel boundary's failure radius [deg] along the unit direction ``d`` (6,) of duty ``task``."""
        d_train, logrho = self.units_[self.task_key(task)]
        return float(np.exp(self._log_radius(d_train, logrho, np.asarray(d, float)[None], self.kappa_)[0]))

    def task_key(self, task: str) -> str:
        return task if task in self.units_ else POOLED

    def posterior(self, task: str, n: NDArray, a: NDArray) -> tuple[NDArray, NDArray]:
        """Mean and covariance of the growth rate vector given the unit's estimates ``a`` at cycles ``n``."""
        mean0, cov0, var_e = self.prior_[self.task_key(task)]
        p0 = np.linalg.inv(cov0)
        prec = p0 + np.diag(float(n @ n) / var_e)
        cov = np.linalg.inv(prec)
        return cov @ (p0 @ mean0 + (n @ a) / var_e), cov

    def predict(self, task: str, n: NDArray, a: NDArray) -> tuple[float, float, float]:
        """(median, 5 %, 95 %) RUL [cycles] of a unit of duty ``task`` seen at cycles ``n`` with clearance
        estimates ``a`` (rows of :meth:`clearances`)."""
        n, a = np.asarray(n, float), np.asarray(a, float)
        rng = np.random.default_rng([self.seed, len(n)])
        key = self.task_key(task)
        mean, cov = self.posterior(task, n, a)
        r = rng.multivariate_normal(mean, cov, N_DRAWS, method="eigh")
        r = np.maximum(r, 0.0)
        speed = np.linalg.norm(r, axis=1)
        floor = 1e-3 * np.linalg.norm(self.prior_[key][0])  # clearances do not shrink: growth > 0
        r[speed < floor] = self.prior_[key][0]
        speed = np.linalg.norm(r, axis=1)
        d_train, logrho = self.units_[key]
        log_rho = self._log_radius(d_train, logrho, r / speed[:, None], self.kappa_)
        log_rho = log_rho + self.boundary_sd_[key] * rng.standard_normal(N_DRAWS)
        t = np.exp(log_rho) / speed - n[-1]
        t = grid_rul(t, n[-1] - n[-2] if len(n) > 1 else 0.0)
        lo, med, hi = np.quantile(t, [Q_LO, 0.5, Q_HI])
        return float(med), float(lo), float(hi)
