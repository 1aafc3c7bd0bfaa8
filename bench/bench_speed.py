"""Speed benchmark (not a timed test): figures are printed, never asserted.

Measures in one process, on the same model, physics step and number of steps:
  (a) bare mj_step of the UR5 model from a Python loop, no drive models, as the Python bindings run it: MuJoCo's
      stage timers on (the bindings set ``mjcb_time``; the floor issue 21 names);
  (a_off) the same with MuJoCo's stage timers off, as ur5fault steps (``sim/mjtimers.py``);
  (a0) bare mj_step from a compiled (numba) loop calling libmujoco by address, timers off: the true floor;
  (a0d) the same with a damping on every joint, as the drive's friction slope sets it in every run: MuJoCo's Euler
      step then factorises M + h D once more per step (the floor of the model's physics);
  (b) the full-fidelity simulation of one run (batch of one), compiled step loop;
  (c) the same in batches of 8, 32 and 128 runs on one thread;
  (t) a batch of 32 spread over all cores: numba threads in one process against one process per core;
  (d) optionally (--campaign), the default campaign end to end on all cores, Parquet included.
(a), (a_off), (a0), (a0d) and (b) are measured --repeat times, interleaved; their ratios are reported as min and median;
each batch (c) is also reported against (a0d) measured right before and after it.
Prints one JSON line: per-run-step cost of each in microseconds, ratios to (a) and (a0) per core,
and peak memory per run.

    python bench/bench_speed.py            # full figures (minutes)
    python bench/bench_speed.py --quick    # a few hundred ms of simulated time, for the test suite
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import sys
import time
import tracemalloc

import mujoco
import numpy as np

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.sim.mjtimers import timers_off


def bare_mj_step_us(sim: Simulator, n_steps: int, clock=time.perf_counter, timers: bool = True) -> float:
    """(a) bare ``mj_step`` from a Python loop; ``timers=False``: (a_off), MuJoCo's stage timers off."""
    if not timers:
        with timers_off():
            return bare_mj_step_us(sim, n_steps, clock)
    m = sim.model
    d = mujoco.MjData(m)
    d.qpos[:] = pick_and_place().q_set_rad[0]
    mujoco.mj_forward(m, d)
    step = mujoco.mj_step
    t = clock()
    for _ in range(n_steps):
        step(m, d)
    return (clock() - t) / n_steps * 1e6


def bare_compiled_us(sim: Simulator, n_steps: int, clock=time.perf_counter, damping_Nms_per_rad: float = 0.0) -> float:
    """(a0) the same steps from a compiled loop (``sim/mjlib.py``: ``mj_step`` called by its address); with
    ``damping_Nms_per_rad`` > 0 on every joint (a0d) Euler's implicit damping is on (its cost does not depend on
    the value: MuJoCo factorises M + h D whenever any joint has damping)."""
    import copy

    from numba import njit

    from ur5fault.sim.mjlib import MJ_STEP_ADDRESS, call_step

    @njit
    def loop(fn, m, d, n):
        for _ in range(n):
            call_step(fn, m, d)

    m = sim.model
    if damping_Nms_per_rad:
        m = copy.deepcopy(m)
        m.dof_damping[:] = damping_Nms_per_rad
    d = mujoco.MjData(m)
    d.qpos[:] = pick_and_place().q_set_rad[0]
    mujoco.mj_forward(m, d)
    loop(MJ_STEP_ADDRESS, m._address, d._address, 10)  # compile
    with timers_off():  # as ur5fault's loop steps
        t = clock()
        loop(MJ_STEP_ADDRESS, m._address, d._address, n_steps)
        return (clock() - t) / n_steps * 1e6


