"""``ur5fault prognose DIR``: fit the RUL estimators on the training units of a life campaign, predict
at every inspection of the held-out units before their failure, judge the goals, and write ``metrics.json``
(every number), ``report.md`` (report.py) and the figures beside each other."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd

from ...campaign.store import check_table_of_manifest, read_manifest
from ...errors import ConfigFileError
from ...util.io import (
    StoredFileError,
    read_parquet_stored,
    write_figure_atomic,
    write_json_atomic,
    write_parquet_atomic,
    write_text_atomic,
)
from ...util.results import check_new_output, result_folder
from ..diagnostics.report import clean
from . import metrics as M
from .clearance_rul import ClearanceRUL
from .figures import health_index_paths, rul_alpha_cone
from .joint_index import JOINTS, JointHealthIndex
from .life_store import life_stats
from .report import markdown
from .rul import LinearRUL, PopulationRUL, TaskHealthIndex, WienerRUL
from .spec import Failure
from .twin_boundary import TwinSetup
from .twin_cache import RadiusCache
from .twin_friction import FrictionRise
from .twin_rul import CALIBRATION_UNITS_PER_TASK, TwinRUL
from .wear import WEAR_KINDS

if TYPE_CHECKING:
    from ...config import Overlay

NEEDED = ("unit_id", "inspection", "cycles", "split", "rul_cycles", "eol_cycles", "censored", "failed")
ESTIMATORS = ("wiener", "linear", "wiener_joint", "clearance", "twin", "naive")
#: the estimator the issue's goals are judged on when the twin did not run (the others are shown beside it)
BASELINE = "wiener"
#: ... and when it ran: its only inputs per unit are the inspections' health features (clearance and friction maps
#: fitted on the training units), its simulator ur5fault's drive model, scored under model and wear-law error
#: in docs/prognostics.md
TWIN = "twin"


def load_inspections(folder: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The inspections table and manifest of a life-campaign folder (one-line errors)."""
    path = Path(folder) / "inspections.parquet"
    if not path.is_file():
        raise ConfigFileError(f"{path}: not found; {_what_is_there(Path(folder))}")
    remake = f"run the life campaign into {folder} again (`ur5fault campaign run CAMPAIGN.yaml --out DIR`)"
    df = read_parquet_stored(path, remake)
    missing = [c for c in NEEDED if c not in df.columns]
    if missing:
        raise ConfigFileError(f"{path}: column {missing[0]!r} missing; not the inspections of a life campaign")
    manifest, damaged = read_manifest(Path(folder))
    if damaged:  # a manifest that changed on disk would give a wrong wear law and inputs: refused
        raise StoredFileError(f"{Path(folder) / 'manifest.json'}: {damaged}; {remake}")
    check_table_of_manifest(path, remake, manifest)  # an earlier fleet's table left by a rerun that stopped
    return df, manifest


def _what_is_there(folder: Path) -> str:
    """What to do about a folder without an inspections table, from what its manifest says it holds."""
    from ...campaign.store import read_manifest

    m = read_manifest(folder)[0]
    if not m:  # nothing ran here (or not ur5fault, or a manifest that fails its checksum)
        return (f"run a life campaign into {folder} first (a shipped one: `ur5fault campaign run prognostics --out "
                f"{folder} --yes`, or prognostics_small)")
    name, campaign = m.get("name", "?"), m.get("campaign_file") or "its campaign file"
    if m.get("kind") != "life":
        return (f"{folder} holds the fault campaign {name!r}, not a life campaign; run one into another folder "
                "(`ur5fault campaign run prognostics --out NEW_DIR --yes`)")
    return (f"the life campaign {name!r} in {folder} has not finished (state {m.get('state', '?')!r}): resume it "
            f"with `ur5fault campaign run {campaign} --out {folder}` (with --yes for a fleet that could take over 1000 "
            f"runs or 2e9 steps; `ur5fault campaign status {folder}` shows how far it got)")


#: where the twin's friction rise per degree of clearance and per 10^6 cycles comes from: "learned" from the
#: inspections (twin_friction.py), or the fleet's wear "law" as the manifest states it
TWIN_FRICTION = ("learned", "law")


