"""Out-of-fold figures of the fault-kind classifier by joint on a campaign's training runs alone: the loop in which
changes to its rows or its kind rule are chosen (docs/diagnostics.md, "Fault kind and per-kind detection").

The classifier by joint is refitted five times on the train split, each time without a fifth of its motions
(``GroupKFold`` on ``split_group``, as :mod:`ur5fault.health.diagnostics.calibration` does), and every training
run is scored by the fit that did not see its motion.  From those out-of-fold probabilities: the by-joint ROC AUC
per kind (all sizes, upper half of each kind's sizes), the share flagged at the training runs' own 5 % false-alarm
threshold, the kind called there (balanced accuracy, also with the pair of :data:`MERGED_KINDS` merged) and the
confusion matrix; and, for the operating point, the false alarms each fold's healthy runs give at the threshold
read off the other four folds.  No test run is read.

    PYTHONPATH=. python bench/diagnostics_kind_oof.py results/diagnostics --rows current --out /tmp/oof

The probabilities are cached in ``OUT/oof_<rows>.npz`` (a refit costs about 5 fits of the classifier by joint).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from ur5fault.health.diagnostics import joint_kind
from ur5fault.health.diagnostics.classifier import make_classifier, single_threaded
from ur5fault.health.diagnostics.data import load_dataset
from ur5fault.health.diagnostics.kind_call import balanced_accuracy_as_called, merge_kinds, tell_pair
from ur5fault.health.diagnostics.metrics import FALSE_ALARM_RATE, alarm_threshold, roc_auc, size_edges

N_FOLDS = 5


def contrast(rows: np.ndarray, stems: list[str]) -> np.ndarray:
    """``(n_runs, 6, n_t)``: for every t-value stem (ending in ``_t``: on one scale on every joint), the joint's
    ``|t|`` minus the largest ``|t|`` of the other five joints
    (NaN where the joint's own or every other joint's is NaN).

    A single-joint fault stands out on one joint; what the twin does not know (the payload, its centre of mass,
    the latency) lifts several joints' t values at once.  A joint row alone cannot tell the two apart."""
    idx = [i for i, s in enumerate(stems) if s.endswith("_t")]
    a = np.abs(rows[:, :, idx])
    out = np.full_like(a, np.nan)
    for j in range(rows.shape[1]):
        best = np.nan_to_num(np.delete(a, j, axis=1), nan=-np.inf).max(axis=1)
        out[:, j] = a[:, j] - np.where(np.isneginf(best), np.nan, best)
    return out


def rows_current(df, inputs, fit) -> np.ndarray:
    return joint_kind.joint_rows(df, inputs)


def rows_contrast(df, inputs, fit) -> np.ndarray:
    """The joint rows with :func:`contrast` appended (a candidate change)."""
    x = joint_kind.joint_rows(df, inputs)
    return np.concatenate([x, contrast(x, joint_kind.layout(inputs)[0])], axis=2)


def rows_healthy_z(df, inputs, fit) -> np.ndarray:
    """The joint rows with every per-joint stem also referred to that joint's healthy runs among the fitted ones
    (``fit``): (value - median) / (1.4826 MAD) - a candidate change: a split on it means the same on every joint."""
    x = joint_kind.joint_rows(df, inputs)
    ref = joint_kind.joint_rows(fit[fit["fault"] == "healthy"], inputs)
    n = len(joint_kind.layout(inputs)[0])
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            med = np.nanmedian(ref[:, :, :n], axis=0)
            mad = 1.4826 * np.nanmedian(np.abs(ref[:, :, :n] - med), axis=0)
        # MAD 0: centred only
        z = np.nan_to_num((x[:, :, :n] - np.nan_to_num(med)) / np.where(mad > 0, mad, 1.0), nan=np.nan)
    return np.concatenate([x, z], axis=2)


ROWS = {"current": rows_current, "contrast": rows_contrast, "healthy_z": rows_healthy_z}


