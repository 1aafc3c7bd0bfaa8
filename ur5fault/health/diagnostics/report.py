"""The benchmark's files: ``metrics.json`` (every number), ``report.md`` (the headline tables)
and the figures as PNG."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

from ...sim.axes import JOINT_NAMES
from ...util.io import (
    write_figure_atomic,
    write_json_atomic,
    write_parquet_atomic,
    write_text_atomic,
)
from .kind_call import PAIR
from .limit_report import limit_lines
from .metrics import FROM_TEST_SPLIT
from .predictions import FILE as PREDICTIONS_FILE
from .transfer import lines as transfer_lines


def _f(v: Any, fmt: str = ".3f") -> str:
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, fmt)


def left_out(inputs: dict[str, str]) -> str:
    """The input columns left out, one sentence per reason, a per-joint feature named once (``name_j*`` and its
    joints): a UR-log campaign leaves out some 90 motor-encoder columns, which a sentence each buried the report in."""
    by_why: dict[str, dict[str, list[str]]] = {}
    for column, why in inputs.items():
        base, joint = (column[:-3], column[-1]) if re.fullmatch(r".+_j[1-6]", column) else (column, "")
        by_why.setdefault(why, {}).setdefault(base, []).append(joint)
    text = ""
    for why, bases in by_why.items():
        names = [base if joints == [""] else f"{base}_j{'1-6' if len(joints) == 6 else '/'.join(sorted(joints))}"
                 for base, joints in bases.items()]
        n = sum(len(j) for j in bases.values())
        text += f" Left out ({why}), {n} input{'s' if n != 1 else ''}: {', '.join(names)}."
    return text


def markdown(m: dict[str, Any]) -> str:
    """The report text from the metrics."""
    d, det, loc, kind, bl = m["dataset"], m["detection"], m["localisation"], m["kind"], m["backlash"]
    lines = [
        f"# Diagnostics benchmark: {d['source']}",
        "",
        f"{d['n_train']} train and {d['n_test']} test runs ({d['n_groups_train']} and {d['n_groups_test']} "
        f"split groups, by {d['split_by']}; no group on both sides); {sum(d['n_dropped_not_ok'].values())} runs "
        f"left out (not ok). Inputs: {len(d['inputs'])} ({d['n_features']} health features from the robot's own "
        f"signals and {', '.join(d['context'])}). Classifier: gradient-boosted trees, fixed hyper-parameters."
        + left_out(d.get("inputs_left_out", {}))
        + (" **Control run: training labels shuffled.**" if m["shuffled_labels"] else "")
        + "".join(f" **Note:** {n}." for n in m.get("notes", [])),
        "",
        "## Detection (healthy vs faulty)",
        f"ROC AUC over all faults: **{_f(det['auc_all'])}**; at its {det['false_alarm_rate']:.0%} false-alarm "
        f"threshold ({_f(det['threshold_score'])}, from the {det.get('threshold_from', '?')}; measured "
        f"{_f(det['false_alarm_rate_measured'])}) the detector flags {_f(det['detection_rate_all'])} "
        f"of the faulty test runs.",
        "",
        "| fault kind | test runs | AUC (s.e.) | flagged at 5 % FA | AUC by size bin (size range, runs) |",
        "| --- | --- | --- | --- | --- |",
    ]
    for k, v in det["per_kind"].items():
        bins = "; ".join(f"{_f(b['auc'], '.2f')} ({b['size_lo']:.3g}-{b['size_hi']:.3g} {v['unit']}, {b['n_test']})"
                         for b in v["by_size"])
        lines.append(f"| {k} | {v['n_test']} | {_f(v['auc'])} ({_f(v['auc_se'], '.3f')}) | "
                     f"{_f(v['detection_rate'], '.2f')} | {bins} |")
    bj = m.get("detection_by_joint") or {}
    if bj:
        lines += [
            "",
            "The fault-kind classifier by joint as a detector (its probability of a fault on any joint, "
            f"`joint_kind.py`; the p(fault) of `ur5fault diagnose`): ROC AUC **{_f(bj['auc_all'])}**. **At its "
            f"operating point** (the {bj['false_alarm_rate']:.0%} false-alarm threshold {_f(bj['threshold_score'])}, "
            f"from the {bj.get('threshold_from', '?')}; the one `ur5fault diagnose` flags at) it gives "
            f"**{_f(bj['false_alarm_rate_measured'], '.1%')} false alarms and flags "
            f"{_f(bj['detection_rate_all'], '.0%')}** "
            "of the faulty test runs"
            + (f" (oracle, not an operating point a user has: at the test split's own 5 % threshold "
               f"{_f(bj['oracle_test_split']['threshold_score'])}, "
               f"{_f(bj['oracle_test_split']['false_alarm_rate_measured'], '.1%')} false alarms and "
               f"{_f(bj['oracle_test_split']['detection_rate_all'], '.0%')} flagged)"
               if bj.get("oracle_test_split") and bj.get("threshold_from") != FROM_TEST_SPLIT else "")
            + "; per kind (AUC / upper half of its sizes): "
            + "; ".join(f"{k} {_f(v['auc'], '.2f')} / {_f(v['auc_upper_half'], '.2f')}"
                        for k, v in bj["per_kind"].items()) + ".",
            "",
            "Upper half of each kind's sizes by faulty joint (AUC against every healthy test run; - under "
            "3 runs):",
            "",
            "| fault kind | " + " | ".join(JOINT_NAMES) + " |",
            "| --- |" + " --- |" * len(JOINT_NAMES),
            *[f"| {k} | " + " | ".join(_f(v.get("auc_upper_half_by_joint", {}).get(str(j)), ".2f")
                                       for j in range(1, len(JOINT_NAMES) + 1)) + " |"
              for k, v in bj["per_kind"].items()],
        ]
    lines += [
        "",
        "## Localisation (which joint) and fault kind",
        f"Joint accuracy over {loc['n_test']} single-joint-fault test runs: **{_f(loc['accuracy'])}** (chance "
        f"{_f(loc.get('chance'))}); over the {loc.get('n_test_detected', 0)} the detector flags: "
        f"**{_f(loc.get('accuracy_detected'))}**.",
        "",
        "| fault kind | test runs | joint accuracy | on flagged runs |",
        "| --- | --- | --- | --- |",
    ]
    for k, v in loc.get("per_kind", {}).items():
        lines.append(f"| {k} | {v['n_test']} | {_f(v['accuracy'], '.2f')} | {_f(v['accuracy_detected'], '.2f')} |")
    lines += [
        "",
        f"Fault-kind accuracy ({len(kind.get('labels', []))} classes incl. healthy): **{_f(kind['accuracy'])}**, "
        f"balanced {_f(kind.get('balanced_accuracy'))} (chance {_f(kind.get('chance_balanced'))}), "
        f"{_f(kind.get('balanced_accuracy_merged'))} with {' and '.join(kind.get('merged_kinds', []))} merged "
        "(the same shape in every signal); on flagged "
        f"faulty runs {_f(kind.get('accuracy_detected_faulty'))}. Confusion matrices: `confusion.png`.",
        "",
    ]
    bj = kind.get("by_joint") or {}
    if bj:
        lines += [
            "Fault kind by joint (one classifier shared by the joints, reading one joint's evidence at a time; "
            f"`joint_kind.py`): accuracy **{_f(bj['accuracy'])}**, balanced {_f(bj['balanced_accuracy'])}, "
            f"{_f(bj['balanced_accuracy_merged'])} with the pair merged; on flagged faulty runs "
            f"{_f(bj['accuracy_detected_faulty'])}; its joint right on {_f(bj['joint_accuracy'])} of the single-joint "
            "faults.",
            "",
        ]
        op = bj.get("at_operating_point")
        if op:
            up = op["upper_half"]
            lines += [
                "The same, a run called faulty where the by-joint score passes its 5 % false-alarm threshold "
                f"({_f(op['threshold_score'])}; the rule of `ur5fault diagnose`): balanced "
                f"**{_f(op['balanced_accuracy'])}** "
                f"({_f(op['balanced_accuracy_merged'])} merged); over the upper half of each kind's sizes "
                f"({up['n_test']} runs with the healthy) {_f(up['balanced_accuracy'])} "
                f"({_f(up['balanced_accuracy_merged'])} merged); on the {op['n_detected_faulty']} flagged faulty runs "
                f"{_f(op['accuracy_detected_faulty'])}, "
                f"balanced over their kinds {_f(op['balanced_accuracy_detected_faulty'])} "
                f"({_f(op['balanced_accuracy_detected_faulty_merged'])} merged).",
                "",
                "| true \\ called | " + " | ".join(op["labels"]) + " |",
                "| --- |" + " --- |" * len(op["labels"]),
                *[f"| {lab} | " + " | ".join(str(v) for v in row) + " |"
                  for lab, row in zip(op["labels"], op["confusion"])],
                "",
            ]
            ct = op.get("cannot_tell")
            if ct:
                forced, up_ct = _f(op["balanced_accuracy"]), _f(ct["upper_half"]["balanced_accuracy"])
                lines += [
                    "Called with \"cannot tell\" for current-sensor gain and torque constant (one signature: "
                    f"`{PAIR}`, a call right for either; `current_sensor_gain` where the gain estimate of the called "
                    "joint is negative, which a torque-constant loss cannot give; `kind_call.py`): balanced "
                    f"**{_f(ct['balanced_accuracy'])}** (forced to choose between the two: {forced}); "
                    f"{ct['n_called_pair']} runs called `{PAIR}`, {ct['n_called_gain_by_sign']} "
                    f"`current_sensor_gain` by the sign; over the upper half of each kind's sizes {up_ct}.",
                    "",
                ]
    lines += [
        "## Backlash: smallest alpha detected per joint",
        f"alpha_90: {bl['detection_probability']:.0%} of the runs with that backlash flagged at "
        f"{det['false_alarm_rate']:.0%} false alarms (logistic fit in log alpha, 90 % bootstrap interval; "
        f"empirical: smallest tested alpha above which >= 90 % are flagged). TCP deviation: the healthy-twin "
        f"deviation at alpha_90 (median, 10-90 % over motions). The paper: alpha = "
        f"{bl['paper']['alpha_deg']:g} deg keeps the TCP within {bl['paper']['tcp_mm']:g} mm.",
        "",
        "Crossed: share of all runs with alpha >= 0.2 deg on that joint whose motor-vs-joint encoder mismatch "
        "spans at least alpha/2, i.e. whose clearance was crossed at all (gravity can keep one flank loaded "
        "through a whole motion); flagged: share of such test runs the detector flags.",
        "",
        "| joint | test runs (flagged) | alpha_90 [deg] | 90 % interval | empirical | TCP dev at alpha_90 [mm] "
        f"| alpha for {bl['threshold_mm']:g} mm [deg] | crossed (alpha >= 0.2 deg) | flagged when crossed |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for j, v in bl["per_joint"].items():
        tcp = v.get("tcp_at_alpha_90_mm", {})
        ci = v["alpha_90_ci90_deg"]
        a90 = v.get("alpha_90_bound") or _f(v["alpha_90_deg"], ".3g")
        lo = v.get("alpha_90_ci90_open_below") or _f(ci[0], ".3g")
        hi = v.get("alpha_90_ci90_open_above") or _f(ci[1], ".3g")
        interval = "-" if lo == hi == "-" else (lo if lo == hi else f"{lo} to {hi}")
        dev = "-" if tcp.get("median") is None else (
            f"{_f(tcp.get('median'), '.3g')} ({_f(tcp.get('p10'), '.2g')}-{_f(tcp.get('p90'), '.2g')})")
        emp = _f(v["alpha_90_empirical_deg"], ".3g")
        at_thr = v.get("alpha_at_threshold_bound") or _f(v.get("alpha_at_threshold_deg"), ".3g")
        crossed = f"{_f(v.get('share_crossed'), '.0%')} of {v.get('n_runs_alpha_ge_min', 0)}"
        flagged = f"{_f(v.get('detection_rate_crossed_test'), '.0%')} of {v.get('n_test_crossed', 0)}"
        lines.append(f"| J{j} {JOINT_NAMES[int(j) - 1]} | {v['n_test']} ({v['detected']}) | {a90} | {interval} | "
                     f"{emp} | {dev} | {at_thr} | {crossed} | {flagged} |")
    if m.get("detection_limits"):
        lines += limit_lines(m["detection_limits"], (m.get("detection_by_joint") or det)["per_kind"])
    lines += ["", "## What the detector uses (permutation importance, test ROC AUC drop)", "",
              "| input | AUC drop (s.d.) |", "| --- | --- |"]
    lines += [f"| {x['feature']} | {_f(x['auc_drop_mean'], '.4f')} ({_f(x['auc_drop_std'], '.4f')}) |"
              for x in m["importance"][:12]]
    if m.get("calibration"):
        lines += calibration_lines(m["calibration"])
    if m.get("comparison"):
        lines += comparison_lines(m["comparison"])
    if m.get("transfer"):
        lines += transfer_lines(m["transfer"])
    lines += ["", f"Benchmark wall time {m['timing']['benchmark_wall_s']:.1f} s. Figures: "
              + ", ".join(f"`{f}`" for f in m["figures"]) + "."]
    return "\n".join(lines) + "\n"


def calibration_lines(cal: dict[str, Any]) -> list[str]:
    """Reliability of p(fault) on the test runs, before and after the calibration."""
    names = {"detector": "the by-joint score itself", "calibrated": f"calibrated ({cal.get('method', '?')}, saved)",
             "isotonic": "isotonic (comparison, not saved)"}
    lines = ["", f"## Calibration of p(fault) (the fault-kind classifier by joint's score, fitted on out-of-fold "
                 f"scores of the train split, {cal.get('n_folds', '?')} folds grouped by motion; scored on "
                 f"{cal['test']['detector']['n']} test runs)", "",
             "| probability | Brier score | expected calibration error |", "| --- | --- | --- |"]
    lines += [f"| {names.get(k, k)} | {_f(v['brier'])} | {_f(v['ece'])} |" for k, v in cal["test"].items()]
    lines += ["", "Reliability (test runs, calibrated): " + "; ".join(
        f"{b['lo']:.1f}-{b['hi']:.1f}: {b['n']} runs, mean p {b['mean_p']:.2f}, {b['share_faulty']:.0%} faulty"
        for b in cal["test"]["calibrated"]["bins"]) + "."]
    oof = cal.get("test_at_threshold_out_of_fold")
    if oof:
        lines += ["", f"The 5 % false-alarm threshold read off the training runs' out-of-fold scores alone "
                      f"({_f(cal.get('threshold_out_of_fold'))}; the by-joint detector's operating point) gives "
                      f"{_f(oof['false_alarm_rate'], '.1%')} false alarms and flags {_f(oof['detection_rate'], '.0%')} "
                      "of the faulty test runs."]
    return lines


def comparison_lines(cmp: dict[str, Any]) -> list[str]:
    """The feature-set table: each set trained and with shuffled training labels, on the same split."""
    sets = list(cmp)
    kinds = list(next(iter(cmp.values()))["trained"]["auc_per_kind"])
    joints = list(next(iter(cmp.values()))["trained"]["alpha_90_deg"])
    lines = ["", "## Feature sets compared (same split; in brackets: training labels shuffled)", "",
             "| figure | " + " | ".join(sets) + " |", "| --- |" + " --- |" * len(sets)]

    def row(name: str, get, fmt: str = ".2f") -> None:
        cells = []
        for fs in sets:
            t, s = get(cmp[fs]["trained"]), get(cmp[fs]["shuffled"])
            cells.append(t if isinstance(t, str) else f"{_f(t, fmt)} ({_f(s, fmt) if not isinstance(s, str) else s})")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")

    row("inputs", lambda r: str(r["n_inputs"]))
    row("detection AUC, all faults", lambda r: r["auc_all"])
    row("flagged at the test split's own 5 % false alarms (oracle)", lambda r: r["detection_rate_all"])
    for k in kinds:
        row(f"AUC {k}", lambda r, k=k: r["auc_per_kind"][k])
        row(f"AUC {k}, upper half of its sizes", lambda r, k=k: r["auc_upper_half_per_kind"][k])
    row("by joint: detection AUC, all faults", lambda r: r.get("auc_all_by_joint"))
    row("by joint: flagged at the test split's own 5 % false alarms (oracle)",
        lambda r: r.get("detection_rate_all_by_joint"))
    for k in kinds:
        row(f"by joint: AUC {k}", lambda r, k=k: (r.get("auc_per_kind_by_joint") or {}).get(k))
        row(f"by joint: AUC {k}, upper half of its sizes",
            lambda r, k=k: (r.get("auc_upper_half_per_kind_by_joint") or {}).get(k))
    row("joint accuracy, all single-joint faults", lambda r: r["joint_accuracy"])
    row("joint accuracy, flagged runs", lambda r: r["joint_accuracy_flagged"])
    row("fault kind, balanced accuracy", lambda r: r["kind_balanced_accuracy"])
    row("fault kind, balanced accuracy, gain and torque constant merged",
        lambda r: r.get("kind_balanced_accuracy_merged"))
    row("fault kind by joint, balanced accuracy", lambda r: r.get("kind_by_joint_balanced_accuracy"))
    row("fault kind by joint, balanced accuracy, gain and torque constant merged",
        lambda r: r.get("kind_by_joint_balanced_accuracy_merged"))
    row("fault kind by joint, joint accuracy, all single-joint faults", lambda r: r.get("kind_by_joint_joint_accuracy"))
    for j in joints:
        row(f"backlash alpha_90 J{j} [deg]", lambda r, j=j: r["alpha_90_deg"][j], ".3g")
    return lines


def write_report(m: dict[str, Any], figures: dict[str, Any], out: Path) -> list[Path]:
    """Write ``<name>.png`` for each figure, ``metrics.json`` (NaN as null), ``report.md`` and, where ``m`` holds
    them (``"_predictions"``, taken out of ``m``), the scored runs' calls as ``predictions.parquet``
    (:mod:`.predictions`), each atomically, inside the benchmark's :func:`ur5fault.util.results.result_folder` (which
    clears a killed writer's temporaries); return the paths."""
    out.mkdir(parents=True, exist_ok=True)
    predictions = m.pop("_predictions", None)
    paths = [write_figure_atomic(fig, out / f"{name}.png") for name, fig in figures.items()]
    m = clean({**m, "figures": [p.name for p in paths]})
    if predictions is not None:
        paths.append(write_parquet_atomic(predictions, out / PREDICTIONS_FILE))
    paths.append(write_json_atomic(out / "metrics.json", m))
    paths.append(write_text_atomic(out / "report.md", markdown(m)))
    return paths


def clean(v: Any) -> Any:
    """JSON-ready copy: numpy scalars as Python numbers, NaN and inf as None (strict JSON has no NaN)."""
    if isinstance(v, dict):
        return {str(k): clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [clean(x) for x in v]
    if hasattr(v, "item") and not isinstance(v, (str, bytes)):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v
