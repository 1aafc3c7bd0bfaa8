"""``ur5fault benchmark DIR``: a campaign folder's benchmark written to its report folder (classifiers saved beside
it), the saved classifiers scored on another campaign (``--test``), and the feature sets compared."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pandas as pd

from ...errors import ConfigFileError, ParameterError
from ...seed_paper import PAPER_TCP_MM
from ...util.results import check_new_output, present, result_folder
from .data import (
    FEATURE_SETS,
    has_twin_features,
    load_dataset,
    load_features,
    refuse_life_folder,
    refuse_time_series,
)
from .evaluation import evaluate
from .models import Models
from .predictions import FILE as PREDICTIONS_FILE
from .report import write_report
from .saved import MODELS_DIR, check_saved_inputs, load_models, save_models, training_hash, unverified_notes
from .transfer import against_training_split, mean_run_duration_s, refuse_training_runs, setup_notes

RESULT_FILES = ("report.md", "metrics.json", PREDICTIONS_FILE, MODELS_DIR)


def run_benchmark(campaign_dir: str | Path, out: str | Path | None = None, *, seed: int = 0,
                  shuffle_labels: bool = False, feature_set: str | None = None, test_dir: str | Path | None = None,
                  models_dir: str | Path | None = None, compare: bool = True, jobs: int = 1, replace: bool = True,
                  progress: bool = False) -> dict[str, Any]:
    """``ur5fault benchmark``: evaluate a campaign folder and write ``report.md``, ``metrics.json``, the figures
    and the trained classifiers (``models/``) into ``out`` (default ``<campaign_dir>/benchmark``); return the
    metrics, with ``out`` and ``replaced`` (whether they replaced an earlier result there), which the file has not.

    Args:
        feature_set: the inputs (default: ``both`` when the table has twin residual features, else ``paper``).
        test_dir: score the classifiers saved by an earlier ``ur5fault benchmark campaign_dir`` on every run of
            this other campaign folder, without retraining (default ``out``: ``<test_dir>/benchmark_transfer``).
        models_dir: the report folder those classifiers were saved in (default ``<campaign_dir>/benchmark``; the
            ``out`` of the benchmark that trained them); only with ``test_dir``.
        compare: when no ``feature_set`` is chosen, also score every feature set (and its shuffled-label
            control) and add the table.
        jobs: worker processes for the comparison's evaluations, run while this process trains and scores the
            chosen set (1: all in this process, one after the other; the figures are the same either way).
        replace: replace an earlier report and classifiers in the report folder (False: refused in one line
            before any work, as `ur5fault benchmark` does without --replace).
        progress: the stages on stderr (a bar on a terminal, lines in a log; ``ur5fault benchmark`` without --quiet).
    """
    campaign_dir = Path(campaign_dir)
    base = campaign_dir if campaign_dir.is_dir() else campaign_dir.parent
    if out is not None:
        out_dir = Path(out)
    elif test_dir is not None:
        out_dir = (Path(test_dir) if Path(test_dir).is_dir() else Path(test_dir).parent) / "benchmark_transfer"
    else:
        out_dir = base / ("benchmark_shuffled" if shuffle_labels else "benchmark")
    if models_dir is not None and test_dir is None:
        raise ParameterError("--models names the saved classifiers --test scores; without --test the benchmark trains "
                             "new ones: give --test OTHER_DIR, or leave --models out")
    saved_dir = Path(models_dir) if models_dir is not None else base / "benchmark"
    refuse_life_folder(campaign_dir)  # said before a word on --out, where prognose writes its report too
    check_new_output(out_dir, folder=True, results=RESULT_FILES, replace=replace)  # before reading or training
    features = load_features(campaign_dir)
    if test_dir is not None:  # the other campaign checked before the saved classifiers are loaded (30 s for the
        # diagnostics campaign's): a mistyped --test was refused only after them
        if shuffle_labels:
            raise ParameterError("--shuffle-labels trains new classifiers; --test scores saved ones: use one of them")
        test_dir = Path(test_dir)
        other = load_features(test_dir)  # there, a campaign's feature table (not a life campaign's folder)
        refuse_time_series(other, f"--test {test_dir}: ")
        check_saved_inputs(saved_dir, other, str(test_dir))  # classifiers there, with these inputs
        refuse_training_runs(features, other, campaign_dir, test_dir)
    thr = PAPER_TCP_MM
    manifest = campaign_dir / "manifest.json"
    man: dict[str, Any] = {}
    if campaign_dir.is_dir() and manifest.exists():
        from ...campaign.store import REBUILD_FEATURES
        from ...util.io import read_json_stored

        man = read_json_stored(manifest, REBUILD_FEATURES)
        if not isinstance(man, dict):
            raise ConfigFileError(f"{manifest}: not a campaign manifest (not a JSON object); {REBUILD_FEATURES}")
        thr = float(man.get("threshold_mm") or PAPER_TCP_MM)
    compare = compare and feature_set is None  # a chosen set is scored alone
    if feature_set is None:
        feature_set = "both" if has_twin_features(features) else "paper"
    if test_dir is not None:
        with _Stages(progress, "scoring the saved classifiers", "writing the report") as bar:
            saved = load_models(saved_dir)
            foreign = _other_training_set(features, saved[1], campaign_dir, saved_dir)
            if foreign and models_dir is not None:  # classifiers of another campaign: DIR's split cannot tell which
                # runs of OTHER they were trained on (scored on their own training runs, they look perfect)
                raise ConfigFileError(f"{saved_dir}: its classifiers were not trained on {campaign_dir}'s training "
                                      "runs (the training-set hash differs): give the campaign they were trained on "
                                      "as DIR, which --test's runs are checked against")
            metrics, figures = evaluate(features, seed=seed, threshold_mm=thr, source=str(test_dir), saved=saved,
                                        test_features=other, with_importance=False)
            metrics.pop("_models")
            metrics["notes"] = unverified_notes(saved_dir) + foreign + setup_notes(saved[1], test_dir, other)
            if saved[0].joint_kind is not None:  # how far apart, against the motions drawn (transfer.py)
                metrics["transfer"] = against_training_split(features, other, saved, seed, str(test_dir))
            bar.next()
            replaced = bool(present(out_dir / name for name in RESULT_FILES))  # with replace: said as replaced
            with result_folder(out_dir, RESULT_FILES, replace):  # one set: a stop between files is marked
                write_report(metrics, figures, out_dir)
            bar.next()
        metrics["out"], metrics["replaced"] = str(out_dir), replaced
        return metrics
    compare = compare and has_twin_features(features)
    # the chosen set's classifiers are its trained row of the comparison: trained once, here
    reused = None if shuffle_labels else feature_set
    with _Stages(progress, "training and scoring", *(["the feature sets compared"] if compare else []),
                 "writing the report") as bar:
        pending = (_start_comparison(features, seed, thr, str(campaign_dir), jobs, reused) if compare and jobs > 1
                   else None)
        metrics, figures = evaluate(features, seed=seed, shuffle_labels=shuffle_labels, threshold_mm=thr,
                                    source=str(campaign_dir), feature_set=feature_set, calibrate=not shuffle_labels)
        models = metrics.pop("_models")
        bar.next()
        if compare:
            reuse = None if reused is None else (reused, dataclasses.replace(models, calibrator=None))
            if pending is None:
                metrics["comparison"] = compare_feature_sets(features, seed, thr, str(campaign_dir), reuse)
            else:
                rows = {fs: {k: f.result() for k, f in row.items()} for fs, row in pending.items()}
                if reuse is not None:
                    rows[reused]["trained"] = _compared(features, seed, False, thr, str(campaign_dir), *reuse)
                metrics["comparison"] = {fs: {k: rows[fs][k] for k in ("trained", "shuffled")} for fs in FEATURE_SETS}
            bar.next()
        replaced = bool(present(out_dir / name for name in RESULT_FILES))  # with replace: said as replaced
        with result_folder(out_dir, RESULT_FILES, replace):  # the report and the classifiers, one set
            _write_trained(metrics, figures, out_dir, models, features, feature_set, shuffle_labels, man)
        bar.next()
    metrics["out"], metrics["replaced"] = str(out_dir), replaced
    return metrics


class _Stages:
    """The benchmark's stages on one bar (:mod:`ur5fault.util.progress`), the current one named; closed however its
    ``with`` block ends (an error's one line is not printed onto an open bar)."""

    def __init__(self, enabled: bool, *names: str) -> None:
        from ...util import progress

        self.names, self.k = names, 0
        self.bar = progress.bar(len(names), f"benchmark: {names[0]}", "stage", enabled=enabled)

    def next(self) -> None:
        self.k += 1
        self.bar.update(1)
        if self.k < len(self.names):
            self.bar.set_description(f"benchmark: {self.names[self.k]}")

    def __enter__(self) -> _Stages:
        return self

    def __exit__(self, *exc) -> None:
        self.bar.__exit__(*exc)  # closed either way; a line bar writes no count before an error's own line


def _write_trained(metrics: dict[str, Any], figures: dict, out_dir: Path, models: Models, features: pd.DataFrame,
                   feature_set: str, shuffle_labels: bool, man: dict[str, Any]) -> None:
    """The report, and the trained classifiers beside it (not a shuffled-label control's)."""
    write_report(metrics, figures, out_dir)
    if not shuffle_labels:
        save_models(models, load_dataset(features, feature_set), feature_set,
                    metrics["detection"]["threshold_score"], out_dir, mean_run_duration_s(man), man.get("log_period_s"),
                    joint_kind_threshold=(metrics["detection_by_joint"] or {}).get("threshold_score"),
                    joint_kind_threshold_from=(metrics["detection_by_joint"] or {}).get("threshold_from"),
                    calibration=None if metrics["calibration"] is None else {
                        k: v for k, v in metrics["calibration"].items() if k != "test"},
                    limit_calibration=(metrics["detection_limits"] or {}).get("calibration"),
                    twin_com_twins=bool((man.get("campaign_data") or {}).get("twin_com_twins", False)),
                    twin_residuals_format=man.get("twin_residuals_format"))


def compare_feature_sets(features: pd.DataFrame, seed: int, threshold_mm: float, source: str,
                         reuse: tuple[str, Models] | None = None) -> dict[str, Any]:
    """Headline figures of every feature set on the same split, each with its shuffled-label control.
    ``reuse``: ``(feature_set, models)`` trained on that set with this seed: its trained row scores them."""
    return {fs: {"shuffled" if shuffled else "trained": _compared(
        features, seed, shuffled, threshold_mm, source, fs,
        reuse[1] if reuse is not None and fs == reuse[0] and not shuffled else None)
        for shuffled in (False, True)} for fs in FEATURE_SETS}


def _compared(features: pd.DataFrame, seed: int, shuffled: bool, threshold_mm: float, source: str,
              feature_set: str, fitted: Models | None = None) -> dict[str, Any]:
    """One row of :func:`compare_feature_sets`: the headline figures of one feature set, trained or shuffled."""
    m, _ = evaluate(features, seed=seed, shuffle_labels=shuffled, threshold_mm=threshold_mm, source=source,
                    with_figures=False, with_importance=False, feature_set=feature_set, with_limits=False,
                    fitted=fitted, with_predictions=False)
    return summary(m)


def _start_comparison(features: pd.DataFrame, seed: int, threshold_mm: float, source: str, jobs: int,
                      reused: str | None = None) -> dict[str, dict[str, Any]]:
    """Submit :func:`compare_feature_sets`' evaluations to ``jobs`` worker processes; futures by set and row
    (``reused``: a set whose trained row the caller scores with the classifiers it trains itself: not submitted).

    Each evaluation is deterministic given the seed and single-threaded (:func:`.classifier.single_threaded`),
    so a worker returns what this process would; the workers run while this process scores the chosen set
    (the comparison was about 70 % of a full benchmark's CPU: 340 of 477 s on the 2,546-run dataset, when it also
    trained the chosen set's classifiers a second time)."""
    import os

    from joblib.externals.loky import get_reusable_executor

    from ...util.parallel import ignore_interrupt

    pool = get_reusable_executor(max_workers=jobs, initializer=ignore_interrupt, initargs=(os.getpid(),))
    return {fs: {"shuffled" if shuffled else "trained": pool.submit(_compared, features, seed, shuffled,
                                                                    threshold_mm, source, fs)
                 for shuffled in (False, True) if shuffled or fs != reused} for fs in FEATURE_SETS}


def summary(m: dict[str, Any]) -> dict[str, Any]:
    """The headline numbers of one evaluation."""
    det, loc, kind, bl = m["detection"], m["localisation"], m["kind"], m["backlash"]
    bj = m.get("detection_by_joint") or {}
    return {
        "n_inputs": len(m["dataset"]["inputs"]),
        "auc_all": det["auc_all"], "detection_rate_all": det["detection_rate_all"],
        "auc_per_kind": {k: v["auc"] for k, v in det["per_kind"].items()},
        "auc_upper_half_per_kind": {k: v["auc_upper_half"] for k, v in det["per_kind"].items()},
        "joint_accuracy": loc.get("accuracy"), "joint_accuracy_flagged": loc.get("accuracy_detected"),
        "kind_balanced_accuracy": kind.get("balanced_accuracy"),
        "auc_all_by_joint": bj.get("auc_all"),
        "detection_rate_all_by_joint": bj.get("detection_rate_all"),
        "auc_per_kind_by_joint": {k: v["auc"] for k, v in bj.get("per_kind", {}).items()},
        "auc_upper_half_per_kind_by_joint": {k: v["auc_upper_half"] for k, v in bj.get("per_kind", {}).items()},
        "kind_balanced_accuracy_merged": kind.get("balanced_accuracy_merged"),
        "kind_by_joint_balanced_accuracy": kind.get("by_joint", {}).get("balanced_accuracy"),
        "kind_by_joint_balanced_accuracy_merged": kind.get("by_joint", {}).get("balanced_accuracy_merged"),
        "kind_by_joint_joint_accuracy": kind.get("by_joint", {}).get("joint_accuracy"),
        "alpha_90_deg": {j: v.get("alpha_90_bound") or v["alpha_90_deg"] for j, v in bl["per_joint"].items()},
    }


__all__ = ["RESULT_FILES", "compare_feature_sets", "run_benchmark", "summary"]


def _other_training_set(features: pd.DataFrame, schema: dict[str, Any], campaign_dir: Path, saved_dir: Path
                        ) -> list[str]:
    """A note when the classifiers saved in ``saved_dir`` were not trained on ``campaign_dir``'s training split (their
    training-set hash differs: another campaign's report, or the campaign run again since): their scores on the
    other campaign stand, but the comparison with ``campaign_dir``'s test split is not against their own."""
    try:
        ds = load_dataset(features, schema["feature_set"])
        ds = dataclasses.replace(ds, inputs=tuple(c["name"] for c in schema["inputs"]))
        same = training_hash(ds) == schema.get("training_set_sha256")
    except (ConfigFileError, KeyError, TypeError):
        same = False
    if same:
        return []
    return [f"{saved_dir}: its classifiers were not trained on {campaign_dir}'s training runs (the training-set hash "
            "differs: another campaign's report, or the campaign run again since): their scores on the other campaign "
            f"stand, the comparison with {campaign_dir}'s test split is not against their own; give the campaign they "
            "were trained on"]