def runs_for(n: int) -> list[RunSpec]:
    levels = (0.0, 0.02, 0.05, 0.1, 0.2, 0.5)
    out = []
    for i in range(n):
        a, j = levels[i % len(levels)], 1 + (i // len(levels)) % 6
        out.append(RunSpec(f"r{i}", i % 4, (make_effect("backlash", j, backlash_deg=a),) if a else ()))
    return out


def full_fidelity_us(sim: Simulator, n_runs: int, duration_s: float, first: int = 0,
                     clock=time.perf_counter) -> float:
    """Per-run-step wall cost [us] of one batch (runs ``first`` .. ``first + n_runs - 1`` of :func:`runs_for`)."""
    traj = pick_and_place()
    n_steps = round(duration_s / sim.params.physics_dt_s)
    t = clock()
    sim.run(traj, runs_for(first + n_runs)[first:], duration_s=duration_s)
    return (clock() - t) / (n_runs * n_steps) * 1e6


def _half_batch(args) -> float:
    n_runs, first, duration_s = args
    return full_fidelity_us(Simulator(), n_runs, duration_s, first)


def spread_us(sim_threads: Simulator, n_runs: int, duration_s: float, cores: int) -> tuple[float, float]:
    """(t) per-run-step wall cost [us] of ``n_runs`` runs over ``cores``: numba threads in this process, and one
    process per core each running its share (started and warmed before the clock, as a campaign's workers)."""
    import multiprocessing as mp

    full_fidelity_us(sim_threads, cores, 0.01)  # compile / load the threaded loop before the clock
    threads = full_fidelity_us(sim_threads, n_runs, duration_s)
    share = -(-n_runs // cores)
    with mp.get_context("fork").Pool(cores) as pool:
        pool.map(_half_batch, [(1, 0, 0.01)] * cores)  # load the cached kernels in every worker
        n_steps = round(duration_s / sim_threads.params.physics_dt_s)
        t = time.perf_counter()
        pool.map(_half_batch, [(share, k * share, duration_s) for k in range(cores)])
        procs = (time.perf_counter() - t) / (n_runs * n_steps) * 1e6
    return threads, procs


def peak_memory_mb_per_run(sim: Simulator, n_runs: int, duration_s: float) -> float:
    """Peak traced Python/numpy memory of a batch divided by its runs [MB] (timed separately:
    tracing slows every allocation)."""
    tracemalloc.start()
    sim.run(pick_and_place(), runs_for(n_runs), duration_s=duration_s)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / n_runs / 1e6


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short durations; figures are rough")
    ap.add_argument("--campaign", action="store_true", help="also time the default campaign end to end")
    ap.add_argument("--drive", choices=("numba", "numpy"), default="numba", help="drive implementation")
    ap.add_argument("--repeat", type=int, default=3, help="repetitions of (a), (a_off), (a0), (a0d) and (b)")
    ap.add_argument("--duration-s", type=float, default=None, help="simulated seconds per run (default: 13, the "
                    "whole pick-and-place; 0.2 with --quick)")
    ap.add_argument("--cpu-time", action="store_true", help="time (a), (a_off), (a0), (a0d), (b) and (c) by the "
                    "process's CPU time instead of wall time (steadier on a shared, loaded machine; (t) and (d) "
                    "stay wall time)")
    args = ap.parse_args(argv)
    dur = args.duration_s or (0.2 if args.quick else 13.0)  # default: the whole 2 kg pick-and-place
    clock = time.process_time if args.cpu_time else time.perf_counter
    sim = Simulator(drive=args.drive)
    n_steps = round(dur / sim.params.physics_dt_s)
    out: dict = {
        "machine": f"{platform.machine()} {os.cpu_count()} cores, {platform.python_implementation()} "
                   f"{platform.python_version()}, mujoco {mujoco.__version__}, numpy {np.__version__}",
        "physics_dt_s": sim.params.physics_dt_s,
        "drive": args.drive,
        "clock": "cpu" if args.cpu_time else "wall",
        "simulated_s_per_run": dur,
        "steps_per_run": n_steps,
    }
    sim.run(pick_and_place(), runs_for(1), duration_s=0.01)  # compile / load the kernels once
    bare_compiled_us(sim, 1000)
    a, a_off, a0, a0d, b = [], [], [], [], []
    for _ in range(args.repeat):  # interleaved: a load change on the shared machine hits all five alike
        a.append(bare_mj_step_us(sim, max(n_steps, 20000), clock))
        a_off.append(bare_mj_step_us(sim, max(n_steps, 20000), clock, timers=False))
        a0.append(bare_compiled_us(sim, max(n_steps, 20000), clock))
        a0d.append(bare_compiled_us(sim, max(n_steps, 20000), clock, damping_Nms_per_rad=1.0))
        b.append(full_fidelity_us(sim, 1, dur, clock=clock))
    out["a_bare_mj_step_us"] = float(np.median(a))
    out["a_off_bare_mj_step_timers_off_us"] = float(np.median(a_off))
    out["a0_bare_compiled_loop_us"] = float(np.median(a0))
    out["a0d_bare_compiled_damped_us"] = float(np.median(a0d))
    out["b_one_run_us_per_step"] = float(np.median(b))
    out["b_one_run_wall_s"] = out["b_one_run_us_per_step"] * n_steps / 1e6
    rb = np.array(b) / np.array(a)
    rb0 = np.array(b) / np.array(a0)
    out["ratio_b_to_a_min"], out["ratio_b_to_a_median"] = float(rb.min()), float(np.median(rb))
    out["ratio_b_to_a0_min"], out["ratio_b_to_a0_median"] = float(rb0.min()), float(np.median(rb0))
    out["ratio_b_to_a_off_median"] = float(np.median(np.array(b) / np.array(a_off)))
    out["ratio_a_to_a_off_median"] = float(np.median(np.array(a) / np.array(a_off)))
    out["ratio_a_to_a0_median"] = float(np.median(np.array(a) / np.array(a0)))
    out["ratio_a0d_to_a0_median"] = float(np.median(np.array(a0d) / np.array(a0)))
    out["ratio_b_to_a0d_median"] = float(np.median(np.array(b) / np.array(a0d)))
    best = None
    for n in (8, 32, 128):
        # the floor (a0d) right before and after the batch as well: on a loaded machine the medians above may be
        # minutes old when a batch runs
        before = bare_compiled_us(sim, max(n_steps, 20000), clock, damping_Nms_per_rad=1.0)
        us = full_fidelity_us(sim, n, dur if n <= 32 or args.quick else dur / 4, clock=clock)
        after = bare_compiled_us(sim, max(n_steps, 20000), clock, damping_Nms_per_rad=1.0)
        out[f"c_batch{n}_us_per_run_step"] = us
        out[f"ratio_c_batch{n}_to_a0d_adjacent"] = 2.0 * us / (before + after)
        out[f"ratio_c_batch{n}_to_a"] = us / out["a_bare_mj_step_us"]
        out[f"ratio_c_batch{n}_to_a_off"] = us / out["a_off_bare_mj_step_timers_off_us"]
        out[f"ratio_c_batch{n}_to_a0"] = us / out["a0_bare_compiled_loop_us"]
        out[f"ratio_c_batch{n}_to_a0d"] = us / out["a0d_bare_compiled_damped_us"]
        if best is None or us < best[1]:
            best = (n, us)
    cores = os.cpu_count() or 1
    if cores > 1:
        t_us, p_us = spread_us(Simulator(drive=args.drive, nthread=cores), 32, dur / 4, cores)
        out["t_cores"] = cores
        out["t_batch32_threads_us_per_run_step"] = t_us
        out["t_batch32_processes_us_per_run_step"] = p_us
        out["ratio_t_threads_to_a_per_core"] = t_us * cores / out["a_bare_mj_step_us"]
        out["ratio_t_processes_to_a_per_core"] = p_us * cores / out["a_bare_mj_step_us"]
        out["ratio_t_processes_to_a_off_per_core"] = p_us * cores / out["a_off_bare_mj_step_timers_off_us"]
    mem_dur = 0.2 if args.quick else 2.0
    out["memory_simulated_s"] = mem_dur
    for n in (1, 8, 32):
        out[f"peak_MB_per_run_batch{n}"] = peak_memory_mb_per_run(sim, n, mem_dur)
    out["c_batch32_wall_s"] = out["c_batch32_us_per_run_step"] * 32 * n_steps / 1e6
    out["ratio_c_best_to_a0"] = best[1] / out["a0_bare_compiled_loop_us"]
    out["best_batch"] = best[0]
    out["ratio_c_best_to_a_per_core"] = best[1] / out["a_bare_mj_step_us"]
    if args.campaign:
        out.update(campaign_figures(out["a_bare_mj_step_us"]))
        out["ratio_d_to_a0_over_cores"] = out["ratio_d_to_a_over_cores"] * out["a_bare_mj_step_us"] / out[
            "a0_bare_compiled_loop_us"]
        out["ratio_d_to_a_off_over_cores"] = out["ratio_d_to_a_over_cores"] * out["a_bare_mj_step_us"] / out[
            "a_off_bare_mj_step_timers_off_us"]
    out["max_rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(json.dumps({k: (float(f"{v:.4g}") if isinstance(v, float) else v) for k, v in out.items()}))
    return 0


def campaign_figures(bare_us: float) -> dict:
    """(d) the default campaign end to end on all cores (needs the campaign runner)."""
    import tempfile
    from pathlib import Path

    from ur5fault.campaign import load_campaign, run_campaign

    root = Path(__file__).resolve().parents[1]
    camp = load_campaign(root / "campaigns" / "default.yaml")
    with tempfile.TemporaryDirectory() as tmp:
        t = time.perf_counter()
        manifest = run_campaign(camp, Path(tmp) / "out", jobs=os.cpu_count() or 1, progress=False)
        wall = time.perf_counter() - t
    steps = manifest["n_steps_total"]
    cores = os.cpu_count() or 1
    bare_wall = steps * bare_us / 1e6 / cores
    return {"d_campaign_wall_s": wall, "d_campaign_run_steps": steps, "d_bare_wall_same_steps_over_cores_s": bare_wall,
            "ratio_d_to_a_over_cores": wall / bare_wall}


if __name__ == "__main__":
    sys.exit(main())
