"""The twin size estimates of two diagnostics tables side by side (e.g. one campaign run before and after a change
of the twin features): on the healthy runs, the median and robust spread (1.4826 MAD) of every ``twin_est_*`` on
every joint; on the faulty runs of each kind, how the estimate on the faulted joint follows the true size
(Spearman r over the kind's runs, and the median of estimate / truth, 1 for an unbiased estimate of the right
scale), over all joints and on wrist 2 alone.  docs/diagnostics.md, "Regressors free of the twin's noise".

    PYTHONPATH=. python bench/twin_est_compare.py BEFORE/features.parquet AFTER/features.parquet
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from ur5fault.health.diagnostics.limits import ESTIMATE_OF
from ur5fault.health.twin_features import ESTIMATE_UNITS

#: each kind's true signed estimate from the table's effect columns (twin_features' module docstring)
TRUTH = {
    "current_sensor_offset": lambda d: d["current_sensor_offset_offset_A"],
    "current_sensor_gain": lambda d: d["current_sensor_gain_gain"] - 1.0,
    "torque_constant": lambda d: 1.0 / d["torque_constant_scale"] - 1.0,
    "coulomb_friction": lambda d: d["coulomb_friction_scale"] - 1.0,
    "resolver_offset": lambda d: -np.radians(d["resolver_offset_offset_deg"]),
    "backlash": lambda d: np.radians(d["backlash_deg_swept"]),
    "gear_stiffness": lambda d: 1.0 / d["gear_stiffness_scale"] - 1.0,
}
WRIST_2 = 5


def healthy_table(tables: dict[str, pd.DataFrame]) -> None:
    print("healthy runs: median (1.4826 MAD) of each estimate per joint")
    for est in ESTIMATE_UNITS:
        for name, d in tables.items():
            h = d[(d["fault"] == "healthy") & (d["status"] == "ok")]
            cells = []
            for j in range(1, 7):
                v = h[f"twin_est_{est}_j{j}"].dropna()
                mad = 1.4826 * float(np.median(np.abs(v - v.median()))) if len(v) else float("nan")
                cells.append(f"{v.median():+.3g} ({mad:.2g})")
            print(f"  {est:>20s} {name:>8s} n={len(h)}: " + " | ".join(cells))


def _follow(f: pd.DataFrame, est: str, truth: pd.Series) -> str:
    e = np.array([f.loc[i, f"twin_est_{est}_j{int(f.loc[i, 'fault_joint'])}"] for i in f.index], float)
    t = truth.to_numpy(float)
    ok = np.isfinite(e) & np.isfinite(t)
    if ok.sum() < 3:
        return f"n={int(ok.sum())}"
    r = pd.Series(e[ok]).corr(pd.Series(t[ok]), method="spearman")
    ratio = np.median(e[ok] / t[ok])
    return f"n={int(ok.sum())} r={r:+.2f} est/truth={ratio:+.2f}"


def faulty_table(tables: dict[str, pd.DataFrame]) -> None:
    print("faulty runs: the kind's estimate on its joint against the true size (Spearman r, median est/truth)")
    for kind, est in ESTIMATE_OF.items():
        for name, d in tables.items():
            f = d[(d["fault"] == kind) & (d["status"] == "ok")]
            w2 = f[f["fault_joint"] == WRIST_2]
            print(f"  {kind:>22s} {name:>8s}: all joints {_follow(f, est, TRUTH[kind](f))}; "
                  f"wrist 2 {_follow(w2, est, TRUTH[kind](w2))}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before")
    ap.add_argument("after")
    args = ap.parse_args()
    tables = {"before": pd.read_parquet(args.before), "after": pd.read_parquet(args.after)}
    healthy_table(tables)
    faulty_table(tables)


if __name__ == "__main__":
    main()
