"""Where a life campaign stands, from its stored files alone (read only): each running unit's next inspection,
each finished unit's last, the units' reference paths, and every stored file that cannot be used (missing files
aside), where its unit starts again.  fleet.py resumes from it; ``campaign status`` reports it (life_status.py).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from ...campaign.store import run_path
from ...sim.axes import N_JOINTS
from .life_inspection import Job, next_job
from .life_store import (
    LifeIdentities,
    check_inspection,
    check_reference,
    read_inspection,
    read_reference,
    reference_path,
    run_id,
)
from .spec import LifeCampaign, Unit


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
