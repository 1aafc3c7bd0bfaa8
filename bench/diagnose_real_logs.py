"""``ur5fault diagnose`` on real UR5 logs, healthy and with a fault written into their measured signals
(docs/diagnostics.md, "Real logs").

    python bench/diagnose_real_logs.py [--detector results/diagnostics_urlog/benchmark]
                                       [--out results/diagnose_real_logs] [--n-boot 50]

The detector is one ``ur5fault benchmark`` saved from a campaign logged like a UR robot
(campaigns/diagnostics_urlog.yaml: 8 ms, no motor encoders).  Logs:

* the NIST log (CB3, data/nist-ur5), under the packaged model (its ``[nist]`` values were identified on that
  robot);
* the seven undisturbed moving Kufieta runs (CB2, data/kufieta-ur5; payload 0 kg and the tool at the flange,
  as docs/validation.md replays them), each under an overlay of ``ur5fault identify`` fitted on OTHER Kufieta
  runs: two folds (:data:`FOLDS`), each identified jointly on the other fold's runs plus the standstill run
  after its last push (its only constant-target stretch, as bench/cross_robot.py does), never on the run
  diagnosed.

Every log is diagnosed as it is (healthy: a flag is a false alarm) and with one fault written into its measured
current (tests/real_hidden.py, written independently of the workflow): a current-sensor offset of
:data:`OFFSET_A` on :data:`OFFSET_JOINT` and a current-sensor gain of :data:`GAIN` on :data:`GAIN_JOINT`.  The
fault changes only the measured signals, so the twin (the replay of the log's commands) is replayed once per
log and shared.  Per case: windows flagged at the detector's saved 5 % false-alarm threshold (p(fault) is the
fault-kind classifier by joint's, calibrated; in brackets the run-level detector's flags), p(fault), the
likeliest joint and kind of the flagged windows, and the size estimate of the injected kind on its joint minus
the same estimate on the healthy log (the physics says: the injected size).

Where a healthy log is flagged, its cause is looked for: every detector input of each window against the same
input over the campaign's healthy training runs (robust z-score, (x - median) / (1.4826 MAD)), and the model's
own error on that robot (the current-residual RMS at speed against the healthy runs' spread).

Writes ``OUT/summary.json``, ``OUT/table.md`` and the diagnosis folders (diagnosis.json, report.md, figure) of
the healthy logs and of the NIST log's injected cases.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from real_hidden import inject  # noqa: E402

KUFIETA = REPO / "data" / "kufieta-ur5"
NIST_LOG = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
#: undisturbed moving Kufieta runs, in two folds: each diagnosed under the overlay identified on the other
FOLDS = (("Movement_No1", "Movement_No3_Acc", "Movement_No5_Acc_slow_no_disturbance",
          "Movement_No8_Singularity_Free_1"),
         ("Movement_No2", "Movement_No4_Acc", "TEST"))
REST_RUN, REST_FROM_S = "Movement_No10_Standstill_WDist", 12.0
#: injected faults (0-based joints): sizes a maintenance engineer cares about, above the issue's floor (0.05 A, 5 %)
OFFSET_A, OFFSET_JOINT = 0.1, 3  # wrist 1
GAIN, GAIN_JOINT = 1.10, 1  # shoulder: the largest current, so a gain error is largest in amperes
INJECTIONS = (("healthy", None, None, {}),
              ("current_sensor_offset", "current_sensor_offset", OFFSET_JOINT, {"offset_A": OFFSET_A}),
              ("current_sensor_gain", "current_sensor_gain", GAIN_JOINT, {"gain": GAIN}))
#: size the physics predicts for each injected kind, in the unit diagnose reports it
EXPECTED_SIZE = {"current_sensor_offset": OFFSET_A, "current_sensor_gain": GAIN - 1.0}
MAD_SCALE = 1.4826  # MAD -> standard deviation of a normal distribution


def read_kufieta(name: str):
    from ur5fault.logs import read_rtde

    return read_rtde(KUFIETA / f"{name}.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))


def healthy_spread(detector: Path, inputs: list[str]) -> pd.DataFrame:
    """Median and MAD-scale of every input over the healthy training runs of the detector's campaign."""
    campaign = detector.parent if (detector / "models").exists() else detector.parent.parent
    df = pd.read_parquet(campaign / "features.parquet")
    h = df[(df["fault"] == "healthy") & (df["split"] == "train") & (df["status"] == "ok")][inputs].astype(float)
    med = h.median()
    return pd.DataFrame({"median": med, "scale": MAD_SCALE * (h - med).abs().median(), "n": h.count()})


