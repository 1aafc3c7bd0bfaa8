"""What ``ur5fault monitor`` writes: ``monitor.json``, ``baseline.json``, ``report.md`` and one figure per log
(each residual's transient against its limit per joint, current and position, the events shaded, the stretches
judged against a baseline run that repeats the task tinted)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import NDArray

from ...sim.axes import JOINT_NAMES, N_JOINTS
from ...util.io import (
    checksum_path,
    remove_unwritten,
    write_figure_atomic,
    write_json_atomic,
    write_text_atomic,
)
from .baseline import Baseline
from .changes import sentence
from .events import CHANNELS, FALSE_ALARM_PER_LOG, FEATURES, UNITS, WINDOW_S, event_limits, multiplier
from .observe import Observed
from .verdict import transients_and_limits


def figure(baseline: Baseline, obs: Observed, entry: dict[str, Any], channels: Sequence[str],
           judged_as: tuple | None = None) -> Figure:
    """Per joint and channel (current [A] left, position [mrad] right): the residual's transient ``|h|`` and, for
    the ``channels`` judged, its limit (the baseline's spread at the log's motion times the multiplier for its
    length); the events shaded, and over each event, on the joints it names, the limit for the event's own
    windows that named them (:func:`.events.name_joints`: below the log's where the event is shorter than the log).
    ``judged_as``: :func:`.verdict.transients_and_limits` of the log, when already made."""
    hs, limits_at, judged, paired = judged_as or transients_and_limits(baseline, obs, channels)
    thr = limits_at(1.0)
    own = event_limits(entry["events"], obs.t_s, limits_at, judged, baseline.period_s)
    h = [hs[c] for c in CHANNELS]
    fig = Figure(figsize=(13, 9), layout="constrained")
    axes = fig.subplots(N_JOINTS, len(CHANNELS), sharex=True)
    for i, c in enumerate(CHANNELS):
        k = 1e3 if c == "position" else 1.0  # rad -> mrad on the axis
        unit = "mrad" if c == "position" else UNITS[c]
        dev = np.where(judged[:, None], np.abs(h[i]), np.nan) * k
        for j in range(N_JOINTS):
            ax = axes[j, i]
            ax.plot(obs.t_s, dev[:, j], lw=0.7, color="tab:blue", label=f"|{c} transient| (residual - its running "
                                                                         "median)")
            if c in thr:
                lim = thr[c][:, j] * k
                ax.plot(obs.t_s, lim, lw=0.9, color="tab:red", label="limit")
                _clip_to_the_transient(ax, dev[:, j], np.where(judged, lim, np.nan), unit)
            if c == "current" and paired.any():
                ax.fill_between(obs.t_s, 0, 1, where=paired, transform=ax.get_xaxis_transform(), color="tab:green",
                                alpha=0.08, lw=0, label="against a baseline run repeating the task")
            for ev, (sl, lims) in zip(entry["events"], own):
                mine = JOINT_NAMES[j] in ev["joints"] and c in ev.get("channels", ())
                ax.axvspan(ev["t_start_s"], ev["t_end_s"], color="orange", alpha=0.35 if mine else 0.1, lw=0)
                if mine and c in lims:
                    ax.plot(obs.t_s[sl], lims[c][sl, j] * k, lw=0.9, ls="--", color="tab:red",
                            label="limit for the event's own windows")
            ax.set_ylabel(f"J{j + 1} [{unit}]")
        handles = {}  # every label of the column once (an event's own limit is drawn on the joints it names)
        for ax in axes[:, i]:
            for hnd, lab in zip(*ax.get_legend_handles_labels()):
                handles.setdefault(lab, hnd)
        axes[0, i].legend(handles.values(), handles.keys(), loc="upper right", fontsize=7)
        axes[-1, i].set_xlabel("log time [s]")
    fig.suptitle(f"{obs.name}: {entry['verdict']} (events shaded)")
    return fig


def _clip_to_the_transient(ax, dev: NDArray, lim: NDArray, unit: str) -> None:
    """Where a few stretches' limit dwarfs the rest (a motion condition the baseline held little of is judged
    by its widest statistics), the axis shows the transient and the typical limit, and says how far the limit
    goes beyond it."""
    if not np.isfinite(lim).any():
        return
    top = 1.5 * max(float(np.nanmax(dev)) if np.isfinite(dev).any() else 0.0, float(np.nanmedian(lim)))
    peak = float(np.nanmax(lim))
    if top > 0 and peak > 2.0 * top:
        ax.set_ylim(0.0, top)
        ax.text(0.01, 0.95, f"limit up to {peak:.3g} {unit} (off the axis)", transform=ax.transAxes, fontsize=7,
                va="top", color="tab:red")


def markdown(baseline: Baseline, entries: Sequence[dict[str, Any]], figs: Sequence[str], model: str,
             channels: Sequence[str], paired_s: Sequence[tuple[float, float]] = (), notes: Sequence[str] = ()) -> str:
    """``paired_s``: per log, the seconds judged against a baseline run repeating its task, and its judged
    seconds; ``notes``: what the logs' reading assumed (no temperatures, gaps filled, ...)."""
    lines = ["# Monitoring report", "",
             f"Baseline: model overlay `{model}`, residual statistics of {len(baseline.segments)} healthy run(s): "
             + ", ".join(f"`{s}`" for s in baseline.segments) + ".", "",
             f"Events judged on the {' and '.join(channels)} residual. Spread of each residual's transient, "
             "sigma^2 = c . [" + ", ".join(FEATURES) + "] (current [A^2], position [rad^2]), and the multiplier on "
             f"sigma for a 20 s log ({int(20 / WINDOW_S)} windows of {WINDOW_S:g} s, the false-alarm probability "
             "split between the channels judged):", "",
             "| channel | joint | " + " | ".join(f"c[{f}]" for f in FEATURES) + " | multiplier (20 s) |",
             "| --- | --- |" + " --- |" * (len(FEATURES) + 1)]
    for i, ch in enumerate(CHANNELS):
        mult = multiplier(baseline.tail[i], int(20 / WINDOW_S), FALSE_ALARM_PER_LOG / len(channels))
        for j in range(N_JOINTS):
            lines.append(f"| {ch} | {JOINT_NAMES[j]} | " + " | ".join(f"{c:.3g}" for c in baseline.scale[i, j])
                         + f" | {mult[j]:.2f} |")
    lines += ["", "| log | verdict | changes | events | events not seen on |", "| --- | --- | --- | --- | --- |"]
    for e in entries:
        lines.append(f"| {e['log']} | {e['verdict']} | {len(e['changes'])} | {len(e['events'])} | "
                     f"{', '.join(e.get('events_not_seen', ())) or '-'} |")
    for k, (e, fig) in enumerate(zip(entries, figs)):
        lines += ["", f"## {e['log']}: {e['verdict']}", ""]
        lines += [f"- changed: {sentence(c)}" for c in e["changes"]]
        lines += [f"- event {ev['t_start_s']:.2f}-{ev['t_end_s']:.2f} s on {', '.join(ev['joints'])} "
                  f"({' and '.join(ev['channels'])}), peak {ev['peak_A']:.2f} A, {ev['peak_rad'] * 1e3:.3f} mrad"
                  for ev in e["events"]]
        if not e["changes"] and not e["events"]:
            lines.append("- nothing beyond what the baseline runs showed" + (
                f" (events not seen on {', '.join(e['events_not_seen'])}: note below)" if e.get("events_not_seen")
                else ""))
        if paired_s:
            lines.append(f"- current judged against a baseline run repeating its task on {paired_s[k][0]:.1f} of "
                         f"{paired_s[k][1]:.1f} s (elsewhere against the baseline's spread at its motion)")
        lines += [f"- note: {n}" for n in e.get("notes", ())]
        for c, per in (e.get("event_limit_median") or {}).items():
            lines.append(f"- {c} event limit at this log's motion (median over its judged samples): "
                         + ", ".join(f"{jn} {v:.3g}" for jn, v in per.items()) + f" {UNITS[c]}")
        lines += ["", f"![{e['log']}]({fig})"]
    if notes:
        lines += ["", "## Assumed", ""] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def write(out: Path, baseline: Baseline, observed: Sequence[Observed], entries: Sequence[dict[str, Any]],
          model: str, channels: Sequence[str], verified: bool = True, notes: Sequence[str] = ()) -> list[Path]:
    """Write every output into ``out`` (created), atomically; returns the paths, ``monitor.json`` first.
    ``verified``: the baseline's statistics were built here or read against their checksum; a baseline read
    unverified is written without one (a fresh checksum would vouch for what nothing checked). ``notes``: what
    the logs' reading assumed, printed as ``note:`` lines, kept in ``monitor.json`` and ``report.md`` too."""
    out.mkdir(parents=True, exist_ok=True)  # inside the command's result_folder, which clears stale temporaries
    if not verified:  # an earlier result's (--replace), removed first: a crash between would leave it mismatched
        checksum_path(out / "baseline.json").unlink(missing_ok=True)
    paths = [write_json_atomic(out / "monitor.json", {"logs": list(entries), "notes": list(notes)}),
             write_json_atomic(out / "baseline.json", baseline.to_json(), checksum=verified)]
    figs, paired_s = [], []
    for k, (obs, e) in enumerate(zip(observed, entries)):
        name = f"monitor_{k + 1}.png"
        judged_as = transients_and_limits(baseline, obs, channels)
        paired_s.append((float((judged_as[3] & judged_as[2]).sum() * obs.period_s),
                         float(judged_as[2].sum() * obs.period_s)))
        paths.append(write_figure_atomic(figure(baseline, obs, e, channels, judged_as), out / name))
        figs.append(name)
    remove_unwritten(out, "monitor_*.png", paths)  # an earlier result's figures of more logs (--replace)
    paths.append(write_text_atomic(out / "report.md", markdown(baseline, entries, figs, model, channels,
                                                               paired_s, notes)))
    return paths
