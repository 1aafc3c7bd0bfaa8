"""Campaign execution: runs grouped into lockstep batches, spread over processes (this one and ``jobs - 1``
loky workers, ``util/parallel.py``; or Dask for clusters), each finished run written atomically to the store as
it arrives.

Before anything is simulated the campaign's cost is checked (:mod:`.limits`) and the output folder
must be writable.  On a rerun into an existing folder every stored run is verified
(:mod:`.verify`): sound results made under the same settings are kept, bad files are reported
and re-simulated, and results made under other settings stop the campaign with the first
difference named (``replace_changed=True`` re-simulates them instead); so does an edited campaign whose runs
leave out stored runs of the campaign the folder's manifest records (``replace_changed=True``: they are left as
strays).  On an interruption
(Ctrl-C, SIGTERM) the loky workers are stopped and the lock released; a worker whose parent
process dies (even by SIGKILL) exits within about two seconds (it checks every second).
"""

from __future__ import annotations

import json
import logging
import os
import time
from collections.abc import Callable, Mapping, Sequence
from contextlib import closing
from pathlib import Path
from typing import Any

import numpy as np

from ..config import parse_trajectory
from ..errors import ParameterError, Ur5FaultError
from ..sim.params import load_params
from ..util.checks import as_bool, short
from ..util.io import (
    check_writable,
    checksum_path,
    remove_stale_temporaries,
    write_json_atomic,
    write_parquet_atomic,
)
from ..util.lock import Lock
from ..util.parallel import one_blas_thread, return_freed_memory
from ..util.progress import campaign_progress
from .batches import plan_batches
from .digital_twin import add_twin_features, regressor_grid, regressor_runs, twin_id, twin_runs
from .identity import DRIVE, STEPPER, Identities, first_difference
from .identity import run_effects as _effects_of
from .labels import assign_splits, refresh_labels, row_labels
from .limits import check_limits, estimate
from .manifest import build_manifest, recorded_campaign
from .runs import CampaignRun
from .spec import Campaign
from .store import (
    SUBFOLDERS,
    BadRunFilesError,
    CampaignChangedError,
    check_timeseries_file,
    consolidate,
    read_manifest,
    run_path,
    timeseries_path,
    write_run_file,
)
from .verify import scan
from .workers import check_backend, dask_client, dispatch, exit_with_parent, note_stderr

_log = logging.getLogger(__name__)


def run_batch(camp: Campaign, batch: Sequence[CampaignRun], ts_dir: str | None,
              identities: Mapping[str, str] | None = None, parent_pid: int | None = None) -> list[dict[str, Any]]:
    """Simulate one lockstep batch; return one feature row per run (twins included).

    Args:
        ts_dir: folder for the runs' time series (None: not written).
        identities: run_id -> run identity, recorded in the time-series files.
        parent_pid: the campaign process, for loky workers: a worker exits when it dies.
    """
    exit_with_parent(parent_pid)
    with one_blas_thread():  # a batch is one core's work: the campaign's processes fill the cores
        rows = _simulate_batch(camp, batch, ts_dir, identities)
    return_freed_memory()  # the batch's arrays, freed on return, back to the system (not kept by the allocator)
    return rows


