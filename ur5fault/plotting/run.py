"""One run's time series in one figure (``ur5fault show``): setpoint against resolver, tracking error,
encoder mismatch, motor currents and TCP deviation, joints in the same colours in every panel."""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..errors import ParameterError
from ..sim.axes import JOINT_NAMES, N_JOINTS
from ..util.checks import short
from .paper import TCP_COLUMNS, tcp_deviation_mm

#: panels of :func:`run_figure`, top to bottom
PANELS = ("joint angle", "tracking error", "encoder mismatch", "motor current", "TCP deviation")
#: gear ratio assumed when the table carries no ``gear_ratio`` metadata (UR5, all joints; ../shared/ur5-facts.md)
DEFAULT_GEAR_RATIO = 101.0


def _joint_cols(name: str) -> list[str]:
    return [f"{name}_j{j}" for j in range(1, N_JOINTS + 1)]


def _check_run_arguments(series: object, twin: object, title: object) -> None:
    for name, value in (("series", series), ("twin", twin)):
        if value is None and name == "twin":
            continue
        if not isinstance(value, pd.DataFrame):
            hint = (" (a SimResult: give res.to_pandas(run))" if type(value).__name__ == "SimResult"
                    else " (a file: read it with pandas.read_parquet, or draw it with `ur5fault show FILE`)"
                    if isinstance(value, (str, os.PathLike)) else "")
            raise ParameterError(f"{name} = {short(value)} must be a run's time-series table (a pandas DataFrame)"
                                 f"{hint}")
    if title is not None and not isinstance(title, str):
        raise ParameterError(f"title = {short(title)} must be a string, or None for the run's own")


def _gear_ratio(value: object) -> np.ndarray:
    """One gear ratio per joint (a single number: every joint's), each finite and > 0."""
    ratio = None
    if not isinstance(value, (str, bytes)):
        try:
            ratio = np.broadcast_to(np.asarray(value, dtype=float), (N_JOINTS,))
        except (TypeError, ValueError):
            pass
    if ratio is None or not np.all(np.isfinite(ratio)) or not np.all(ratio > 0):
        raise ParameterError(f"gear_ratio = {short(value)} must be one positive number or {N_JOINTS}, one per joint")
    return ratio


def columns_without_values(series: pd.DataFrame, twin: pd.DataFrame | None = None) -> list[str]:
    """The columns :func:`run_figure` draws that hold no finite value at all (NaN or inf in every row): their curves
    are missing from the figure. A column finite in some rows (a run stopped early: NaN after its stop) is drawn
    there and not named; the twin's are named ``twin COLUMN``."""
    drawn = ["t_s", *_joint_cols("q_set_rad"), *_joint_cols("q_FB_rad"), *_joint_cols("i_FB_A")]
    for group in (_joint_cols("q_M_FB_rad"), [*TCP_COLUMNS, "tcp_des_x_m", "tcp_des_y_m", "tcp_des_z_m"]):
        if all(c in series.columns for c in group):  # as run_figure draws them: a group only whole
            drawn += group
    tables = [("", series, drawn)] + ([("twin ", twin, TCP_COLUMNS)] if twin is not None else [])
    return [f"{prefix}{c}" for prefix, table, cols in tables for c in cols if c in table.columns
            and not np.isfinite(pd.to_numeric(table[c], errors="coerce").to_numpy(dtype=float)).any()]


