"""Campaign execution: runs grouped into lockstep batches, spread over processes (joblib loky,
or Dask for clusters), each finished run written atomically to the store as it arrives."""

from __future__ import annotations

import hashlib
import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ..config import parse_trajectory
from ..effects import EffectSpec, make_effect
from ..errors import ParameterError
from ..io import write_json_atomic, write_parquet_atomic
from ..params import load_params
from ..progress import campaign_progress
from .labels import assign_splits, refresh_splits, row_labels
from .spec import Campaign, CampaignRun
from .store import Lock, consolidate, done_ids, file_sha256, runs_dir


def _effects_of(camp: Campaign, rc: CampaignRun) -> tuple[EffectSpec, ...]:
    c = rc.cond
    return camp.base_effects + rc.fault_effects() + (
        make_effect("payload", mass_kg=c["payload_kg"]),
        make_effect("temperature", temperature_C=c["temperature_C"]),
    ) + _condition_effects(c)


def _condition_effects(cond: dict[str, Any]) -> tuple[EffectSpec, ...]:
    """Whole-robot effects held as run conditions (``<effect>.<param>`` keys, e.g. a sampled campaign's
    ``payload_com.dz_m`` or ``delay.delay_ms``): shared with the healthy twin, not faults."""
    by_effect: dict[str, dict[str, Any]] = {}
    for key, v in cond.items():
        name, dot, par = key.partition(".")
        if dot:
            by_effect.setdefault(name, {})[par] = v
    return tuple(make_effect(name, **vals) for name, vals in sorted(by_effect.items()))


