"""Are the diagnostics classifier's fixed hyper-parameters (``classifier.HGB_PARAMS``) near what the training runs
themselves would choose?  Grouped cross-validation on the *training* split only (folds of whole motions, as the
test split is cut), never on the test split: the by-joint kind classifier (the detector of ``ur5fault diagnose``)
fitted per fold under a few settings, scored on the held-out motions by its detection AUC (the largest joint
probability of a fault, healthy against faulty), its joint on single-joint faults and its balanced kind at even
odds.  Usage::

    .venv/bin/python bench/hgb_grouped_cv.py results/diagnostics [--folds 5] [--features both]
    .venv/bin/python bench/hgb_grouped_cv.py results/diagnostics --against results/diagnostics_f9

Prints one Markdown row per setting: mean and spread over the folds, and its paired difference from the shipped
setting (the same folds).  With ``--against OTHER``, another build of the same campaign (other features of the same
runs, e.g. before a feature change): the shipped setting on both, fold by fold on the same motions, and their paired
difference - whether a feature change helps, judged on the training motions alone.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ur5fault.health.diagnostics import classifier, joint_kind
from ur5fault.health.diagnostics.data import load_dataset

SHIPPED = dict(classifier.HGB_PARAMS)
SETTINGS = {
    "shipped": {},
    "lr 0.1": {"learning_rate": 0.1},
    "600 rounds": {"max_iter": 600},
    "31 leaves": {"max_leaf_nodes": 31},
    "leaves of 20 runs": {"min_samples_leaf": 20},
    "no L2": {"l2_regularization": 0.0},
}


def scores(model, val, inputs) -> tuple[float, float, float]:
    from sklearn.metrics import balanced_accuracy_score, roc_auc_score

    healthy = (val["fault"] == "healthy").to_numpy()
    auc = roc_auc_score(~healthy, joint_kind.fault_score(model, val, inputs))
    kind, joint = joint_kind.predict(model, val, inputs)
    single = (val["fault_scope"] == "joint").to_numpy()
    joint_acc = float(np.mean(joint[single] == val["fault_joint"].to_numpy(int)[single]))
    return float(auc), joint_acc, float(balanced_accuracy_score(val["fault"].to_numpy(str), kind))


def folds_of(train, n_folds: int) -> list[np.ndarray]:
    """``n_folds`` folds of whole motions of the training runs (the split groups shuffled with seed 0)."""
    groups = np.array(sorted(train["split_group"].unique()))
    np.random.default_rng(0).shuffle(groups)
    return np.array_split(groups, n_folds)


def fold_scores(ds, folds) -> np.ndarray:
    """``(n_folds, 3)``: the shipped setting fitted on the other folds, scored on each (:func:`scores`)."""
    tr, rows = ds.train, []
    for held in folds:
        val_mask = tr["split_group"].isin(held).to_numpy()
        model = joint_kind.fit(tr[~val_mask], ds.inputs, seed=0, rng=None)
        rows.append(scores(model, tr[val_mask].reset_index(drop=True), ds.inputs))
    return np.array(rows)


def against(campaign: str, other: str, n_folds: int, features: str) -> None:
    """The shipped setting on two builds of one campaign, paired by fold (module docstring)."""
    ds, ref = load_dataset(campaign, features), load_dataset(other, features)
    if sorted(ds.train["split_group"].unique()) != sorted(ref.train["split_group"].unique()):
        raise SystemExit(f"{campaign} and {other}: not the same training motions")
    folds = folds_of(ds.train, n_folds)
    with classifier.single_threaded():
        r, b = fold_scores(ds, folds), fold_scores(ref, folds)
    print(f"{len(ds.train)} training runs, {n_folds} folds of whole motions; inputs {len(ds.inputs)} / "
          f"{len(ref.inputs)}")
    print("| build | detection AUC | joint right | balanced kind (even odds) |\n| --- | --- | --- | --- |")
    for name, x in ((campaign, r), (other, b)):
        print(f"| {name} | {x[:, 0].mean():.3f} ± {x[:, 0].std(ddof=1):.3f} | {x[:, 1].mean():.3f} | "
              f"{x[:, 2].mean():.3f} |")
    for k, what in enumerate(("detection AUC", "joint right", "balanced kind")):
        d = r[:, k] - b[:, k]
        print(f"{what}: {campaign} - {other} = {d.mean():+.4f} per fold ({d.min():+.4f}..{d.max():+.4f}; "
              f"better in {int((d > 0).sum())} of {n_folds} folds)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign")
    ap.add_argument("--folds", type=int, default=5)
    ap.add_argument("--features", default="both")
    ap.add_argument("--settings", default=None, help="comma-separated names of SETTINGS (default: all)")
    ap.add_argument("--against", default=None, help="another build of the same campaign: the shipped setting on "
                                                    "both, paired by fold")
    a = ap.parse_args()
    if a.against is not None:
        return against(a.campaign, a.against, a.folds, a.features)
    ds = load_dataset(a.campaign, a.features)
    tr = ds.train
    folds = folds_of(tr, a.folds)
    groups = np.unique(tr["split_group"])
    names = list(SETTINGS) if a.settings is None else a.settings.split(",")
    print(f"{len(tr)} training runs, {len(groups)} motions, {a.folds} folds; inputs {len(ds.inputs)}")
    print("| setting | detection AUC | joint right | balanced kind (even odds) | AUC - shipped (paired) | s per fit |")
    print("| --- | --- | --- | --- | --- | --- |")
    base = None
    with classifier.single_threaded():
        for name in names:
            classifier.HGB_PARAMS = {**SHIPPED, **SETTINGS[name]}
            rows, t0 = [], time.perf_counter()
            for held in folds:
                val_mask = tr["split_group"].isin(held).to_numpy()
                model = joint_kind.fit(tr[~val_mask], ds.inputs, seed=0, rng=None)
                rows.append(scores(model, tr[val_mask].reset_index(drop=True), ds.inputs))
            r = np.array(rows)
            base = r if base is None else base
            d = r[:, 0] - base[:, 0]
            print(f"| {name} | {r[:, 0].mean():.3f} ± {r[:, 0].std(ddof=1):.3f} | {r[:, 1].mean():.3f} | "
                  f"{r[:, 2].mean():.3f} | {d.mean():+.3f} ({d.min():+.3f}..{d.max():+.3f}) | "
                  f"{(time.perf_counter() - t0) / a.folds:.0f} |", flush=True)
    classifier.HGB_PARAMS = SHIPPED


if __name__ == "__main__":
    main()
