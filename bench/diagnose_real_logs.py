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
  diagnosed. The overlay is identify's whole output, its motor-angle ripples (``motor_harmonic`` effects)
  included, as ``diagnose --model`` reads it; ``--params-only`` takes its parameters alone (the bench before
  2026-11-30).

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

Each diagnosis is made twice: as it is, and with the robot's own healthy baseline (``diagnose --baseline-logs``,
ur5fault/health/diagnosis/baseline.py), never holding the diagnosed run: a Kufieta run's baseline is the other
runs of its own fold (replayed under the same overlay, which was identified on the other fold, so neither the
baseline nor the overlay saw the run diagnosed, and the baseline's runs are as unseen by the overlay as the
diagnosed one); the NIST log is one log, so its first half (:data:`NIST_SPLIT_S`) is the baseline and its second
half is diagnosed (under the packaged model, whose ``[nist]`` values were identified on the same robot's logs).
Per case with the baseline: windows flagged, share of the injected fault's windows flagged, share where its
joint is the likeliest, and the inputs still more than 3 robust SD from the healthy training runs after the
mapping.  A Kufieta run is also diagnosed with a second baseline, all six other undisturbed runs (the other
fold's were fitted by its overlay: the natural baseline of a user who fits the model on the robot's healthy runs
and keeps them as its baseline; replayed under the run's own overlay, so still never the run diagnosed).

Writes ``OUT/summary.json``, ``OUT/table_baseline.md`` and, under ``OUT/with_baseline/``, the diagnosis folders
(diagnosis.json, report.md, figure) of the healthy logs diagnosed with their baseline.
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
#: a Kufieta run's baselines: the other runs of its fold (as unseen by the overlay as the run diagnosed), and all
#: six other undisturbed runs (the other fold's were fitted by the overlay: a user's natural baseline is the
#: healthy runs the model was fitted on)
BASE_FOLD, BASE_ALL = "own fold", "all others"
#: the NIST log's split: baseline before, diagnosed after [s] (the log is 63 s: six 5 s windows each side)
NIST_SPLIT_S = 31.5


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


def outliers(windows, spread: pd.DataFrame, top: int = 5, baseline=None) -> dict:
    """Robust z-scores of a log's windows' inputs against the healthy training runs: share beyond 3, largest
    (``baseline``: of the inputs after they are referred to it, as the classifiers see them)."""
    x = pd.DataFrame([w.features for w in windows])[list(spread.index)].astype(float)
    if baseline is not None:
        x = pd.DataFrame(baseline.apply(x.to_numpy()), columns=x.columns)
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
           "n_flagged_training_threshold": int(sum(training_flags(d))),
           "flag_threshold": d["flag_threshold"],
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


def training_flags(d: dict) -> list[bool]:
    """Each window flagged at the training runs' 5 % threshold alone (the diagnosis's own ``flagged`` is above
    the robot's threshold too, where a baseline gave one)."""
    thr = d["detector"]["threshold_5pct_false_alarms"]
    return [x["p_fault_score"] > thr for x in d["windows"]]


def flagged_on_joint(d: dict, joint: int) -> dict:
    """Share of the windows flagged, and share where ``joint`` (0-based) is the likeliest faulty joint (each also
    at the training runs' threshold alone)."""
    w = d["windows"]
    top = [max(x["joints"], key=lambda j: j["p_fault_joint"] or 0.0)["joint"] for x in w]
    train = training_flags(d)
    return {"share_flagged": float(np.mean([x["flagged"] for x in w])),
            "share_flagged_training_threshold": float(np.mean(train)),
            "share_joint_likeliest": float(np.mean([t == joint + 1 for t in top])),
            "share_flagged_on_joint": float(np.mean([x["flagged"] and t == joint + 1 for x, t in zip(w, top)])),
            "share_flagged_on_joint_training_threshold": float(np.mean([f and t == joint + 1
                                                                        for f, t in zip(train, top)])),
            "p_fault_joint_median": float(np.median([x["joints"][joint]["p_fault_joint"] or 0.0 for x in w]))}


@dataclasses.dataclass(frozen=True)
class Model:
    """The model a log is diagnosed under: parameter overrides and effects, as ``ur5fault identify --out`` writes
    them and ``diagnose --model`` reads them (None and (): the packaged model)."""

    params: dict | None = None
    effects: tuple = ()


PACKAGED = Model()


def twin_and_windows(log, model: Model, window_s: float):
    from ur5fault.health.diagnosis import log_windows, replay_twin

    twin = replay_twin(log, model.params, model.effects)
    return twin, log_windows(log, window_s, twin)


def run_pair(log, model: Model, detector: Path, spread: pd.DataFrame, out: Path, twin, windows,
             baselines: dict) -> list[dict]:
    """The log diagnosed healthy and with each injected fault, without and with each of ``baselines`` (label ->
    baseline map): one row per case and baseline."""
    from ur5fault.health.diagnosis import diagnose
    from ur5fault.health.diagnosis.report import write_diagnosis

    t0 = time.perf_counter()
    rows, healthy = [], None
    for _label, kind, joint, values in INJECTIONS:
        lg = log if kind is None else inject(log, kind, joint, **values)
        d0 = diagnose(lg, detector, model.params, model.effects, twin=twin, windows=windows if kind is None else None)
        if kind is None:
            healthy = d0
        for name, baseline in baselines.items():
            d1 = diagnose(lg, detector, model.params, model.effects, twin=twin, windows=d0["_windows"],
                          baseline=baseline)
            row = {"log": log.source, "injected": kind, "joint": None if joint is None else joint + 1,
                   "model": "packaged" if model == PACKAGED else "identified on the other fold",
                   "baseline": name, "baseline_logs": list(baseline.logs), "baseline_windows": baseline.n_windows,
                   "n_windows": d0["n_windows"], "without": summarise(d0, kind, joint),
                   "with": summarise(d1, kind, joint)}
            if kind is None:
                row["outliers_without"] = outliers(d0["_windows"], spread)
                row["outliers_with"] = outliers(d0["_windows"], spread, baseline=baseline)
                row["baseline_summary"] = d1["baseline"]
                stem = Path(log.source).name.split(".")[0]
                write_diagnosis(d1, out / "with_baseline" / f"{stem}+{name.replace(' ', '_')}")
            else:
                row["size_minus_healthy_median"] = size_delta(d0["_windows"], healthy["_windows"], kind, joint)
                row["without"].update(flagged_on_joint(d0, joint))
                row["with"].update(flagged_on_joint(d1, joint))
            rows.append(row)
    print(f"{log.source}: {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    return rows


def table_baseline(rows: list[dict]) -> str:
    """Per diagnosed log and baseline: the robot's threshold; healthy windows flagged without the baseline, with
    it at the training runs' threshold, and with it above the robot's threshold too; inputs beyond 3 robust SD of
    the healthy training runs, without -> with the baseline; each injected fault: share of windows flagged, and
    flagged with its joint the likeliest, with the baseline at the training threshold -> above the robot's."""
    lines = ["| log | baseline (windows) | robot threshold: score (false-alarm bound) | healthy windows flagged: "
             "no baseline / baseline / **baseline and robot threshold** | inputs beyond 3 robust SD | + 0.1 A offset "
             "J4: flagged / flagged on J4 | + 10 % gain J2: flagged / flagged on J2 |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    by: dict[tuple, dict] = {}
    for r in rows:
        by.setdefault((r["log"], r["baseline"]), {})[r["injected"]] = r
    pct = "{:.0f} %".format
    for (name, base), c in by.items():
        h = c[None]
        cells = []
        for kind in ("current_sensor_offset", "current_sensor_gain"):
            b = c[kind]["with"]
            cells.append(f"{pct(100 * b['share_flagged_training_threshold'])} / "
                         f"{pct(100 * b['share_flagged_on_joint_training_threshold'])} -> "
                         f"**{pct(100 * b['share_flagged'])} / {pct(100 * b['share_flagged_on_joint'])}**")
        t = (h.get("baseline_summary") or {}).get("robot_threshold")
        thr = "-" if t is None else f"{t['score']:.3f} ({t['false_alarm_bound']:.2f})"
        lines.append(f"| {Path(name).name.split('.')[0]} | {base} ({h['baseline_windows']}) | {thr} | "
                     f"{h['without']['n_flagged']} / {h['with']['n_flagged_training_threshold']} / "
                     f"**{h['with']['n_flagged']}** of {h['n_windows']} | "
                     f"{pct(100 * h['outliers_without']['share_inputs_beyond_3'])} -> "
                     f"{pct(100 * h['outliers_with']['share_inputs_beyond_3'])} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines) + "\n"


def nist_second_half(detector: Path, window_s: float):
    """The NIST log's second half (diagnosed), its twin and windows, and its baseline: the first half."""
    from ur5fault.health.diagnosis import robot_baseline
    from ur5fault.logs import read_nist

    nist = read_nist(NIST_LOG)
    halves = [dataclasses.replace(nist.window(a, b), source=f"{nist.source}[{a:g},{b:g})")
              for a, b in ((0.0, NIST_SPLIT_S), (NIST_SPLIT_S, 1e9))]
    base_tw = twin_and_windows(halves[0], PACKAGED, window_s)
    return (halves[1], twin_and_windows(halves[1], PACKAGED, window_s),
            robot_baseline([halves[0]], detector, windows=[base_tw[1]]))


def fold_overlay(k: int, n_boot: int, params_only: bool = False) -> Model:
    """The model the runs of fold ``k`` are diagnosed under: the overlay of ``ur5fault identify`` on the other fold's
    runs and the standstill run's rest, its motor-angle ripples (``motor_harmonic`` effects) included as
    ``diagnose --model`` reads it (``params_only``: its parameters alone, as this bench did before 2026-11-30)."""
    from ur5fault.config import parse_effects
    from ur5fault.identify import identify
    from ur5fault.sim.params import load_params

    params = load_params()
    other = [n for f in FOLDS[:k] + FOLDS[k + 1:] for n in f]
    print(f"identifying on {', '.join(other)}", file=sys.stderr, flush=True)
    ident = identify([read_kufieta(n) for n in other] + [read_kufieta(REST_RUN).window(REST_FROM_S, 60.0)],
                     params, sweep=False, n_boot=n_boot)
    overlay = ident.overlay(params)
    effects = () if params_only else parse_effects(overlay.get("effects"), "identify's overlay: effects")
    return Model(overlay["params"], tuple(effects))


def arguments(doc: str, out_name: str, argv=None) -> tuple[Path, Path, int, bool]:
    """The detector folder, the output folder, the identification's bootstrap count of a real-log bench and whether
    the Kufieta runs take identify's parameters only."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    ap.add_argument("--detector", default=str(REPO / "results" / "diagnostics_urlog" / "benchmark"))
    ap.add_argument("--out", help=f"default results/{out_name} (with --params-only: results/{out_name}_params_only)")
    ap.add_argument("--n-boot", type=int, default=50, help="bootstrap resamples of the identification")
    ap.add_argument("--params-only", action="store_true",
                    help="diagnose the Kufieta runs under identify's parameters without its motor-angle ripples "
                         "(the bench before 2026-11-30)")
    args = ap.parse_args(argv)
    out = args.out if args.out is not None else str(REPO / "results" / (out_name + ("_params_only" if
                                                                                   args.params_only else "")))
    return Path(args.detector), Path(out), args.n_boot, args.params_only


def main(argv=None) -> int:
    from ur5fault.health.diagnosis import robot_baseline
    from ur5fault.health.diagnostics.saved import load_models
    from ur5fault.util.io import write_json_atomic, write_text_atomic

    detector, out, n_boot, params_only = arguments(__doc__, "diagnose_real_logs", argv)
    t0 = time.perf_counter()
    _, schema = load_models(detector)
    window_s = float(schema["window_s"])
    spread = healthy_spread(detector, [c["name"] for c in schema["inputs"]])
    nist, nist_tw, nist_base = nist_second_half(detector, window_s)
    rows = run_pair(nist, PACKAGED, detector, spread, out, *nist_tw, {"first half": nist_base})
    overlays = {}
    for k, fold in enumerate(FOLDS):
        overlays[k] = fold_overlay(k, n_boot, params_only)
        # every undisturbed run replayed under this fold's overlay: the fold's own (unseen by the overlay) and
        # the other fold's (the overlay was identified on them)
        logs = {n: read_kufieta(n) for f in FOLDS for n in f}
        tw = {n: twin_and_windows(lg, overlays[k], window_s) for n, lg in logs.items()}
        for name in fold:
            choice = {BASE_FOLD: [n for n in fold if n != name], BASE_ALL: [n for n in logs if n != name]}
            bases = {label: robot_baseline([logs[n] for n in names], detector, overlays[k].params,
                                           overlays[k].effects, windows=[tw[n][1] for n in names])
                     for label, names in choice.items()}
            rows += run_pair(logs[name], overlays[k], detector, spread, out, *tw[name], bases)
    summary = {"detector": str(detector), "feature_set": schema.get("feature_set"),
               "threshold_5pct_false_alarms": schema["joint_kind_threshold_5pct_false_alarms"],
               "threshold_from": schema.get("joint_kind_threshold_from"),
               "run_level_threshold_5pct_false_alarms": schema["detector_threshold_5pct_false_alarms"],
               "calibration": schema.get("calibration", {}) and schema["calibration"].get("method"),
               "folds": FOLDS, "nist_split_s": NIST_SPLIT_S, "rows": rows, "overlays": overlays,
               "kufieta_model": "identify's parameters only" if params_only else "identify's whole overlay",
               "wall_s": time.perf_counter() - t0}
    write_json_atomic(out / "summary.json", json.loads(json.dumps(summary, default=_jsonable)))
    md = table_baseline(rows)
    write_text_atomic(out / "table_baseline.md", md)
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
