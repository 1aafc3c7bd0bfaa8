"""Where the fault-kind classifier by joint misses: per fault kind, size bin and joint, the runs flagged and the kind
called at an operating point, and the upper-half runs it misses with their joint, size, payload and motion
(docs/diagnostics.md, "Fault kind and per-kind detection").  An explanation, not a selection: it reads either the
training runs' out-of-fold probabilities (``--oof OUT/oof_<rows>.npz`` of ``bench/diagnostics_kind_oof.py``) at
their own 5 % threshold, or the test split scored by the saved classifiers at their saved operating point
(``--saved BENCHMARK_DIR``).

    PYTHONPATH=. python bench/diagnostics_kind_misses.py results/diagnostics --saved results/diagnostics/benchmark
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import pandas as pd

from ur5fault.health.diagnostics import joint_kind
from ur5fault.health.diagnostics.classifier import single_threaded
from ur5fault.health.diagnostics.data import load_dataset
from ur5fault.health.diagnostics.metrics import alarm_threshold, size_edges
from ur5fault.health.diagnostics.saved import load_models
from ur5fault.health.diagnostics.thresholds import CROSSING_MIN_ALPHA_DEG


def scored(campaign: Path, oof: Path | None, saved: Path | None):
    """``(runs, p, classes, threshold)``: the runs read, their by-joint class probabilities, the classes and the
    operating point."""
    if saved is not None:
        models, schema = load_models(saved)
        ds = load_dataset(campaign, schema["feature_set"])
        with single_threaded():
            p = joint_kind.probabilities(models.joint_kind, ds.test, ds.inputs)
        return ds.test, p, [str(c) for c in models.joint_kind.classes_], float(
            schema["joint_kind_threshold_5pct_false_alarms"]), ds.train
    z = np.load(oof, allow_pickle=False)
    ds = load_dataset(campaign, "both")
    classes = [str(c) for c in z["classes"]]
    p = z["p"]
    score = 1.0 - p[:, :, classes.index(joint_kind.NONE)].min(axis=1)
    return ds.train, p, classes, alarm_threshold(score, (ds.train["fault"] == "healthy").to_numpy()), ds.train


def crossed(df: pd.DataFrame) -> np.ndarray:
    """Backlash runs whose encoder mismatch spans at least half the clearance on the faulty joint
    (:func:`ur5fault.health.diagnostics.thresholds._crossing`'s rule; False elsewhere)."""
    out = np.zeros(len(df), bool)
    for j in range(1, 7):
        on = ((df["fault"] == "backlash") & (df["fault_joint"] == j)).to_numpy()
        out[on] = (df.loc[on, f"enc_mismatch_p2p_rad_j{j}"] >= 0.5 * np.radians(df.loc[on, "fault_size"])).to_numpy()
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("--oof", type=Path)
    ap.add_argument("--saved", type=Path)
    a = ap.parse_args()
    df, p, classes, thr, train = scored(a.campaign, a.oof, a.saved)
    kinds = [c for c in classes if c != joint_kind.NONE]
    score = 1.0 - p[:, :, classes.index(joint_kind.NONE)].min(axis=1)
    flagged = score > thr
    pk = p[:, :, [classes.index(k) for k in kinds]].max(axis=1)
    call = np.where(flagged, np.array(kinds)[pk.argmax(axis=1)], "healthy")
    df = df.assign(score=score, flagged=flagged, call=call, crossed=crossed(df),
                   top_joint=1 + (1.0 - p[:, :, classes.index(joint_kind.NONE)]).argmax(axis=1))
    y = df["fault"].to_numpy(str)
    h = y == "healthy"
    print(f"threshold {thr:.4f}; healthy false alarms {flagged[h].mean():.3f} ({flagged[h].sum()} of {h.sum()}); "
          f"faulty flagged {flagged[~h].mean():.3f}")
    print("confusion (rows true, columns called):")
    print(pd.crosstab(df["fault"], df["call"]).to_string())
    all_sizes = pd.concat([train, df]) if df is not train else df
    for k in sorted(set(y) - {"healthy"}):
        on = df["fault"] == k
        e = size_edges(all_sizes.loc[all_sizes["fault"] == k, "fault_size"].to_numpy(float))
        bins = pd.cut(df.loc[on, "fault_size"], e, right=False)
        sub = df[on].assign(bin=bins, right=df.loc[on, "call"] == k)
        print(f"\n== {k}: {on.sum()} runs; flagged {sub['flagged'].mean():.2f}, kind right {sub['right'].mean():.2f}")
        print(sub.groupby("bin", observed=True)[["flagged", "right"]].agg(["mean", "size"]).round(2).to_string())
        print(sub.groupby("fault_joint")[["flagged", "right"]].mean().round(2).T.to_string())
        up = sub[sub["fault_size"] >= math.sqrt(e[0] * e[-1])]
        miss = up[~up["flagged"]]
        wrong = up[up["flagged"] & ~up["right"]]
        cols = ["fault_joint", "fault_size", "payload_kg", "temperature_C", "split_group", "score", "call"] + (
            ["crossed"] if k == "backlash" else [])
        print(f"upper half: {len(up)} runs, missed {len(miss)}, wrong kind {len(wrong)}")
        if len(miss):
            print(miss[cols].sort_values(["fault_joint", "fault_size"]).round(4).to_string(index=False))
        if len(wrong):
            print("wrong kind:\n" + wrong[cols].sort_values(["call"]).round(4).to_string(index=False))
        if k == "backlash":
            big = sub["fault_size"] >= CROSSING_MIN_ALPHA_DEG
            print("alpha >= 0.2 deg, flagged by joint and crossed:")
            print(sub[big].groupby(["fault_joint", "crossed"])["flagged"].agg(["mean", "size"]).round(2).to_string())


if __name__ == "__main__":
    main()
