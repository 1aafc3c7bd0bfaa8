"""The paper's Fig. 3 claim, measured on our model: maximum TCP deviation from the healthy
twin run for backlash alpha = 0.1 deg on each joint in turn (2 kg pick-and-place), under the
default parameters and as a band over the share of friction on the motor side of the gear
clearance (the same share on every joint of the faulty run and of its twin).

    python bench/paper_tcp_deviation.py  [--alpha 0.1] [--shares 0 0.25 0.5 0.75 1]

Prints a Markdown table and a JSON line.  Nothing here is tuned to the paper's result.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from ur5fault import JOINT_NAMES, RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.seed_paper import PAPER_BACKLASH_DEG, PAPER_TCP_MM
from ur5fault.sim.params import load_params


def runs_for(tag: str, alpha_deg: float, seed: int, share: float | None) -> list[RunSpec]:
    """Healthy twin and one faulty run per joint, all with the given motor-side share (None: default)."""
    common = () if share is None else tuple(make_effect("friction_share", j, motor_side_share=share)
                                            for j in range(1, 7))
    out = [RunSpec(f"{tag}-healthy", seed, common)]
    for j in range(1, 7):
        out.append(RunSpec(f"{tag}-j{j}", seed, common + (make_effect("backlash", j, backlash_deg=alpha_deg),)))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--alpha", type=float, default=PAPER_BACKLASH_DEG, help="backlash [deg]")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--shares", type=float, nargs="*", default=[0.0, 0.25, 0.5, 0.75, 1.0],
                    help="motor-side friction shares of the band")
    a = ap.parse_args(argv)
    groups: list[tuple[str, float | None]] = [("default", None)] + [(f"s{s:g}", s) for s in a.shares]
    runs = [r for tag, s in groups for r in runs_for(tag, a.alpha, a.seed, s)]
    res = Simulator().run(pick_and_place(), runs)
    dev = {}
    for g, (tag, _) in enumerate(groups):
        h = 7 * g
        dev[tag] = [float(np.nanmax(np.linalg.norm(res.tcp_m[h + j] - res.tcp_m[h], axis=-1)) * 1e3)
                    for j in range(1, 7)]
    bad = [f"{runs[i].run_id}: {res.status[i]}" for i in range(len(runs)) if res.status[i] != "ok"]
    default_share = load_params().friction.motor_side_share
    band = [(min(dev[t][j] for t, _ in groups[1:]), max(dev[t][j] for t, _ in groups[1:])) for j in range(6)]
    head = " | ".join(f"share {s:g}" for s in a.shares)
    print(f"Max TCP deviation [mm] from the healthy twin, backlash {a.alpha} deg on one joint (2 kg pick-and-place)\n")
    print(f"| joint | default (share {'/'.join(f'{s:g}' for s in sorted(set(default_share)))}) | band | {head} |")
    print("| --- | --- | --- |" + " --- |" * len(a.shares))
    for j in range(6):
        cells = " | ".join(f"{dev[t][j]:.3f}" for t, _ in groups[1:])
        print(f"| {j + 1} {JOINT_NAMES[j]} | {dev['default'][j]:.3f} | {band[j][0]:.3f}-{band[j][1]:.3f} | {cells} |")
    above = [JOINT_NAMES[j] for j in range(6) if dev["default"][j] > PAPER_TCP_MM]
    print(f"\nAbove {PAPER_TCP_MM} mm under the default: {', '.join(above) or 'none'}")
    if bad:
        print("Runs not ok:", "; ".join(bad))
    print(json.dumps({"alpha_deg": a.alpha, "shares": a.shares, "tcp_dev_max_mm": dev,
                      "above_threshold_default": above, "not_ok": bad}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
