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

from ur5fault.identify.friction_choice import replay
from ur5fault.logs import read_nist
from ur5fault.sim.params import load_params

NIST_LOG = Path(__file__).resolve().parents[1] / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"


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
