"""``ur5fault campaign status DIR`` of a life-campaign folder: the fleet rebuilt from its manifest, every
stored inspection and reference path verified the way a resume would use them (read only), and
whether ``inspections.parquet`` holds exactly the finished units' verified inspections."""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from ...campaign.identity import digest
from ...campaign.store import read_consolidated, runs_dir
from ...errors import Ur5FaultError
from .life_store import LifeIdentities, run_id
from .spec import build_life

MAX_LISTED = 20
_RUN_NAME = re.compile(r"^u(\d+)_i(\d+)$")


def life_status(out: Path, manifest: dict[str, Any], info: dict[str, Any]) -> dict[str, Any]:
    """Add to ``info`` (folder, state, lock from the generic status) what a life folder holds."""
    from .life_resume import resume_state

    out = Path(out)
    info["kind"] = "life"
    info.pop("n_runs_expected", None)
    data = manifest.get("campaign_data")
    try:
        if not isinstance(data, dict):
            raise Ur5FaultError("manifest.json without the campaign")
        camp = build_life(data, "manifest.json", str(manifest.get("campaign_text", "")), None, out)
    except Ur5FaultError as exc:
        info["campaign_error"] = f"{exc}: files not verified"
        info["problems"] = []
        return info
    ids = LifeIdentities(camp)
    pending, finished, _refs, unusable = resume_state(camp, out, ids)
    ok = {run_id(u, k) for u, last in finished.items() for k in range(last + 1)}
    ok |= {run_id(job.unit, k) for job in pending.values() for k in range(job.inspection)}
    bad = [(rid, why, where) for rid, state, why, where in unusable if state == "bad"]
    changed = [(rid, why, where) for rid, state, why, where in unusable if state == "changed"]
    known = {u.unit_id for u in camp.units}
    stored = sorted(p.stem for p in runs_dir(out).glob("*.parquet")) if runs_dir(out).is_dir() else []
    stray = [s for s in stored if not _ours(s, known, camp.max_inspections)]
    unused = [s for s in stored if s not in ok and s not in stray and s not in {r for r, _, _ in bad + changed}]
    info["units"] = {"expected": len(camp.units), "finished": len(finished), "running": len(pending)}
    info["inspections"] = {"ok": len(ok), "bad": len(bad), "changed": len(changed),
                           # stored after an unusable inspection of their unit: simulated again on resume
                           "not_reachable": len(unused), "stray": len(stray)}
    problems = [f"{where}: bad: {why}" for _, why, where in bad]
    problems += [f"{where}: made under other settings: {why}" for _, why, where in changed]
    info["problems"] = _listed(problems)
    info["ignored"] = _listed([f"runs/{s}.parquet: not an inspection of this fleet (stray)" for s in stray]
                              + [f"runs/{s}.parquet: after an unusable inspection of its unit" for s in unused])
    if not pending and not unusable:
        info["inspections_table"] = _check_table(out, ids, finished)
    elif (out / "inspections.parquet").exists():  # written by an earlier complete run; units to simulate again
        info["inspections_table"] = {"state": "stale", "detail": f"{len(pending)} unit(s) to simulate again; "
                                                                 "run the life campaign again to rebuild it"}
    else:
        info["inspections_table"] = {"state": "not expected yet"}
    return info


def _ours(stem: str, known: set[str], max_inspections: int) -> bool:
    m = _RUN_NAME.match(stem)
    return bool(m) and f"u{m.group(1)}" in known and int(m.group(2)) < max_inspections


def _listed(items: list[str]) -> list[str]:
    return items[:MAX_LISTED] + ([f"... and {len(items) - MAX_LISTED} more"] if len(items) > MAX_LISTED else [])


def _check_table(out: Path, ids: LifeIdentities, finished) -> dict[str, Any]:
    """``inspections.parquet`` against the finished units' inspections (its recorded identities)."""
    table, recorded, state = read_consolidated(out / "inspections.parquet")
    if state is not None:
        return state
    expected = digest({run_id(u, k): ids.identity(u, k) for u, last in sorted(finished.items(),
                                                                              key=lambda x: x[0].index)
                       for k in range(last + 1)})
    if recorded != expected:
        return {"state": "stale", "detail": "does not hold exactly the fleet's verified inspections; "
                                            "run the life campaign again to rebuild it"}
    return {"state": "ok", "rows": table.num_rows}
