"""What the baseline achieves on the test split: detection ROC AUC per fault kind and size,
localisation and fault-kind accuracy with confusion matrices, and which inputs carry the detection
(permutation importance).

The operating point "5 % false alarms" is the detector-score threshold that at most 5 % of the
healthy test runs exceed (the test ROC curve read at a false-positive rate of 0.05).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import joint_kind
from .data import Dataset
from .kind_call import MERGED_KINDS, PAIR, balanced_accuracy_as_called, merge_kinds, right_as_called, tell_pair
from .models import Models, joint_fault_rows

FALSE_ALARM_RATE = 0.05
N_SIZE_BINS = 4  # log-spaced fault-size bins per kind
IMPORTANCE_REPEATS = 5
MIN_BIN_RUNS = 3  # a size bin with fewer faulty test runs gets no AUC


def auc_standard_error(auc: float, n_pos: int, n_neg: int) -> float:
    """Standard error of a ROC AUC (Hanley and McNeil, Radiology 143, 1982, eq. 2)."""
    if n_pos < 1 or n_neg < 1 or not math.isfinite(auc):
        return math.nan
    q1, q2 = auc / (2 - auc), 2 * auc**2 / (1 + auc)
    var = (auc * (1 - auc) + (n_pos - 1) * (q1 - auc**2) + (n_neg - 1) * (q2 - auc**2)) / (n_pos * n_neg)
    return math.sqrt(max(var, 0.0))


def roc_auc(y: np.ndarray, score: np.ndarray) -> float:
    from sklearn.metrics import roc_auc_score

    return float(roc_auc_score(y, score)) if len(np.unique(y)) == 2 else math.nan


def detector_scores(ds: Dataset, models: Models) -> np.ndarray:
    """Probability of 'faulty' for every test run."""
    return models.detector.predict_proba(ds.x("test"))[:, 1]


def alarm_threshold(score: np.ndarray, healthy: np.ndarray, far: float = FALSE_ALARM_RATE) -> float:
    """Score threshold exceeded by at most ``far`` of the healthy runs."""
    return float(np.quantile(score[healthy], 1.0 - far, method="higher"))


def size_edges(sizes: np.ndarray, n_bins: int = N_SIZE_BINS) -> np.ndarray:
    """Log-spaced bin edges over the positive sizes of one kind."""
    s = sizes[np.isfinite(sizes) & (sizes > 0)]
    if s.size == 0:
        return np.array([])
    return np.geomspace(s.min(), s.max() * (1 + 1e-9), n_bins + 1)


def joint_fault_scores(ds: Dataset, models: Models) -> np.ndarray:
    """The fault-kind classifier by joint's probability of a fault on any joint, ``max_j (1 - p_j(none))``, for
    every test run (:mod:`.joint_kind`)."""
    return joint_kind.fault_score(models.joint_kind, ds.test, ds.inputs)


#: where an operating point's threshold was read (``detection``'s ``threshold_from``)
FROM_TEST_SPLIT = "test split (oracle: read off the scored runs' own healthy runs)"
FROM_OUT_OF_FOLD = "training runs out of fold"


def detection(ds: Dataset, models: Models, threshold: float | None = None,
              score: np.ndarray | None = None, threshold_from: str | None = None) -> dict[str, Any]:
    """Detection AUC overall, per fault kind, per fault-size bin and over the upper half of each kind's size
    range (log scale, the range of the train and test runs; also per faulty joint, NaN under
    :data:`MIN_BIN_RUNS` runs: where a kind is not seen); detection rate at 5 % false alarms: at
    ``threshold`` (an operating point fixed before these runs were scored: read off the training runs out of
    fold, or a saved detector's; ``threshold_from`` says which) or, without one, at the threshold read off these
    test runs themselves.  The latter - an oracle no user has, since it needs the labels of the runs it scores -
    is always given too, under ``oracle_test_split``.  ``score``: the test runs' scores of another detector
    (default: the detector's probability)."""
    te = ds.test
    score = detector_scores(ds, models) if score is None else score
    healthy = (te["fault"] == "healthy").to_numpy()
    oracle = alarm_threshold(score, healthy)
    thr = oracle if threshold is None else float(threshold)
    detected = score > thr
    all_sizes = np.concatenate([ds.train["fault_size"].to_numpy(float), te["fault_size"].to_numpy(float)])
    all_kinds = np.concatenate([ds.train["fault"].to_numpy(str), te["fault"].to_numpy(str)])
    per_kind = {}
    for kind in sorted(set(te["fault"]) - {"healthy"}):
        pos = (te["fault"] == kind).to_numpy()
        sizes = te["fault_size"].to_numpy(float)
        unit = str(te.loc[pos, "fault_size_unit"].iloc[0]) if "fault_size_unit" in te else ""
        bins = []
        edges = size_edges(all_sizes[all_kinds == kind])
        for lo, hi in zip(edges[:-1], edges[1:]):
            inb = pos & (sizes >= lo) & (sizes < hi)
            n = int(inb.sum())
            auc = auc_vs_healthy(score, healthy, inb) if n >= MIN_BIN_RUNS else math.nan
            bins.append({"size_lo": float(lo), "size_hi": float(hi), "n_test": n, "auc": auc,
                         "auc_se": auc_standard_error(auc, n, int(healthy.sum())),
                         "detection_rate": float(detected[inb].mean()) if n else math.nan})
        auc = auc_vs_healthy(score, healthy, pos)
        upper = pos & (sizes >= math.sqrt(edges[0] * edges[-1])) if edges.size else pos & False
        auc_up = auc_vs_healthy(score, healthy, upper) if upper.sum() >= MIN_BIN_RUNS else math.nan
        joints = te["fault_joint"].to_numpy(int)
        up_by_joint = {str(j): auc_vs_healthy(score, healthy, upper & (joints == j))
                       if (upper & (joints == j)).sum() >= MIN_BIN_RUNS else math.nan
                       for j in sorted(set(joints[upper]))}
        per_kind[kind] = {"unit": unit, "n_test": int(pos.sum()), "auc": auc,
                          "auc_upper_half": auc_up, "n_test_upper_half": int(upper.sum()),
                          "auc_upper_half_by_joint": up_by_joint,
                          "detection_rate_upper_half": float(detected[upper].mean()) if upper.any() else math.nan,
                          "auc_se": auc_standard_error(auc, int(pos.sum()), int(healthy.sum())),
                          "detection_rate": float(detected[pos].mean()), "by_size": bins}
    return {
        "auc_all": roc_auc((~healthy).astype(int), score),
        "n_test_healthy": int(healthy.sum()),
        "n_test_faulty": int((~healthy).sum()),
        "false_alarm_rate": FALSE_ALARM_RATE,
        "threshold_score": thr,
        "threshold_from": FROM_TEST_SPLIT if threshold is None else (threshold_from or "given"),
        "false_alarm_rate_measured": float(detected[healthy].mean()),
        "detection_rate_all": float(detected[~healthy].mean()),
        "oracle_test_split": {"threshold_score": oracle,
                              "false_alarm_rate_measured": float((score[healthy] > oracle).mean()),
                              "detection_rate_all": float((score[~healthy] > oracle).mean())},
        "per_kind": per_kind,
    }


def auc_vs_healthy(score: np.ndarray, healthy: np.ndarray, pos: np.ndarray) -> float:
    """ROC AUC of ``score`` with the ``pos`` runs against the ``healthy`` ones (the others left out)."""
    keep = healthy | pos
    return roc_auc(pos[keep].astype(int), score[keep])


def confusion(y_true: np.ndarray, y_pred: np.ndarray, labels: list) -> list[list[int]]:
    """Counts, rows = true label, columns = predicted label, in the order of ``labels``."""
    index = {lab: i for i, lab in enumerate(labels)}
    m = np.zeros((len(labels), len(labels)), dtype=int)
    for t, p in zip(y_true, y_pred):
        m[index[t], index[p]] += 1
    return m.tolist()


def localisation(ds: Dataset, models: Models, detected: np.ndarray) -> dict[str, Any]:
    """Which joint, among the test runs with a single joint fault (all, and those the detector flags)."""
    jm = joint_fault_rows(ds.test)
    if models.localiser is None or not jm.any():
        return {"n_test": int(jm.sum()), "accuracy": math.nan}
    y = ds.test.loc[jm, "fault_joint"].to_numpy(int)
    pred = models.localiser.predict(ds.x("test")[jm]).astype(int)
    det = detected[jm]
    per_kind = {}
    kinds = ds.test.loc[jm, "fault"].to_numpy(str)
    for kind in sorted(set(kinds)):
        k = kinds == kind
        per_kind[kind] = {"n_test": int(k.sum()), "accuracy": float((pred[k] == y[k]).mean()),
                          "accuracy_detected": float((pred[k & det] == y[k & det]).mean()) if (k & det).any()
                          else math.nan}
    return {
        "n_test": int(jm.sum()),
        "accuracy": float((pred == y).mean()),
        "n_test_detected": int(det.sum()),
        "accuracy_detected": float((pred[det] == y[det]).mean()) if det.any() else math.nan,
        "chance": 1.0 / 6.0,
        "labels": list(range(1, 7)),
        "confusion": confusion(y, pred, list(range(1, 7))),
        "per_kind": per_kind,
    }


def upper_half(ds: Dataset) -> np.ndarray:
    """Mask of the test runs whose fault size lies in the upper half of its kind's size range (log scale, the
    range of the train and test runs: :func:`detection`'s "upper half"); healthy runs are in it."""
    te = ds.test
    sizes = te["fault_size"].to_numpy(float)
    kinds = te["fault"].to_numpy(str)
    all_sizes = np.concatenate([ds.train["fault_size"].to_numpy(float), sizes])
    all_kinds = np.concatenate([ds.train["fault"].to_numpy(str), kinds])
    out = kinds == "healthy"
    for kind in set(kinds) - {"healthy"}:
        edges = size_edges(all_sizes[all_kinds == kind])
        if edges.size:
            out |= (kinds == kind) & (sizes >= math.sqrt(edges[0] * edges[-1]))
    return out


def fault_kind(ds: Dataset, models: Models, detected: np.ndarray, joint_threshold: float | None = None
               ) -> dict[str, Any]:
    """Healthy or which kind, over every test run; accuracy, balanced accuracy (also with the indistinguishable
    kinds of :data:`MERGED_KINDS` merged: a prediction of either counts for both), confusion matrix.
    ``joint_threshold``: the by-joint detector's operating point (:func:`_kind_by_joint`)."""
    import warnings

    from sklearn.metrics import balanced_accuracy_score

    y = ds.test["fault"].to_numpy(str)
    if models.kind is None:
        return {"n_test": len(y), "accuracy": math.nan}
    pred = models.kind.predict(ds.x("test")).astype(str)
    labels = ["healthy"] + sorted((set(y) | set(pred)) - {"healthy"})
    faulty_det = detected & (y != "healthy")
    with warnings.catch_warnings():  # a small test split may lack a kind the classifier calls: still scored
        warnings.simplefilter("ignore", UserWarning)
        balanced = (float(balanced_accuracy_score(y, pred)),
                    float(balanced_accuracy_score(merge_kinds(y), merge_kinds(pred))))
    return {
        "n_test": len(y),
        "accuracy": float((pred == y).mean()),
        "balanced_accuracy": balanced[0],
        "balanced_accuracy_merged": balanced[1],
        "merged_kinds": sorted(MERGED_KINDS),
        "accuracy_detected_faulty": float((pred[faulty_det] == y[faulty_det]).mean()) if faulty_det.any()
        else math.nan,
        "chance_balanced": 1.0 / len(set(y)),
        "labels": labels,
        "confusion": confusion(y, pred, labels),
        "by_joint": _kind_by_joint(ds, models, detected, joint_threshold),
    }


def _kind_by_joint(ds: Dataset, models: Models, detected: np.ndarray, threshold: float | None = None
                   ) -> dict[str, Any]:
    """The fault-kind classifier by joint (:mod:`.joint_kind`): kind and joint of every test run, a run called
    faulty at even odds; with ``threshold`` (its score's 5 % false-alarm operating point) also the kind called
    at that point (``at_operating_point``: a flagged run gets the likeliest kind, the rule ``ur5fault diagnose``
    follows), there over all test runs, over the upper half of each kind's sizes, and on the flagged faulty
    runs."""
    if models.joint_kind is None:
        return {}
    y = ds.test["fault"].to_numpy(str)
    pred, joint = joint_kind.predict(models.joint_kind, ds.test, ds.inputs)
    jm = joint_fault_rows(ds.test)
    right_joint = joint == ds.test["fault_joint"].to_numpy(int)
    out = {**_kind_scores(y, pred, detected & (y != "healthy")),
           "joint_accuracy": float(right_joint[jm].mean()) if jm.any() else math.nan}
    if threshold is not None:
        at, at_joint = joint_kind.predict(models.joint_kind, ds.test, ds.inputs, float(threshold), strict=True)
        flagged = joint_kind.fault_score(models.joint_kind, ds.test, ds.inputs) > float(threshold)
        up = upper_half(ds)
        told = tell_pair(at, ds.test, at_joint, ds.inputs)
        out["at_operating_point"] = {
            "threshold_score": float(threshold), **_kind_scores(y, at, flagged & (y != "healthy")),
            "upper_half": {"n_test": int(up.sum()), **_kind_scores(y[up], at[up], (flagged & (y != "healthy"))[up])},
            "cannot_tell": {**_as_called(y, told), "upper_half": _as_called(y[up], told[up])},
        }
    return out


def _as_called(y: np.ndarray, told: np.ndarray) -> dict[str, Any]:
    """The kind calls of :func:`.kind_call.tell_pair` ("cannot tell" for the gain / torque-constant pair) scored as
    a set: balanced accuracy, accuracy, how many runs got the pair call and how many the gain by the sign of its
    estimate, and the confusion matrix (a column for the pair call)."""
    labels = ["healthy"] + sorted((set(y) | set(told)) - {"healthy", PAIR}) + [PAIR]
    return {
        "balanced_accuracy": balanced_accuracy_as_called(y, told),
        "accuracy": float(right_as_called(y, told).mean()),
        "n_called_pair": int((told == PAIR).sum()),
        "n_called_gain_by_sign": int((told == "current_sensor_gain").sum()),
        "labels": labels,
        "confusion": confusion(y, told, labels),
    }


def _kind_scores(y: np.ndarray, pred: np.ndarray, faulty_flagged: np.ndarray) -> dict[str, Any]:
    """Accuracy, balanced accuracy (also merged: :data:`MERGED_KINDS`), accuracy on the flagged faulty runs
    (also balanced over their kinds) and the confusion matrix of kind calls ``pred`` against labels ``y``."""
    import warnings

    from sklearn.metrics import balanced_accuracy_score

    labels = ["healthy"] + sorted((set(y) | set(pred)) - {"healthy"})
    f = faulty_flagged
    with warnings.catch_warnings():  # a subset may hold one kind, or calls of a kind it does not hold: still scored
        warnings.simplefilter("ignore", UserWarning)
        return _scores(y, pred, f, labels, balanced_accuracy_score)


def _scores(y, pred, f, labels, balanced_accuracy_score) -> dict[str, Any]:
    return {
        "accuracy": float((pred == y).mean()),
        "balanced_accuracy": float(balanced_accuracy_score(y, pred)),
        "balanced_accuracy_merged": float(balanced_accuracy_score(merge_kinds(y), merge_kinds(pred))),
        "accuracy_detected_faulty": float((pred[f] == y[f]).mean()) if f.any() else math.nan,
        "n_detected_faulty": int(f.sum()),
        "balanced_accuracy_detected_faulty": float(balanced_accuracy_score(y[f], pred[f])) if f.any() else math.nan,
        "balanced_accuracy_detected_faulty_merged": float(balanced_accuracy_score(
            merge_kinds(y[f]), merge_kinds(pred[f]))) if f.any() else math.nan,
        "labels": labels,
        "confusion": confusion(y, pred, labels),
    }


def importance(ds: Dataset, models: Models, seed: int = 0, top: int = 20) -> list[dict[str, Any]]:
    """Permutation importance of each input for the detector: drop of the test ROC AUC when shuffled."""
    from sklearn.inspection import permutation_importance

    y = (ds.test["fault"] != "healthy").to_numpy(int)
    r = permutation_importance(models.detector, ds.x("test"), y, scoring="roc_auc", n_repeats=IMPORTANCE_REPEATS,
                               random_state=seed)
    order = np.argsort(-r.importances_mean)[:top]
    return [{"feature": ds.inputs[i], "auc_drop_mean": float(r.importances_mean[i]),
             "auc_drop_std": float(r.importances_std[i])} for i in order]