def outliers(windows, spread: pd.DataFrame, top: int = 5) -> dict:
    """Robust z-scores of a log's windows' inputs against the healthy training runs: share beyond 3, largest."""
    x = pd.DataFrame([w.features for w in windows])[list(spread.index)].astype(float)
    z = (x - spread["median"]) / spread["scale"].replace(0.0, np.nan)
    med = z.abs().median(axis=0).dropna().sort_values(ascending=False)
    return {"share_inputs_beyond_3": float((med > 3).mean()),
            "largest": [{"input": k, "median_abs_z": float(v),
                         "log_median": float(x[k].median()), "healthy_median": float(spread.loc[k, "median"]),
                         "healthy_scale": float(spread.loc[k, "scale"])} for k, v in med.head(top).items()]}


def current_rms_at_speed(windows, spread: pd.DataFrame) -> list[dict]:
    """Per joint, the current-residual RMS at speed on the log (median over windows) against the healthy
    simulated runs (median, MAD scale): the model's own error on this robot against the healthy spread."""
    out = []
    for j in range(1, 7):
        k = f"twin_current_rms_A_speed_j{j}"
        v = [w.features.get(k, np.nan) for w in windows]
        out.append({"joint": j, "log_A": float(np.nanmedian(v)),
                    "healthy_sim_A": float(spread.loc[k, "median"]) if k in spread.index else None,
                    "healthy_sim_scale_A": float(spread.loc[k, "scale"]) if k in spread.index else None})
    return out


def summarise(d: dict, kind: str | None, joint: int | None) -> dict:
    """One row of the table from a diagnosis."""
    w = d["windows"]
    flagged = [x for x in w if x["flagged"]]
    top_joint = [max(x["joints"], key=lambda j: j["p_fault_joint"] or 0.0) for x in flagged]
    top_kind = [j["kinds"][0]["kind"] for j in top_joint if j["kinds"]]
    row = {"log": d["log"], "injected": kind, "joint": None if joint is None else joint + 1,
           "n_windows": d["n_windows"], "n_flagged": d["n_flagged"],
           "n_flagged_run_level": int(sum(x["flagged_run_level"] for x in w)),
           "p_fault_median": float(np.median([x["p_fault"] for x in w])),
           "p_fault_max": float(max(x["p_fault"] for x in w)),
           "flagged_joint_mode": Counter(j["joint"] for j in top_joint).most_common(1)[0][0] if top_joint else None,
           "flagged_kind_mode": Counter(top_kind).most_common(1)[0][0] if top_kind else None}
    if kind is not None:
        on_joint = [x["joints"][joint]["p_fault_joint"] or 0.0 for x in w]
        row["p_fault_joint_median"] = float(np.median(on_joint))
        row["injected_joint_likeliest_share"] = float(np.mean(
            [x["joints"][joint]["p_fault_joint"] == max(j["p_fault_joint"] or 0.0 for j in x["joints"]) for x in w]))
        row["expected_size"] = EXPECTED_SIZE[kind]
    return row


def size_delta(feats, healthy_feats, kind: str, joint: int) -> float:
    """The injected kind's estimate on its joint minus the healthy log's (median over windows), from the
    windows' twin features (written whatever the kind classifier ranks first)."""
    from ur5fault.health.diagnosis.score import size_estimate

    d = [size_estimate(kind, a.features, joint + 1)[0] - size_estimate(kind, b.features, joint + 1)[0]
         for a, b in zip(feats, healthy_feats)]
    return float(np.nanmedian(d))


