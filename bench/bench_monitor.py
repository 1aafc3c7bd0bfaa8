"""Monitoring without false alarms (docs/monitoring.md): ``ur5fault monitor``'s verdicts on every real run.

    python bench/bench_monitor.py [--jobs N] [--no-identify] [--out results/bench_monitor.json] [--cache FILE]

``--cache FILE``: keep the replayed log parts (and the identified overlay) in FILE, a pickle, and reuse them when
it exists: the verdicts can then be recomputed in seconds after a change to the monitor's rules (not to its
replay, :mod:`ur5fault.health.monitoring.observe`, nor to identify: delete the file then).

*Kufieta robot* (data/kufieta-ur5, payload 0 kg, TCP at the flange). The baseline overlay is ``ur5fault
identify`` fitted jointly on the five undisturbed runs :data:`BASE_RUNS` (``--no-identify``: the packaged
model). Each of those runs is monitored against the residual statistics of the other four (leave one out: a run
never sets its own thresholds; the overlay was fitted with it, which the statistics do not use); every other
run against all five: the undisturbed Movement_No5_Acc_slow_no_disturbance and TEST, the pushed
Movement_No5_Acc_slow_w_disturbance and Movement_No10_Standstill_WDist, and TEST with a current-sensor gain
injected on one joint (the logged current of that joint times :data:`GAINS`).

*NIST robot* (data/nist-ur5, one log): the packaged model (fitted on this log), the baseline statistics from its
first :data:`~ur5fault.twin.residuals.FIT_FRACTION` of log time, the rest monitored; and the rest with a gain
injected.

*Push labels* come from UR's own current model (``actual - target_current``), which knows nothing of ours:
smoothed like the monitor's residual (0.1 s), its deviation from a reference level; a push is a stretch of at
least :data:`MIN_PUSH_S` where that deviation exceeds the largest one of an undisturbed reference of the same
motion: for the pushed moving run, the paired undisturbed run Movement_No5_Acc_slow_no_disturbance (whole run,
deviation from its median); for the standstill run, the same undisturbed run's standing start (before its
target first moves; the pushed standstill's deviation from its own median). A label is *found* when an event on
one of
its joints starts and ends within 0.5 s of it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
KUFIETA = REPO / "data" / "kufieta-ur5"
NIST_LOG = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
BASE_RUNS = ("Movement_No1", "Movement_No2", "Movement_No3_Acc", "Movement_No4_Acc", "Movement_No8_Singularity_Free_1")
QUIET, PUSHED, STANDSTILL = ("Movement_No5_Acc_slow_no_disturbance", "Movement_No5_Acc_slow_w_disturbance",
                             "Movement_No10_Standstill_WDist")
OTHER_RUNS = (QUIET, "TEST", PUSHED, STANDSTILL)
#: injected current-sensor gains (joint index, gain) on TEST and on the NIST log's rest
GAINS = ((1, 1.2), (1, 1.5), (3, 1.2), (3, 1.5))
WINDOW_S = 0.5
#: a push by hand lasts at least this long [s] (the monitor's smoothing assumes the same, events.SMOOTH_S)
MIN_PUSH_S = 0.2
#: a target this far from its start has begun to move [rad] (the CB2 targets jitter by up to 3e-4 rad at rest)
START_MOVE_RAD = 1e-3


def read(name: str):
    from ur5fault.logs import read_rtde

    return read_rtde(KUFIETA / f"{name}.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))


def inject(log, joint: int, gain: float):
    cur = log.current_A.copy()
    cur[:, joint] *= gain
    return dataclasses.replace(log, current_A=cur, source=f"{log.source} x{gain:g} J{joint + 1}")


def _observe(log, params, part_s=None):
    from ur5fault.health.monitoring import observe

    return observe(log, params, part_s=part_s)


def ur_smoothed(log):
    from ur5fault.health.monitoring.events import smooth

    return smooth((log.current_A - log.target_current_A)[1:], log.period_s)


def standing_start(log) -> np.ndarray:
    """``(n - 1,)``: the samples before the log's target first leaves its start by :data:`START_MOVE_RAD`."""
    away = np.abs(log.q_target_rad - log.q_target_rad[0]).max(axis=1)[1:] > START_MOVE_RAD
    return np.arange(away.size) < int(np.argmax(away))


