"""The RUL estimators of ``ur5fault prognose`` fitted on a life campaign's failed training units, and their
predictions at every pre-failure inspection of its failed test units (:func:`predict`), with the fitted constants
the benchmark's metrics.json records."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

from ...errors import ConfigFileError
from .clearance_rul import ClearanceRUL
from .joint_index import JOINTS, JointHealthIndex
from .rul import LinearRUL, PopulationRUL, TaskHealthIndex, WienerRUL
from .spec import Failure
from .twin_boundary import TwinSetup
from .twin_cache import RadiusCache
from .twin_friction import FrictionRise
from .twin_rul import CALIBRATION_UNITS_PER_TASK, TwinRUL

ESTIMATORS = ("wiener", "linear", "wiener_joint", "clearance", "twin", "naive")


def predict(df: pd.DataFrame, failure: Failure, seed: int = 0, twin: TwinSetup | None = None,
            twin_calibration: str = "pooled", twin_cache: RadiusCache | None = None, twin_friction: str = "learned",
            progress: bool = False) -> tuple[dict[str, pd.DataFrame], dict[str, Any], np.ndarray]:
    """Fit on the failed training units; predict at every pre-failure inspection of the failed test units.
    ``twin``: also the estimator whose failure boundary the digital twin simulates (twin_rul.py; minutes);
    ``twin_friction``: one of :data:`.twin_choices.TWIN_FRICTION`; ``progress``: report the twin's simulations
    on stderr (util/progress.py).

    Returns the prediction tables per estimator, the fitted constants, and the health index of every row.
    """
    # a unit failed at its first inspection (unworn) shows no degradation to fit or predict: left out of both
    unworn = set(df.loc[~df["censored"] & (df["eol_cycles"] == 0), "unit_id"])
    failed = df[~df["censored"] & ~df["unit_id"].isin(unworn)]
    train, test = failed[failed["split"] == "train"], failed[failed["split"] == "test"]
    n_tr, n_te = train["unit_id"].nunique(), test["unit_id"].nunique()
    if n_tr < 3 or n_te < 1:
        raise ConfigFileError(
            f"{n_tr} failed training and {n_te} failed test units with a degradation path: need at least 3 and 1 "
            "(a larger fleet or a longer max_cycles"
            + (f"; {len(unworn)} units met the failure criterion {failure.feature} >= {failure.threshold:g} at their "
               "first inspection, unworn: the healthy robot meets it on their task, raise life.failure.threshold"
               if unworn else "") + ")")
    hi_model = TaskHealthIndex(failure.feature, failure.threshold).fit(train)
    hi_all = hi_model.transform(df)
    hi_of = pd.Series(hi_all, index=df.index)
    hist = {uid: (g["cycles"].to_numpy(float), hi_of[g.index].to_numpy()) for uid, g in
            df.sort_values("cycles").groupby("unit_id")}
    wiener = WienerRUL(seed).fit([hist[u][0] for u in train["unit_id"].unique()],
                                 [hist[u][1] for u in train["unit_id"].unique()], hi_model.failure_level_,
                                 hi_model.residual_sd_)
    train_ids = train["unit_id"].unique()
    linear = LinearRUL(seed).fit([hist[u][0] for u in train_ids], [hist[u][1] for u in train_ids])
    # the per-joint index (joint_index.py) under the same Wiener estimator, reported beside the baseline
    # (only where the fleet records per-joint clearances to fit its first stage on)
    joint_model = wiener_j = clear = None
    if all(f"backlash_deg_j{j}" in df.columns for j in JOINTS):
        # the clearance-space estimator (clearance_rul.py): per-joint growth meets the task's failure boundary
        clear = ClearanceRUL(seed=seed).fit(train)
        a_of = clear.clearances(df)
        hist_a = {uid: (g["cycles"].to_numpy(float), a_of[df.index.get_indexer(g.index)], str(g["trajectory"].iloc[0])
                        if "trajectory" in g.columns else "") for uid, g in df.sort_values("cycles").groupby("unit_id")}
        joint_model = JointHealthIndex(failure.feature, failure.threshold).fit(train)
        hj_of = pd.Series(joint_model.transform(df), index=df.index)
        hist_j = {uid: (g["cycles"].to_numpy(float), hj_of[g.index].to_numpy()) for uid, g in
                  df.sort_values("cycles").groupby("unit_id")}
        wiener_j = WienerRUL(seed).fit([hist_j[u][0] for u in train_ids], [hist_j[u][1] for u in train_ids],
                                       joint_model.failure_level_, joint_model.residual_sd_)
    naive = PopulationRUL().fit(train.groupby("unit_id")["eol_cycles"].first().to_numpy())
    twin_rul, twin_pred, friction, rises = None, {}, None, None
    if twin is not None and clear is not None:
        cond = {str(uid): (str(g["trajectory"].iloc[0]), float(g["payload_kg"].iloc[0]),
                           float(g["temperature_C"].iloc[0])) for uid, g in df.groupby("unit_id")}
        try:
            if twin_friction == "learned":
                friction = FrictionRise().fit(train, clear)
                y_of = friction.rises(df)
                rises = {str(uid): y_of[df.index.get_indexer(g.index)]
                         for uid, g in df.sort_values("cycles").groupby("unit_id")}
            per_task = 0 if twin_calibration == "pooled" else CALIBRATION_UNITS_PER_TASK
            twin_rul = TwinRUL(twin, clear, seed, twin_calibration, twin_cache, per_task, friction,
                               progress).calibrate(
                {u: cond[u] for u in map(str, train_ids)})
        except ValueError as exc:
            raise ConfigFileError(f"--twin: {exc}") from None
        sound = test[test["rul_cycles"] > 0].groupby("unit_id").size()   # a unit's inspections before failure
        twin_pred = twin_rul.predict_units({str(uid): (cond[str(uid)], hist_a[uid][0][:k], hist_a[uid][1][:k])
                                            for uid, k in sound.items()}, rises)
    rows: dict[str, list] = {name: [] for name in ESTIMATORS}
    for uid, g in test.sort_values("cycles").groupby("unit_id"):
        n_all, h_all = hist[uid]
        for k, (_, r) in enumerate(g.iterrows()):
            if r["rul_cycles"] <= 0:
                continue  # the failure inspection itself: nothing left to predict
            base = {"unit_id": uid, "cycles": r["cycles"], "eol_cycles": r["eol_cycles"], "rul_true": r["rul_cycles"]}
            if k == 0:  # no history yet: the population's residual life
                w = lin = naive.predict(r["cycles"])
                wj = w if wiener_j else None
                cl = w if clear else None
                tw = w if twin_rul else None
            else:
                w = wiener.predict(n_all[: k + 1], h_all[: k + 1])
                lin = linear.predict(n_all[: k + 1], h_all[: k + 1])
                wj = wiener_j.predict(hist_j[uid][0][: k + 1], hist_j[uid][1][: k + 1]) if wiener_j else None
                cl = clear.predict(hist_a[uid][2], hist_a[uid][0][: k + 1], hist_a[uid][1][: k + 1]) if clear else None
                tw = twin_pred[str(uid)][k - 1] if twin_rul else None
            for name, e in (("linear", lin), ("wiener", w), ("wiener_joint", wj), ("clearance", cl), ("twin", tw),
                            ("naive", naive.predict(r["cycles"]))):
                if e is not None:
                    rows[name].append({**base, "rul_est": e[0], "rul_lo": e[1], "rul_hi": e[2]})
    pred = {name: pd.DataFrame(v) for name, v in rows.items() if v}
    fitted = {
        "health_index": {"features": hi_model.features_, "coef_pooled": hi_model.coef_.tolist(),
                         "tasks_with_own_index": sorted(hi_model.by_task_),
                         "failure_level": hi_model.failure_level_,
                         "residual_sd": hi_model.residual_sd_, "criterion": failure.feature,
                         "threshold": failure.threshold},
        "wiener": {"theta_mean_per_cycle": wiener.theta_mean_, "theta_sd_per_cycle": wiener.theta_sd_,
                   "sigma2_per_cycle": wiener.sigma2_},
        "linear": {"failure_level": linear.level_, "failure_level_sd": linear.level_sd_,
                   "prior_mean_intercept": float(linear.prior_mean_[0]),
                   "prior_mean_slope_per_cycle": float(linear.prior_mean_[1]),
                   "prior_sd_intercept": float(linear.prior_cov_[0, 0] ** 0.5),
                   "prior_sd_slope_per_cycle": float(linear.prior_cov_[1, 1] ** 0.5),
                   "measurement_sd": linear.meas_var_**0.5, "process_var_per_cycle": linear.proc_var_},
        "wiener_joint": None if joint_model is None else {"index_residual_sd": joint_model.residual_sd_,
                         "lever_arms_per_deg": {t: v[:-1].tolist() for t, v in joint_model.lever_.items()},
                         "theta_mean_per_cycle": wiener_j.theta_mean_, "sigma2_per_cycle": wiener_j.sigma2_},
        "clearance": None if clear is None else {"kernel_kappa": clear.kappa_,
                      "loo_rmse_log_radius_by_kappa": {f"{k:g}": v for k, v in clear.loo_rmse_log_radius_.items()},
                      "boundary_log_sd_by_task": clear.boundary_sd_},
        "twin": None if twin_rul is None else {
            "calibration": twin_rul.calibration,
            "log_radius_bias_sd_rays_by_checkpoint": {str(c): list(v) for c, v in twin_rul.calibration_.items()},
            "log_radius_by_task_by_checkpoint": {str(c): v.to_dict() for c, v in twin_rul.task_calibration_.items()},
            "calibration_residuals_task_checkpoint_log_ratio": twin_rul.calibration_residuals_,
            "radius_cache": None if twin_cache is None else {"path": str(twin_cache.path), "hits": twin_cache.hits,
                                                             "simulated": twin_cache.misses},
            "n_calibration_units": twin_rul.n_calibration_units_, "n_calibration_rays": twin_rul.n_calibration_rays_,
            "n_twin_rays_test": twin_rul.n_twin_rays_,
            "friction": {"source": twin_friction,
                         "law": {"friction_per_deg": twin.wear.friction_per_deg,
                                 "friction_per_Mcycle": twin.wear.friction_per_Mcycle},
                         "learned": None if friction is None else {
                             **friction.summary(),
                             "test_rays_friction_per_deg_mean_sd_per_Mcycle_mean_sd": twin_rul.friction_rays_,
                             "calibration_rays_friction_per_deg_mean_sd_per_Mcycle_mean_sd":
                                 twin_rul.calibration_friction_}},
            "model": None if twin.model is None else {"params": dict(twin.model.params),
                                                      "effects": [e.describe() for e in twin.model.effects]}},
        "naive": {"train_eol_cycles": naive.eol_.tolist()},
        "n_train_units": int(n_tr), "n_test_units": int(n_te),
    }
    return pred, fitted, hi_all