def run_log(log, overlay: dict | None, detector: Path, spread: pd.DataFrame, out: Path, write_injected: bool
            ) -> list[dict]:
    from ur5fault.health.diagnosis import diagnose, replay_twin
    from ur5fault.health.diagnosis.report import write_diagnosis

    t0 = time.perf_counter()
    twin = replay_twin(log, overlay)
    rows, healthy = [], None
    for label, kind, joint, values in INJECTIONS:
        lg = log if kind is None else inject(log, kind, joint, **values)
        d = diagnose(lg, detector, overlay, twin=twin)
        row = summarise(d, kind, joint)
        if kind is None:
            healthy = d
            row["outliers"] = outliers(d["_windows"], spread)
            row["current_rms_at_speed"] = current_rms_at_speed(d["_windows"], spread)
        else:
            row["size_minus_healthy_median"] = size_delta(d["_windows"], healthy["_windows"], kind, joint)
        if kind is None or write_injected:
            name = Path(log.source).name.split(".")[0] + ("" if kind is None else f"+{label}")
            write_diagnosis(d, out / name)
        row["model"] = "packaged" if overlay is None else "identified on the other fold"
        rows.append(row)
    print(f"{log.source}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return rows


def table(rows: list[dict]) -> str:
    lines = ["| log | model | injected | windows flagged (run-level detector) | p(fault) median / max | "
             "flagged: likeliest joint, kind | size estimate - healthy (expected) |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        inj = "-" if r["injected"] is None else f"{r['injected']} J{r['joint']}"
        where = "-" if r["flagged_joint_mode"] is None else f"J{r['flagged_joint_mode']}, {r['flagged_kind_mode']}"
        size = "-" if r["injected"] is None else f"{r['size_minus_healthy_median']:.3g} ({r['expected_size']:g})"
        lines.append(f"| {r['log']} | {r['model']} | {inj} | {r['n_flagged']} of {r['n_windows']} "
                     f"({r['n_flagged_run_level']}) | {r['p_fault_median']:.2f} / {r['p_fault_max']:.2f} | "
                     f"{where} | {size} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    from ur5fault.health.diagnostics.saved import load_models
    from ur5fault.identify import identify
    from ur5fault.logs import read_nist
    from ur5fault.sim.params import load_params
    from ur5fault.util.io import write_json_atomic, write_text_atomic

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--detector", default=str(REPO / "results" / "diagnostics_urlog" / "benchmark"))
    ap.add_argument("--out", default=str(REPO / "results" / "diagnose_real_logs"))
    ap.add_argument("--n-boot", type=int, default=50, help="bootstrap resamples of the identification")
    args = ap.parse_args(argv)
    detector, out = Path(args.detector), Path(args.out)
    t0 = time.perf_counter()
    _, schema = load_models(detector)
    spread = healthy_spread(detector, [c["name"] for c in schema["inputs"]])
    rows = run_log(read_nist(NIST_LOG), None, detector, spread, out, write_injected=True)
    params = load_params()
    overlays = {}
    for k, fold in enumerate(FOLDS):
        other = [n for f in FOLDS[:k] + FOLDS[k + 1:] for n in f]
        print(f"identifying on {', '.join(other)}", file=sys.stderr, flush=True)
        ident = identify([read_kufieta(n) for n in other] + [read_kufieta(REST_RUN).window(REST_FROM_S, 60.0)],
                         params, sweep=False, n_boot=args.n_boot)
        overlays[k] = ident.overlay(params)["params"]
        for name in fold:
            rows += run_log(read_kufieta(name), overlays[k], detector, spread, out, write_injected=False)
    summary = {"detector": str(detector), "feature_set": schema.get("feature_set"),
               "threshold_5pct_false_alarms": schema["joint_kind_threshold_5pct_false_alarms"],
               "run_level_threshold_5pct_false_alarms": schema["detector_threshold_5pct_false_alarms"],
               "calibration": schema.get("calibration", {}) and schema["calibration"].get("method"),
               "folds": FOLDS, "rows": rows, "overlays": overlays, "wall_s": time.perf_counter() - t0}
    write_json_atomic(out / "summary.json", json.loads(json.dumps(summary, default=_jsonable)))
    md = table(rows)
    write_text_atomic(out / "table.md", md)
    print(md)
    print(f"wall {summary['wall_s']:.0f} s; wrote {out}", file=sys.stderr)
    return 0


def _jsonable(v):
    if dataclasses.is_dataclass(v):
        return dataclasses.asdict(v)
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, np.ndarray):
        return v.tolist()
    return str(v)


if __name__ == "__main__":
    sys.exit(main())
