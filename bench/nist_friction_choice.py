"""How the friction defaults were chosen on the real UR5 log (docs/parameters.md): replay the NIST log's
targets under the nominal model with each candidate and compare the simulated motor current with the
measured one (RMS of the difference, held out = the last 40 %, at rest = target speed below 1e-3 rad/s,
near reversals as the discrepancy workflow defines them).

    python bench/nist_friction_choice.py [--quick]   # ~15 min on 2 cores; --quick: law and share only

Prints Markdown tables and one JSON line.  Candidates are swept through effects of the registry
(``presliding_stiffness``, ``friction_share``) on every joint, in lockstep batches.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.discrepancy import conditions
from ur5fault.logs import read_nist
from ur5fault.params import deep_merge, load_params

NIST_LOG = Path(__file__).resolve().parents[2] / "shared" / "data" / "nist-ur5" / \
    "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
HELD_OUT_FROM = 0.6


def replay(log, friction: dict | None, cases: list[dict]) -> list[dict]:
    """Replay once per case (``{"s0": scale, "share": value}`` on every joint); RMS figures per case."""
    over = {"tcp_offset_m": list(log.tcp_offset_m), "joint_temperature_C": log.temperature_C.mean(axis=0).tolist()}
    p = load_params(overrides=deep_merge(over, {"friction": friction} if friction else {}))
    runs = []
    for i, c in enumerate(cases):
        eff = []
        for j in range(1, 7):
            if "s0" in c:
                eff.append(make_effect("presliding_stiffness", j, scale=c["s0"]))
            if "share" in c:
                eff.append(make_effect("friction_share", j, motor_side_share=c["share"]))
        runs.append(RunSpec(f"c{i}", 1, tuple(eff)))
    res = Simulator(p).run(log.to_trajectory(), runs, log_period_s=log.period_s)
    n = res.t_s.size
    meas = log.current_A[1 : n + 1]
    masks = conditions(log, n, meas)
    held = np.broadcast_to((res.t_s >= HELD_OUT_FROM * (log.t_s[-1] - log.t_s[0]))[:, None], (n, 6))
    sel = {"held_out": held, "at_rest": masks["at rest"], "near_reversals": masks["near velocity reversals"]}

    def rms(x, m):
        return np.sqrt(np.nanmean(np.where(m, x, np.nan) ** 2, axis=0)).round(4).tolist()

    near = masks["near velocity reversals"]
    e_meas = log.q_target_rad[1 : n + 1] - log.q_actual_rad[1 : n + 1]
    out = [{"case": c, "status": res.status[i], **{k: rms(res["i_FB_A"][i] - meas, m) for k, m in sel.items()},
            "tracking_near_reversals_sim_over_measured":
                (np.array(rms(log.q_target_rad[1 : n + 1] - res["q_FB_rad"][i], near)) /
                 np.array(rms(e_meas, near))).round(3).tolist()}
           for i, c in enumerate(cases)]
    out.append({"case": "UR's model", **{k: rms(log.target_current_A[1 : n + 1] - meas, m) for k, m in sel.items()}})
    return out


def table(title: str, rows: list[dict], key: str) -> None:
    print(f"\n{title}: current RMS {key.replace('_', ' ')} [A]\n")
    print("| case | J1 | J2 | J3 | J4 | J5 | J6 | sum |\n| --- |" + " --- |" * 7)
    for r in rows:
        v = np.nan_to_num(np.array(r[key], dtype=float))
        print(f"| {json.dumps(r['case'])} | " + " | ".join(f"{x:.3f}" for x in v) + f" | {v.sum():.3f} |")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="law and share only")
    a = ap.parse_args(argv)
    if not NIST_LOG.exists():
        print(f"real UR5 log not found at {NIST_LOG}", file=sys.stderr)
        return 2
    log = read_nist(NIST_LOG)
    results = {}
    smooth, lugre = replay(log, {"model": "smooth"}, [{}]), replay(log, None, [{}])  # each: [case, UR's model]
    smooth[0]["case"], lugre[0]["case"] = "smooth sign", "LuGre (default)"
    results["law"] = [smooth[0], lugre[0], lugre[1]]
    table("Friction law", results["law"], "at_rest")
    table("Friction law", results["law"], "held_out")
    results["share"] = replay(log, None, [{"share": s} for s in (0.0, 0.25, 0.5, 0.75, 1.0)])
    table("Motor-side share", results["share"], "held_out")
    table("Motor-side share", results["share"], "near_reversals")
    print("\ntracking error near velocity reversals, simulated / measured, J1..J6:")
    for r in results["share"][:-1]:
        print(json.dumps(r["case"]), r["tracking_near_reversals_sim_over_measured"])
    if not a.quick:
        results["presliding"] = replay(log, None, [{"s0": s} for s in (0.1, 0.3, 0.5, 1.0, 2.0, 10.0)])
        table("Presliding stiffness (x default)", results["presliding"], "held_out")
        base = np.asarray(load_params().friction.bristle_damping_Nms_per_rad)
        results["bristle_damping"] = []
        for k in (0.0, 0.1, 3.0):
            r = replay(log, {"bristle_damping_Nms_per_rad": (k * base).tolist()}, [{}])[0]
            r["case"] = f"sigma1 x {k:g}"
            results["bristle_damping"].append(r)
        table("Bristle damping", results["bristle_damping"], "held_out")
    print(json.dumps(results))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
