"""Figures from campaign results: the paper's Fig. 3 (TCP deviation over time, alpha = 0.1 deg
on each joint) and Fig. 4 (shoulder motor current for several alpha), and a heat map of any
feature over fault joint x backlash level.

Time series come from ``OUT/timeseries`` when the campaign saved them; otherwise the needed
runs are re-simulated (the simulator is deterministic, so they are the same runs).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from .axes import JOINT_NAMES
from .errors import ConfigFileError


def _series(out: Path, features: pd.DataFrame, run_ids: list[str]) -> dict[str, pd.DataFrame]:
    ts = out / "timeseries"
    have = {r: pd.read_parquet(ts / f"{r}.parquet") for r in run_ids if (ts / f"{r}.parquet").exists()}
    missing = [r for r in run_ids if r not in have]
    if missing:
        have.update(_resimulate(out, features, missing))
    return have


def _resimulate(out: Path, features: pd.DataFrame, run_ids: list[str]) -> dict[str, pd.DataFrame]:
    from . import yamlsafe
    from .campaign import build_campaign, run_batch

    manifest = json.loads((out / "manifest.json").read_text())
    camp = build_campaign(yamlsafe.loads(manifest["campaign_text"], "manifest"), "manifest", manifest["campaign_text"])
    by_id = {rc.run_id: rc for rc in camp.runs}
    batch = [by_id[r] for r in run_ids if r in by_id]
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        run_batch(camp, batch, tmp)
        return {rc.run_id: pd.read_parquet(Path(tmp) / f"{rc.run_id}.parquet") for rc in batch}


def _finish(fig, ax, ylabel: str, title: str, path: Path) -> Path:
    """Label a time plot, save it as PNG and close it."""
    import matplotlib.pyplot as plt

    ax.set_xlabel("time [s]")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_campaign(out: Path, feature: str = "tcp_dev_max_mm", plot_dir: Path | None = None) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fpath = out / "features.parquet"
    if not fpath.exists():
        raise ConfigFileError(f"{out}: no features.parquet (run the campaign first)")
    df = pd.read_parquet(fpath)
    if feature not in df.columns:
        from .errors import UnknownNameError

        raise UnknownNameError("feature", feature, [c for c in df.columns if df[c].dtype.kind == "f"])
    plot_dir = plot_dir or out / "plots"
    plot_dir.mkdir(parents=True, exist_ok=True)
    written = []
    ok = df[df["status"] == "ok"]
    bl = ok[ok["fault"].isin(["backlash"])]

    # Fig. 3: alpha = 0.1 deg on each joint
    fig3 = bl[np.isclose(bl["backlash_deg"], 0.1)]
    if not fig3.empty:
        ids = list(fig3["run_id"]) + list(fig3["twin_run_id"].unique())
        series = _series(out, df, ids)
        fig, ax = plt.subplots(figsize=(10, 5))
        for _, row in fig3.sort_values("fault_joint").iterrows():
            a, b = series[row["run_id"]], series[row["twin_run_id"]]
            dev = np.linalg.norm(a[["tcp_x_m", "tcp_y_m", "tcp_z_m"]].to_numpy() -
                                 b[["tcp_x_m", "tcp_y_m", "tcp_z_m"]].to_numpy(), axis=1) * 1e3
            ax.plot(a["t_s"], dev, lw=0.8, label=f"J{row['fault_joint']} {JOINT_NAMES[row['fault_joint'] - 1]}")
        ax.axhline(0.5, color="k", ls="--", lw=0.8, label="0.5 mm threshold")
        written.append(_finish(fig, ax, "TCP deviation from healthy twin [mm]",
                               "Backlash 0.1 deg in each joint (cf. paper Fig. 3)",
                               plot_dir / "fig3_tcp_deviation_alpha0.1.png"))

    # Fig. 4: shoulder current for several alpha
    fig4 = bl[bl["fault_joint"] == 2].sort_values("backlash_deg")
    if not fig4.empty:
        ids = list(fig4["run_id"]) + list(fig4["twin_run_id"].unique()[:1])
        series = _series(out, df, ids)
        fig, ax = plt.subplots(figsize=(10, 5))
        twin = series[fig4["twin_run_id"].iloc[0]]
        ax.plot(twin["t_s"], twin["i_FB_A_j2"], lw=0.8, color="k", label="healthy")
        for _, row in fig4.iterrows():
            s = series[row["run_id"]]
            ax.plot(s["t_s"], s["i_FB_A_j2"], lw=0.7, label=f"alpha = {row['backlash_deg']:g} deg")
        written.append(_finish(fig, ax, "shoulder motor current i_FB (q axis) [A]",
                               "Shoulder backlash: current spikes at torque reversals (cf. paper Fig. 4)",
                               plot_dir / "fig4_shoulder_current.png"))

    # heat map of a feature over joint x level
    if not bl.empty:
        pivot = bl.pivot_table(index="fault_joint", columns="backlash_deg", values=feature, aggfunc="max")
        fig, ax = plt.subplots(figsize=(8, 4.5))
        im = ax.imshow(pivot.to_numpy(), aspect="auto", cmap="viridis")
        ax.set_xticks(range(pivot.shape[1]), [f"{v:g}" for v in pivot.columns])
        ax.set_yticks(range(pivot.shape[0]), [f"J{j} {JOINT_NAMES[j - 1]}" for j in pivot.index])
        ax.set_xlabel("backlash [deg]")
        for (r, c), v in np.ndenumerate(pivot.to_numpy()):
            ax.text(c, r, f"{v:.3g}", ha="center", va="center", color="w", fontsize=7)
        fig.colorbar(im, label=feature)
        ax.set_title(f"{feature} by fault joint and backlash level")
        fig.tight_layout()
        p = plot_dir / f"heatmap_{feature}.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)
    return written
