"""The wear law's friction rise learned from the inspections, so the twin does not have to assume it.

Why: the twin's failure boundary on an elbow-led duty cycle sits where the worn elbow's Coulomb friction
reaches a fixed level (docs/prognostics.md, "The twin with a model error"), and the wear law sets that
level from the clearance through ``friction_per_deg`` -- a constant nobody has measured to failure
(wear.py: an assumption, 3..8 /deg defensible).  Told 3 or 8 /deg against the fleet's 5, the twin missed
both RUL goals.  Here the friction rise per degree of clearance ``f_alpha`` and per million cycles ``f_N``
(the lubricant ageing) are estimated from data instead:

1. per duty task (fewer than :data:`~.rul.MIN_TASK_UNITS` training units: the whole fleet), per joint, a
   ridge map from the joint's feature changes since inspection 0 onto its friction rise
   ``friction_scale - 1`` (the training units' measured friction is the fitting *target*, as their measured
   clearance is for the clearance maps: both are what a teardown or a starting-torque test of a
   run-to-failure gear gives, the quantities the harmonic-drive degradation tests report; nothing
   measured is read at prediction);
2. every unit's friction rise per inspection from its own features (training units cross-fitted, by the
   clearance estimator's folds, so they carry a held-out unit's error), regressed through the origin on
   its estimated clearances and cycles, ``y_jk = f_alpha a_jk + f_N n_k / 1e6`` over its joints and
   inspections (the joints' different clearance growth separates the two: a joint that barely wears
   carries the ageing term);
3. a population prior (mean and covariance of the training units' ``(f_alpha, f_N)``) updated by a unit's
   inspections so far (conjugate normal, residual variance pooled over the training units): the unit's
   friction rise and its uncertainty, which the twin uses in place of the wear law's two constants.

What this does and does not show: in a simulated fleet every unit's friction follows one law, so the
estimate recovers that law (on the default fleet 5.2 +- 0.2 /deg per held-out unit against the true 5);
the features that carry friction also carry the clearance, so a unit whose friction rose differently
from its clearance would be told apart only as far as its current features separate the two -- not
tested here (no fleet has per-unit friction laws).  The residuals of one unit are correlated (its
clearance estimates' errors), so the posterior sd is a lower bound of the unit's uncertainty; the twin's
calibration units use their own learned rise, so the calibration's spread carries its error.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from .clearance_rul import FOLDS, POOLED, ClearanceRUL, _tasks
from .joint_index import JOINTS, ClearanceMap, estimate_clearances, fit_clearance_maps
from .rul import MIN_TASK_UNITS

#: ridge penalty of the friction maps (as the clearance maps': joint_index.JOINT_RIDGE, measured there)
FRICTION_RIDGE = 1e-4
#: the columns the training units must carry (their measured friction factor per joint)
TARGET = "friction_scale"
#: the least residual variance of the rise regression [-^2] (a friction factor's sd of 1e-6: far below any
#: measurement; only a fleet whose friction never changes fits tighter, and then the posterior is the prior)
RESID_VAR_FLOOR = 1e-12


def rise_design(n: NDArray, a: NDArray) -> NDArray:
    """Regressors of the friction rise per (inspection, joint), row-major like ``a.ravel()``: the estimated
    clearance [deg] and the cycles [10^6]; ``n`` (k,), ``a`` (k, 6)."""
    a = np.asarray(a, float)
    return np.column_stack([a.ravel(), np.repeat(np.asarray(n, float) * 1e-6, a.shape[1])])


def fit_rise(n: NDArray, a: NDArray, y: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Least squares of the friction rise ``y`` (k, 6) on clearance ``a`` (k, 6) and cycles ``n`` (k,):
    ``(f_alpha [1/deg], f_N [1/Mcycle])``, its covariance (residual variance of this fit) and the residuals."""
    x, yy = rise_design(n, a), np.asarray(y, float).ravel()
    b, *_ = np.linalg.lstsq(x, yy, rcond=None)
    r = yy - x @ b
    s2 = float(r @ r) / max(len(yy) - 2, 1)
    return b, s2 * np.linalg.pinv(x.T @ x), r


def posterior(prior_mean: NDArray, prior_cov: NDArray, resid_var: float, n: NDArray, a: NDArray, y: NDArray
              ) -> tuple[NDArray, NDArray]:
    """Conjugate-normal posterior (mean, covariance) of ``(f_alpha, f_N)`` from a prior and a unit's rows."""
    x, yy = rise_design(n, a), np.asarray(y, float).ravel()
    p0 = np.linalg.inv(prior_cov)
    cov = np.linalg.inv(p0 + x.T @ x / resid_var)
    return cov @ (p0 @ prior_mean + x.T @ yy / resid_var), cov


