"""Figures of the benchmark, as matplotlib ``Figure`` objects (no backend is chosen here; the
report saves them, a notebook shows them): ROC curves, detectability vs size, backlash detection
per joint, confusion matrices, permutation importance."""

from __future__ import annotations

from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import NullFormatter

from ...sim.axes import JOINT_NAMES
from .metrics import FALSE_ALARM_RATE


def roc_curves(y_kind: np.ndarray, score: np.ndarray, ax=None) -> Figure:
    """Test ROC curve of the detector for each fault kind against the healthy runs."""
    from sklearn.metrics import roc_curve

    fig, ax = _axes(ax, (6, 5))
    healthy = y_kind == "healthy"
    for kind in sorted(set(y_kind) - {"healthy"}):
        keep = healthy | (y_kind == kind)
        fpr, tpr, _ = roc_curve((y_kind[keep] == kind).astype(int), score[keep])
        ax.plot(fpr, tpr, lw=1.2, label=kind)
    ax.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls=":", label="chance")
    ax.axvline(FALSE_ALARM_RATE, color="0.3", lw=0.8, ls="--", label=f"{FALSE_ALARM_RATE:.0%} false alarms")
    ax.set(xlabel="false-alarm rate (healthy test runs flagged)", ylabel="detection rate",
           title="Detection on the test split, all fault sizes")
    ax.legend(fontsize=7, loc="lower right")
    return fig


