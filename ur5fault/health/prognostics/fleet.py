"""Running a life campaign: inspections in rounds, each round's units in lockstep batches over
processes (this one beside loky workers, or Dask: campaign/workers.dispatch, as fault campaigns), every inspection
written atomically as it arrives, and the campaign's manifest.

Round r simulates the next inspection of every unit still running (life_inspection.py); the parent then carries
each unit's wear forward (wear.py) and starts the next round.  A unit's next state is always computed
from its stored row (clearances and gear work as float64, the increments from the stream of
(fleet seed, unit, inspection)), so a campaign killed at any moment and run again resumes from
the files (life_resume.py) and writes the same bytes an uninterrupted run would (tested).
"""

from __future__ import annotations

import dataclasses
import json
import os
import time
from collections.abc import Callable, Iterable, Sequence
from contextlib import closing
from pathlib import Path
from typing import Any

from ...campaign.identity import first_difference
from ...campaign.store import CampaignChangedError, read_manifest
from ...campaign.workers import check_backend, dask_client, dispatch, note_stderr
from ...util.io import check_writable, remove_stale_temporaries, write_json_atomic
from ...util.lock import Lock
from ...util.progress import campaign_progress, clock_text
from .life_inspection import Job, beyond_model, inspect_batch, next_job, noise_seed
from .life_resume import log_lengths, resume_state
from .life_store import SUBFOLDERS, LifeIdentities, consolidate_life, life_stats, write_inspection, write_reference
from .spec import LifeCampaign, check_life_limits

#: this module's :func:`run_life`; the rest re-exported where callers (and tests) have imported it from
__all__ = ["Job", "beyond_model", "inspect_batch", "log_lengths", "next_job", "noise_seed", "resume_state",
           "run_life"]


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
    earlier, lost = _earlier_version(out, camp)
    if lost and not replace_changed:
        raise CampaignChangedError(
            f"{out}: holds the results of another version of life campaign {camp.name!r} ({earlier}; {lost}): use "
            "another --out, or --replace-changed to run this campaign there (the earlier version's inspection files "
            "are then left as strays)")
    if earlier:
        say(f"{out}: its manifest records another version of life campaign {camp.name!r} ({earlier}"
            + (f"; {lost}, left as strays: --replace-changed" if lost else "") + "); the stored inspections of "
            "this campaign's units are kept where their identity matches")
        if (out / "benchmark").is_dir():  # prognose's default report folder, made from the earlier table (said now:
            # the manifest written below records this version, so a resumed run no longer sees the edit)
            say(f"{out / 'benchmark'}: reports on the earlier version's inspections: run `ur5fault prognose {out}` "
                "again once this campaign is complete")
    for _, state, why, where in unusable[:5]:
        say(f"{out / where}: {why or state}; simulating the unit again from there")
    kept = sum(k + 1 for k in finished.values()) + sum(j.inspection for j in pending.values())  # stored, verified
    say(f"life campaign {camp.name}: {len(camp.units)} units, {len(finished)} finished, {len(pending)} to run"
        + (f" ({kept} stored inspections kept)" if kept else "") + f" -> {out}"
        + ("" if finished or kept else f"; {bound.split(': ', 1)[-1]}"))  # how long the whole fleet can take
    write_json_atomic(out / "manifest.json", _manifest(camp, ids, "running", backend, n_jobs, t0, None),
                      checksum=True)
    # it counts finished units, not runs; a unit finishes when it fails, mostly in the last rounds, so the rate of
    # finished units says nothing of the time left: each round states a bound instead (_rounds_left)
    report = campaign_progress(progress, len(camp.units), "unit", eta=False)
    report(len(finished), 0.0)
    rounds = 0
    try:
        while pending and (max_rounds is None or rounds < max_rounds):
            t_round = time.perf_counter()
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
            left = _rounds_left(camp, pending.values())
            report.describe(f"round {rounds} done, {len(pending)} units running, at most {left} more round(s) of at "
                            f"most {clock_text(time.perf_counter() - t_round)} each" if pending else
                            f"round {rounds} done, every unit finished")
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


def _rounds_left(camp: LifeCampaign, pending: Iterable[Job]) -> int:
    """At most this many more rounds: the running unit with the most inspections to go before max_cycles (a round
    costs no more than the one before it: units only leave the fleet)."""
    return max(((camp.max_cycles - j.cycles) // camp.interval_cycles + 1 for j in pending), default=0)


def _earlier_version(out: Path, camp: LifeCampaign) -> tuple[str | None, str | None]:
    """How the life campaign recorded in ``out``'s manifest differs from ``camp`` (its first difference; None:
    the same campaign, or no life campaign of that name recorded) and which stored units ``camp`` lacks (``"N
    stored unit(s) ... are not units of this campaign"``; None: none is lost, e.g. a split seed or more units, or the
    campaign is the one recorded: strays an earlier ``--replace-changed`` left are not lost again)."""
    manifest, _ = read_manifest(out)
    if manifest.get("kind") != "life" or manifest.get("name") != camp.name or "campaign_data" not in manifest:
        return None, None
    why = first_difference(manifest["campaign_data"], camp.data, was="the folder's manifest")
    if why is None:  # the campaign the folder records (strays there were left by an earlier --replace-changed)
        return None, None
    ours = {u.unit_id for u in camp.units}
    stray = sorted({p.name.split("_i")[0] for p in (out / "runs").glob("u*_i*.parquet")} - ours)
    lost = (f"{len(stray)} stored unit(s) ({', '.join(stray[:3])}{', ...' if len(stray) > 3 else ''}) are not "
            "units of this campaign") if stray else None
    return why, lost


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