@dataclasses.dataclass
class FrictionRise:
    """The friction rise per degree of clearance and per million cycles, per unit, from its features."""

    ridge: float = FRICTION_RIDGE

    def _fit_maps(self, df: pd.DataFrame) -> dict[str, dict[int, ClearanceMap]]:
        maps = {POOLED: fit_clearance_maps(df, self.ridge, TARGET)}
        for task, g in df.groupby(_tasks(df)):
            if g["unit_id"].nunique() >= MIN_TASK_UNITS and str(task) != POOLED:
                maps[str(task)] = fit_clearance_maps(g, self.ridge, TARGET)
        return maps

    @staticmethod
    def _estimate(maps: dict[str, dict[int, ClearanceMap]], df: pd.DataFrame) -> NDArray:
        out = np.zeros((len(df), len(JOINTS)))
        for task, g in df.groupby(_tasks(df)):
            out[df.index.get_indexer(g.index)] = estimate_clearances(maps.get(str(task), maps[POOLED]), g)
        return out

    def rises(self, df: pd.DataFrame) -> NDArray:
        """Estimated friction rise per joint since inspection 0 (``friction_scale - 1``), (rows, 6); reads
        features and the duty task only."""
        return self._estimate(self.maps_, df)

    def fit(self, df: pd.DataFrame, clearance: ClearanceRUL) -> FrictionRise:
        """``df``: the failed training units' inspections (with ``friction_scale_j1..6``); ``clearance``: the
        fitted clearance estimator whose cross-fitted estimates (``train_history_``) the rise is regressed on."""
        missing = [f"{TARGET}_j{j}" for j in JOINTS if f"{TARGET}_j{j}" not in df.columns]
        if missing:
            raise ValueError(f"the training inspections carry no measured friction ({missing[0]}): the friction "
                             "rise cannot be learned; use the wear law's (--twin-friction law)")
        df = df.sort_values(["unit_id", "cycles"])
        self.maps_ = self._fit_maps(df)
        units = np.array(sorted(df["unit_id"].unique()))
        folds = min(FOLDS, len(units))            # the clearance estimator's folds (clearance_rul.py)
        y_cf = np.zeros((len(df), len(JOINTS)))
        for f in range(folds):
            rows = df["unit_id"].isin(units[f::folds]).to_numpy()
            y_cf[rows] = self._estimate(self._fit_maps(df[~rows]), df[rows])
        self.train_rises_: dict[str, NDArray] = {}
        est, resid = [], []
        for uid, g in df.groupby("unit_id", sort=True):
            y = y_cf[df.index.get_indexer(g.index)]
            self.train_rises_[str(uid)] = y
            n, a = clearance.train_history_[str(uid)]
            if len(n) >= 3:
                b, _, r = fit_rise(n, a, y)
                est.append(b)
                resid.append(r)
        if len(est) < 3:
            raise ValueError(f"{len(est)} training units with three inspections or more: the friction rise needs 3")
        e = np.array(est)
        self.prior_mean_ = e.mean(0)
        self.prior_cov_ = np.cov(e.T, ddof=1) + np.diag([1e-8, 1e-8])   # never singular
        # floored: a fleet whose friction never rises (a wear law with both rises 0) fits with zero residuals,
        # and a zero variance made every unit's posterior 0/0
        self.resid_var_ = max(float(np.mean(np.concatenate(resid) ** 2)), RESID_VAR_FLOOR)
        self.train_estimates_ = e
        return self

    def unit(self, n: NDArray, a: NDArray, y: NDArray) -> tuple[NDArray, NDArray]:
        """Posterior (mean, covariance) of ``(f_alpha [1/deg], f_N [1/Mcycle])`` of a unit seen at cycles
        ``n`` with clearance estimates ``a`` and friction-rise estimates ``y`` (rows of :meth:`rises`)."""
        return posterior(self.prior_mean_, self.prior_cov_, self.resid_var_, n, a, y)

    def summary(self) -> dict:
        sd = np.sqrt(np.diag(self.prior_cov_))
        return {"friction_per_deg_mean": float(self.prior_mean_[0]), "friction_per_deg_sd": float(sd[0]),
                "friction_per_Mcycle_mean": float(self.prior_mean_[1]), "friction_per_Mcycle_sd": float(sd[1]),
                "residual_sd": self.resid_var_ ** 0.5, "n_training_units": int(len(self.train_estimates_))}