def _simulate_batch(camp: Campaign, batch: Sequence[CampaignRun], ts_dir: str | None,
                    identities: Mapping[str, str] | None) -> list[dict[str, Any]]:
    """:func:`run_batch` in this process."""
    from ..health.features import FEATURE_UNITS, run_features
    from ..health.signals import needs_motor_encoders
    from ..sim.engine import RunSpec, Simulator

    traj_spec = batch[0].cond["trajectory"]
    traj = parse_trajectory(traj_spec, "trajectory")
    sim = Simulator(load_params(overrides=dict(camp.base_params)), stepper=STEPPER, drive=DRIVE)
    specs = [RunSpec(rc.run_id, int(rc.cond["seed"]), _effects_of(camp, rc)) for rc in batch]
    twins = twin_runs(camp, batch) if camp.twin_residuals else {}
    twin_index = {tid: len(specs) + k for k, tid in enumerate(twins)}
    specs += [RunSpec(tid, seed, eff) for tid, (seed, eff) in twins.items()]
    grid_temp = sim.params.friction.reference_temp_C  # the regressor twins' temperature: f_v's reference
    grid, grid_runs = regressor_runs(camp, batch, grid_temp) if camp.twin_residuals else ((), {})
    grid_at = {rid: len(specs) + k for k, rid in enumerate(grid_runs)}
    grid_index = list(grid_at.values())
    specs += [RunSpec(rid, seed, eff) for rid, (seed, eff) in grid_runs.items()]
    t0 = time.perf_counter()
    res = sim.run(traj, specs, log_period_s=camp.log_period_s, duration_s=camp.duration_s)
    wall = time.perf_counter() - t0
    index = {rc.run_id: i for i, rc in enumerate(batch)}
    ratio = np.asarray(sim.params.gear.ratio)
    splits = assign_splits(camp.split, (rc.cond for rc in camp.runs))
    motion = None  # the batch's commanded motion, built once for its runs' twin features
    regressors = None  # the batch's noise-free twins (the fits' regressors), or (status, reason) if one failed
    if camp.twin_residuals:
        from ..health.twin_features import commanded_motion

        motion = commanded_motion(res.t_s, res.q_set_rad, sim.params)
        failed = [g for g in grid_index if res.status[g] != "ok"]
        if failed:  # every run of the batch loses its twin features: its regressors are missing
            regressors = (res.status[failed[0]], f"noise-free regressor twin {specs[failed[0]].run_id}: "
                                                 f"{res.reason[failed[0]]}")
        else:
            regressors = regressor_grid(res, grid, grid_at, grid_temp, motion.qd, sim.params, camp.twin_com_twins)
    held = traj.gripped(res.t_s)  # when the gripper holds the payload: the batch's trajectory
    rows = []
    for i, rc in enumerate(batch):
        twin_i = index.get(rc.twin().run_id)  # None: the campaign simulates no twin for this run
        twin_ok = twin_i is None or res.status[twin_i] == "ok"
        ok = res.status[i] == "ok" and twin_ok
        feats = run_features(res.t_s, res.q_set_rad, res["q_FB_rad"][i], res["q_M_FB_rad"][i], res["i_FB_A"][i],
                             ratio, res.tcp_m[i], res.tcp_des_m[i],
                             res.tcp_m[twin_i] if ok and twin_i is not None else None)
        if ts_dir is not None:
            meta = {**res.run_metadata(i), "run_identity": (identities or {}).get(rc.run_id)}
            series = res.to_pandas(i)
            series.attrs["ur5fault"] = meta  # read back as df.attrs by pandas: figures titled with effects, status
            write_parquet_atomic(series, Path(ts_dir) / f"{rc.run_id}.parquet", {"ur5fault": json.dumps(meta)},
                                 checksum=True)
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
        for key in FEATURE_UNITS:  # every file has the full schema (tcp_dev_* is NaN without a sound twin)
            row.setdefault(key, float("nan"))
        if camp.twin_residuals:
            add_twin_features(row, res, i, twin_index[twin_id(rc)], sim.params, rc.cond, held, motion, regressors)
        if not camp.motor_encoders:  # logged like a UR robot: what the motor encoder gives is unknown
            row.update({k: float("nan") for k in row if needs_motor_encoders(k)})
        rows.append(row)
    return rows


def run_campaign(camp: Campaign, out: Path | None = None, *, jobs: int | None = None, backend: str = "loky",
                 scheduler: str | None = None, progress: bool | Callable[[int, int, float], None] = True,
                 save_timeseries: bool | None = None, replace_changed: bool = False,
                 note: Callable[[str], None] | None = note_stderr) -> dict[str, Any]:
    """Run every run of ``camp`` not yet soundly done in ``out``; return the manifest.

    Args:
        jobs: worker processes (default, and at most: the cores available; a cap is noted).
        backend: ``"loky"`` (local processes) or ``"dask"`` (``scheduler`` address required).
        progress: print a progress line to stderr, or a callback ``(done, total, eta_s)``.
        replace_changed: re-simulate stored runs made under other settings, and replace the results of another
            version of the campaign (its run files left as strays), instead of stopping.
        note: receives one-line notes (jobs capped, bad files re-simulated); None: silent.

    Raises:
        CampaignChangedError: stored runs were made under other settings, or ``out`` holds another version of the
            campaign (first difference named).
        FolderLockedError: another process writes ``out``.
        ParameterError: a bad argument (named with its value), the campaign exceeds a limit (memory, steps), or a
            bad backend/scheduler.
        OutputError: ``out`` cannot be written.
    """
    _check_arguments(camp, out, scheduler, progress, save_timeseries, replace_changed, note)
    out = Path(out) if out is not None else camp.out
    say = note or (lambda message: None)
    jobs, capped = check_backend(backend, scheduler, jobs)
    check_limits(camp, estimate(camp, jobs))
    check_writable(out, folder=True)
    save_ts = camp.save_timeseries if save_timeseries is None else save_timeseries
    client = dask_client(str(scheduler)) if backend == "dask" else None  # before anything is written
    try:
        return _run_locked(camp, out, jobs, backend, client, progress, save_ts, replace_changed, say, capped)
    finally:
        if client is not None:
            client.close()


