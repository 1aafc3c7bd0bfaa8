"""Running a life campaign: inspections in rounds, each round's units in lockstep batches over
processes (this one beside loky workers, or Dask: campaign/workers.dispatch, as fault campaigns), every inspection
written atomically as it arrives.

Round r simulates the next inspection of every unit still running; the parent then carries each
unit's wear forward (wear.py) and starts the next round.  A unit's next state is always computed
from its stored row (clearances and gear work as float64, the increments from the stream of
(fleet seed, unit, inspection)), so a campaign killed at any moment and run again resumes from
the files and writes the same bytes an uninterrupted run would (tested).
"""

from __future__ import annotations

import dataclasses
import json
import logging
import os
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import closing
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...campaign.identity import DRIVE, STEPPER
from ...campaign.store import CampaignChangedError, run_path
from ...campaign.workers import check_backend, dask_client, dispatch, exit_with_parent, note_stderr
from ...config import parse_trajectory
from ...errors import ParameterError
from ...sim.axes import N_JOINTS
from ...sim.effects import make_effect
from ...util.io import check_writable, remove_stale_temporaries, write_json_atomic
from ...util.lock import Lock
from ...util.progress import campaign_progress
from .life_store import (
    SUBFOLDERS,
    LifeIdentities,
    check_inspection,
    check_reference,
    consolidate_life,
    life_stats,
    read_inspection,
    read_reference,
    reference_path,
    run_id,
    write_inspection,
    write_reference,
)
from .spec import LifeCampaign, Unit, check_life_limits
from .wear import (
    STREAM_NOISE,
    advance_backlash_deg,
    friction_scale,
    gear_work_J,
    stiffness_scale,
    stream,
    unit_rates_deg_per_MJ,
    wear_effects,
)

_log = logging.getLogger(__name__)


@dataclasses.dataclass(frozen=True)
class Job:
    """One inspection to simulate: the unit, its number, its cycles and its clearances [deg]."""

    unit: Unit
    inspection: int
    cycles: int
    backlash_deg: tuple[float, ...]


def noise_seed(camp: LifeCampaign, unit: Unit, k: int) -> int:
    """Sensor-noise seed of inspection ``k`` of ``unit`` (a fresh one per inspection)."""
    return int(stream(camp.seed, unit.index, k, STREAM_NOISE).integers(0, 2**31 - 1))


def inspect_batch(camp: LifeCampaign, jobs: Sequence[Job], refs: Mapping[str, np.ndarray | None],
                  parent_pid: int | None = None) -> list[tuple[dict[str, Any], np.ndarray | None, np.ndarray | None]]:
    """Simulate one lockstep batch of inspections (one trajectory); return (row, t_s, tcp) per job,
    t_s and tcp only for inspection 0 (the unit's reference)."""
    from ...sim.engine import RunSpec, Simulator
    from ...sim.params import load_params
    from ..features import FEATURE_UNITS, run_features

    exit_with_parent(parent_pid)
    traj = parse_trajectory(jobs[0].unit.trajectory, "trajectory")
    sim = Simulator(load_params(), stepper=STEPPER, drive=DRIVE)
    specs = []
    for job in jobs:
        a = np.asarray(job.backlash_deg)
        eff = wear_effects(camp.wear, a, job.cycles) + (
            make_effect("payload", mass_kg=job.unit.payload_kg),
            make_effect("temperature", temperature_C=job.unit.temperature_C))
        specs.append(RunSpec(run_id(job.unit, job.inspection), noise_seed(camp, job.unit, job.inspection), eff))
    res = sim.run(traj, specs, log_period_s=camp.log_period_s, duration_s=camp.duration_s)
    work = gear_work_J(res.t_s, res["q_rad"], res["T_gear_Nm"])
    ratio = np.asarray(sim.params.gear.ratio)
    out = []
    for i, job in enumerate(jobs):
        ref = res.tcp_m[i] if job.inspection == 0 else refs.get(job.unit.unit_id)
        ok = res.status[i] == "ok"
        feats = run_features(res.t_s, res.q_set_rad, res["q_FB_rad"][i], res["q_M_FB_rad"][i], res["i_FB_A"][i],
                             ratio, res.tcp_m[i], res.tcp_des_m[i], ref)
        a = np.asarray(job.backlash_deg)
        row: dict[str, Any] = {
            "run_id": run_id(job.unit, job.inspection), "twin_run_id": run_id(job.unit, 0),
            "unit_id": job.unit.unit_id, "inspection": job.inspection, "cycles": job.cycles, "split": job.unit.split,
            "trajectory": json.dumps(job.unit.trajectory, sort_keys=True), "payload_kg": job.unit.payload_kg,
            "temperature_C": job.unit.temperature_C, "seed": specs[i].seed,
            "status": res.status[i], "reason": res.reason[i],
            **{f"backlash_deg_j{j + 1}": float(a[j]) for j in range(N_JOINTS)},
            **{f"friction_scale_j{j + 1}": float(v) for j, v in
               enumerate(friction_scale(camp.wear, a, job.cycles))},
            **{f"stiffness_scale_j{j + 1}": float(v) for j, v in enumerate(stiffness_scale(camp.wear, a))},
            **{f"gear_work_J_j{j + 1}": float(work[i, j]) for j in range(N_JOINTS)},
        }
        for key in FEATURE_UNITS:
            row[key] = float(feats.get(key, float("nan")))
        # a run the robot stops (protective stop) or that diverges has failed its task too
        row["failed"] = bool(not ok or row[camp.failure.feature] >= camp.failure.threshold)
        keep = job.inspection == 0
        out.append((row, res.t_s if keep else None, res.tcp_m[i] if keep else None))
    return out