def run_figure(series: pd.DataFrame, twin: pd.DataFrame | None = None, *, gear_ratio: Sequence[float] | None = None,
               title: str | None = None, axes: Sequence[Axes] | None = None) -> Figure:
    """Draw one run.

    Args:
        series: the run's wide time-series table (``SimResult.to_pandas``, a ``simulate`` Parquet file or a
            campaign's ``timeseries/<run_id>.parquet``; columns in docs/outputs.md).
        twin: the healthy twin's table; the TCP panel then shows the deviation from it as well.
        gear_ratio: per joint, for the encoder mismatch ``q_M_FB / N - q_FB`` (default: the table's
            ``attrs["ur5fault"]["gear_ratio"]``, else 101).
        title: figure title (default: run id, effects and status from the table's metadata).
        axes: five axes to draw into, in the order of :data:`PANELS` (default: a new figure).

    Returns:
        The figure.
    """
    _check_run_arguments(series, twin, title)
    need = ["t_s", *_joint_cols("q_set_rad"), *_joint_cols("q_FB_rad"), *_joint_cols("i_FB_A")]
    missing = [c for c in need if c not in series.columns]
    if missing and len(series) == 1 and "run_id" in series.columns:  # a campaign's run file: one row of features
        raise ParameterError(f"a campaign's run file (one row of features), not a time series: give `ur5fault show "
                             f"{series['run_id'].iloc[0]} --campaign DIR` (DIR: the campaign's folder; the run is "
                             "simulated again if its time series was not saved)")
    if missing:
        raise ParameterError(f"time series lacks column {missing[0]!r} (a ur5fault time series has {need[0]}, "
                             "q_set_rad_j1.., q_FB_rad_j1.., i_FB_A_j1..: a table of `ur5fault simulate` or "
                             "SimResult.to_pandas)")
    if series.empty:
        raise ParameterError("series: the time series has no rows: nothing to draw")
    if twin is not None:
        lacking = [c for c in TCP_COLUMNS if c not in twin.columns]
        if lacking:
            raise ParameterError(f"twin: the healthy twin's table lacks column {lacking[0]!r} (its TCP is what the "
                                 "run's deviation is measured from)")
        if len(twin) != len(series):
            raise ParameterError(f"twin: {len(twin)} samples, the run {len(series)}: give the twin of the same "
                                 "motion, duration and log period")
    meta = series.attrs.get("ur5fault", {})
    ratio = _gear_ratio(gear_ratio if gear_ratio is not None else meta.get("gear_ratio", [DEFAULT_GEAR_RATIO] * 6))
    if axes is None:
        fig = Figure(figsize=(10, 12), layout="constrained")
        axes = fig.subplots(len(PANELS), 1, sharex=True)
    elif not hasattr(axes, "__len__") or not all(isinstance(a, Axes) for a in np.ravel(np.asarray(axes, object))):
        raise ParameterError(f"axes = {short(axes)} must be {len(PANELS)} matplotlib Axes ({', '.join(PANELS)})")
    elif len(axes) != len(PANELS):
        raise ParameterError(f"axes: {len(axes)} given, run_figure draws {len(PANELS)} panels ({', '.join(PANELS)})")
    fig = axes[0].figure
    t = series["t_s"].to_numpy()
    q_set = series[_joint_cols("q_set_rad")].to_numpy()
    q_fb = series[_joint_cols("q_FB_rad")].to_numpy()
    a_ang, a_err, a_mis, a_cur, a_tcp = axes
    for j in range(N_JOINTS):
        c, lab = f"C{j}", f"J{j + 1} {JOINT_NAMES[j]}"
        a_ang.plot(t, np.degrees(q_set[:, j]), color=c, lw=3, alpha=0.3)
        a_ang.plot(t, np.degrees(q_fb[:, j]), color=c, lw=0.8, label=lab)
        a_err.plot(t, np.degrees(q_set[:, j] - q_fb[:, j]), color=c, lw=0.7)
        a_cur.plot(t, series[f"i_FB_A_j{j + 1}"], color=c, lw=0.6)
    a_ang.set_ylabel("joint angle [deg]\nsetpoint (wide), resolver")
    a_ang.legend(fontsize=7, ncol=6, loc="lower center", bbox_to_anchor=(0.5, 1.0), frameon=False)
    a_err.set_ylabel("tracking error [deg]\nsetpoint - resolver")
    a_cur.set_ylabel("motor current [A]\n(current sensor)")
    if all(c in series.columns for c in _joint_cols("q_M_FB_rad")):
        mis = series[_joint_cols("q_M_FB_rad")].to_numpy() / ratio - q_fb
        for j in range(N_JOINTS):
            a_mis.plot(t, np.degrees(mis[:, j]), color=f"C{j}", lw=0.7)
        a_mis.set_ylabel("encoder mismatch [deg]\nmotor encoder / N - resolver")
    else:
        a_mis.text(0.5, 0.5, "no motor encoder (q_M_FB_rad) in this table", ha="center", transform=a_mis.transAxes)
    if all(c in series.columns for c in TCP_COLUMNS + ["tcp_des_x_m"]):
        des = series[["tcp_des_x_m", "tcp_des_y_m", "tcp_des_z_m"]].to_numpy()
        a_tcp.plot(t, np.linalg.norm(series[TCP_COLUMNS].to_numpy() - des, axis=1) * 1e3, color="0.4", lw=0.7,
                   label="from desired TCP")
        if twin is not None:
            a_tcp.plot(t, tcp_deviation_mm(series, twin), color="C3", lw=0.8, label="from healthy twin")
        a_tcp.legend(fontsize=7)
        a_tcp.set_ylabel("TCP deviation [mm]")
    else:
        a_tcp.text(0.5, 0.5, "no TCP columns in this table", ha="center", transform=a_tcp.transAxes)
    a_tcp.set_xlabel("time [s]")
    if title is None:
        effects = meta.get("effects")
        effects = "effects unknown" if effects is None else "; ".join(effects) or "healthy"
        title = f"{meta.get('run_id', 'run')}: {effects} ({meta.get('status', 'status unknown')})"
    fig.suptitle(title, fontsize=10)
    return fig
