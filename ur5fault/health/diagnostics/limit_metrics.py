"""Detection over the faults each run's motion could show: the per-kind AUC and the backlash alpha_90 restricted
to the test runs whose fault size is above that run's detection limit on its joint (:mod:`.limits`), beside
today's figures over every run (kept: they are the goal's literal figures).

Issue 19 states the backlash goal "on the motions where its gear torque reverses": :func:`torque_reverses` reads
that off each run's own twin (no label: the noise-free twin's gear torque on the joint takes both flanks,
``twin_gear_flank_share_j<k>`` above the flank column's 2 %, :func:`.limits.reverses`, and the backlash estimate
is identified), and the alpha_90 over those runs (z-independent) is reported beside the counts of the runs whose
motion never reverses it.

For every ``z`` of :data:`.limits.Z_VALUES`: per kind, the AUC over the upper half of its sizes (as
:func:`.metrics.detection`) and over all its sizes, each over the faulty test runs above their limit only, with
``n`` kept of ``N`` (negatives: every healthy test run, as today); per joint, the backlash alpha_90 over the
backlash test runs above their limit (:func:`.thresholds.backlash_thresholds`, the run-level detector's flags as
today's).  Independent of ``z``: the share of test runs (all, healthy or faulty: a property of the motion) whose
limit is infinite - "cannot tell" - per kind and joint, and the median finite limit.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from ...sim.axes import N_JOINTS
from .data import Dataset
from .limits import (
    DEFAULT_Z,
    ESTIMATE_OF,
    SIZE_UNIT,
    WHY_NOT_IDENTIFIED,
    Z_VALUES,
    LimitCalibration,
    detection_limits,
    has_estimates,
    standard_errors,
)
from .metrics import MIN_BIN_RUNS, auc_vs_healthy, upper_half
from .thresholds import backlash_thresholds

#: the backlash figures kept per joint (the TCP and crossing ones stay in today's table)
ALPHA_KEYS = ("n_test", "detected", "alpha_tested_deg", "alpha_90_deg", "alpha_90_bound", "alpha_90_ci90_deg",
              "alpha_90_ci90_open_below", "alpha_90_ci90_open_above", "alpha_90_empirical_deg", "note")


def own_limit(test: pd.DataFrame, limits: dict[str, np.ndarray]) -> np.ndarray:
    """``(n_runs,)``: each faulty run's limit for its own kind on its own joint; NaN for healthy runs, kinds
    without a size estimate and faults not on one joint."""
    kinds = test["fault"].to_numpy(str)
    joints = test["fault_joint"].to_numpy(int)
    out = np.full(len(test), np.nan)
    for kind, lim in limits.items():
        on = (kinds == kind) & (joints >= 1) & (joints <= N_JOINTS)
        out[on] = lim[np.flatnonzero(on), joints[on] - 1]
    return out


def detectable(test: pd.DataFrame, limits: dict[str, np.ndarray]) -> np.ndarray:
    """``(n_runs,)``: whether each faulty run's ``fault_size`` is above its own limit (False where infinite)."""
    lim = own_limit(test, limits)
    with np.errstate(invalid="ignore"):
        return np.isfinite(lim) & (test["fault_size"].to_numpy(float) > lim)


def torque_reverses(test: pd.DataFrame) -> np.ndarray:
    """``(n_runs, 6)``: whether the run's motion reverses each joint's gear torque, read off its twin (since twin
    format 11 with the payload CoM its current fit finds fed back): the flank share above 2 % (:func:`.limits.reverses`;
    a campaign without the column: the SE alone) and the backlash estimate's SE finite and positive.  The label is
    not read."""
    se = standard_errors(test, ESTIMATE_OF["backlash"])
    return np.isfinite(se) & (se > 0)


def reversing_alpha_90(test: pd.DataFrame, detected: np.ndarray) -> dict[str, Any]:
    """Per joint: the backlash alpha_90 (:func:`.thresholds.backlash_thresholds`) with the flags ``detected`` (the
    run-level detector's, as the other alpha_90 figures, or the by-joint detector's) over the backlash test runs
    whose motion reverses that joint's gear torque, with ``n_not_reversing``: the backlash test runs on the joint
    whose motion never does (no signal can show them)."""
    rev = torque_reverses(test)
    kinds = test["fault"].to_numpy(str)
    joints = test["fault_joint"].to_numpy(int)
    on = (kinds == "backlash") & (joints >= 1) & (joints <= N_JOINTS)
    own = np.zeros(len(test), bool)
    own[on] = rev[np.flatnonzero(on), joints[on] - 1]
    keep = ~on | own
    bl = backlash_thresholds(test[keep].reset_index(drop=True), detected[keep], pd.DataFrame())
    out = {}
    for j, v in bl["per_joint"].items():
        out[j] = {key: v[key] for key in ALPHA_KEYS if key in v}
        out[j]["n_not_reversing"] = int((on & ~own & (joints == int(j))).sum())
    return out


def _auc(score: np.ndarray, healthy: np.ndarray, pos: np.ndarray) -> float:
    return auc_vs_healthy(score, healthy, pos) if pos.sum() >= MIN_BIN_RUNS else math.nan


