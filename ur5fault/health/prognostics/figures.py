"""Figures of the RUL benchmark as matplotlib ``Figure`` objects (saved by report.py)."""

from __future__ import annotations

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from .metrics import ALPHA, LAMBDA


def rul_alpha_cone(pred: dict[str, pd.DataFrame], alpha: float = ALPHA) -> Figure:
    """Estimated vs true RUL over life (both as fractions of each unit's life), with the alpha cone:
    one panel per estimator, one line per held-out unit, the median unit's 5-95 % band shaded."""
    fig = Figure(figsize=(5.2 * len(pred), 4.4), layout="constrained")
    axes = fig.subplots(1, len(pred), sharey=True, squeeze=False)[0]
    x = np.linspace(0, 1, 50)
    for ax, (name, p) in zip(axes, pred.items()):
        ax.fill_between(x, (1 - alpha) * (1 - x), (1 + alpha) * (1 - x), color="0.85", label=f"alpha = {alpha:g} cone")
        ax.plot(x, 1 - x, color="k", lw=1.2, label="true RUL")
        for _, d in p.groupby("unit_id"):
            d = d.sort_values("cycles")
            f, eol = d["cycles"] / d["eol_cycles"], d["eol_cycles"]
            ax.plot(f, d["rul_est"] / eol, lw=0.8, alpha=0.7)
            if "rul_lo" in d:
                ax.fill_between(f, d["rul_lo"] / eol, d["rul_hi"] / eol, alpha=0.06, color="C0")
        for sign in (-1, 1):  # the cone's edges on top of the bands
            ax.plot(x, (1 + sign * alpha) * (1 - x), color="k", lw=0.8, ls="--")
        ax.axvline(LAMBDA, color="0.4", ls=":", lw=0.8, label=f"lambda = {LAMBDA:g}")
        ax.set(xlabel="life fraction (cycles / end of life)", title=f"{name}: {p['unit_id'].nunique()} held-out units",
               xlim=(0, 1), ylim=(0, 2.0))
        ax.legend(fontsize=7, loc="upper right")
    axes[0].set_ylabel("RUL / end of life")
    return fig


def health_index_paths(df: pd.DataFrame, hi: np.ndarray, level: float) -> Figure:
    """Health index of every unit over its cycles (train grey, test coloured) and the failure level."""
    fig = Figure(figsize=(7, 4.4), layout="constrained")
    ax = fig.subplots()
    d = df.assign(_hi=hi)
    for (_, split), g in d.groupby(["unit_id", "split"]):
        g = g.sort_values("cycles")
        ax.plot(g["cycles"], g["_hi"], lw=0.8 if split == "test" else 0.5,
                color=None if split == "test" else "0.7", alpha=0.9 if split == "test" else 0.6)
    ax.axhline(level, color="C3", ls="--", lw=1, label=f"failure level {level:.2f} (criterion = threshold)")
    ax.set(xlabel="duty cycles", ylabel="health index (-)", title="Health index per unit (grey: train, colour: test)")
    ax.legend(fontsize=7, loc="upper left")
    return fig
