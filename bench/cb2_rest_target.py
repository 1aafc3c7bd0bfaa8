"""What a CB2 log's target is while the arm stands, and what replaying it otherwise does to the model's current
(docs/validation.md, "A CB2 log's target at rest").

    python bench/cb2_rest_target.py [--overlay OVERLAY.json] [--runs TEST ...] [--follow-passes 8]

1. *The logs*: per run, the share of the samples with every target speed exactly 0 ("at rest") whose target
   position equals the previous sample's measured position on every joint (to 1e-9 rad), and the same on the NIST
   (CB3) log.
2. *Three replays* of each run under the Kufieta robot's identified model (``--overlay``: the parameter overlay
   written by ``bench/residual_bins.py`` as ``kufieta_overlay.json``; without it, ``identify`` is run here on
   ``cross_robot.FIT_RUNS`` plus the standstill run's rest, as that script does):

   * *as logged*: the log's targets (the twin is commanded to the robot's own reading while it stands);
   * *commanded end pose*: over each stretch at rest the target of its first sample (the pose the motion was
     commanded to, before the controller's target takes the reading), held;
   * *own reading*: over each stretch at rest the twin's own resolver reading one sample earlier, as the CB2
     logs its target; made by fixed-point passes (each pass replays with the previous pass's readings; the
     replays are deterministic, so the passes agree up to the first changed sample).

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
SAME_RAD = 1e-9  # the CSV's positions carry 6-7 decimals: equal means equal to the file's precision
SKIP_S = 0.5


def follows_reading(target: np.ndarray, actual: np.ndarray, target_speed: np.ndarray) -> tuple[float, int]:
    """Share of the at-rest samples (every target speed exactly 0) whose target equals the previous reading on
    every joint, and their number."""
    rest = np.all(target_speed == 0.0, axis=1)
    rest[0] = False
    same = np.zeros(rest.shape, dtype=bool)
    same[1:] = np.all(np.abs(target[1:] - actual[:-1]) < SAME_RAD, axis=1)
    n = int(rest.sum())
    return (float(same[rest].mean()) if n else float("nan")), n


def log_table() -> None:
    print("| log | samples at rest | target = previous reading |")
    print("| --- | --- | --- |")
    for name in RUNS:
        raw = pd.read_csv(KUFIETA / f"{name}.csv.gz")
        q, a, w = (raw[[f"{p}_{j}" for j in range(6)]].to_numpy() for p in ("target_q", "actual_q", "target_qd"))
        share, n = follows_reading(q, a, w)
        print(f"| {name} | {n} | {share:.1%} |")
    raw = pd.read_csv(NIST)
    q, a, w = (raw[[f"ROBOT_{p} (J{j})" for j in range(1, 7)]].to_numpy()
               for p in ("TARGET_JOINT_POSITIONS", "ACTUAL_JOINT_POSITIONS", "TARGET_JOINT_VELOCITIES"))
    share, n = follows_reading(q, a, w)
    print(f"| NIST (CB3) | {n} | {share:.1%} |")


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
    rest = np.all(speed == 0.0, axis=1)[1:]
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
    end_pose = tq.copy()
    for s, e in stretches:
        end_pose[s:e] = tq[s]
    row("commanded end pose", run(end_pose))
    own = tq.copy()
    idx = np.flatnonzero(np.all(speed == 0.0, axis=1))
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
