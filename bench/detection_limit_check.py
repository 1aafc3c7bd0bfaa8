"""Checks of the detection limits (ur5fault/health/diagnostics/limits.py) on a diagnostics feature table, training
runs only (docs/diagnostics.md, "Detection limits"):

1. the size mapping: on the faulty training runs of each kind, the twin's estimate on the faulty joint against the
   estimate the mapping expects from the labelled size (``estimate_from_size``): median ratio and its quartiles
   (signed where the campaign draws the kind one way; magnitude where it draws both signs), over the runs whose
   estimate is identified, all joints and by joint;
2. the calibration: the robust spread of each estimate's t value on the healthy training runs, per joint.

    PYTHONPATH=. python bench/detection_limit_check.py --features results/diagnostics/features.parquet
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from ur5fault.health.diagnostics.limits import ESTIMATE_OF, ESTIMATES, LimitCalibration, estimate_from_size

#: kinds the diagnostics campaign draws in one direction, with the sign of their estimate (a resolver offset o
#: gives -o, but its direction is "both": magnitude)
ONE_WAY = {"backlash": 1.0, "coulomb_friction": 1.0, "torque_constant": 1.0, "gear_stiffness": 1.0}


def mapping(train: pd.DataFrame) -> None:
    print("estimate / expected from the labelled size (faulty training runs, estimate identified): "
          "median [25-75 %] all joints; medians J1..J6")
    for kind, est in ESTIMATE_OF.items():
        on = train[train["fault"] == kind]
        if on.empty:
            continue
        j = on["fault_joint"].to_numpy(int)
        rows = np.arange(len(on))
        value = np.stack([on[f"twin_est_{est}_j{k}"].to_numpy(float) for k in range(1, 7)], axis=1)[rows, j - 1]
        se = np.stack([on[f"twin_est_{est}_se_j{k}"].to_numpy(float) for k in range(1, 7)], axis=1)[rows, j - 1]
        expected = estimate_from_size(kind, on["fault_size"].to_numpy(float))
        ratio = (ONE_WAY[kind] * value if kind in ONE_WAY else np.abs(value)) / expected
        ok = np.isfinite(se) & (se > 0)
        q = np.quantile(ratio[ok], [0.25, 0.5, 0.75]) if ok.any() else [np.nan] * 3
        by_joint = " ".join(f"{np.median(ratio[ok & (j == k)]):+.2f}" if (ok & (j == k)).any() else "-"
                            for k in range(1, 7))
        print(f"  {kind:22s} ({'signed' if kind in ONE_WAY else '|est|'}): {q[1]:+.3f} [{q[0]:+.3f} to {q[2]:+.3f}]"
              f", {ok.sum()} of {len(on)} runs; by joint {by_joint}")


def calibration(train: pd.DataFrame) -> None:
    cal = LimitCalibration.from_training(train)
    print("robust spread of the t values on the healthy training runs (n finite), J1..J6:")
    for e in ESTIMATES:
        print(f"  {e:20s} " + " ".join(f"{s:6.2f} ({n})" for s, n in zip(cal.spread[e], cal.n[e])))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--features", required=True, help="a diagnostics campaign's features.parquet")
    args = ap.parse_args()
    df = pd.read_parquet(args.features)
    train = df[(df["status"] == "ok") & (df["split"] == "train")]
    print(f"{len(train)} training runs ({(train['fault'] == 'healthy').sum()} healthy)")
    mapping(train)
    calibration(train)


if __name__ == "__main__":
    main()