def _check_arguments(camp: Any, out: Any, scheduler: Any, progress: Any, save_timeseries: Any, replace_changed: Any,
                     note: Any) -> None:
    """run_campaign's arguments of the wrong kind, refused by name before anything is read or written (``jobs`` and
    ``backend`` are checked with the backend)."""
    if not isinstance(camp, Campaign):
        path = isinstance(camp, (str, os.PathLike))
        hint = (f"load it first: run_campaign(load_campaign({short(str(camp))}), ...)" if path
                else "load one with load_campaign(path or shipped name) or build_campaign(mapping, where)")
        raise ParameterError(f"run_campaign: camp = {short(camp)} must be a Campaign; {hint}")
    if out is not None and (not isinstance(out, (str, os.PathLike)) or not str(out).strip()):
        raise ParameterError(f"run_campaign: out = {short(out)} must be a folder path, or None for the campaign's own "
                             f"({camp.out})")
    if scheduler is not None and not isinstance(scheduler, str):
        raise ParameterError(f"run_campaign: scheduler = {short(scheduler)} must be a Dask scheduler address "
                             "(tcp://HOST:PORT) or None")
    if as_bool(progress) is None and not callable(progress):
        raise ParameterError(f"run_campaign: progress = {short(progress)} must be true, false or a function "
                             "(done, total, eta_s)")
    for name, value, none_ok in (("save_timeseries", save_timeseries, True),
                                 ("replace_changed", replace_changed, False)):
        if as_bool(value) is None and not (none_ok and value is None):
            raise ParameterError(f"run_campaign: {name} = {short(value)} must be true or false"
                                 + (" (or None: the campaign's own)" if none_ok else ""))
    if note is not None and not callable(note):
        raise ParameterError(f"run_campaign: note = {short(note)} must be a function of one line of text, or None")


def _other_campaign(out: Path, name: str) -> str | None:
    """The name of another campaign whose manifest ``out`` holds (None: none, this one's, or no readable name;
    an unreadable manifest is rewritten by the run as before)."""
    try:
        recorded = json.loads((out / "manifest.json").read_text()).get("name")
    except (OSError, ValueError, AttributeError):
        return None
    return recorded if isinstance(recorded, str) and recorded != name else None


def _earlier_version(out: Path, camp: Campaign, stray: Sequence[str]) -> str | None:
    """What makes the campaign ``out``'s manifest records another version of ``camp``, one whose stored runs this
    run would leave behind as strays and whose feature table it would replace (a condition, a trajectory or a
    payload edited, a level dropped): its first difference and how many of its stored runs ``camp`` lacks.

    None where no stored run of the recorded campaign is lost: the same campaign (a resume), one that extends it
    (swept levels added: only the new runs are simulated), or a folder whose manifest holds no campaign this
    ur5fault can rebuild (a damaged or absent one is rewritten by the run as before; runs of another ur5fault
    differ by their identity, refused by the scan)."""
    if not stray:
        return None
    manifest, _ = read_manifest(out)
    if manifest.get("name") != camp.name:  # another campaign's: _other_campaign's case
        return None
    try:
        earlier = recorded_campaign(manifest, out)
    except Ur5FaultError:
        return None
    if earlier is None:
        return None
    stored = {Path(name).stem for name in stray}
    lost = [rc.run_id for rc in earlier.runs if rc.run_id in stored]
    if not lost:
        return None
    why = (first_difference(dict(earlier.data), dict(camp.data), was="the folder's manifest")
           or f"run {lost[0]} of the folder's manifest is not a run of this campaign")
    return f"{why}; {len(lost)} of its stored run(s) are not runs of this campaign"


