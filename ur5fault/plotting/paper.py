"""The seed paper's backlash figures from a campaign: Fig. 3 (TCP deviation from the healthy twin over
time, the same backlash on each joint in turn) and Fig. 4 (shoulder motor current for several backlash
sizes).  Both need time series, read from the campaign or re-simulated (:class:`CampaignResult`).

When the campaign sweeps conditions too (seeds, payloads), the figures show the runs of one condition
group: those compared with the most frequent healthy twin.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..campaign.summary import effect_sweep, swept_effects
from ..errors import ParameterError
from ..seed_paper import PAPER_BACKLASH_DEG
from ..sim.axes import JOINT_NAMES
from ..util.checks import is_real, short
from ._figure import check_ax, figure_and_axes

if TYPE_CHECKING:  # pragma: no cover
    from ..campaign.result import CampaignResult

TCP_COLUMNS = ["tcp_x_m", "tcp_y_m", "tcp_z_m"]
#: the joint of the paper's Fig. 4 (1-based: the shoulder, which carries the largest gravity load)
FIG4_JOINT = 2


def check_result(result: object, where: str) -> None:
    """A :class:`CampaignResult` (a folder path is named with the call that reads it)."""
    from ..campaign.result import CampaignResult

    if not isinstance(result, CampaignResult):
        hint = (f"; read the folder with CampaignResult.load({short(str(result))})"
                if isinstance(result, (str, os.PathLike)) else "")
        raise ParameterError(f"{where}: result = {short(result)} must be a CampaignResult{hint}")


def _backlash_rows(result: CampaignResult) -> pd.DataFrame:
    sweep = effect_sweep(result.features, "backlash", swept_effects(result.swept_keys).get("backlash"))
    if isinstance(sweep, str):
        raise ParameterError(f"{result.out}: no backlash figure: {sweep}")
    rows = sweep.rows
    rows = rows[rows["twin_run_id"].fillna("").astype(str) != ""]  # a run without a twin has no TCP deviation
    if rows.empty:
        raise ParameterError(f"{result.out}: no Fig. 3 or Fig. 4: no backlash run has a healthy twin (a sampled "
                             "campaign's `twins` key leaves backlash out)")
    counts = rows["twin_run_id"].value_counts()
    data = result.manifest.get("campaign_data")
    sampled = isinstance(data, dict) and "sample" in data
    if sampled and counts.iloc[0] < 2 <= len(rows):  # each backlash run on its own motion and conditions, own twin
        raise ParameterError(f"{result.out}: no Fig. 3 or Fig. 4: they need backlash runs of several sizes or joints "
                             f"under one condition (one healthy twin shared, as `ur5fault campaign run paper` makes); "
                             f"this sampled campaign's {len(rows)} backlash run(s) each have their own")
    return rows[rows["twin_run_id"] == counts.index[0]]  # one condition group (a grid: the largest)


def tcp_deviation_mm(run: pd.DataFrame, twin: pd.DataFrame) -> np.ndarray:
    """Distance of a run's TCP from its healthy twin's TCP at each logged sample [mm]."""
    return np.linalg.norm(run[TCP_COLUMNS].to_numpy() - twin[TCP_COLUMNS].to_numpy(), axis=1) * 1e3


def fig3_tcp_deviation(result: CampaignResult, backlash_deg: float = PAPER_BACKLASH_DEG, ax: Axes | None = None
                       ) -> Figure:
    """TCP deviation from the healthy twin over time, ``backlash_deg`` on each joint in turn (paper Fig. 3),
    with the campaign's ``threshold_mm``."""
    check_result(result, "fig3_tcp_deviation")
    if not is_real(backlash_deg) or not backlash_deg > 0:
        raise ParameterError(f"fig3_tcp_deviation: backlash_deg = {short(backlash_deg)} must be a backlash size > 0 "
                             "[deg] of the campaign")
    check_ax(ax, "fig3_tcp_deviation: ax")
    rows = _backlash_rows(result)
    sel = rows[np.isclose(rows["size"], backlash_deg)].sort_values("fault_joint")
    if sel.empty:
        levels = ", ".join(f"{v:g}" for v in sorted(rows["size"].unique()))
        raise ParameterError(f"{result.out}: no Fig. 3: no backlash run at {backlash_deg:g} deg (levels: {levels})")
    series = result.time_series([*sel["run_id"], sel["twin_run_id"].iloc[0]])
    twin = series[sel["twin_run_id"].iloc[0]]
    fig, ax = figure_and_axes(ax, (10, 5))
    for _, row in sel.iterrows():
        run = series[row["run_id"]]
        j = int(row["fault_joint"])
        ax.plot(run["t_s"], tcp_deviation_mm(run, twin), lw=0.8, label=f"J{j} {JOINT_NAMES[j - 1]}")
    ax.axhline(result.threshold_mm, color="k", ls="--", lw=0.8, label=f"{result.threshold_mm:g} mm threshold")
    ax.set(xlabel="time [s]", ylabel="TCP deviation from healthy twin [mm]",
           title=f"Backlash {backlash_deg:g} deg in each joint (cf. paper Fig. 3)")
    ax.legend(fontsize=8)
    return fig


def fig4_shoulder_current(result: CampaignResult, ax: Axes | None = None) -> Figure:
    """Shoulder motor current (q axis) of the healthy twin and every shoulder backlash size (paper Fig. 4)."""
    check_result(result, "fig4_shoulder_current")
    check_ax(ax, "fig4_shoulder_current: ax")
    rows = _backlash_rows(result)
    sel = rows[rows["fault_joint"] == FIG4_JOINT].sort_values("size")
    if sel.empty:
        raise ParameterError(f"{result.out}: no Fig. 4: no backlash run on joint {FIG4_JOINT}")
    twin_id = sel["twin_run_id"].iloc[0]
    series = result.time_series([*sel["run_id"], twin_id])
    col = f"i_FB_A_j{FIG4_JOINT}"
    fig, ax = figure_and_axes(ax, (10, 5))
    ax.plot(series[twin_id]["t_s"], series[twin_id][col], lw=0.8, color="k", label="healthy")
    for _, row in sel.iterrows():
        run = series[row["run_id"]]
        ax.plot(run["t_s"], run[col], lw=0.7, label=f"alpha = {row['size']:g} deg")
    ax.set(xlabel="time [s]", ylabel="shoulder motor current i_FB (q axis) [A]",
           title="Shoulder backlash: current spikes at torque reversals (cf. paper Fig. 4)")
    ax.legend(fontsize=8)
    return fig
