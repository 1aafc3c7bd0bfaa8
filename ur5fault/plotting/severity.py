"""Severity figures for any swept effect: a feature against the fault size, one line per fault joint
(:func:`severity_figure`), and the same numbers as a fault joint x size heat map (:func:`heatmap`)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..campaign.summary import MANY_SIZES, EffectSweep, joint_feature, severity_table
from ..errors import ParameterError
from ..health.features import feature_label
from ..util.checks import short
from ._figure import check_ax, check_feature, check_kind, check_optional_number, figure_and_axes


def _display(feature: str) -> tuple[float, str]:
    """(factor, axis label) to show ``feature`` to a person: angles in degrees (the features are stored in
    radians, docs/outputs.md "Units"), everything else as stored."""
    label = feature_label(feature)
    if " [rad]" in label:
        return float(np.degrees(1.0)), label.replace(" [rad]", " [deg]")
    return 1.0, label


def _is_generic(df: pd.DataFrame, feature: str) -> bool:
    """A per-joint feature named without its ``_j{j}`` suffix."""
    return feature not in df.columns and f"{feature}_j1" in df.columns


def _check_sweep(sweep: object, feature: object, where: str) -> None:
    """An :class:`EffectSweep` with runs to draw, and a feature name."""
    if isinstance(sweep, str):  # effect_sweep's reason why an effect has no figure, or an effect's name
        raise ParameterError(f"{where}: sweep = {short(sweep)} must be an EffectSweep (effect_sweep(features, effect) "
                             "returns one, or a string saying why the effect has no figure)")
    check_kind(sweep, EffectSweep, f"{where}: sweep", "an EffectSweep (effect_sweep(features, effect))")
    if sweep.rows.empty:
        raise ParameterError(f"{where}: the {sweep.effect} sweep holds no successful run: nothing to draw")
    check_feature(feature, where)


def severity_figure(sweep: EffectSweep, feature: str = "tcp_dev_max_mm", *, healthy: pd.DataFrame | None = None,
                    threshold_mm: float | None = None, ax: Axes | None = None) -> Figure:
    """``feature`` against the fault size of one swept effect.

    Args:
        sweep: the effect's runs (:func:`ur5fault.campaign.summary.effect_sweep`).
        feature: a feature column, or a per-joint feature without ``_j{j}`` (read on the faulty joint).
        healthy: feature rows of the healthy runs, drawn as dotted reference lines.
        threshold_mm: the campaign's TCP threshold, drawn for ``tcp_dev_*`` features.
        ax: axes to draw into (default: a new figure).

    Returns:
        The figure.
    """
    _check_sweep(sweep, feature, "severity_figure")
    if healthy is not None:
        check_kind(healthy, pd.DataFrame, "severity_figure: healthy", "the healthy runs' feature rows (a pandas "
                   "DataFrame), or None")
    check_optional_number(threshold_mm, "severity_figure: threshold_mm")
    check_ax(ax, "severity_figure: ax")
    fig, ax = figure_and_axes(ax, (8, 4.5))
    scale, name = _display(feature)
    table = severity_table(sweep, feature) * scale
    values = joint_feature(sweep.rows, feature) * scale
    generic = _is_generic(sweep.rows, feature)
    # a sampled campaign's sizes are continuous, one run each on its own motion and conditions: a line through them
    # in size order zig-zags between motions, so its points stand alone (the effect's distinct sizes, as campaign
    # run counts them, not one joint's)
    style = "o" if table.shape[1] > MANY_SIZES else "o-"
    for k, (label, line) in enumerate(table.iterrows()):
        color = f"C{k % 10}"
        line = line.dropna()
        ax.plot(line.index, line.to_numpy(), style, color=color, ms=4, lw=1.2, label=f"J{label}" if sweep.per_joint
                else "robot")
        if sweep.per_joint:
            j = int(str(label).split()[0])
            pts = sweep.rows["fault_joint"] == j
        else:
            pts = np.ones(len(sweep.rows), bool)
        if pts.sum() > len(line):  # several runs per size (seeds, payloads): show them all
            ax.plot(sweep.rows.loc[pts, "size"], values[pts], ".", color=color, alpha=0.4, ms=3)
        if healthy is not None and len(healthy) and generic and sweep.per_joint:
            ax.axhline(healthy[f"{feature}_j{j}"].max() * scale, color=color, ls=":", lw=0.8)
    if healthy is not None and len(healthy) and not (generic and sweep.per_joint):
        ax.axhline(joint_feature(healthy, feature).max() * scale, color="k", ls=":", lw=0.8, label="healthy")
    if threshold_mm is not None and feature.startswith("tcp_dev_"):
        ax.axhline(threshold_mm, color="k", ls="--", lw=0.8, label=f"{threshold_mm:g} mm threshold")
    on = " of the faulty joint" if generic and sweep.per_joint else (" (max over joints)" if generic else "")
    title = f"{name.split(' [')[0]}{on} against {sweep.effect} size"
    if sweep.n_not_ok:
        title += f" ({sweep.n_not_ok} run(s) not ok, not shown)"
    ax.set(xlabel=sweep.label, ylabel=name + on, title=title)
    ax.legend(fontsize=8)
    return fig


def heatmap(sweep: EffectSweep, feature: str = "tcp_dev_max_mm", ax: Axes | None = None) -> Figure:
    """``feature`` (largest over repeated runs) by fault joint x fault size, values written in the cells."""
    _check_sweep(sweep, feature, "heatmap")
    check_ax(ax, "heatmap: ax")
    fig, ax = figure_and_axes(ax, (8, 4.5))
    scale, name = _display(feature)
    table = severity_table(sweep, feature) * scale
    im = ax.imshow(table.to_numpy(), aspect="auto", cmap="viridis")
    ax.set_xticks(range(table.shape[1]), [f"{v:g}" for v in table.columns])
    ax.set_yticks(range(table.shape[0]), [f"J{label}" for label in table.index] if sweep.per_joint else table.index)
    ax.set_xlabel(sweep.label)
    for (r, c), v in np.ndenumerate(table.to_numpy()):
        ax.text(c, r, f"{v:.3g}", ha="center", va="center", color="w", fontsize=7)
    fig.colorbar(im, ax=ax, label=name)
    ax.set_title(f"{name.split(' [')[0]} by fault joint and {sweep.effect} size")
    return fig

