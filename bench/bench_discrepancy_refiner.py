"""Refinement by re-simulation: the workflow's own secant Gauss-Newton against mujoco.minimize.least_squares
(finite differences, bounds, Levenberg-Marquardt), on hidden-effect logs of the test suite.

For each case: estimate error against the hidden truth, simulated runs and simulated seconds spent in the
refinement, and wall time (also as a ratio to a bare mj_step timed in the same process, since the machine
may be shared).  Usage::

    .venv/bin/python bench/bench_discrepancy_refiner.py [--out docs/figures/refiner.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from hidden_logs import edited_model, simulate, write_sim  # noqa: E402

from ur5fault import make_effect  # noqa: E402
from ur5fault.discrepancy import DiscrepancyModel  # noqa: E402
from ur5fault.discrepancy.report import size  # noqa: E402
from ur5fault.discrepancy.speed import bare_mj_step_us, wall_over_mj_steps  # noqa: E402
from ur5fault.logs import read_sim  # noqa: E402

#: (name, library effects, passive torque (joint, law) or None, MJCF edit or None, what to check)
CASES = [
    ("backlash 0.2 deg J2", [make_effect("backlash", 2, backlash_deg=0.2)], None, None, ("backlash", 1, 0.2)),
    ("gear stiffness 0.4 J3", [make_effect("gear_stiffness", 3, scale=0.4)], None, None, ("gear_stiffness", 2, 0.4)),
    ("delay 7 ms", [make_effect("delay", delay_ms=7.0)], None, None, ("delay", None, 7.0)),
    ("Coulomb x1.6 J1", [make_effect("coulomb_friction", 1, scale=1.6)], None, None, ("coulomb_friction", 0, 1.6)),
    ("ripple 3 N*m 3/rev J2", [], (1, lambda q, qd: 3.0 * np.sin(3 * q + 0.5)), None, ("joint_harmonic", 1, 3.0)),
    ("forearm +1.165 kg, gain 1.12 J2", [make_effect("current_sensor_gain", 2, gain=1.12)], None,
     ('mass="2.33"', 'mass="3.495"'), ("current_sensor_gain", 1, 1.12)),
]


def estimate(model, what):
    kind, joint, _ = what
    for f in model.findings_:
        if not f.kept:
            continue
        for c, th in [(f.candidate, f.theta), *f.alternatives]:
            name = c.effect if c.source == "library" else c.family
            if name == kind and c.joint == joint:
                return c.value(th) if c.source == "library" else size(f)
    return float("nan")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", help="write the table as JSON here")
    args = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, effs, torque, edit, what in CASES:
            path = edited_model(tmp, *edit) if edit else None
            res = simulate(effs, seed=2024, model_path=path, torque=torque[1] if torque else None,
                           joint=torque[0] if torque else None)
            log = read_sim(write_sim(res, tmp / "m.parquet"))
            for method in ("secant", "minimize"):
                t = time.perf_counter()
                m = DiscrepancyModel(refiner=method, jobs=2).fit(log)
                wall = time.perf_counter() - t
                runs = len(m.refinement_)
                est = estimate(m, what)
                rows.append({"case": name, "refiner": method, "truth": what[2], "estimate": est,
                             "error_pct": 100 * (est - what[2]) / what[2], "refinement_runs": runs,
                             "refinement_s": m.timings_s_["refinement"], "wall_s": wall,
                             "wall_over_mj_steps": wall_over_mj_steps(m, bare_mj_step_us(5e-5))})
                print(json.dumps(rows[-1]), flush=True)
    if args.out:
        Path(args.out).write_text(json.dumps(rows, indent=1))
    print(f"bare mj_step now: {bare_mj_step_us(5e-5):.2f} us")


if __name__ == "__main__":
    main()