def limit_detection(test: pd.DataFrame, cal: LimitCalibration, upper: np.ndarray, score: np.ndarray,
                    run_score: np.ndarray, run_detected: np.ndarray, z_values: tuple[float, ...] = Z_VALUES,
                    joint_detected: np.ndarray | None = None) -> dict[str, Any]:
    """The figures of the module docstring.

    Args:
        test: the test rows (labels and the ``twin_est_*`` SE columns).
        cal: the calibration read off the training runs.
        upper: :func:`.metrics.upper_half` of the test rows.
        score: the by-joint detector's score (the goal's figure); ``run_score``: the run-level detector's.
        run_detected: the run-level detector's flags at its operating point (today's backlash alpha_90).
        joint_detected: the by-joint detector's flags at its saved operating point (the flags of ``ur5fault
            diagnose`` and of the headline rates), or None: the reversing motions' alpha_90 also read with them.
    """
    healthy = (test["fault"] == "healthy").to_numpy()
    kinds_all = test["fault"].to_numpy(str)
    joints_all = test["fault_joint"].to_numpy(int)
    kinds = [k for k in ESTIMATE_OF if k in set(kinds_all)]
    base = detection_limits(test, cal, DEFAULT_Z)
    cannot = {}
    for k in kinds:
        inf = np.isinf(base[k])
        on = kinds_all == k
        finite = np.where(inf, np.nan, base[k])
        cannot[k] = {
            "why": WHY_NOT_IDENTIFIED[ESTIMATE_OF[k]],
            "share_of_test_runs_by_joint": {str(j + 1): float(inf[:, j].mean()) for j in range(N_JOINTS)},
            "faulty_cannot_tell_by_joint": {str(j + 1): [int((inf[:, j] & on & (joints_all == j + 1)).sum()),
                                                        int((on & (joints_all == j + 1)).sum())]
                                            for j in range(N_JOINTS)},
            f"median_limit_z{DEFAULT_Z:g}_by_joint": {
                str(j + 1): float(np.nanmedian(finite[:, j])) if np.isfinite(finite[:, j]).any() else math.nan
                for j in range(N_JOINTS)},
            "unit": SIZE_UNIT[k],
        }
    by_z = {}
    for z in z_values:
        lims = base if z == DEFAULT_Z else detection_limits(test, cal, z)
        det = detectable(test, lims)
        lim_own = own_limit(test, lims)
        per_kind = {}
        for k in kinds:
            pos = kinds_all == k
            up = pos & upper
            per_kind[k] = {
                "n_upper_half": int(up.sum()), "n_upper_half_kept": int((up & det).sum()),
                "auc_upper_half_kept": _auc(score, healthy, up & det),
                "auc_upper_half_kept_run_level": _auc(run_score, healthy, up & det),
                "n_upper_half_cannot_tell": int((up & np.isinf(lim_own)).sum()),
                "n_test": int(pos.sum()), "n_kept": int((pos & det).sum()),
                "auc_kept": _auc(score, healthy, pos & det),
                "auc_kept_run_level": _auc(run_score, healthy, pos & det),
                "auc_upper_half_kept_by_joint": {
                    str(j): _auc(score, healthy, up & det & (joints_all == j)) for j in range(1, N_JOINTS + 1)},
            }
        keep = ~(kinds_all == "backlash") | det
        sub = test[keep].reset_index(drop=True)
        bl = backlash_thresholds(sub, run_detected[keep], pd.DataFrame())
        by_z[f"{z:g}"] = {"per_kind": per_kind,
                          "backlash_alpha_90": {j: {key: v[key] for key in ALPHA_KEYS if key in v}
                                                for j, v in bl["per_joint"].items()}}
    return {"z_default": DEFAULT_Z, "z_values": list(z_values),
            "score": "by-joint detector (p(fault) of `ur5fault diagnose`; the goal's per-kind figure); "
                     "`_run_level`: the run-level detector",
            "calibration": cal.to_dict(), "cannot_tell": cannot, "by_z": by_z,
            "backlash_alpha_90_torque_reverses": reversing_alpha_90(test, run_detected),
            "backlash_alpha_90_torque_reverses_by_joint_detector": (
                None if joint_detected is None else reversing_alpha_90(test, np.asarray(joint_detected, bool)))}


def for_dataset(ds: Dataset, schema: dict[str, Any] | None, score: np.ndarray, run_score: np.ndarray,
                run_detected: np.ndarray, joint_detected: np.ndarray | None = None) -> dict[str, Any] | None:
    """:func:`limit_detection` of a benchmark's test runs, calibrated on its training runs (or with the calibration
    saved in ``schema``, a saved detector's); None when the table has no twin estimates' SE and t columns."""
    if not (has_estimates(ds.test) and has_estimates(ds.train)):
        return None
    saved = (schema or {}).get("detection_limit_calibration")
    cal = LimitCalibration.from_dict(saved) if saved else LimitCalibration.from_training(ds.train)
    return limit_detection(ds.test, cal, upper_half(ds), score, run_score, run_detected,
                           joint_detected=joint_detected)


__all__ = ["detectable", "for_dataset", "limit_detection", "own_limit", "reversing_alpha_90", "torque_reverses"]