def _run_locked(camp: Campaign, out: Path, jobs: int, backend: str, client, progress, save_ts: bool,
                replace_changed: bool, say: Callable[[str], None], capped: str | None) -> dict[str, Any]:
    with Lock(out):  # notes only from here: an error before is the one line a user sees
        _remove_stale_temporaries(out)
        other = _other_campaign(out, camp.name)
        if other and not replace_changed:
            raise CampaignChangedError(
                f"{out}: holds the results of campaign {other!r}, not {camp.name!r}; use another --out, or "
                "--replace-changed to simulate this campaign there (the other's run files are then left as strays)")
        ids = Identities(camp)
        found = scan(out, camp, ids, save_ts)
        if found.changed and not replace_changed:
            rid, why = found.changed[0]
            raise CampaignChangedError(
                f"{run_path(out, rid)}: made under other settings ({why}); {len(found.changed)} stored run(s) differ "
                "from this campaign: use another --out, or --replace-changed to re-simulate them")
        earlier = _earlier_version(out, camp, found.stray)
        if earlier and not replace_changed:
            raise CampaignChangedError(
                f"{out}: holds the results of another version of campaign {camp.name!r} ({earlier}): use another "
                "--out, or --replace-changed to simulate this campaign there (the earlier version's run files are "
                "then left as strays)")
        if earlier:
            say(f"{out}: replacing the results of another version of campaign {camp.name!r} ({earlier}; "
                "--replace-changed): its run files are left as strays")
        for rid, why in found.bad[:5]:
            say(f"{run_path(out, rid)}: {why}; simulating it again")
        if len(found.bad) > 5:
            say(f"... and {len(found.bad) - 5} more bad run files; simulating them again")
        if found.changed:
            say(f"re-simulating {len(found.changed)} run(s) made under other settings (--replace-changed)")
        redo = set(found.missing) | {rid for rid, _ in found.bad} | {rid for rid, _ in found.changed}
        todo = [rc for rc in camp.runs if rc.run_id in redo]
        if not save_ts:  # a run simulated again without its time series: a stored one of other settings is stale
            for rc in todo:
                path = timeseries_path(out, rc.run_id)
                if path.exists() and check_timeseries_file(path, ids.identity(rc), None).state != "ok":
                    path.unlink(missing_ok=True)
                    checksum_path(path).unlink(missing_ok=True)
        if capped:
            say(capped)
        for line in camp.notes:
            say(line)
        say(f"campaign {camp.name}: {len(camp.runs)} runs (twins included), {len(todo)} to simulate -> {out}")
        t0 = time.perf_counter()
        started = build_manifest(camp, ids, None, "running", backend, jobs, save_ts, t0)
        write_json_atomic(out / "manifest.json", started, checksum=True)
        ts_dir = out / "timeseries" if save_ts else None
        batches = plan_batches(camp, todo, jobs)
        total, done = len(camp.runs), len(camp.runs) - len(todo)
        _log.info("campaign %s: %d of %d runs already in %s; %d to do in %d batch(es) on %d %s worker(s)", camp.name,
                  done, total, out, len(todo), len(batches), jobs, backend)
        report = campaign_progress(progress, total)
        report(done, 0.0)
        try:
            _execute(camp, batches, out, ts_dir, jobs, client, ids, {rc.run_id for rc in todo}, done, report, t0)
        finally:
            report.close()
        records = {rc.run_id: ids.record(rc) for rc in camp.runs}

        def relabel(df):  # labels are not results: stored rows follow the current split rule and fault sizes
            return refresh_labels(df, camp.split, camp.runs)[0]

        try:
            features = consolidate(out, records, relabel)
        except BadRunFilesError as exc:  # damaged after the scan (a disk, another tool): simulate them again
            for rid, why in exc.bad[:5]:
                say(f"{run_path(out, rid)}: {why}; simulating it again")
            redo_ids = {rid for rid, _ in exc.bad}
            found.bad += [b for b in exc.bad if b[0] not in {r for r, _ in found.bad}]
            again = plan_batches(camp, [rc for rc in camp.runs if rc.run_id in redo_ids], jobs)
            report = campaign_progress(progress, total)
            try:
                _execute(camp, again, out, ts_dir, jobs, client, ids, set(redo_ids), total - len(redo_ids), report,
                         t0)
            finally:
                report.close()
            features = consolidate(out, records, relabel)
        manifest = build_manifest(camp, ids, features, "complete", backend, jobs, save_ts, t0, earlier=started)
        manifest["runs_resimulated"] = {"missing": len(found.missing), "bad": len(found.bad),
                                        "changed": len(found.changed)}
        write_json_atomic(out / "manifest.json", manifest, checksum=True)
        return manifest


def _remove_stale_temporaries(out: Path) -> None:
    """Temporary files of a writer killed mid-write (we hold the lock, so no one else writes here)."""
    for folder in (out, *(out / f for f in SUBFOLDERS)):
        remove_stale_temporaries(folder, 0)


def _execute(camp: Campaign, batches: list[list[CampaignRun]], out: Path, ts_dir: Path | None, jobs: int,
             client, ids: Identities, todo: set[str], done: int, report, t0: float) -> None:
    """Run the batches in parallel (``workers.dispatch``); write each run's row to the store as soon as its batch
    returns."""
    if not batches:
        return
    if ts_dir is not None:
        ts_dir.mkdir(exist_ok=True)
    by_id = {rc.run_id: rc for b in batches for rc in b}
    idents = {rid: ids.identity(rc) for rid, rc in by_id.items()}
    args = [(camp, b, str(ts_dir) if ts_dir else None, {rc.run_id: idents[rc.run_id] for rc in b},
             os.getpid() if client is None else None) for b in batches]
    with closing(dispatch(run_batch, args, jobs, client, cost=[len(b) for b in batches])) as results:
        for rows in results:
            for row in rows:
                if row["run_id"] in todo:
                    write_run_file(out, row, ids.record(by_id[row["run_id"]]))
                    todo.discard(row["run_id"])
                    done += 1
            report(done, time.perf_counter() - t0)