def labels(log, ref: np.ndarray) -> list[dict]:
    """Push labels of ``log`` (module docstring): ``ref`` the smoothed UR residual of the undisturbed reference."""
    from ur5fault.health.monitoring.events import MERGE_S
    from ur5fault.sim.axes import JOINT_NAMES

    limit = np.abs(ref - np.median(ref, axis=0)).max(axis=0)
    r = ur_smoothed(log)
    level = np.median(r, axis=0)
    over = np.abs(r - level) > limit
    t = log.t_s[1:] - log.t_s[0]
    rows = np.flatnonzero(over.any(axis=1))
    out, gap = [], int(round(MERGE_S / log.period_s))
    for k, row in enumerate(rows):
        if not out or row - rows[k - 1] > gap:
            out.append({"t_start_s": float(t[row]), "rows": [row]})
        out[-1]["rows"].append(row)
        out[-1]["t_end_s"] = float(t[row])
    for lab in out:
        rs = lab.pop("rows")
        lab["joints"] = [JOINT_NAMES[j] for j in range(6) if over[rs[0] : rs[-1] + 1, j].any()]
    return [lab for lab in out if lab["t_end_s"] - lab["t_start_s"] >= MIN_PUSH_S]


def separable(base) -> dict[str, dict[str, float]]:
    """Per joint, the smallest current-sensor offset [A] and gain change [-] the change test can tell from the
    baseline's blocks: the bar times the prediction interval's width with the new log's own standard error taken
    as 0 (a lower bound: a real log's SE adds to it)."""
    from ur5fault.health.monitoring.changes import bar
    from ur5fault.sim.axes import JOINT_NAMES

    out = {}
    for j in JOINT_NAMES:
        row = {}
        for key, label in (("offset_A", f"{j}: current_sensor_offset.offset_A"),
                           ("gain", f"{j}: current_sensor_gain.gain")):
            if label in base.candidates:
                _, var, k = base.candidates[label]
                limit, inflate = bar(k)
                row[key] = float(limit * np.sqrt(var * inflate))
        out[j] = row
    return out


def found(label: dict, events: list[dict]) -> bool:
    return any(abs(e["t_start_s"] - label["t_start_s"]) <= WINDOW_S and abs(e["t_end_s"] - label["t_end_s"]) <= WINDOW_S
               and set(e["joints"]) & set(label["joints"]) for e in events)