def oof_probabilities(tr, inputs, rows=rows_current, seed: int = 0) -> tuple[np.ndarray, list[str], np.ndarray]:
    """``(n_runs, 6, n_classes)`` out-of-fold class probabilities of the classifier by joint, its classes and each
    run's fold."""
    from sklearn.model_selection import GroupKFold

    y = joint_kind.joint_labels(tr)
    groups = tr["split_group"].astype(str).to_numpy()
    fold = np.full(len(tr), -1)
    out, classes = None, None
    for f, (fit_rows, left) in enumerate(GroupKFold(n_splits=N_FOLDS).split(np.zeros(len(tr)), None, groups)):
        x = rows(tr, inputs, tr.iloc[fit_rows])  # a reference the rows need is read off the fitted runs alone
        m = make_classifier(seed).fit(x[fit_rows].reshape(-1, x.shape[2]), y[fit_rows].reshape(-1))
        cls = [str(c) for c in m.classes_]
        if classes is None:
            classes = cls
            out = np.full((len(tr), x.shape[1], len(cls)), np.nan)
        p = m.predict_proba(x[left].reshape(-1, x.shape[2])).reshape(len(left), x.shape[1], -1)
        out[left] = p[:, :, [cls.index(c) for c in classes]]
        fold[left] = f
        print(f"fold {f}: {len(fit_rows)} runs fitted, {len(left)} scored", flush=True)
    return out, classes, fold


def upper_half(tr) -> np.ndarray:
    kinds, sizes = tr["fault"].to_numpy(str), tr["fault_size"].to_numpy(float)
    out = kinds == "healthy"
    for k in set(kinds) - {"healthy"}:
        e = size_edges(sizes[kinds == k])
        out |= (kinds == k) & (sizes >= math.sqrt(e[0] * e[-1]))
    return out


def kind_calls(p: np.ndarray, classes: list[str], flagged: np.ndarray, prior: dict[str, float] | None = None
               ) -> np.ndarray:
    """The kind of each run: healthy where not flagged, else the kind with the largest probability on any joint
    (divided by its training prior when ``prior`` is given)."""
    kinds = [c for c in classes if c != joint_kind.NONE]
    pk = p[:, :, [classes.index(k) for k in kinds]].max(axis=1)
    if prior is not None:
        pk = pk / np.array([prior[k] for k in kinds])
    return np.where(flagged, np.array(kinds)[pk.argmax(axis=1)], "healthy")


def balanced(y: np.ndarray, pred: np.ndarray) -> float:
    from sklearn.metrics import balanced_accuracy_score

    return float(balanced_accuracy_score(y, pred))


def figures(tr, p: np.ndarray, classes: list[str], fold: np.ndarray, inputs, prior=None) -> dict:
    y = tr["fault"].to_numpy(str)
    healthy = y == "healthy"
    score = 1.0 - p[:, :, classes.index(joint_kind.NONE)].min(axis=1)  # max_j (1 - p_j(none))
    thr = alarm_threshold(score, healthy)
    flagged = score > thr
    up = upper_half(tr)
    per_kind = {}
    wrist_2 = tr["fault_joint"].to_numpy(float) == 5
    for k in sorted(set(y) - {"healthy"}):
        pos = y == k
        keep, keep_up = healthy | pos, healthy | (pos & up)
        per_kind[k] = {"n": int(pos.sum()), "auc": roc_auc(pos[keep].astype(int), score[keep]),
                       "n_upper": int((pos & up).sum()),
                       "auc_upper": roc_auc(pos[keep_up].astype(int), score[keep_up]),
                       "flagged_upper": float(flagged[pos & up].mean())}
        w2 = pos & wrist_2  # the kind on wrist 2 alone against every healthy run
        if w2.any():
            per_kind[k].update({"n_wrist_2": int(w2.sum()),
                                "auc_wrist_2": roc_auc(w2[healthy | w2].astype(int), score[healthy | w2]),
                                "flagged_wrist_2": float(flagged[w2].mean())})
    pred = kind_calls(p, classes, flagged, prior)
    told = tell_pair(pred, tr, 1 + (1.0 - p[:, :, classes.index(joint_kind.NONE)]).argmax(axis=1), inputs)
    labels = ["healthy"] + sorted(set(y) - {"healthy"})
    conf = np.zeros((len(labels), len(labels)), int)
    for t, c in zip(y, pred):
        conf[labels.index(t), labels.index(c)] += 1
    lofo = []  # each fold's healthy false alarms at the threshold read off the other folds' healthy runs
    for f in np.unique(fold):
        other = fold != f
        t = alarm_threshold(score[other], healthy[other])
        lofo.append(float((score[(fold == f) & healthy] > t).mean()))
    return {
        "auc_all": roc_auc((~healthy).astype(int), score), "threshold": thr,
        "flagged_faulty": float(flagged[~healthy].mean()), "false_alarms": float(flagged[healthy].mean()),
        "false_alarms_leave_one_fold_out": lofo,
        "kind_balanced": balanced(y, pred), "kind_balanced_merged": balanced(merge_kinds(y), merge_kinds(pred)),
        "kind_balanced_cannot_tell": balanced_accuracy_as_called(y, told),
        "kind_balanced_upper": balanced(y[up], pred[up]),
        "kind_balanced_upper_merged": balanced(merge_kinds(y[up]), merge_kinds(pred[up])),
        "per_kind": per_kind, "labels": labels, "confusion": conf.tolist(),
    }