def next_job(camp: LifeCampaign, unit: Unit, row: Mapping[str, Any]) -> Job | None:
    """The unit's next inspection from its stored row, or None when it failed, reached max_cycles, or its next wear
    state lies beyond what the simulator's effects may take (:func:`beyond_model`: censored there)."""
    k, cycles = int(row["inspection"]), int(row["cycles"])
    if row["failed"] or cycles + camp.interval_cycles > camp.max_cycles:
        return None
    a = np.array([row[f"backlash_deg_j{j + 1}"] for j in range(N_JOINTS)], float)
    w = np.array([row[f"gear_work_J_j{j + 1}"] for j in range(N_JOINTS)], float)
    rates = unit_rates_deg_per_MJ(camp.wear, camp.seed, unit.index)
    a = advance_backlash_deg(camp.wear, rates, a, w, camp.interval_cycles, camp.seed, unit.index, k)
    if beyond_model(camp, a, cycles + camp.interval_cycles):
        return None
    return Job(unit, k + 1, cycles + camp.interval_cycles, tuple(float(v) for v in a))


def beyond_model(camp: LifeCampaign, backlash_deg: NDArray, cycles: float) -> str | None:
    """Why the wear state (clearance ``(6,)`` [deg] after ``cycles``) lies beyond the declared range of an effect
    it puts on the unit (e.g. a Coulomb friction factor above 10, where the wear law's constants take a unit that
    never meets the failure criterion), or None. Such a unit is not simulated further: it ends censored at its
    last inspection, as one reaching max_cycles does, and the fleet's summary counts it apart."""
    try:
        wear_effects(camp.wear, np.asarray(backlash_deg, float), cycles)
    except ParameterError as exc:
        return str(exc)
    return None


def _resume(camp: LifeCampaign, out: Path, ids: LifeIdentities, n_log: int) -> tuple[dict, dict, dict, list]:
    """From the stored files: each unit's next job (or its last inspection when finished), its
    reference path, and the (file, state, detail) of every stored file that cannot be used."""
    pending, finished, refs, unusable = {}, {}, {}, []
    for unit in camp.units:
        job: Job | None = Job(unit, 0, 0, (0.0,) * N_JOINTS)
        ref = read_reference(out, ids, unit, n_log)
        k = 0
        while job is not None:
            check, where = check_inspection(out, ids, unit, k), run_path(out, run_id(unit, k)).relative_to(out)
            if check.state == "ok" and ref is None:  # the reference is missing, bad or changed: start again
                check, where = check_reference(out, ids, unit, n_log), reference_path(out, unit).relative_to(out)
            if check.state != "ok":
                if check.state != "missing":
                    unusable.append((run_id(unit, k), check.state, check.detail, where))
                break
            job = next_job(camp, unit, read_inspection(out, unit, k))
            if job is None:
                finished[unit] = k
            k += 1
        if job is not None:
            pending[unit] = job if ref is not None else Job(unit, 0, 0, (0.0,) * N_JOINTS)
        refs[unit.unit_id] = ref
    return pending, finished, refs, unusable


