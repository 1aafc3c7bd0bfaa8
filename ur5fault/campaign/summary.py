"""Campaign summaries: the paper's TCP-deviation table and the acceptable backlash per joint."""

from __future__ import annotations

import numpy as np
import pandas as pd

from ..axes import JOINT_NAMES


def tcp_table(features: pd.DataFrame) -> pd.DataFrame:
    """Maximum TCP deviation [mm] per fault joint (rows) x backlash level [deg] (columns)."""
    bl = features[(features["fault"].isin(["backlash", "healthy"])) & (features["status"] == "ok")]
    rows = {}
    healthy = bl[bl["fault_joint"] == 0]["tcp_dev_max_mm"].max() if (bl["fault_joint"] == 0).any() else np.nan
    for j in range(1, 7):
        sub = bl[bl["fault_joint"] == j]
        if sub.empty:
            continue
        row = sub.groupby("backlash_deg")["tcp_dev_max_mm"].max()
        row.loc[0.0] = healthy
        rows[f"{j} {JOINT_NAMES[j - 1]}"] = row.sort_index()
    return pd.DataFrame(rows).T


def acceptable_backlash(features: pd.DataFrame, threshold_mm: float) -> pd.Series:
    """Largest simulated backlash [deg] per joint whose max TCP deviation stays within the threshold."""
    table = tcp_table(features)
    out = {}
    for joint, row in table.iterrows():
        ok = [lvl for lvl, v in row.items() if np.isfinite(v) and v <= threshold_mm]
        bad = [lvl for lvl, v in row.items() if np.isfinite(v) and v > threshold_mm]
        below = [lvl for lvl in ok if not bad or lvl < min(bad)]
        out[joint] = max(below) if below else np.nan
    return pd.Series(out, name=f"max_backlash_deg_within_{threshold_mm:g}mm")