def plan_batches(camp: Campaign, todo: Sequence[CampaignRun], n_workers: int = 1) -> list[list[CampaignRun]]:
    """Group runs by trajectory, cut into lockstep batches (at most ``batch_size`` runs, and at
    least ``n_workers`` batches when there are enough runs), and add each batch's missing twins
    (those the campaign lists: every twin of a swept campaign, the chosen ones of a sampled one)."""
    listed = {rc.run_id for rc in camp.runs}  # a twin is simulated when the campaign lists it
    by_traj: dict[str, list[CampaignRun]] = {}
    for rc in todo:
        by_traj.setdefault(json.dumps(rc.cond["trajectory"], sort_keys=True), []).append(rc)
    batches = []
    for runs in by_traj.values():
        runs = sorted(runs, key=lambda r: (json.dumps(r.conditions, default=str), r.run_id))
        size = max(1, min(camp.batch_size - 1, -(-len(runs) // max(1, n_workers))))
        for i in range(0, len(runs), size):
            chunk = runs[i : i + size]
            ids = {r.run_id for r in chunk}
            for r in list(chunk):
                t = r.twin()
                if t.run_id not in ids and t.run_id in listed:
                    chunk.append(t)
                    ids.add(t.run_id)
            batches.append(chunk)
    return batches


def run_batch(camp: Campaign, batch: Sequence[CampaignRun], ts_dir: str | None) -> list[dict[str, Any]]:
    """Simulate one lockstep batch; return one feature row per run (twins included)."""
    from ..engine import RunSpec, Simulator
    from ..features import run_features

    traj_spec = batch[0].cond["trajectory"]
    traj = parse_trajectory(traj_spec, "trajectory")
    sim = Simulator(load_params(overrides=dict(camp.base_params)))
    specs = [RunSpec(rc.run_id, int(rc.cond["seed"]), _effects_of(camp, rc)) for rc in batch]
    t0 = time.perf_counter()
    res = sim.run(traj, specs, log_period_s=camp.log_period_s, duration_s=camp.duration_s)
    wall = time.perf_counter() - t0
    index = {rc.run_id: i for i, rc in enumerate(batch)}
    ratio = np.asarray(sim.params.gear.ratio)
    splits = assign_splits(camp.split, (rc.cond for rc in camp.runs))
    rows = []
    for i, rc in enumerate(batch):
        twin_i = index.get(rc.twin().run_id)  # None: the campaign simulates no twin for this run
        twin_ok = twin_i is None or res.status[twin_i] == "ok"
        ok = res.status[i] == "ok" and twin_ok
        feats = run_features(res.t_s, res.q_set_rad, res["q_FB_rad"][i], res["q_M_FB_rad"][i], res["i_FB_A"][i],
                             ratio, res.tcp_m[i], res.tcp_des_m[i],
                             res.tcp_m[twin_i] if ok and twin_i is not None else None)
        if ts_dir is not None:
            res.to_parquet(Path(ts_dir) / f"{rc.run_id}.parquet", i)
        eff = rc.fault_effects()
        row: dict[str, Any] = {
            "run_id": rc.run_id,
            **row_labels(rc.cond, eff, camp.split, splits),
            "twin_run_id": rc.twin().run_id if twin_i is not None else "",
            "status": res.status[i] if res.status[i] != "ok" or ok else "ok",
            "reason": res.reason[i] or ("" if ok else f"twin: {res.reason[twin_i]}"),
            "effects": "; ".join(e.describe() for e in eff),
            "wall_s_batch": wall,
            "batch_size": len(batch),
            "tcp_dev_max_mm": np.nan,  # without a twin; run_features fills both when there is one
            "tcp_dev_rms_mm": np.nan,
            **feats,
        }
        rows.append(row)
    return rows


def run_campaign(camp: Campaign, out: Path | None = None, *, jobs: int | None = None, backend: str = "loky",
                 scheduler: str | None = None, progress: bool | Callable[[int, int, float], None] = True,
                 save_timeseries: bool | None = None) -> dict[str, Any]:
    """Run every run of ``camp`` not yet done in ``out``; return the manifest.

    Args:
        jobs: worker processes (default: all cores).
        backend: ``"loky"`` (local processes) or ``"dask"`` (``scheduler`` address required).
        progress: print a progress line to stderr, or a callback ``(done, total, eta_s)``.
    """
    from .. import __version__
    from ..engine import DEFAULT_MODEL_PATH

    out = Path(out) if out is not None else camp.out
    jobs = jobs or os.cpu_count() or 1
    if backend not in ("loky", "dask"):
        raise ParameterError(f"backend = {backend!r} is not valid; choose one of: loky, dask")
    if backend == "dask" and not scheduler:
        raise ParameterError("--backend dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    save_ts = camp.save_timeseries if save_timeseries is None else save_timeseries
    with Lock(out):
        runs_dir(out).mkdir(parents=True, exist_ok=True)
        ts_dir = out / "timeseries" if save_ts else None
        if ts_dir is not None:
            ts_dir.mkdir(exist_ok=True)
        already = done_ids(out)
        todo = [rc for rc in camp.runs if rc.run_id not in already]
        batches = plan_batches(camp, todo, jobs)
        total, done = len(camp.runs), len(camp.runs) - len(todo)
        report = campaign_progress(progress, total)
        report(done, 0.0)
        t0 = time.perf_counter()
        try:
            _execute(camp, batches, out, ts_dir, jobs, backend, scheduler, already, done, report, t0)
        finally:
            report.close()
        features = consolidate(out, camp)
        features, changed = refresh_splits(features, camp.split, camp.runs)
        if changed:  # the campaign's split rule differs from the one the stored rows were labelled with
            write_parquet_atomic(features, out / "features.parquet")
        p = load_params(overrides=dict(camp.base_params))
        import mujoco

        duration = camp.duration_s if camp.duration_s else _duration(camp)
        manifest = {
            "name": camp.name,
            "campaign_file": str(camp.path) if camp.path else None,
            "campaign_sha256": camp.sha256,
            "campaign_text": camp.text,
            "model_file": str(DEFAULT_MODEL_PATH),
            "model_sha256": file_sha256(DEFAULT_MODEL_PATH),
            "params_sha256": hashlib.sha256(json.dumps(p.to_dict(), sort_keys=True).encode()).hexdigest(),
            "ur5fault_version": __version__,
            "mujoco_version": mujoco.__version__,
            "numpy_version": np.__version__,
            "python": sys.version.split()[0],
            "n_runs": int(len(features)),
            "physics_dt_s": p.physics_dt_s,
            "duration_s": duration,
            "n_steps_total": int(len(features) * round(duration / p.physics_dt_s)),
            "threshold_mm": camp.threshold_mm,
            "swept_keys": list(camp.swept_keys),
            "wall_s_this_invocation": time.perf_counter() - t0,
            "backend": backend,
            "jobs": jobs,
            "status_counts": features["status"].value_counts().to_dict(),
            "feature_units": _units(),
        }
        write_json_atomic(out / "manifest.json", manifest)
        return manifest


def _duration(camp: Campaign) -> float:
    traj = parse_trajectory(camp.runs[0].cond["trajectory"], "trajectory")
    return traj.duration_s


def _units() -> dict[str, str]:
    from ..features import FEATURE_UNITS

    return dict(FEATURE_UNITS)


def _execute(camp: Campaign, batches: list[list[CampaignRun]], out: Path, ts_dir: Path | None, jobs: int,
             backend: str, scheduler: str | None, already: set[str], done: int, report, t0: float) -> None:
    """Run the batches in parallel; write each run's row to the store as soon as its batch returns."""
    import joblib

    if not batches:
        return
    if backend == "dask":
        from dask.distributed import Client

        client = Client(scheduler)
        ctx = joblib.parallel_backend("dask", wait_for_workers_timeout=60)
    else:
        client, ctx = None, joblib.parallel_backend("loky")
    try:
        with ctx:
            par = joblib.Parallel(n_jobs=jobs if backend == "loky" else -1, return_as="generator_unordered")
            gen = par(joblib.delayed(run_batch)(camp, b, str(ts_dir) if ts_dir else None) for b in batches)
            for rows in gen:
                for row in rows:
                    if row["run_id"] not in already:
                        write_parquet_atomic(pd.DataFrame([row]), runs_dir(out) / f"{row['run_id']}.parquet")
                        already.add(row["run_id"])
                        done += 1
                report(done, time.perf_counter() - t0)
    finally:
        if client is not None:
            client.close()