def _batches(jobs: Sequence[Job], batch_size: int, n_workers: int) -> list[list[Job]]:
    by_traj: dict[str, list[Job]] = {}
    for job in sorted(jobs, key=lambda j: j.unit.index):
        by_traj.setdefault(json.dumps(job.unit.trajectory, sort_keys=True), []).append(job)
    out = []
    for group in by_traj.values():
        size = max(1, min(batch_size, -(-len(group) // max(1, n_workers))))
        out += [group[i : i + size] for i in range(0, len(group), size)]
    return out


def run_life(camp: LifeCampaign, out: Path | None = None, *, jobs: int | None = None, backend: str = "loky",
             scheduler: str | None = None, progress: bool | Callable[[int, int, float], None] = True,
             note: Callable[[str], None] | None = note_stderr, max_rounds: int | None = None,
             replace_changed: bool = False) -> dict[str, Any]:
    """Run (or resume) a life campaign into ``out``; return its manifest.

    Args:
        jobs: worker processes (loky; default and at most the cores available).
        backend: ``"loky"`` or ``"dask"`` (``scheduler`` address required).
        progress: a progress bar of finished units on stderr, or a callback ``(done, total, eta_s)``.
        max_rounds: stop after this many rounds (tests: an interrupted campaign); None: to the end.
        replace_changed: simulate again the units whose stored inspections were made under other
            settings (default: stop and name the first difference).
    """
    out = Path(out) if out is not None else camp.out
    say = note or (lambda m: None)
    bound, _ = check_life_limits(camp)  # the hard limit, as run_campaign's check_limits (--yes is the command line's)
    n_jobs, capped = check_backend(backend, scheduler, jobs)
    check_writable(out, folder=True)
    client = dask_client(str(scheduler)) if backend == "dask" else None
    try:
        with Lock(out):
            if capped:
                say(capped)
            return _run_locked(camp, out, n_jobs, client, progress, say, max_rounds, backend, replace_changed, bound)
    finally:
        if client is not None:
            client.close()


def _run_locked(camp, out: Path, n_jobs: int, client, progress, say, max_rounds, backend,
                replace_changed, bound: str) -> dict[str, Any]:
    t0 = time.perf_counter()
    for folder in (out, *(out / f for f in SUBFOLDERS)):
        remove_stale_temporaries(folder, 0)  # a writer killed mid-write; we hold the lock
    ids = LifeIdentities(camp)
    pending, finished, refs, unusable = resume_state(camp, out, ids)
    changed = [u for u in unusable if u[1] == "changed"]
    if changed and not replace_changed:
        _, _, why, where = changed[0]
        raise CampaignChangedError(
            f"{out / where}: made under other settings ({why}); {len(changed)} unit(s) differ from this "
            "life campaign: use another --out, or --replace-changed to simulate them again")
    for _, state, why, where in unusable[:5]:
        say(f"{out / where}: {why or state}; simulating the unit again from there")
    kept = sum(k + 1 for k in finished.values()) + sum(j.inspection for j in pending.values())  # stored, verified
    say(f"life campaign {camp.name}: {len(camp.units)} units, {len(finished)} finished, {len(pending)} to run"
        + (f" ({kept} stored inspections kept)" if kept else "") + f" -> {out}"
        + ("" if finished or kept else f"; {bound.split(': ', 1)[-1]}"))  # how long the whole fleet can take
    write_json_atomic(out / "manifest.json", _manifest(camp, ids, "running", backend, n_jobs, t0, None),
                      checksum=True)
    report = campaign_progress(progress, len(camp.units))
    report(len(finished), 0.0)
    rounds = 0
    try:
        while pending and (max_rounds is None or rounds < max_rounds):
            batches = _batches(list(pending.values()), camp.batch_size, n_jobs)
            args = [(camp, b, {j.unit.unit_id: refs[j.unit.unit_id] for j in b},
                     os.getpid() if client is None else None) for b in batches]
            by_id = {j.unit.unit_id: j.unit for j in pending.values()}
            with closing(dispatch(inspect_batch, args, n_jobs, client, cost=[len(b) for b in batches])) as results:
                for batch in results:
                    for row, t_s, tcp in batch:
                        unit = by_id[row["unit_id"]]
                        if tcp is not None:
                            write_reference(out, ids, unit, t_s, tcp)
                            refs[unit.unit_id] = tcp
                        write_inspection(out, ids, unit, row)
                        job = next_job(camp, unit, row)
                        if job is None:
                            finished[unit] = int(row["inspection"])
                            pending.pop(unit)
                        else:
                            pending[unit] = job
                    report(len(finished), time.perf_counter() - t0)
            rounds += 1
    finally:
        report.close()
    if pending:
        write_json_atomic(out / "manifest.json", _manifest(camp, ids, "running", backend, n_jobs, t0, None),
                          checksum=True)
        return _manifest(camp, ids, "running", backend, n_jobs, t0, None)
    df = consolidate_life(out, ids, finished)
    manifest = _manifest(camp, ids, "complete", backend, n_jobs, t0, df)
    write_json_atomic(out / "manifest.json", manifest, checksum=True)
    return manifest


def log_lengths(camp: LifeCampaign) -> dict[str, int]:
    """Logged samples of one inspection per task (keyed by the trajectory's JSON)."""
    from ...sim.params import load_params

    dt = load_params().physics_dt_s
    return {key: int(round(d / dt)) // int(round(camp.log_period_s / dt)) for key, d in camp.inspection_s().items()}


def resume_state(camp: LifeCampaign, out: Path, ids: LifeIdentities) -> tuple[dict, dict, dict, list]:
    """What the stored files of ``out`` say (read only): each running unit's next job, each finished
    unit's last inspection, the reference paths, and the (run_id, state, detail, file relative to ``out``) of
    every unusable file (the unit's inspection ``run_id``, or its reference) where the unit starts again."""
    n_log = log_lengths(camp)
    pending, finished, refs, unusable = {}, {}, {}, []
    by_traj: dict[str, list[Unit]] = {}
    for unit in camp.units:
        by_traj.setdefault(json.dumps(unit.trajectory, sort_keys=True), []).append(unit)
    for key, units in by_traj.items():
        sub = dataclasses.replace(camp, units=tuple(units))
        p, f, r, b = _resume(sub, out, ids, n_log[key])
        pending.update(p)
        finished.update(f)
        refs.update(r)
        unusable += b
    return pending, finished, refs, unusable


def _manifest(camp: LifeCampaign, ids: LifeIdentities, state: str, backend: str, jobs: int, t0: float,
              df) -> dict[str, Any]:
    from ...util.provenance import dependency_versions, git_revision

    m: dict[str, Any] = {
        "name": camp.name, "kind": "life", "state": state,
        "campaign_file": str(camp.path) if camp.path else None, "campaign_sha256": camp.sha256,
        "campaign_text": camp.text, "campaign_data": camp.data, "identity_inputs": ids.common,
        "git_revision": git_revision(), "dependencies": dependency_versions(),
        "n_units": len(camp.units), "interval_cycles": camp.interval_cycles, "max_cycles": camp.max_cycles,
        "failure": dataclasses.asdict(camp.failure), "wear": dataclasses.asdict(camp.wear),
        "split": {"by": "unit", "test_fraction": camp.test_fraction, "seed": camp.split_seed},
        "backend": backend, "jobs": jobs, "wall_s_this_invocation": time.perf_counter() - t0,
    }
    if df is not None:
        per_unit = df.groupby("unit_id").agg(n=("inspection", "size"), eol=("eol_cycles", "first"),
                                             last=("cycles", "max"))
        m.update({
            "n_inspections": int(len(df)), "n_failed": int(per_unit["eol"].notna().sum()),
            "n_censored": int(per_unit["eol"].isna().sum()),
            # of them, units whose next inspection's wear lay beyond an effect's declared range (next_job)
            "n_censored_beyond_model": int((per_unit["eol"].isna()
                                            & (per_unit["last"] + camp.interval_cycles <= camp.max_cycles)).sum()),
            # failed at the first inspection, unworn: the failure criterion is met by the healthy robot's task
            "n_failed_unworn": int((per_unit["eol"] == 0).sum()),
            "inspections_per_unit": {"min": int(per_unit["n"].min()), "mean": float(per_unit["n"].mean()),
                                     "max": int(per_unit["n"].max())},
            "eol_cycles": life_stats(per_unit["eol"]),
            "status_counts": {str(k): int(v) for k, v in df["status"].value_counts().items()},
        })
    return m