def predict(df: pd.DataFrame, failure: Failure, seed: int = 0, twin: TwinSetup | None = None,
            twin_calibration: str = "pooled", twin_cache: RadiusCache | None = None, twin_friction: str = "learned"
            ) -> tuple[dict[str, pd.DataFrame], dict[str, Any], np.ndarray]:
    """Fit on the failed training units; predict at every pre-failure inspection of the failed test units.
    ``twin``: also the estimator whose failure boundary the digital twin simulates (twin_rul.py; minutes);
    ``twin_friction``: one of :data:`TWIN_FRICTION`.

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
            twin_rul = TwinRUL(twin, clear, seed, twin_calibration, twin_cache, per_task, friction).calibrate(
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


#: what a prognose benchmark writes into its report folder; one of them there is an earlier result
RESULT_FILES = ("report.md", "metrics.json")
#: columns every inspection of a fleet holds a finite value in (its duty cycles and true clearances)
RECORDED_COLUMNS = ("cycles", *(f"backlash_deg_j{j}" for j in range(1, 7)))


def run_prognose(folder: Path, out: Path | None = None, *, seed: int = 0, twin: bool = False,
                 twin_model: Overlay | None = None, twin_calibration: str = "pooled",
                 twin_cache: Path | None = None, twin_friction: str = "learned",
                 replace: bool = True) -> dict[str, Any]:
    """The benchmark on a life-campaign folder; returns the metrics written to ``out/metrics.json`` (default ``out``:
    ``folder/benchmark``).
    ``twin_model``: the overlay the twin runs instead of the packaged model (a model error the twin carries);
    ``twin_calibration``: one of twin_rul.CALIBRATIONS; ``twin_cache``: the file of the twin's
    radii (twin_cache.py), default ``out/twin_radii.json``; ``twin_friction``: one of :data:`TWIN_FRICTION`;
    ``replace``: replace an earlier report in ``out`` (False: refused in one line before any work, as `ur5fault
    prognose` does without --replace; the twin's radius cache there is a cache, read and extended either way)."""
    if twin_friction not in TWIN_FRICTION:
        raise ConfigFileError(f"twin friction must be one of {', '.join(TWIN_FRICTION)}, not {twin_friction!r}")
    t0 = time.perf_counter()
    folder = Path(folder)
    if folder.exists() and not folder.is_dir():  # before the output folder inside it is checked
        raise ConfigFileError(f"{folder}: a file, not a folder: give the folder a life campaign ran into")
    out = Path(out) if out is not None else folder / "benchmark"  # as `ur5fault benchmark DIR` writes DIR/benchmark
    check_new_output(out, folder=True, results=RESULT_FILES, replace=replace)  # before reading or simulating
    df, manifest = load_inspections(folder)
    failure = Failure(**manifest["failure"]) if isinstance(manifest.get("failure"), dict) else Failure()
    # the criterion every label is read off, and the fleet's own record of each inspection (its cycles and true
    # wear, which every inspection has): a gap is no fleet's as the campaign wrote it (a table edited by hand)
    ok = df[df["status"] == "ok"] if "status" in df else df  # a stopped run has failed whatever its features
    checked = [(failure.feature, ok, "the failure criterion's feature", "the labels are read off it")]
    checked += [(c, df, "the fleet's record", "the estimators read it") for c in RECORDED_COLUMNS]
    for col, rows, what, why in checked:
        bad = int((~np.isfinite(pd.to_numeric(rows[col], errors="coerce"))).sum()) if col in rows else 0
        if bad:
            raise ConfigFileError(f"{folder}: {what} {col} is missing (NaN) or infinite in {bad} inspection(s); "
                                  f"{why}: run the life campaign again into this folder (it verifies the stored "
                                  "inspections and rebuilds the table)")
    setup = None
    if twin:
        if "wear" not in manifest or "identity_inputs" not in manifest:
            raise ConfigFileError(f"{folder}/manifest.json: no wear law or identity inputs; --twin needs the manifest "
                                  "of a life campaign")
        worn = sorted({e.name for e in (twin_model.effects if twin_model else ())} & WEAR_KINDS)
        if worn:
            raise ConfigFileError(f"the twin's model overlay carries {', '.join(worn)}: the wear law sets those "
                                  "effects itself; give them as params instead")
        setup = TwinSetup.from_manifest(manifest, seed, twin_model)
    cache = RadiusCache(twin_cache if twin_cache is not None else out / "twin_radii.json") if twin else None
    try:
        pred, fitted, hi = predict(df, failure, seed, setup, twin_calibration, cache, twin_friction)
    except ConfigFileError as exc:  # predict's own refusal (too few failed units) already says what to change
        beyond = manifest.get("n_censored_beyond_model") or 0
        raise ConfigFileError(f"{folder}: {exc}" + (
            f"; {beyond} unit(s) were censored where their wear left the simulator's effect ranges, which no longer "
            "max_cycles changes: lower the wear law's constants or life.failure.threshold" if beyond else "")) from None
    except ValueError as exc:  # the estimators' own "too few units or inspections to fit" (rul.py, twin_*.py)
        raise ConfigFileError(f"{folder}: {exc} (a larger fleet, shorter inspection intervals or a longer "
                              "max_cycles)") from None
    per_unit = df.groupby("unit_id").agg(split=("split", "first"), n=("inspection", "size"),
                                         eol=("eol_cycles", "first"))
    if set(per_unit[per_unit["split"] == "train"].index) & set(per_unit[per_unit["split"] == "test"].index):
        raise ConfigFileError(f"{folder}: a unit is on both sides of the split")  # cannot happen: one label per unit
    m: dict[str, Any] = {
        "source": str(folder),
        "dataset": {
            "n_units": int(len(per_unit)), "n_train_units": fitted["n_train_units"],
            "n_test_units": fitted["n_test_units"], "n_censored_units": int(per_unit["eol"].isna().sum()),
            "n_inspections": int(len(df)), "split_by": "unit",
            "inspections_per_unit": {"min": int(per_unit["n"].min()), "mean": float(per_unit["n"].mean()),
                                     "max": int(per_unit["n"].max())},
            "eol_cycles": life_stats(per_unit["eol"]),
            "failure": {"feature": failure.feature, "threshold": failure.threshold},
            "fleet_wall_s": manifest.get("wall_s_this_invocation"),
        },
        "alpha": M.ALPHA, "lambda": M.LAMBDA,
        "estimators": {name: M.summary(p) for name, p in pred.items()},
        "fitted": fitted,
    }
    judged = TWIN if TWIN in m["estimators"] else BASELINE
    w, n = m["estimators"][judged], m["estimators"]["naive"]
    m["goals"] = {
        "baseline": judged,
        "rmse_50_ratio_baseline_to_naive": w["rmse_cycles"]["0.5"] / n["rmse_cycles"]["0.5"],
        "rmse_50_at_most_half_of_naive": w["rmse_cycles"]["0.5"] <= 0.5 * n["rmse_cycles"]["0.5"],
        "alpha_lambda_at_least_0.8": w["alpha_lambda_accuracy"] >= 0.8,
        "by_estimator": {name: {"rmse_50_ratio_to_naive": (q := r["rmse_cycles"]["0.5"] / n["rmse_cycles"]["0.5"]),
                                "rmse_50_at_most_half_of_naive": q <= 0.5,
                                "alpha_lambda_at_least_0.8": r["alpha_lambda_accuracy"] >= 0.8}
                         for name, r in m["estimators"].items() if name != "naive"},
    }
    figures = {"rul_alpha_cone": rul_alpha_cone(pred), "health_index": health_index_paths(df, hi,
                                                                                        fitted["health_index"]
                                                                                        ["failure_level"])}
    with result_folder(out, RESULT_FILES, replace):  # one set: a stop between files is marked
        names = []
        for name, fig in figures.items():
            write_figure_atomic(fig, out / f"{name}.png")  # its temporary file removed on any failure
            names.append(f"{name}.png")
        for name, p in pred.items():
            write_parquet_atomic(p, out / f"predictions_{name}.parquet")
        m["figures"] = names
        m["benchmark_wall_s"] = time.perf_counter() - t0
        m["out"] = str(out)
        m = clean(m)
        write_json_atomic(out / "metrics.json", m)
        write_text_atomic(out / "report.md", markdown(m))
    return m
