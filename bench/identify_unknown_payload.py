"""``identify`` with each log's payload unknown (docs/validation.md, *The unknown payload of each run*): the
fitted payloads with their intervals, the identified parameters beside those with the payload stated as 0 kg,
and the held-out current RMS of the overlay on TEST as a multiple of UR's own model (scored as
bench/cross_robot.py scores it).

    nice -n 5 python bench/identify_unknown_payload.py [--out results/identify_unknown_payload.json]

Kufieta: the six undisturbed runs of bench/cross_robot.py (:data:`cross_robot.FIT_RUNS`) identified jointly, their
payloads unknown, once with the payload at the flange (``--tcp-offset-m 0 0 0``) and once with its centre of mass
unknown too; the standstill run's constant-target stretch joins for the rest-only estimates, stated 0 kg as in
cross_robot.py (it never moves, so no payload or torque-constant regression sees it). TEST is replayed as
cross_robot.py replays it (0 kg at the flange). NIST: the log (0.726 kg at its tool offset) declared unknown, at
its tool offset and with the centre of mass unknown too. No bandwidth sweep; 100 resamples per interval.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cross_robot import FIT_RUNS, KUFIETA, NIST_LOG, REPO, REST_FROM_S, REST_RUN, read, score  # noqa: E402

KEYS = (("motor.torque_constant_Nm_per_A", (1,)), ("friction.coulomb_A", (0, 1, 2, 3)),
        ("friction.viscous_A_s_per_rad", (0, 1, 2, 3)), ("check.current_offset_A", (1, 3)))


def estimates(ident) -> dict:
    out: dict = {}
    for key, joints in KEYS:
        for j in joints:
            e = ident.get(key, j)
            out[f"{key} J{j + 1}"] = {"value": e.value, "lo": e.lo, "hi": e.hi, "identifiable": e.identifiable}
    return out


def main(argv=None) -> int:
    from ur5fault.identify import identify
    from ur5fault.logs import read_nist, read_rtde
    from ur5fault.sim.params import load_params

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(REPO / "results" / "identify_unknown_payload.json"))
    args = ap.parse_args(argv)
    params = load_params()
    rest = read(REST_RUN).window(REST_FROM_S, 60.0)
    result: dict = {}
    variants = {"stated 0 kg": "stated", "unknown, at the flange": (0.0, 0.0, 0.0), "unknown, centre of mass too": None}
    for name, tcp in variants.items():
        t0 = time.perf_counter()
        if tcp == "stated":
            logs = [read(n) for n in FIT_RUNS]
        else:
            logs = [read_rtde(KUFIETA / f"{n}.csv.gz", payload_kg=None, tcp_offset_m=tcp) for n in FIT_RUNS]
        print(f"Kufieta, payload {name}", file=sys.stderr, flush=True)
        ident = identify([*logs, rest], params, sweep=False, n_boot=100)
        wall = time.perf_counter() - t0
        test = score(read("TEST"), ident.overlay(params)["params"])
        result[f"kufieta: {name}"] = {"identify_s": wall, "payloads": [r.to_json() | {"log": r.log}
                                                                      for r in ident.payloads if not r.known],
                                      "estimates": estimates(ident), "TEST": test}
    nist = read_nist(NIST_LOG)
    for name, log in (("unknown, at its tool offset", dataclasses.replace(nist, payload_kg=None)),
                      ("unknown, centre of mass too", dataclasses.replace(nist, payload_kg=None, tcp_offset_m=None)),
                      ("stated 0.726 kg", nist)):
        print(f"NIST, payload {name}", file=sys.stderr, flush=True)
        ident = identify(log, params, sweep=False, n_boot=100)
        result[f"nist: {name}"] = {"payloads": [r.to_json() | {"log": r.log} for r in ident.payloads if not r.known],
                                   "estimates": estimates(ident)}
    for case, r in result.items():
        print(f"\n## {case}")
        for rec in r["payloads"]:
            lo, hi = rec["interval_kg"]
            com = rec["com_m"]
            r2 = rec["r2_mass_vs_torque_constant_friction_offset"]
            where = "-" if com is None else tuple(round(c, 3) for c in com)
            print(f"- {rec['log']}: {rec['mass_kg']:.2f} kg ({lo:.2f}..{hi:.2f}), com {where}, r2 {r2:.3f}, "
                  f"separable {rec['separable']}")
        for k, e in r["estimates"].items():
            iv = f"[{e['lo']:.3f}, {e['hi']:.3f}]" if e["identifiable"] else "n.i."
            print(f"  {k}: {e['value']:.4g} {iv}")
        if "TEST" in r:
            print("  TEST ratio to UR's model:", " / ".join(f"{x:.2f}" for x in r["TEST"]["ratio"]))
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    from ur5fault.util.io import write_json_atomic

    write_json_atomic(Path(args.out), result)
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
