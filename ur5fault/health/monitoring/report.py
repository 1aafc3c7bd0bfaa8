"""What ``ur5fault monitor`` writes: ``monitor.json``, ``baseline.json``, ``report.md`` and one figure per log
(the current residual's transient against its limit per joint, the events shaded)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ...sim.axes import JOINT_NAMES, N_JOINTS
from ...util.io import write_figure_atomic, write_json_atomic, write_text_atomic
from .baseline import Baseline, segment
from .changes import sentence
from .events import FEATURES, WINDOW_S, multiplier
from .observe import Observed
from .verdict import limit_A


def figure(baseline: Baseline, obs: Observed, entry: dict[str, Any]) -> Figure:
    """Per joint: the residual's transient ``|h|`` [A] and its limit (the baseline's spread at the log's motion
    times the multiplier for its length); the log's events shaded."""
    h, feats, judged = segment(obs)
    dev = np.where(judged[:, None], np.abs(h), np.nan)
    thr = limit_A(baseline, feats, judged)
    fig = Figure(figsize=(10, 9), layout="constrained")
    axes = fig.subplots(N_JOINTS, 1, sharex=True)
    for j, ax in enumerate(axes):
        ax.plot(obs.t_s, dev[:, j], lw=0.7, color="tab:blue", label="|transient| (residual - its running median)")
        ax.plot(obs.t_s, thr[:, j], lw=0.9, color="tab:red", label="limit")
        for ev in entry["events"]:
            ax.axvspan(ev["t_start_s"], ev["t_end_s"], color="orange", alpha=0.35 if JOINT_NAMES[j] in ev["joints"]
                       else 0.1, lw=0)
        ax.set_ylabel(f"J{j + 1} [A]")
    axes[0].legend(loc="upper right", fontsize=7)
    axes[0].set_title(f"{obs.name}: {entry['verdict']} (events shaded)")
    axes[-1].set_xlabel("log time [s]")
    return fig


def markdown(baseline: Baseline, entries: Sequence[dict[str, Any]], figs: Sequence[str], model: str) -> str:
    lines = ["# Monitoring report", "",
             f"Baseline: model overlay `{model}`, residual statistics of {len(baseline.segments)} healthy run(s): "
             + ", ".join(f"`{s}`" for s in baseline.segments) + ".", "",
             "Spread of the current residual's transient, sigma^2 = c . [" + ", ".join(FEATURES) + "], and the "
             f"multiplier on sigma for a 20 s log ({int(20 / WINDOW_S)} windows of {WINDOW_S:g} s):", "",
             "| joint | " + " | ".join(f"c[{f}]" for f in FEATURES) + " | multiplier (20 s) |",
             "| --- |" + " --- |" * (len(FEATURES) + 1)]
    mult = multiplier(baseline.tail, int(20 / WINDOW_S))
    for j in range(N_JOINTS):
        lines.append(f"| {JOINT_NAMES[j]} | " + " | ".join(f"{c:.3g}" for c in baseline.scale[j])
                     + f" | {mult[j]:.2f} |")
    lines += ["", "| log | verdict | changes | events |", "| --- | --- | --- | --- |"]
    for e in entries:
        lines.append(f"| {e['log']} | {e['verdict']} | {len(e['changes'])} | {len(e['events'])} |")
    for e, fig in zip(entries, figs):
        lines += ["", f"## {e['log']}: {e['verdict']}", ""]
        lines += [f"- changed: {sentence(c)}" for c in e["changes"]]
        lines += [f"- event {ev['t_start_s']:.2f}-{ev['t_end_s']:.2f} s on {', '.join(ev['joints'])}, peak "
                  f"{ev['peak_A']:.2f} A" for ev in e["events"]]
        if not e["changes"] and not e["events"]:
            lines.append("- nothing beyond what the baseline runs showed")
        lines += ["", f"![{e['log']}]({fig})"]
    return "\n".join(lines) + "\n"


def write(out: Path, baseline: Baseline, observed: Sequence[Observed], entries: Sequence[dict[str, Any]],
          model: str) -> list[Path]:
    """Write every output into ``out`` (created), atomically; returns the paths, ``monitor.json`` first."""
    out.mkdir(parents=True, exist_ok=True)
    paths = [write_json_atomic(out / "monitor.json", {"logs": list(entries)}),
             write_json_atomic(out / "baseline.json", baseline.to_json())]
    figs = []
    for k, (obs, e) in enumerate(zip(observed, entries)):
        name = f"monitor_{k + 1}.png"
        paths.append(write_figure_atomic(figure(baseline, obs, e), out / name))
        figs.append(name)
    paths.append(write_text_atomic(out / "report.md", markdown(baseline, entries, figs, model)))
    return paths
