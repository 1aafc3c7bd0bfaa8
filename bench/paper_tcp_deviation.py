"""The paper's Fig. 3 claim, measured on our model: maximum TCP deviation from the healthy
twin run for backlash alpha = 0.1 deg on each joint in turn (2 kg pick-and-place).

    python bench/paper_tcp_deviation.py  [--alpha 0.1]

Prints a Markdown table and a JSON line.  Nothing here is tuned to the paper's result.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from ur5fault import JOINT_NAMES, RunSpec, Simulator, make_effect, pick_and_place


def main(argv=None) -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--alpha", type=float, default=0.1, help="backlash [deg]")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args(argv)
    runs = [RunSpec("healthy", a.seed)] + [
        RunSpec(f"j{j + 1}", a.seed, (make_effect("backlash", j + 1, backlash_deg=a.alpha),)) for j in range(6)
    ]
    res = Simulator().run(pick_and_place(), runs)
    dev = [float(np.nanmax(np.linalg.norm(res.tcp_m[i] - res.tcp_m[0], axis=-1)) * 1e3) for i in range(1, 7)]
    rms = [float(np.sqrt(np.nanmean(np.sum((res.tcp_m[i] - res.tcp_m[0]) ** 2, axis=-1))) * 1e3) for i in range(1, 7)]
    print(f"| joint with alpha = {a.alpha} deg | max TCP deviation [mm] | RMS TCP deviation [mm] | status |")
    print("| --- | --- | --- | --- |")
    for j in range(6):
        print(f"| {j + 1} {JOINT_NAMES[j]} | {dev[j]:.3f} | {rms[j]:.4f} | {res.status[j + 1]} |")
    print(json.dumps({"alpha_deg": a.alpha, "tcp_dev_max_mm": dev, "tcp_dev_rms_mm": rms}))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
