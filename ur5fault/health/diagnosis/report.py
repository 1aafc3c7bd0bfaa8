"""``diagnosis.json``, ``report.md`` and ``diagnosis.png`` of a diagnosed log."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...util.io import write_figure_atomic, write_json_atomic, write_text_atomic
from .baseline import ROBOT_THRESHOLD_FROM, set_by_sentence

JSON_FILE, REPORT_FILE, FIGURE_FILE = "diagnosis.json", "report.md", "diagnosis.png"


def _figure(d: dict[str, Any]):
    """Per window: the fault probability and each joint's share, with the 5 % false-alarm threshold."""
    from matplotlib.figure import Figure

    w = d["windows"]
    mid = np.array([(x["start_s"] + x["end_s"]) / 2 for x in w])
    fig = Figure(figsize=(8, 4.5), layout="constrained")
    ax = fig.add_subplot(2, 1, 1)
    ax.step(mid, [x["p_fault"] for x in w], where="mid", color="k", label="p(fault)")
    ft = d.get("flag_threshold") or {"p_fault": d["detector"]["p_fault_at_threshold"]}
    robot = ft["p_fault"] != d["detector"]["p_fault_at_threshold"]
    ax.axhline(ft["p_fault"], color="r", ls="--", lw=1,
               label="robot's own threshold (healthy baseline held out)" if robot else
               "threshold at 5 % false alarms (training runs)")
    ax.set_ylim(0, 1.02)
    ax.set_ylabel("p(fault)")
    ax.legend(loc="upper right", fontsize=7)
    ax.set_title(f"{d['log']}: {d['n_flagged']} of {d['n_windows']} windows of {d['detector']['window_s']:.3g} s "
                 "flagged", fontsize=9)
    ax2 = fig.add_subplot(2, 1, 2, sharex=ax)
    pj = np.array([[j["p_fault_joint"] or 0.0 for j in x["joints"]] for x in w])
    for j in range(pj.shape[1]):
        ax2.plot(mid, pj[:, j], marker="o", ms=3, label=f"J{j + 1}")
    ax2.set_ylim(0, 1.02)
    ax2.set_xlabel("window centre [s]")
    ax2.set_ylabel("p(fault on joint)")
    ax2.legend(ncol=6, fontsize=7, loc="upper right")
    return fig


def _fmt(v: float | None, unit: str) -> str:
    return "-" if v is None else f"{v:.3g} {unit}"


def _baseline(b: dict[str, Any] | None, robot_bar: bool = False, p_fault: float | None = None,
              calibrated: bool = True) -> str:
    """The sentence saying which baseline the inputs were referred to (or that there was none); ``robot_bar``: the
    robot's own threshold is the one windows are flagged above (not the training runs', which is higher), at
    ``p_fault`` on the table's scale; ``calibrated``: whether the detector maps its raw score to p(fault)."""
    if b is None:
        return ("No baseline of this robot: the inputs are scored as they are, against the simulated healthy "
                "training runs only (a real robot's model error then reads as a fault: `--baseline-logs`).")
    n = {r: v["n_inputs"] for r, v in b["rules"].items()}
    t = b.get("robot_threshold")
    robot = ("" if t is None else
             f" The robot's own threshold: each of its {t['n_held_out_windows']} baseline windows scored against a "
             f"baseline of the other {len(t['groups']) - 1} group(s) of windows, the "
             + ("largest held-out score" if t["rank"] > t["n_held_out_windows"] else f"{t['rank']}-th smallest")
             + f" ({t['score']:.3f} on the by-joint score"
             + (f", p(fault) {p_fault:.3f} on the table's scale" if robot_bar and p_fault is not None else "")
             + "; a healthy window like them exceeds it with probability "
             f"{t['false_alarm_bound']:.2g}); windows are flagged above it and the training runs' threshold."
             + (f" As a window's score is its joints' largest, {set_by}."
                if robot_bar and (set_by := set_by_sentence(t, calibrated)) else ""))
    return (f"Baseline: {b['n_windows']} windows of {len(b['logs'])} healthy log(s) of the robot "
            f"({', '.join(b['logs'])}); every input referred to it ({b['mapping']}): {n['scaled']} scaled, "
            f"{n['shifted']} shifted, {n['shifted_zero_spread']} shifted (zero spread in the baseline), "
            f"{n['shifted_training_zero_spread']} shifted (zero spread in the training runs), "
            f"{n['shifted_few_windows']} shifted (too few baseline values), {n['left_as_measured']} left as measured "
            f"(no value), {n['condition']} operating conditions left as they are; reference: {b['reference']}."
            + robot)


