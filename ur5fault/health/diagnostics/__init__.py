"""The diagnostics benchmark (``ur5fault benchmark OUT``): baseline classifiers trained on a
campaign's train split and scored on its test split (split by trajectory seed, so no motion is on
both sides).

Modules by concern: :mod:`.data` (split and inputs), :mod:`.models` (the classifiers),
:mod:`.metrics` (detection, localisation, kind, importance), :mod:`.thresholds` (smallest backlash
detected and its TCP deviation), :mod:`.figures` (matplotlib Figures), :mod:`.report` (files).
Needs scikit-learn: ``pip install 'scikit-learn>=1.3'`` (from a checkout: ``pip install '.[ml]'``).
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import pandas as pd

from . import figures as figs
from .data import CONTEXT_COLUMNS, Dataset, load_dataset, load_features
from .metrics import alarm_threshold, detection, detector_scores, fault_kind, importance, localisation
from .models import fit_models
from .report import write_report
from .thresholds import PAPER_TCP_MM, backlash_thresholds


def evaluate(features: pd.DataFrame, *, seed: int = 0, shuffle_labels: bool = False,
             threshold_mm: float = PAPER_TCP_MM, source: str = "features", with_figures: bool = True,
             with_importance: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
    """Train on the train split, score on the test split.

    Args:
        features: a campaign's feature table (``features.parquet``) with the label columns.
        seed: random state of the classifiers, the importance and the bootstrap.
        shuffle_labels: the control run: training labels permuted (results must be at chance).
        threshold_mm: TCP threshold for the backlash acceptability column.

    Returns:
        ``(metrics, figures)``: every number (JSON-able) and the matplotlib Figures by name.
    """
    from .models import single_threaded

    with single_threaded():
        return _evaluate(features, seed, shuffle_labels, threshold_mm, source, with_figures, with_importance)


def _evaluate(features: pd.DataFrame, seed: int, shuffle_labels: bool, threshold_mm: float, source: str,
              with_figures: bool, with_importance: bool) -> tuple[dict[str, Any], dict[str, Any]]:
    t0 = time.perf_counter()
    ds: Dataset = load_dataset(features)
    models = fit_models(ds, seed, shuffle_labels)
    t_fit = time.perf_counter() - t0
    te = ds.test
    score = detector_scores(ds, models)
    healthy = (te["fault"] == "healthy").to_numpy()
    detected = score > alarm_threshold(score, healthy)
    det = detection(ds, models)
    loc = localisation(ds, models, detected)
    kind = fault_kind(ds, models, detected)
    ok_rows = features[features["status"] == "ok"] if "status" in features else features
    bl = backlash_thresholds(te, detected, ok_rows, threshold_mm, seed)
    imp = importance(ds, models, seed) if with_importance else []
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
        "shuffled_labels": shuffle_labels,
        "seed": seed,
        "detection": det,
        "localisation": loc,
        "kind": kind,
        "backlash": bl,
        "importance": imp,
        "timing": {"fit_s": t_fit, "benchmark_wall_s": time.perf_counter() - t0},
    }
    out_figs: dict[str, Any] = {}
    if with_figures:
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
    metrics["timing"]["benchmark_wall_s"] = time.perf_counter() - t0
    return metrics, out_figs


def _split_by(te: pd.DataFrame) -> str:
    g = str(te["split_group"].iloc[0]) if len(te) else ""
    return "trajectory seed" if ":" in g else "split group"


def run_benchmark(campaign_dir: str | Path, out: str | Path | None = None, *, seed: int = 0,
                  shuffle_labels: bool = False) -> dict[str, Any]:
    """``ur5fault benchmark``: evaluate a campaign folder and write ``report.md``, ``metrics.json`` and
    the figures into ``out`` (default ``<campaign_dir>/benchmark``); return the metrics."""
    campaign_dir = Path(campaign_dir)
    features = load_features(campaign_dir)
    thr = PAPER_TCP_MM
    manifest = campaign_dir / "manifest.json"
    if campaign_dir.is_dir() and manifest.exists():
        thr = float(json.loads(manifest.read_text()).get("threshold_mm") or PAPER_TCP_MM)
    metrics, figures = evaluate(features, seed=seed, shuffle_labels=shuffle_labels, threshold_mm=thr,
                                source=str(campaign_dir))
    out_dir = Path(out) if out is not None else (campaign_dir if campaign_dir.is_dir() else campaign_dir.parent) / (
        "benchmark_shuffled" if shuffle_labels else "benchmark")
    write_report(metrics, figures, out_dir)
    metrics["out"] = str(out_dir)
    return metrics


__all__ = ["evaluate", "load_dataset", "load_features", "run_benchmark"]
