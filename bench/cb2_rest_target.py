"""What a CB2 log's target is while the arm stands, and what replaying it otherwise does to the model's current
(docs/validation.md, "A CB2 log's target at rest").

    python bench/cb2_rest_target.py [--overlay OVERLAY.json] [--runs TEST ...] [--follow-passes 8]

1. *The logs*: per run, the rows with every target speed exactly 0 ("at rest"), those one controller tick after
   the previous row (``regular.ticks``, the reader's rule; a row after a gap has no previous reading to equal), the
   share of those whose target position equals the previous row's measured position on every joint (to 1e-9 rad),
   and how many of the others are the first row of a stretch at rest; the same on the NIST (CB3) log.
2. *Three replays* of each run under the Kufieta robot's identified model (``--overlay``: the parameter overlay
   written by ``bench/residual_bins.py`` as ``kufieta_overlay.json``; without it, ``identify`` is run here on
   ``cross_robot.FIT_RUNS`` plus the standstill run's rest, as that script does):

   * *as logged*: the log's targets (the twin is commanded to the robot's own reading while it stands);
   * *commanded end pose*: over each stretch at rest the target of its first sample (the pose the motion was
     commanded to, before the controller's target takes the reading), held;
   * *own reading*: over each stretch at rest after its first row (which keeps the commanded end pose, as in the
     log) the twin's own resolver reading one sample earlier, as the CB2 logs its target; made by fixed-point
     passes (each pass replays with the previous pass's readings; the replays are deterministic, so the passes
     agree up to the first changed sample).

   Current RMS [A] of measured minus simulated, and in brackets as a multiple of UR's own model (``actual -
   target_current``) on the same samples, per joint: over all samples, at rest, moving; the first 0.5 s left out.

Nothing here changes the package: it measures whether the CB2's at-rest target explains the model's at-rest error.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))

KUFIETA = REPO / "data" / "kufieta-ur5"
NIST = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
RUNS = ("Movement_No1", "Movement_No2", "Movement_No3_Acc", "Movement_No4_Acc",
        "Movement_No5_Acc_slow_no_disturbance", "Movement_No5_Acc_slow_w_disturbance",
        "Movement_No8_Singularity_Free_1", "Movement_No10_Standstill_WDist", "TEST")
SKIP_S = 0.5


def previous_written(log) -> np.ndarray:
    """``(n,)`` int: the last row before each row that the robot wrote (-1 where there is none)."""
    idx = np.where(log.logged_rows(), np.arange(log.t_s.size), -1)
    return np.concatenate(([-1], np.maximum.accumulate(idx)[:-1]))


def reading_rows(log) -> np.ndarray:
    """``(n,)`` bool: rows written by the robot whose target is the measured position of the last row written
    before them, on every joint (to the files' precision, the reader's ``SAME_POSITION_RAD``; the ticks the reader
    filled in, ``MeasuredLog.logged``, skipped: a recorder that dropped rows). Found on the log as read, which
    keeps no target speeds."""
    from ur5fault.logs.rest_target import SAME_POSITION_RAD

    prev = previous_written(log)
    same = np.all(np.abs(log.q_target_rad - log.q_actual_rad[np.maximum(prev, 0)]) < SAME_POSITION_RAD, axis=1)
    return log.logged_rows() & (prev >= 0) & same


def held_pose(log):
    """``(log, n_rows)``: ``log`` (a ``MeasuredLog``) with the targets of its reading rows (:func:`reading_rows`),
    and of the filled-in ticks before each, held at the pose the controller holds: each stretch takes the target of
    the last written row before it (the stretch's first row at rest, which carries the commanded pose; already held
    when that row is itself a reading row). ``n_rows``: the rows changed (0: ``log`` itself, e.g. NIST's CB3 log).
    The "commanded end pose" replay below, and ``bench_monitor.py --held-pose``."""
    rows = reading_rows(log)
    if not rows.any():
        return log, 0
    prev = previous_written(log)
    q = np.array(log.q_target_rad, copy=True)
    for i in np.flatnonzero(rows):  # in time order: q[prev[i]] is already held when that row is a reading row
        q[prev[i] + 1 : i + 1] = q[prev[i]]
    changed = int(np.any(q != log.q_target_rad, axis=1).sum())
    notes = tuple(n for n in log.notes if "the logged target is the previous measured position" not in n)
    return dataclasses.replace(log, q_target_rad=q, rest_target="setpoint", notes=notes), changed


def follows_reading(t: np.ndarray, target: np.ndarray, actual: np.ndarray, target_speed: np.ndarray) -> dict:
    """Rows at rest (every target speed exactly 0, after the first row): how many, how many of them one tick after
    the previous row (the reader's rule, ``logs.rest_target.rest_target_rows``), the share of those whose target equals
    the previous reading on every joint, and how many of those that do not are the first row of a stretch at
    rest."""
    from ur5fault.logs.rest_target import rest_target_rows

    at_rest = np.all(target_speed == 0.0, axis=1)
    sel, same = rest_target_rows(t, target, actual, target_speed)  # rows 1..n-1
    first = at_rest[1:] & ~at_rest[:-1]
    other = sel & ~same
    return {"rest": int(at_rest[1:].sum()), "one_tick": int(sel.sum()),
            "share": float(same[sel].mean()) if sel.any() else float("nan"),
            "other": int(other.sum()), "other_first": int((other & first).sum())}


def log_table() -> None:
    print("| log | rows at rest | of them one tick after the previous row | target = previous reading there | "
          "other rows (of them the first of a stretch at rest) |")
    print("| --- | --- | --- | --- | --- |")

    def line(name, f):
        if not f["one_tick"]:
            print(f"| {name} | {f['rest']} | - | - | - |")
        else:
            print(f"| {name} | {f['rest']} | {f['one_tick']} | {f['share']:.1%} | {f['other']} ({f['other_first']}) |")

    for name in RUNS:
        raw = pd.read_csv(KUFIETA / f"{name}.csv.gz")
        q, a, w = (raw[[f"{p}_{j}" for j in range(6)]].to_numpy() for p in ("target_q", "actual_q", "target_qd"))
        line(name, follows_reading(raw["time"].to_numpy(), q, a, w))
    raw = pd.read_csv(NIST)
    q, a, w = (np.radians(raw[[f"ROBOT_{p} (J{j})" for j in range(1, 7)]].to_numpy()) if "POSITIONS" in p
               else raw[[f"ROBOT_{p} (J{j})" for j in range(1, 7)]].to_numpy()
               for p in ("TARGET_JOINT_POSITIONS", "ACTUAL_JOINT_POSITIONS", "TARGET_JOINT_VELOCITIES"))
    line("NIST (CB3)", follows_reading(raw["ROBOT_TIME"].to_numpy(), q, a, w))


def rest_stretches(speed: np.ndarray) -> list[tuple[int, int]]:
    """``[start, end)`` of the runs of samples with every target speed exactly 0."""
    rest = np.all(speed == 0.0, axis=1)
    out, i = [], 0
    while i < rest.size:
        if rest[i]:
            e = i
            while e < rest.size and rest[e]:
                e += 1
            out.append((i, e))
            i = e
        else:
            i += 1
    return out


def overlay(path: str | None) -> dict:
    if path:
        return json.loads(Path(path).read_text())
    from cross_robot import FIT_RUNS, REST_FROM_S, REST_RUN, read

    from ur5fault.identify import identify
    from ur5fault.sim.params import load_params

    params = load_params()
    ident = identify([read(n) for n in FIT_RUNS] + [read(REST_RUN).window(REST_FROM_S, 60.0)], params,
                     sweep=False, n_boot=20)
    return ident.overlay(params)["params"]


def replays(name: str, over: dict, passes: int) -> None:
    from cross_robot import read

    from ur5fault.discrepancy.model import WORKFLOW_SEED
    from ur5fault.sim.engine import Simulator
    from ur5fault.sim.runspec import RunSpec
    from ur5fault.twin.replay import replay_params

    log = read(name)
    raw = pd.read_csv(KUFIETA / f"{name}.csv.gz")
    if len(raw) != log.t_s.size:
        print(f"\n{name}: the reader kept {log.t_s.size} of {len(raw)} rows; not replayed here")
        return
    speed = raw[[f"target_qd_{j}" for j in range(6)]].to_numpy()
    params = replay_params(log, over)
    n = log.t_s.size - 1

    def run(q):
        lg = dataclasses.replace(log, q_target_rad=np.array(q, copy=True))
        return Simulator(params).run(lg.to_trajectory(), [RunSpec("c0", WORKFLOW_SEED, ())],
                                     log_period_s=log.period_s, duration_s=n * log.period_s)

    t = log.t_s[1:] - log.t_s[0]
    keep = log.logged_rows()[1:] & (t >= SKIP_S)
    rest_rows = np.all(speed == 0.0, axis=1)
    rest = rest_rows[1:]
    meas, ur = log.current_A[1:], log.target_current_A[1:]

    def rms(x):
        return float(np.sqrt(np.mean(x * x))) if x.size else float("nan")

    def row(label, res):
        r = meas - res["i_FB_A"][0]
        u = meas - ur
        for part, sel in (("all", keep), ("at rest", keep & rest), ("moving", keep & ~rest)):
            cells = [f"{rms(r[sel, j]):.3f} ({rms(r[sel, j]) / rms(u[sel, j]):.2f})" for j in range(6)]
            print(f"| {label} | {part} | " + " | ".join(cells) + " |")

    stretches = rest_stretches(speed)
    print(f"\n{name}: {len(stretches)} stretches at rest, {int(rest.sum())} of {n} samples\n")
    print("| replay | samples | J1 | J2 | J3 | J4 | J5 | J6 |")
    print("| --- " * 8 + "|")
    tq = np.asarray(log.q_target_rad)
    row("as logged", run(tq))
    row("commanded end pose", run(held_pose(log)[0].q_target_rad))
    own = tq.copy()
    idx = np.flatnonzero(rest_rows[1:] & rest_rows[:-1]) + 1  # the first row of a stretch keeps the end pose
    idx = idx[idx >= 2]
    res = run(own)
    for _ in range(passes):
        own[idx] = res["q_FB_rad"][0][idx - 2]  # log sample i's target: the reading at sample i - 1 (result row i - 2)
        res = run(own)
    row(f"own reading ({passes} passes)", res)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--overlay", help="parameter overlay (JSON) of the Kufieta robot; default: identify here")
    ap.add_argument("--runs", nargs="*", default=["TEST", "Movement_No5_Acc_slow_no_disturbance"])
    ap.add_argument("--follow-passes", type=int, default=8)
    args = ap.parse_args(argv)
    log_table()
    over = overlay(args.overlay)
    for name in args.runs:
        replays(name, over, args.follow_passes)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