def _limit_lines(d: dict[str, Any]) -> list[str]:
    """Per joint and kind, the median over the windows of the smallest size the motion could show (``cannot tell``
    in how many windows); nothing when the detector saved no calibration."""
    w = d["windows"]
    if not w or d.get("detection_limit_z") is None or "detection_limits" not in w[0]["joints"][0]:
        return []
    kinds = list(w[0]["joints"][0]["detection_limits"])
    lines = ["", f"Smallest fault each joint's motion could show (detection limit at z = {d['detection_limit_z']:g}: "
                 "median over the windows; cannot tell: in how many windows the motion leaves it unidentified; "
                 "`detection_limits` in diagnosis.json):", "",
             "| joint | " + " | ".join(f"{k} [{w[0]['joints'][0]['detection_limits'][k]['unit']}]" for k in kinds)
             + " |", "| --- |" + " --- |" * len(kinds)]
    for j in range(len(w[0]["joints"])):
        cells = []
        for k in kinds:
            vals = [x["joints"][j]["detection_limits"][k]["detectable_from"] for x in w]
            ok = [v for v in vals if v is not None]
            blind = len(vals) - len(ok)
            cells.append((f"{np.median(ok):.3g}" if ok else "-")
                         + (f" (cannot tell {blind}/{len(vals)})" if blind else ""))
        lines.append(f"| J{j + 1} | " + " | ".join(cells) + " |")
    return lines


def _report(d: dict[str, Any]) -> str:
    det = d["detector"]
    lines = [f"# Diagnosis of {d['log']}", "",
             f"{d['duration_s']:.1f} s sampled every {1e3 * d['log_period_s']:g} ms; payload "
             f"{d['conditions']['payload_kg']:g} kg, temperature {d['conditions']['temperature_C']:.1f} degC. "
             f"Detector: {det['folder']} ({det['feature_set']} features, training set "
             f"{str(det['training_set_sha256'])[:12]}), windows of {det['window_s']:.3g} s, flagged at "
             f"p(fault) > {det['p_fault_at_threshold']:.3f} (5 % false alarms, {det['threshold_from']}"
             + (f"; and above {d['flag_threshold']['p_fault']:.3f}, the robot's own threshold"
                if d.get("flag_threshold", {}).get("p_fault", det["p_fault_at_threshold"])
                != det["p_fault_at_threshold"] else "")
             + "; p(fault): the "
             "fault-kind classifier by joint's largest joint probability of a fault, "
             f"{'calibrated' if det['calibrated'] else 'NOT calibrated: the detector saved no calibration'}; "
             "the run-level detector's reading is in diagnosis.json).", "",
             _baseline(d.get("baseline"), d["flag_threshold"]["from"] == ROBOT_THRESHOLD_FROM,
                       d["flag_threshold"].get("p_fault"), det["calibrated"]), "",
             f"**{d['n_flagged']} of {d['n_windows']} windows flagged.**", "",
             "| window [s] | p(fault) | flagged | likeliest joint "
             "| likeliest kinds there (size; the two halves' estimates) |",
             "| --- | --- | --- | --- | --- |"]
    for w in d["windows"]:
        js = [j for j in w["joints"] if j["p_fault_joint"] is not None]
        top = max(js, key=lambda j: j["p_fault_joint"]) if js else None
        kinds = "-"
        if top is not None:
            kinds = "; ".join(
                f"{k['kind']} {k['p_given_fault']:.2f}" + (" (cannot tell)" if k["cannot_tell"] else
                                                            f" ({_fmt(k['size'], k['unit'])}" +
                                                            (f"; halves {k['interval'][0]:.3g}..{k['interval'][1]:.3g})"
                                                             if k["interval"] else ")"))
                for k in top["kinds"])
            noise = top.get("current_noise_ratio_rest")
            if noise is not None and any(k["same_signature_as"] for k in top["kinds"]):
                kinds += (f"; current noise at rest x{noise:.2f} the twin's (a gain reads about its gain, a torque "
                          "constant 1)")
        where = f"J{top['joint']} {top['p_fault_joint']:.2f}" if top else "-"
        lines.append(f"| {w['start_s']:.1f}-{w['end_s']:.1f} | {w['p_fault']:.3f} | {'yes' if w['flagged'] else 'no'}"
                     f" | {where} | {kinds} |")
    lines += _limit_lines(d)
    lines += ["", f"![p(fault) per window and joint]({FIGURE_FILE})", ""]
    if d["notes"]:
        lines += ["Notes:", *[f"- {n}" for n in d["notes"]], ""]
    return "\n".join(lines)


def write_diagnosis(d: dict[str, Any], out: str | Path) -> list[Path]:
    """Write the three files into ``out``; return their paths (the command writes them inside
    :func:`ur5fault.util.results.result_folder`, which clears a killed writer's temporaries)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = {k: v for k, v in d.items() if not k.startswith("_")}
    return [write_json_atomic(out / JSON_FILE, data), write_text_atomic(out / REPORT_FILE, _report(d)),
            write_figure_atomic(_figure(d), out / FIGURE_FILE)]
