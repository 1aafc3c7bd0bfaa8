"""The table of docs/discrepancy.md: every hidden-effect case of the test suite (library effects, effects
outside the library, library effects under a structural model error), fitted once, with the estimate
against the hidden truth, the held-out gap before and after, and the cost.  Usage::

    .venv/bin/python bench/discrepancy_hidden_table.py > table.md
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import test_discovery as D  # noqa: E402
from hidden_logs import edited_model, named, simulate, write_sim  # noqa: E402
from test_discrepancy import CONDITIONS, KINDS, draw, noise_seed  # noqa: E402

from ur5fault import make_effect  # noqa: E402
from ur5fault.discrepancy import DiscrepancyModel  # noqa: E402
from ur5fault.discrepancy.report import size  # noqa: E402
from ur5fault.discrepancy.speed import bare_mj_step_us, wall_over_mj_steps  # noqa: E402
from ur5fault.logs import read_sim  # noqa: E402
from ur5fault.sim.axes import JOINT_NAMES  # noqa: E402

JOBS = 2


def row(label, truth, est, model, signal, joint_name, wall):
    b, a = model.rms_before_[signal][joint_name], model.rms_after_[signal][joint_name]
    extra = [f.candidate.label for f in model.findings_ if f.kept]
    print(f"| {label} | {truth:.4g} | {est:.4g} | {100 * (est - truth) / truth:+.1f} % | {signal} {joint_name}: "
          f"{b:.3g} -> {a:.3g} | {len(extra)} | {model.n_simulated_runs_} | {wall:.0f} s "
          f"({wall_over_mj_steps(model, bare_mj_step_us(model.replay_.params.physics_dt_s)):.2f}) |", flush=True)


def main() -> None:
    print("| hidden | truth | estimate | error | held-out RMS before -> after | findings kept | runs | wall "
          "(x bare mj_step per run-step) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for kind in sorted(KINDS):
            eff, j, par, truth, signal = draw(kind)
            log = read_sim(write_sim(simulate([*CONDITIONS.get(kind, ()), eff], seed=noise_seed(kind)),
                                     tmp / "m.parquet"))
            t = time.perf_counter()
            m = DiscrepancyModel(jobs=JOBS).fit(log)
            wall = time.perf_counter() - t
            hit = named(m, kind, j)
            est = hit[1] if hit else float("nan")
            x0 = hit[0].x0 if hit else 0.0
            jn = JOINT_NAMES[j] if j is not None else max(m.rms_before_[signal], key=m.rms_before_[signal].get)
            row(eff.describe(), truth - x0, est - x0, m, signal, jn, wall)
        for form in D.FORMS:
            h = D.draw(form)
            log = D.make_log(tmp, form, h)
            t = time.perf_counter()
            m = DiscrepancyModel(jobs=JOBS).fit(log)
            wall = time.perf_counter() - t
            family, truth = D.EXPECTED[form]
            hits = [f for f in m.terms_ if f.candidate.family == family and f.candidate.joint == h["joint"]]
            desc = f"{form} on {JOINT_NAMES[h['joint']]} " + ", ".join(
                f"{k}={v:.3g}" for k, v in h.items() if k != "joint")
            row(desc, truth(h), size(hits[0]) if hits else float("nan"), m, "current_A", JOINT_NAMES[h["joint"]], wall)
        path = edited_model(tmp, 'mass="2.33"', 'mass="6.99"')
        log = read_sim(write_sim(simulate(seed=555, model_path=path), tmp / "m.parquet"))
        t = time.perf_counter()
        m = DiscrepancyModel(jobs=JOBS).fit(log)
        wall = time.perf_counter() - t
        hits = [f for f in m.terms_ if f.candidate.family == "link_mass" and f.candidate.joint == 2]
        row("forearm 3x heavier (+4.66 kg)", 4.66, size(hits[0]) if hits else float("nan"), m, "current_A",
            "shoulder_lift_joint", wall)
        for label, effs, kw, kind, joint, truth in [
            ("current-sensor gain 1.12 on shoulder_lift + forearm 1.5x heavier",
             [make_effect("current_sensor_gain", "shoulder_lift", gain=1.12)],
             {"seed": 4321, "model_path": edited_model(tmp, 'mass="2.33"', 'mass="3.495"')},
             "current_sensor_gain", 1, 1.12),
            ("Coulomb friction x1.5 on shoulder_pan + extra low-speed friction hump",
             [make_effect("coulomb_friction", "shoulder_pan", scale=1.5)],
             {"seed": 8765, "joint": 0, "torque": lambda q, qd: 1.5 * np.tanh(qd / 0.01) * np.exp(-abs(qd) / 0.05)},
             "coulomb_friction", 0, 1.5)]:
            log = read_sim(write_sim(simulate(effs, **kw), tmp / "m.parquet"))
            t = time.perf_counter()
            m = DiscrepancyModel(jobs=JOBS).fit(log)
            wall = time.perf_counter() - t
            hit = named(m, kind, joint)
            row(label, truth - 1.0, (hit[1] if hit else float("nan")) - 1.0, m, "current_A", JOINT_NAMES[joint], wall)


if __name__ == "__main__":
    main()