def auc_vs_size(detection: dict[str, Any]) -> Figure:
    """Detection AUC per fault-size bin, one panel per kind (error bars: Hanley-McNeil s.e.)."""
    kinds = sorted(detection["per_kind"])
    ncol = min(4, max(1, len(kinds)))
    nrow = -(-len(kinds) // ncol)
    fig = Figure(figsize=(3.2 * ncol, 2.8 * nrow), layout="constrained")
    axes = fig.subplots(nrow, ncol, squeeze=False)
    for ax, kind in zip(axes.flat, kinds):
        info = detection["per_kind"][kind]
        b = [x for x in info["by_size"] if np.isfinite(x["auc"])]
        mid = [np.sqrt(x["size_lo"] * x["size_hi"]) for x in b]
        ax.axhline(0.5, color="0.6", lw=0.8, ls=":")
        if b:
            ax.errorbar(mid, [x["auc"] for x in b], yerr=[x["auc_se"] for x in b], marker="o", ms=4, capsize=2)
            ax.set_xscale("log")
            ax.xaxis.set_minor_formatter(NullFormatter())  # minor labels of a short log axis overlap
        else:
            ax.text(0.5, 0.5, "too few test runs per size bin", ha="center", va="center", transform=ax.transAxes,
                    fontsize=8)
        ax.set_ylim(0.3, 1.02)
        ax.set_title(kind, fontsize=9)
        ax.set_xlabel(f"fault size [{info['unit']}]", fontsize=8)
        ax.set_ylabel("ROC AUC vs healthy", fontsize=8)
    for ax in list(axes.flat)[len(kinds):]:
        ax.set_visible(False)
    fig.suptitle("Detectability vs fault size (test split)", fontsize=10)
    return fig


def backlash_detectability(alpha: np.ndarray, joint: np.ndarray, hit: np.ndarray, thresholds: dict[str, Any]) -> Figure:
    """Backlash runs flagged at 5 % false alarms vs alpha, per joint, with the logistic fit and alpha_90."""
    from .thresholds import fit_logistic

    fig = Figure(figsize=(11, 5.5), layout="constrained")
    axes = fig.subplots(2, 3, sharex=True, sharey=True)
    grid = np.geomspace(max(alpha.min(), 1e-4) if alpha.size else 1e-3, alpha.max() if alpha.size else 1, 100)
    paper = thresholds["paper"]["alpha_deg"]
    for j, ax in zip(range(1, 7), axes.flat):
        on = joint == j
        rng = np.random.default_rng(j)
        ax.plot(alpha[on], hit[on] + rng.uniform(-0.04, 0.04, on.sum()), "o", ms=3, alpha=0.6)
        ab = fit_logistic(np.log(alpha[on]), hit[on]) if on.sum() >= 2 else None
        if ab is not None:
            ax.plot(grid, 1 / (1 + np.exp(-(ab[0] + ab[1] * np.log(grid)))), lw=1.2)
        a90 = thresholds["per_joint"][str(j)].get("alpha_90_deg", np.nan)
        if np.isfinite(a90):
            ax.axvline(a90, color="C3", lw=1, label=f"alpha_90 = {a90:.3g} deg")
        ax.axvline(paper, color="0.3", ls="--", lw=0.8, label=f"paper {paper:g} deg")
        ax.axhline(0.9, color="0.6", ls=":", lw=0.8)
        if alpha.size:
            ax.set_xscale("log")
        if not on.any():
            ax.text(0.5, 0.5, "no test runs", ha="center", va="center", transform=ax.transAxes, fontsize=8)
        ax.set_title(f"J{j} {JOINT_NAMES[j - 1]}", fontsize=9)
        ax.legend(fontsize=7, loc="center left")
    for ax in axes[1]:
        ax.set_xlabel("backlash alpha [deg]")
    for ax in axes[:, 0]:
        ax.set_ylabel("flagged (5 % false alarms)")
    fig.suptitle("Backlash detectability per joint (test split)", fontsize=10)
    return fig


def confusion_matrices(localisation: dict[str, Any], kind: dict[str, Any]) -> Figure:
    """Row-normalised confusion matrices: joint (localisation) and fault kind."""
    fig = Figure(figsize=(13, 5.5), layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, width_ratios=[1, 1.5])
    for ax, info, title in ((ax1, localisation, "fault joint"), (ax2, kind, "fault kind")):
        if "confusion" not in info:
            ax.set_visible(False)
            continue
        m = np.asarray(info["confusion"], float)
        norm = m / np.maximum(m.sum(axis=1, keepdims=True), 1)
        im = ax.imshow(norm, vmin=0, vmax=1, cmap="Blues")
        labels = [str(x) for x in info["labels"]]
        ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right", fontsize=7)
        ax.set_yticks(range(len(labels)), labels, fontsize=7)
        for (r, c), v in np.ndenumerate(m):
            if v:
                ax.text(c, r, int(v), ha="center", va="center", fontsize=7, color="white" if norm[r, c] > 0.5 else "k")
        ax.set(xlabel="predicted", ylabel="true", title=f"{title}: accuracy {info['accuracy']:.2f} (test)")
        fig.colorbar(im, ax=ax, shrink=0.8, label="share of the true class")
    return fig


def importance_bars(importance: list[dict[str, Any]], ax=None) -> Figure:
    """Permutation importance of the detector's inputs (drop of test ROC AUC)."""
    fig, ax = _axes(ax, (6, 0.28 * max(len(importance), 4) + 1))
    names = [x["feature"] for x in importance][::-1]
    ax.barh(names, [x["auc_drop_mean"] for x in importance][::-1], xerr=[x["auc_drop_std"] for x in importance][::-1])
    ax.tick_params(axis="y", labelsize=7)
    ax.set(xlabel="drop of detection ROC AUC when the input is shuffled", title="What the detector uses")
    return fig


def reliability_diagram(test: dict[str, Any], ax=None) -> Figure:
    """Reliability on the test split: per probability bin, the share of faulty runs against the mean
    probability, for the score (the classifier by joint's largest joint probability of a fault) and the
    calibrated one (``test``: :mod:`.calibration`'s ``test_reliability``); the diagonal is a perfectly
    calibrated probability."""
    fig, ax = _axes(ax, (5, 5))
    styles = {"detector": ("0.45", "s", "by-joint score itself"), "calibrated": ("C0", "o", "calibrated (Platt)"),
              "isotonic": ("C2", "^", "isotonic (comparison)")}
    for key, rel in test.items():
        color, marker, label = styles.get(key, ("k", "x", key))
        b = rel["bins"]
        sizes = 12 + 60 * np.sqrt(np.array([x["n"] for x in b]) / max(rel["n"], 1))
        ax.plot([x["mean_p"] for x in b], [x["share_faulty"] for x in b], color=color, lw=1, alpha=0.8)
        ax.scatter([x["mean_p"] for x in b], [x["share_faulty"] for x in b], s=sizes, color=color, marker=marker,
                   label=f"{label}: Brier {rel['brier']:.3f}, ECE {rel['ece']:.3f}")
    ax.plot([0, 1], [0, 1], color="0.6", lw=0.8, ls=":", label="calibrated exactly")
    ax.set(xlim=(0, 1), ylim=(0, 1), xlabel="mean p(fault) in the bin", ylabel="share of faulty test runs",
           title="Reliability of p(fault), test split (marker area ~ runs)")
    ax.legend(fontsize=7, loc="upper left")
    return fig


def _axes(ax, size):
    if ax is not None:
        return ax.figure, ax
    fig = Figure(figsize=size, layout="constrained")
    return fig, fig.subplots()
