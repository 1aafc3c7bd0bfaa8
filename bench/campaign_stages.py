"""Where a campaign run's CPU time goes, stage by stage: stepping in the compiled loop against everything else.

    python bench/campaign_stages.py CAMPAIGN.yaml --out /tmp/c [--duration-s S]

Runs ``ur5fault campaign run CAMPAIGN --out OUT --jobs 1 --quiet --yes`` in this process (one process, so every
stage's CPU time is this process's) with the stages' functions wrapped, and prints one JSON line: per stage its
CPU seconds (``time.process_time``: BLAS threads included), share of the whole, per stored run and per simulated
second, exclusive of the stages nested in it (the compiled loop's ``advance_serial`` inside ``steploop.run``
inside ``Simulator.run``...).  ``other`` is the process's CPU time outside every stage: start-up and imports,
expanding the campaign, the manifest.  Simulated seconds count every run simulated, the digital twins (never
stored) included; ``stored_run_s`` counts only the runs of ``features.parquet`` (``bench/diagnostics_timing.py``'s
figure).  No profiler: cProfile inflates Python-heavy stages several times.  OUT must not hold the campaign yet.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import json
import sys
import time
from collections import defaultdict
from pathlib import Path


class Stages:
    """Exclusive CPU time of nested wrapped calls, by stage name."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = defaultdict(float)
        self.calls: dict[str, int] = defaultdict(int)
        self._stack: list[list[float]] = []  # [start, time spent in nested stages]

    def wrap(self, owner, attr: str, name: str, kind: str = "function") -> None:
        fn = owner.__dict__[attr] if isinstance(owner, type) else getattr(owner, attr)
        inner = fn.__func__ if kind == "classmethod" else fn

        @functools.wraps(inner)
        def timed(*args, **kwargs):
            self._stack.append([time.process_time(), 0.0])
            try:
                return inner(*args, **kwargs)
            finally:
                start, nested = self._stack.pop()
                spent = time.process_time() - start
                self.cpu[name] += spent - nested
                self.calls[name] += 1
                if self._stack:
                    self._stack[-1][1] += spent

        setattr(owner, attr, classmethod(timed) if kind == "classmethod" else timed)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("campaign")
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--duration-s", type=float)
    args = ap.parse_args()
    t_start = time.process_time()

    import ur5fault.campaign.execute as ex
    import ur5fault.health.features as hf
    import ur5fault.health.twin_features as tf
    import ur5fault.sim.engine as eng
    import ur5fault.sim.steploop as sl
    from ur5fault.cli import main as cli_main
    from ur5fault.sim.result import SimResult

    st = Stages()
    simulated = {"runs": 0, "run_steps": 0}
    run = eng.Simulator.run

    def counting_run(self, trajectory, runs, **kw):
        dur = trajectory.duration_s if kw.get("duration_s") is None else kw["duration_s"]
        simulated["runs"] += len(runs)
        simulated["run_steps"] += len(runs) * int(round(dur / self.params.physics_dt_s))
        return run(self, trajectory, runs, **kw)

    eng.Simulator.run = counting_run
    for owner, attr, name, kind in [
        (ex, "scan", "verify stored runs", "function"),
        (ex, "plan_batches", "plan batches", "function"),
        (ex, "run_batch", "batch: rows, labels (rest of run_batch)", "function"),
        (eng.Simulator, "__init__", "simulator set-up (model load, gains)", "function"),
        (eng.Simulator, "run", "simulation: rest (run arrays, multibody, sensor terms)", "function"),
        (eng, "prepare", "simulation: batch set-up (prepare)", "function"),
        (sl, "run", "simulation: noise drawing, chunking (steploop.run)", "function"),
        (sl, "advance_serial", "simulation: stepping (compiled loop)", "function"),
        (SimResult, "build", "simulation: result (TCP kinematics, phase currents)", "classmethod"),
        (hf, "run_features", "features: run_features", "function"),
        (tf, "twin_features", "twin features: rest (residuals, condition means)", "function"),
        (tf, "current_fit", "twin features: current fit, rest (columns)", "function"),
        (tf, "com_columns", "twin features: CoM columns (kinematics)", "function"),
        (tf, "motion_conditions", "twin features: motion conditions", "function"),  # before the per-batch motion
        (tf, "command_conditions", "twin features: motion conditions", "function"),
        (tf, "commanded_motion", "twin features: commanded motion, rest (per batch)", "function"),
        (tf, "flange_kinematics", "twin features: CoM columns (kinematics)", "function"),
        (tf, "hac_fit", "twin features: hac_fit (7 per run)", "function"),
        (ex, "write_run_file", "store: write run file", "function"),
        (ex, "consolidate", "store: consolidate features.parquet", "function"),
    ]:
        if hasattr(owner, attr):  # the stages of this revision of the code
            st.wrap(owner, attr, name, kind)

    argv = ["campaign", "run", args.campaign, "--out", str(args.out), "--jobs", "1", "--quiet", "--yes"]
    if args.duration_s is not None:
        argv += ["--duration-s", str(args.duration_s)]
    sys.argv = ["ur5fault", *argv]
    with contextlib.redirect_stdout(sys.stderr):  # the campaign's own report: this prints only the JSON line
        rc = cli_main()
    total = time.process_time() - t_start

    import pandas as pd

    from ur5fault.sim.params import load_params

    n_stored = len(pd.read_parquet(args.out / "features.parquet", columns=["run_id"]))
    dt = load_params().physics_dt_s
    sim_s = simulated["run_steps"] * dt
    stages = dict(st.cpu)
    stages["other (start-up, imports, campaign, manifest)"] = total - sum(stages.values())
    print(json.dumps({
        "exit": rc, "cpu_s_total": total, "stored_runs": n_stored, "simulated_runs": simulated["runs"],
        "simulated_s": sim_s, "run_steps": simulated["run_steps"],
        "stepping_us_per_run_step": stages["simulation: stepping (compiled loop)"] / simulated["run_steps"] * 1e6,
        "stages": {k: {"cpu_s": round(v, 3), "share": round(v / total, 4), "per_stored_run_s": round(v / n_stored, 5),
                       "per_simulated_s": round(v / sim_s, 5), "calls": st.calls.get(k, 0)}
                   for k, v in sorted(stages.items(), key=lambda kv: -kv[1])},
    }, indent=1))


if __name__ == "__main__":
    main()
