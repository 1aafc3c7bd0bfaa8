"""Wall time of a diagnostics campaign set against bare ``mj_step`` (not a timed test: printed only).

    python bench/diagnostics_timing.py results/diagnostics --wall-s 1234 [--jobs 2]

Counts the simulated run-steps of every run in ``OUT/features.parquet`` (each run's trajectory
duration / physics step; trajectories differ in length) and of the digital twins simulated beside them
(a campaign with ``twin_residuals``: one twin per distinct seed, payload, temperature and trajectory,
never stored - on the diagnostics campaign 2,000 twins, 270 M run-steps beside the stored runs' 344 M) and, with
``--campaign FILE``, the noise-free regressor twins every batch simulates on its payload grid, with their CoM
twins (the batches a from-scratch run with ``--jobs`` plans; a resumed run may have planned others),
times bare ``mj_step`` of the UR5 model in this process, and prints one JSON line: the wall time, the
run-steps, the bare-step cost and the ratio wall x cores / (run-steps x bare step) - the overhead of
everything (drive chain, logging, features, Parquet, process start-up, the benchmark) over stepping the
multibody alone (``..._stored_runs_only``: the same against the stored runs' steps alone, this script's
figure before the twins were counted).  ``bench/campaign_stages.py`` splits a campaign's CPU time by stage.
Figures taken on a shared machine must be re-measured on a quiet one: the ratio is what carries over.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import mujoco
import pandas as pd

from ur5fault.config import parse_trajectory
from ur5fault.sim.engine import DEFAULT_MODEL_PATH
from ur5fault.sim.params import load_params

BARE_STEPS = 40_000


def bare_mj_step_s(n_steps: int = BARE_STEPS) -> float:
    m = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    m.opt.timestep = load_params().physics_dt_s
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    t = time.perf_counter()
    for _ in range(n_steps):
        mujoco.mj_step(m, d)
    return (time.perf_counter() - t) / n_steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--wall-s", type=float, required=True, help="measured wall time of campaign + benchmark")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--campaign", help="the campaign file (or shipped name): count its batches' regressor twins too")
    args = ap.parse_args()
    df = pd.read_parquet(args.out / "features.parquet")
    dt = load_params().physics_dt_s
    duration = json.loads((args.out / "manifest.json").read_text()).get("campaign_data", {})
    duration = duration.get("duration_s") if isinstance(duration, dict) else None
    steps = {t: round((duration or parse_trajectory(json.loads(t) if t.startswith("{") else t,
                                                    "trajectory").duration_s) / dt)
             for t in df["trajectory"].unique()}
    run_steps = sum(steps[t] for t in df["trajectory"])
    twin_steps = 0
    if any(c.startswith("twin_est_") for c in df.columns):  # twin residuals: each run's digital twin simulated too
        twins = df[["seed", "payload_kg", "temperature_C", "trajectory"]].drop_duplicates()
        twin_steps = sum(steps[t] for t in twins["trajectory"])
    grid_steps = 0
    if args.campaign:  # each batch's noise-free twins on its payload grid, with their CoM twins (twin_regressors.py)
        from ur5fault.campaign.batches import plan_batches
        from ur5fault.campaign.digital_twin import regressor_runs
        from ur5fault.campaign.spec import load_campaign

        camp = load_campaign(args.campaign)
        if camp.twin_residuals:
            for batch in plan_batches(camp, camp.runs, args.jobs):
                n = len(regressor_runs(camp, batch, 28.0)[1])  # grid twins and their CoM twins
                t = batch[0].cond["trajectory"]
                t = json.dumps(t, sort_keys=True) if isinstance(t, dict) else t
                grid_steps += n * steps[t]
    twin_steps += grid_steps
    bare = bare_mj_step_s()
    bench = args.out / "benchmark" / "metrics.json"
    out = {
        "n_runs": len(df),
        "simulated_s": (run_steps + twin_steps) * dt,
        "run_steps": run_steps + twin_steps,
        "run_steps_stored_runs": run_steps,
        "run_steps_digital_twins": twin_steps - grid_steps,
        "run_steps_regressor_twins": grid_steps,
        "wall_s": args.wall_s,
        "jobs": args.jobs,
        "bare_mj_step_us": bare * 1e6,
        "bare_stepping_wall_s_on_jobs_cores": (run_steps + twin_steps) * bare / args.jobs,
        "ratio_to_bare_mj_step": args.wall_s * args.jobs / ((run_steps + twin_steps) * bare),
        "ratio_to_bare_mj_step_stored_runs_only": args.wall_s * args.jobs / (run_steps * bare),
        "benchmark_wall_s": json.loads(bench.read_text())["timing"]["benchmark_wall_s"] if bench.exists() else None,
    }
    print(json.dumps(out))


if __name__ == "__main__":
    main()