def main(argv=None) -> int:
    import joblib

    from ur5fault.health.monitoring import assess, fit_baseline
    from ur5fault.health.monitoring.baseline import overlay_sha256
    from ur5fault.logs import read_nist
    from ur5fault.sim.params import load_params
    from ur5fault.twin.residuals import FIT_FRACTION

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-identify", action="store_true", help="the packaged model as the Kufieta baseline overlay")
    ap.add_argument("--out", default=str(REPO / "results" / "bench_monitor.json"))
    ap.add_argument("--cache", help="pickle of the replayed parts: written if absent, reused if present")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    cached = None
    if args.cache and Path(args.cache).exists():
        import pickle

        with open(args.cache, "rb") as f:
            cached = pickle.load(f)
        if cached["no_identify"] != args.no_identify:
            ap.error(f"{args.cache} was written with{'' if cached['no_identify'] else 'out'} --no-identify")
    params = {}
    if cached is not None:
        params = cached["params"]
    elif not args.no_identify:
        from ur5fault.identify import identify

        print("identifying on", ", ".join(BASE_RUNS), file=sys.stderr, flush=True)
        params = identify([read(n) for n in BASE_RUNS], load_params(), sweep=False, n_boot=20).overlay(
            load_params())["params"]
    t_ident = time.perf_counter() - t0
    logs = {n: read(n) for n in BASE_RUNS + OTHER_RUNS}
    injected = [inject(logs["TEST"], j, g) for j, g in GAINS]
    nist = read_nist(NIST_LOG)
    span = float(nist.t_s[-1] - nist.t_s[0])
    split = FIT_FRACTION * span
    nist_inj = [inject(nist, j, g) for j, g in GAINS]
    tasks = [(logs[n], params, None) for n in BASE_RUNS + OTHER_RUNS] + [(lg, params, None) for lg in injected] + \
        [(nist, {}, (0.0, split)), (nist, {}, (split, span + 1))] + [(lg, {}, (split, span + 1)) for lg in nist_inj]
    if cached is not None:
        obs = cached["obs"]
    else:
        print(f"replaying {len(tasks)} log parts", file=sys.stderr, flush=True)
        obs = joblib.Parallel(n_jobs=args.jobs)(joblib.delayed(_observe)(*t) for t in tasks)
        if args.cache:
            import pickle

            from ur5fault.util.io import write_bytes_atomic

            write_bytes_atomic(Path(args.cache), pickle.dumps({"no_identify": args.no_identify, "params": params,
                                                               "obs": obs, "identify_s": t_ident}))
    k = len(BASE_RUNS)
    base_obs, other_obs = obs[:k], obs[k : k + len(OTHER_RUNS)]
    inj_obs = obs[k + len(OTHER_RUNS) : k + len(OTHER_RUNS) + len(GAINS)]
    nist_base, nist_rest, nist_inj_obs = obs[-len(GAINS) - 2], obs[-len(GAINS) - 1], obs[-len(GAINS):]
    sha = overlay_sha256(params, ())
    results = []
    for i, o in enumerate(base_obs):
        results.append(("kufieta, leave one out", assess(fit_baseline(base_obs[:i] + base_obs[i + 1 :], sha), o)))
    full = fit_baseline(base_obs, sha)
    for o in other_obs + inj_obs:
        results.append(("kufieta", assess(full, o)))
    nb = fit_baseline([nist_base], overlay_sha256({}, ()))
    for o in [nist_rest, *nist_inj_obs]:
        results.append(("nist, first part vs rest", assess(nb, o)))

    print("\n| robot | log | verdict | changes | events |\n| --- | --- | --- | --- | --- |")
    for robot, e in results:
        ch = "; ".join(f"{c['joint']}: {c['effect']}.{c['parameter']} = {c['value']:.3g} "
                       f"({c['interval'][0]:.3g}..{c['interval'][1]:.3g})" for c in e["changes"]) or "-"
        ev = "; ".join(f"{x['t_start_s']:.2f}-{x['t_end_s']:.2f} s "
                       f"{','.join(j.split('_joint')[0] for j in x['joints'])} {x['peak_A']:.2f} A"
                       for x in e["events"]) or "-"
        print(f"| {robot} | {e['log']} | {e['verdict']} | {ch} | {ev} |")
    sep = {"kufieta": separable(full), "nist": separable(nb)}
    for robot, rows in sep.items():
        print(f"\n{robot}: smallest separable change (lower bound), offset [A] / gain [-]: " + "; ".join(
            f"{j.split('_joint')[0]} {r.get('offset_A', float('nan')):.3f} / {r.get('gain', float('nan')):.3f}"
            for j, r in rows.items()))
    by = {e["log"]: e for _, e in results}
    pushes = {}
    quiet = ur_smoothed(logs[QUIET])
    refs = {PUSHED: quiet, STANDSTILL: quiet[standing_start(logs[QUIET])]}
    for name in (PUSHED, STANDSTILL):
        labs = labels(logs[name], refs[name])
        ev = by[f"{name}.csv.gz"]["events"]
        for lab in labs:
            lab["found"] = found(lab, ev)
        pushes[name] = labs
        print(f"\n{name}: {sum(lab['found'] for lab in labs)} of {len(labs)} labelled pushes found")
        for lab in labs:
            print(f"  {lab['t_start_s']:.2f}-{lab['t_end_s']:.2f} s {', '.join(lab['joints'])}: "
                  f"{'found' if lab['found'] else 'missed'}")
    out = {"overlay": params, "results": [{"robot": r, **e} for r, e in results], "pushes": pushes, "separable": sep,
           "identify_s": t_ident, "wall_s": time.perf_counter() - t0}
    from ur5fault.util.io import write_json_atomic

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(Path(args.out), json.loads(json.dumps(out, default=float)))
    print(f"\nwall {out['wall_s']:.0f} s (identification {t_ident:.0f} s); wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
