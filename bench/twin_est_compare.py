"""The twin size estimates of two diagnostics tables side by side (e.g. one campaign run before and after a change
of the twin features): on the healthy runs, the median and robust spread (1.4826 MAD) of every ``twin_est_*`` on
every joint; on the faulty runs of each kind, how the estimate on the faulted joint follows the true size
(Spearman r over the kind's runs, and the median of estimate / truth, 1 for an unbiased estimate of the right
scale), over all joints and on wrist 2 alone; wrist 2's healthy gain estimate by payload bin and the CoM estimates
against the drawn shifts.  docs/diagnostics.md, "Regressors free of the twin's noise" and "The unknown payload CoM
from the other joints".

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


def wrist_2_table(tables: dict[str, pd.DataFrame]) -> None:
    """Wrist 2's gain estimate on the healthy runs by payload bin, its median |t|, and the payload CoM estimates
    against the drawn shifts; then every wrist-2 current-gain and torque-constant run."""
    g = f"twin_est_current_gain_err_j{WRIST_2}"
    bins = [-0.01, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
    print("wrist 2's healthy gain estimate by payload bin (0-0.5 / 0.5-1 / 1-1.5 / 1.5-2 / 2-2.5 / 2.5-3 kg), "
          "median |t|, share |t| > 2; CoM estimate - drawn shift (median |error| x y z [mm], runs > 0.5 kg)")
    for name, d in tables.items():
        h = d[(d["fault"] == "healthy") & (d["status"] == "ok")]
        med = h.groupby(pd.cut(h["payload_kg"], bins), observed=True)[g].median()
        t = h[f"twin_est_current_gain_err_t_j{WRIST_2}"].abs()
        heavy = h[h["payload_kg"] > 0.5]
        err = [float(np.median(np.abs(heavy[f"twin_est_payload_com_{a}_m"] - heavy[f"payload_com_d{a}_m"]))) * 1e3
               for a in "xyz"]
        print(f"  {name:>8s}: " + " / ".join(f"{v:+.3f}" for v in med) + f"; |t| {t.median():.1f}, "
              f"{(t > 2).mean():.2f}; CoM error {err[0]:.1f} {err[1]:.1f} {err[2]:.1f} mm")
    for kind in ("current_sensor_gain", "torque_constant"):
        for name, d in tables.items():
            f = d[(d["fault"] == kind) & (d["fault_joint"] == WRIST_2) & (d["status"] == "ok")]
            rows = [f"{TRUTH[kind](f).loc[i]:+.3f}->{f.loc[i, g]:+.3f} ({f.loc[i, 'payload_kg']:.1f} kg)"
                    for i in f.index]
            print(f"  {kind} on wrist 2, {name}: truth->estimate " + ", ".join(rows))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("before")
    ap.add_argument("after")
    args = ap.parse_args()
    tables = {"before": pd.read_parquet(args.before), "after": pd.read_parquet(args.after)}
    healthy_table(tables)
    faulty_table(tables)
    wrist_2_table(tables)


if __name__ == "__main__":
    main()
