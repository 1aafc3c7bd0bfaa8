"""``report.md``'s section on detection over the faults each run's motion could show (:mod:`.limit_metrics`)."""

from __future__ import annotations

import math
from typing import Any

from ...sim.axes import JOINT_NAMES


def _f(v: Any, fmt: str = ".3f") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


def _alpha(v: dict[str, Any]) -> str:
    a = v.get("alpha_90_bound") or _f(v.get("alpha_90_deg"), ".3g")
    return f"{a} ({v.get('detected', 0)}/{v.get('n_test', 0)})"


def limit_lines(lim: dict[str, Any], literal: dict[str, Any]) -> list[str]:
    """The section's lines; ``literal``: today's per-kind detection (``detection_by_joint`` or ``detection``), whose
    upper-half AUC over every run stays the goal's figure."""
    zs = [f"{z:g}" for z in lim["z_values"]]
    zd = f"{lim['z_default']:g}"
    joints = [f"J{j + 1} {n}" for j, n in enumerate(JOINT_NAMES)]
    lines = [
        "", "## Detection where the motion can show the fault (detection limits)",
        "Each run's limit per joint and kind: z x (the twin estimate's SE) x (the spread of that estimate's t value "
        "on the healthy training runs), in the kind's size unit (`limits.py`); no label is used. Infinite where the "
        "motion does not identify the estimate: **cannot tell**. Below, the AUC of the goal's figure recomputed over "
        "the faulty test runs whose size is above their own limit on their joint (n kept of N; negatives: every "
        f"healthy test run). **Not the goal's figure**, which stays the first column. Default z = {zd}.", "",
        "| fault kind | upper half, all runs (goal) | " + " | ".join(f"z = {z}: upper half kept (n of N)" for z in zs)
        + " | " + " | ".join(f"z = {z}: all sizes kept (n of N)" for z in zs) + " |",
        "| --- |" + " --- |" * (1 + 2 * len(zs)),
    ]
    for k in lim["cannot_tell"]:
        lit = (literal.get(k) or {})
        cells = [f"{_f(lit.get('auc_upper_half'))} ({lit.get('n_test_upper_half', '-')})"]
        for z in zs:
            v = lim["by_z"][z]["per_kind"][k]
            cells.append(f"{_f(v['auc_upper_half_kept'])} ({v['n_upper_half_kept']} of {v['n_upper_half']})")
        for z in zs:
            v = lim["by_z"][z]["per_kind"][k]
            cells.append(f"{_f(v['auc_kept'])} ({v['n_kept']} of {v['n_test']})")
        lines.append(f"| {k} | " + " | ".join(cells) + " |")
    lines += ["", "Cannot tell: share of all test runs whose motion leaves the kind's estimate unidentified on the "
                  "joint (faulty runs of that kind and joint in brackets: cannot tell of all):", "",
              "| fault kind | " + " | ".join(joints) + " |", "| --- |" + " --- |" * len(joints)]
    for k, v in lim["cannot_tell"].items():
        lines.append(f"| {k} | " + " | ".join(
            f"{_f(v['share_of_test_runs_by_joint'][str(j)], '.0%')} ({v['faulty_cannot_tell_by_joint'][str(j)][0]} "
            f"of {v['faulty_cannot_tell_by_joint'][str(j)][1]})" for j in range(1, len(joints) + 1)) + " |")
    whys = {}
    for k, v in lim["cannot_tell"].items():
        whys.setdefault(v["why"], []).append(k)
    lines += ["", "Why: " + "; ".join(f"{', '.join(ks)}: {w}" for w, ks in whys.items()) + ".", "",
              f"Median limit at z = {zd} over the test runs where it is finite (the kind's size unit):", "",
              "| fault kind | unit | " + " | ".join(joints) + " |", "| --- | --- |" + " --- |" * len(joints)]
    for k, v in lim["cannot_tell"].items():
        med = v[f"median_limit_z{zd}_by_joint"]
        lines.append(f"| {k} | {v['unit']} | " + " | ".join(_f(med[str(j)], ".3g")
                                                           for j in range(1, len(joints) + 1)) + " |")
    lines += ["", "Backlash alpha_90 [deg] over the backlash test runs above their limit (flagged / kept; the "
                  "run-level detector as the table above):", "",
              "| z | " + " | ".join(joints) + " |", "| --- |" + " --- |" * len(joints)]
    for z in zs:
        a = lim["by_z"][z]["backlash_alpha_90"]
        lines.append(f"| {z} | " + " | ".join(_alpha(a.get(str(j), {})) for j in range(1, len(joints) + 1)) + " |")
    rev = lim.get("backlash_alpha_90_torque_reverses")
    if rev:  # absent from a metrics.json written before it
        lines += ["", "Backlash alpha_90 [deg] on the motions where the joint's gear torque reverses (the goal's "
                      "wording; read off each run's twin with the payload CoM its current fit finds, no label: the "
                      "backlash estimate is identified there), "
                      "flagged / kept, with the run-level detector's flags as the tables above and, where the "
                      "benchmark has it, with the by-joint detector's at its saved operating point (the flags of "
                      "`ur5fault diagnose` and of the headline rates); below, the backlash test runs whose motion "
                      "never reverses it (gravity holds "
                      "the gear on one flank: the clearance is never crossed and no signal can show it):", "",
                  "| | " + " | ".join(joints) + " |", "| --- |" + " --- |" * len(joints),
                  "| alpha_90 | " + " | ".join(_alpha(rev.get(str(j), {})) for j in range(1, len(joints) + 1)) + " |",
                  *([] if not lim.get("backlash_alpha_90_torque_reverses_by_joint_detector") else [
                      "| alpha_90, by-joint detector at its saved operating point | " + " | ".join(
                          _alpha(lim["backlash_alpha_90_torque_reverses_by_joint_detector"].get(str(j), {}))
                          for j in range(1, len(joints) + 1)) + " |"]),
                  "| runs never reversing | " + " | ".join(str(rev.get(str(j), {}).get("n_not_reversing", "-"))
                                                      for j in range(1, len(joints) + 1)) + " |"]
    return lines


__all__ = ["limit_lines"]