def training_prior(tr) -> dict[str, float]:
    """Each fault kind's share of the faulty joint rows of the training runs (= of the faulty runs)."""
    y = tr["fault"].to_numpy(str)
    y = y[y != "healthy"]
    return {k: float((y == k).mean()) for k in np.unique(y)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign")
    ap.add_argument("--rows", default="current", choices=sorted(ROWS), help="the joint rows fitted")
    ap.add_argument("--out", default="/tmp/oof")
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    ds = load_dataset(Path(a.campaign), "both")
    tr = ds.train
    cache = out / f"oof_{a.rows}.npz"
    if cache.exists():
        z = np.load(cache, allow_pickle=False)
        p, classes, fold = z["p"], [str(c) for c in z["classes"]], z["fold"]
    else:
        with single_threaded():
            p, classes, fold = oof_probabilities(tr, ds.inputs, ROWS[a.rows])
        np.savez(cache, p=p, classes=np.array(classes), fold=fold)
    res = {"rows": a.rows, "n_train": len(tr), "false_alarm_rate": FALSE_ALARM_RATE,
           "argmax": figures(tr, p, classes, fold, ds.inputs),
           "prior_corrected": figures(tr, p, classes, fold, ds.inputs, training_prior(tr))}
    (out / f"figures_{a.rows}.json").write_text(json.dumps(res, indent=1))
    for rule in ("argmax", "prior_corrected"):
        r = res[rule]
        print(f"{rule}: AUC {r['auc_all']:.3f} flagged {r['flagged_faulty']:.3f} kind {r['kind_balanced']:.3f} "
              f"(merged {r['kind_balanced_merged']:.3f}; cannot tell {r['kind_balanced_cannot_tell']:.3f}; "
              f"upper {r['kind_balanced_upper']:.3f}/"
              f"{r['kind_balanced_upper_merged']:.3f}) LOFO FA {np.round(r['false_alarms_leave_one_fold_out'], 3)}")
        print("  upper-half AUC: " + ", ".join(f"{k} {v['auc_upper']:.3f}" for k, v in r["per_kind"].items()))
        print("  AUC all sizes: " + ", ".join(f"{k} {v['auc']:.3f}" for k, v in r["per_kind"].items()))
        print("  wrist 2, all sizes: AUC (n, flagged) " + ", ".join(
            f"{k} {v['auc_wrist_2']:.3f} ({v['n_wrist_2']}, {v['flagged_wrist_2']:.2f})"
            for k, v in r["per_kind"].items() if "auc_wrist_2" in v))


if __name__ == "__main__":
    main()
