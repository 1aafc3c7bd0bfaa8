"""One benchmark evaluation: train on a campaign's train split (or take saved classifiers), score the test split
(or another campaign), every figure of the report as numbers and matplotlib Figures (:func:`evaluate`)."""

from __future__ import annotations

import dataclasses
import time
from typing import Any

import pandas as pd

from ...seed_paper import PAPER_TCP_MM
from .calibration import fit_calibration, test_reliability
from .data import (
    CONTEXT_COLUMNS,
    Dataset,
    load_dataset,
)
from .limit_metrics import for_dataset
from .metrics import (
    FROM_OUT_OF_FOLD,
    FROM_TEST_SPLIT,
    alarm_threshold,
    detection,
    detector_scores,
    fault_kind,
    importance,
    joint_fault_scores,
    localisation,
)
from .models import Models, fit_models
from .predictions import test_predictions
from .saved import check_inputs
from .thresholds import backlash_thresholds


def evaluate(features: pd.DataFrame, *, seed: int = 0, shuffle_labels: bool = False,
             threshold_mm: float = PAPER_TCP_MM, source: str = "features", with_figures: bool = True,
             with_importance: bool = True, feature_set: str = "paper", saved: tuple[Models, dict] | None = None,
             test_features: pd.DataFrame | None = None, calibrate: bool = False, with_limits: bool = True,
             fitted: Models | None = None, with_predictions: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
    """Train on the train split, score on the test split.

    Args:
        features: a campaign's feature table (``features.parquet``) with the label columns.
        seed: random state of the classifiers, the importance and the bootstrap.
        shuffle_labels: the control run: training labels permuted (results must be at chance).
        threshold_mm: TCP threshold for the backlash acceptability column.
        feature_set: the inputs (:data:`.data.FEATURE_SETS`).
        saved: ``(models, schema)`` of :func:`.saved.load_models`: score these instead of training
            (their inputs and detector threshold); ``features`` then only gives the size ranges.
        test_features: score on every ``ok`` row of this table (another campaign) instead of the test split.
        calibrate: also calibrate the detector's probability on out-of-fold predictions of the train split
            (:mod:`.calibration`; not with shuffled labels) and report its reliability on the test split.
        with_limits: also report detection over the runs above their detection limit (:mod:`.limit_metrics`;
            needs the twin estimates' SE and t columns).
        fitted: classifiers already trained on this split, inputs and seed (the chosen set's, for its row of the
            comparison): scored instead of training them again.
        with_predictions: also every scored run's call (``metrics["_predictions"]``, :mod:`.predictions`; what
            ``write_report`` writes as ``predictions.parquet``).

    Returns:
        ``(metrics, figures)``: every number (JSON-able) and the matplotlib Figures by name.
    """
    from .classifier import single_threaded

    with single_threaded():
        return _evaluate(features, seed, shuffle_labels, threshold_mm, source, with_figures, with_importance,
                         feature_set, saved, test_features, calibrate, with_limits, fitted, with_predictions)


def _evaluate(features: pd.DataFrame, seed: int, shuffle_labels: bool, threshold_mm: float, source: str,
              with_figures: bool, with_importance: bool, feature_set: str = "paper",
              saved: tuple[Models, dict] | None = None, test_features: pd.DataFrame | None = None,
              calibrate: bool = False, with_limits: bool = True, fitted: Models | None = None,
              with_predictions: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
    t0 = time.perf_counter()
    ds: Dataset = load_dataset(features, feature_set if saved is None else saved[1]["feature_set"])
    if test_features is not None:
        names = check_inputs(test_features, saved[1], source) if saved is not None else list(ds.inputs)
        other = test_features[test_features["status"] == "ok"].reset_index(drop=True)
        ds = dataclasses.replace(ds, test=other, inputs=tuple(names))
    models = saved[0] if saved is not None else fitted if fitted is not None else fit_models(ds, seed, shuffle_labels)
    cal_fit: dict[str, Any] = {}
    if calibrate and saved is None and not shuffle_labels:
        models.calibrator, cal_fit = fit_calibration(ds, seed)
    t_fit = time.perf_counter() - t0
    te = ds.test
    score = detector_scores(ds, models)
    healthy = (te["fault"] == "healthy").to_numpy()
    saved_thr = None if saved is None else float(saved[1]["detector_threshold_5pct_false_alarms"])
    thr = alarm_threshold(score, healthy) if saved_thr is None else saved_thr
    detected = score > thr
    det = detection(ds, models, saved_thr, None, None if saved is None else "saved with the classifiers")
    loc = localisation(ds, models, detected)
    by_joint, joint_score, joint_thr = None, None, None
    if models.joint_kind is not None:  # the kind classifier by joint as a detector: p(fault on any joint)
        # its operating point is fixed before the test runs are scored: the saved one, or the training runs' out-
        # of-fold 5 % threshold (the one saved for `ur5fault diagnose`); the test split's own is the oracle beside it
        if saved is not None:
            joint_thr = saved[1].get("joint_kind_threshold_5pct_false_alarms")
            joint_from = saved[1].get("joint_kind_threshold_from", FROM_TEST_SPLIT)
        else:
            joint_thr = (cal_fit.get("info") or {}).get("threshold_out_of_fold")
            joint_from = FROM_OUT_OF_FOLD
        joint_score = joint_fault_scores(ds, models)
        by_joint = detection(ds, models, joint_thr, joint_score, joint_from)
    kind = fault_kind(ds, models, detected, None if by_joint is None else by_joint["threshold_score"])
    calib = None
    if models.calibrator is not None and joint_score is not None:  # the by-joint score is p(fault): calibration.py
        info = {**(cal_fit.get("info") or saved[1].get("calibration") or {})}
        oof_thr = info.get("threshold_out_of_fold")
        calib = {**info, "test": test_reliability(joint_score, ~healthy, models.calibrator, cal_fit.get("isotonic"))}
        if oof_thr is not None:  # the operating point read off the training runs alone, on the test runs
            calib["test_at_threshold_out_of_fold"] = {
                "false_alarm_rate": float((joint_score[healthy] > oof_thr).mean()),
                "detection_rate": float((joint_score[~healthy] > oof_thr).mean())}
    ok_rows = features[features["status"] == "ok"] if "status" in features else features
    bl = backlash_thresholds(te, detected, ok_rows, threshold_mm, seed)
    imp = importance(ds, models, seed) if with_importance else []
    joint_detected = None if joint_score is None or joint_thr is None else joint_score > float(joint_thr)
    limits = None if not with_limits else for_dataset(
        ds, None if saved is None else saved[1], score if joint_score is None else joint_score, score, detected,
        joint_detected)
    metrics = {
        "dataset": {
            "source": source,
            "n_train": len(ds.train), "n_test": len(te),
            "n_groups_train": int(ds.train["split_group"].nunique()), "n_groups_test": int(te["split_group"].nunique()),
            "split_by": _split_by(te),
            "test_kinds": te["fault"].value_counts().to_dict(),
            "n_dropped_not_ok": ds.n_dropped,
            "inputs": list(ds.inputs), "n_features": len(ds.inputs) - sum(c in ds.inputs for c in CONTEXT_COLUMNS),
            "context": [c for c in CONTEXT_COLUMNS if c in ds.inputs],
            "inputs_left_out": dict(ds.inputs_left_out),
        },
        "feature_set": feature_set if saved is None else saved[1]["feature_set"],
        "saved_models": None if saved is None else {k: saved[1][k] for k in (
            "training_set_sha256", "ur5fault_version", "n_train", "detector_threshold_5pct_false_alarms")},
        "shuffled_labels": shuffle_labels,
        "seed": seed,
        "detection": det,
        "detection_by_joint": by_joint,
        "localisation": loc,
        "kind": kind,
        "backlash": bl,
        # detection over the runs above their own detection limit (None: the table has no twin estimates' SEs)
        "detection_limits": limits,
        "calibration": calib,
        "importance": imp,
        "timing": {"fit_s": t_fit, "benchmark_wall_s": time.perf_counter() - t0},
    }
    out_figs: dict[str, Any] = {}
    if with_figures:
        from . import figures as figs  # matplotlib only when figures are drawn: every CLI command imports this package

        on = (te["fault"] == "backlash").to_numpy()
        out_figs = {
            "roc": figs.roc_curves(te["fault"].to_numpy(str), score),
            "detectability_vs_size": figs.auc_vs_size(det),
            "backlash_per_joint": figs.backlash_detectability(
                te.loc[on, "fault_size"].to_numpy(float), te.loc[on, "fault_joint"].to_numpy(int), detected[on], bl),
            "confusion": figs.confusion_matrices(loc, kind),
        }
        if imp:
            out_figs["importance"] = figs.importance_bars(imp)
        if calib is not None:
            out_figs["reliability"] = figs.reliability_diagram(calib["test"])
    metrics["timing"]["benchmark_wall_s"] = time.perf_counter() - t0
    metrics["_models"] = models  # taken out before writing (run_benchmark saves them)
    if with_predictions:  # every scored run's call (predictions.py); write_report writes it as predictions.parquet
        metrics["_predictions"] = test_predictions(te, score, thr, models, ds.inputs, joint_thr)
    return metrics, out_figs


def _split_by(te: pd.DataFrame) -> str:
    g = str(te["split_group"].iloc[0]) if len(te) else ""
    return "trajectory seed" if ":" in g else "split group"


#: what a benchmark writes into its report folder; one of them there is an earlier result
