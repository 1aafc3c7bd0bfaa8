"""What a campaign folder holds, verified file by file: used on resume (which runs to simulate,
which stored results to refuse) and by ``ur5fault campaign status``."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from ..errors import ConfigFileError, Ur5FaultError
from ..util.io import TEMP_GLOB
from ..util.lock import lock_holder
from .identity import Identities, digest
from .manifest import recorded_campaign
from .spec import Campaign
from .store import (
    REBUILD_FEATURES,
    SUBFOLDERS,
    FileCheck,
    check_manifest_fields,
    check_run_file,
    check_timeseries_file,
    read_consolidated,
    read_manifest,
    run_path,
    runs_dir,
    timeseries_path,
)

MAX_LISTED = 20
#: what to run where a campaign folder's manifest is missing, damaged or incomplete
REWRITE_MANIFEST = "`ur5fault campaign run` on the campaign, with the same --out, rewrites it"


@dataclasses.dataclass
class Scan:
    """Per-run verdicts of a folder against a campaign (run_ids; details for bad and changed)."""

    ok: list[str] = dataclasses.field(default_factory=list)
    missing: list[str] = dataclasses.field(default_factory=list)
    bad: list[tuple[str, str]] = dataclasses.field(default_factory=list)
    changed: list[tuple[str, str]] = dataclasses.field(default_factory=list)
    stray: list[str] = dataclasses.field(default_factory=list)
    #: checksum sidecars whose run file is gone (deleted by hand): listed, not counted as runs (the run is missing)
    orphan_checksums: list[str] = dataclasses.field(default_factory=list)

    def counts(self) -> dict[str, int]:
        return {k: len(getattr(self, k)) for k in ("ok", "missing", "bad", "changed", "stray")}


def scan(out: Path, camp: Campaign, ids: Identities, save_timeseries: bool = False) -> Scan:
    """Verify every run of ``camp`` stored in ``out`` (and its time series when they are wanted)."""
    out = Path(out)
    s = Scan()
    wanted = set()
    for rc in camp.runs:
        rid = rc.run_id
        wanted.add(rid)
        record = ids.record(rc)
        check = check_run_file(run_path(out, rid), record)
        if check.state == "ok" and save_timeseries:
            inputs = record["inputs"]
            n_log = int(round(inputs["duration_s"] / inputs["params"]["physics_dt_s"])) // int(
                round(inputs["log_period_s"] / inputs["params"]["physics_dt_s"]))
            ts = check_timeseries_file(timeseries_path(out, rid), record["identity"], n_log)
            if ts.state != "ok":
                check = FileCheck(ts.state, f"its time series timeseries/{rid}.parquet {ts.state}"
                                            f"{': ' + ts.detail if ts.detail else ''}")
        _add(s, rid, check)
    d = runs_dir(out)
    if d.is_dir():
        s.stray = sorted(p.name for p in d.glob("*.parquet") if p.stem not in wanted)
        s.orphan_checksums = sorted(p.name for p in d.glob("*.parquet.sha256") if not p.with_suffix("").exists())
    return s


def _add(s: Scan, rid: str, check: FileCheck) -> None:
    if check.state == "ok":
        s.ok.append(rid)
    elif check.state == "missing":
        s.missing.append(rid)
    elif check.state == "bad":
        s.bad.append((rid, check.detail))
    else:
        s.changed.append((rid, check.detail))


def _listed(items: list[str]) -> list[str]:
    return items[:MAX_LISTED] + ([f"... and {len(items) - MAX_LISTED} more"] if len(items) > MAX_LISTED else [])


def status(out: Path) -> dict[str, Any]:
    """What a campaign folder holds: the campaign, its state, every per-run file verified against
    the campaign recorded in the manifest (and the installed ur5fault), strays, the lock, and
    whether ``features.parquet`` holds exactly the campaign's runs."""
    out = Path(out)
    if not out.is_dir():
        raise ConfigFileError(f"{out}: " + ("a file, not a campaign folder" if out.exists() else
                                            "no such campaign folder"))
    # a wrong folder (other files, no trace of a campaign) is not "all ok"; an empty one may be a campaign that
    # failed before writing anything (a full disk), and is reported as such
    if any(out.iterdir()) and not runs_dir(out).is_dir() and lock_holder(out) is None and not any(
            (out / name).exists() for name in ("manifest.json", "features.parquet", "inspections.parquet")):
        raise ConfigFileError(f"{out}: not a campaign folder (no manifest.json, runs/ or feature table in it)")
    manifest, damaged = read_manifest(out)
    holder = lock_holder(out)
    state = manifest.get("state")
    if state == "running" and holder is None:  # the manifest of a process that was stopped: nothing runs now
        state = "interrupted"
    info: dict[str, Any] = {
        "folder": str(out), "campaign": manifest.get("name"), "state": state,
        # held by a running campaign, or None (a file left by a killed process is not a lock)
        "lock": (None if holder is None else {"held": True} if holder is True
                 else {"held": True, "host": holder[0], "pid": holder[1]}),
        "n_runs_expected": None,
    }
    manifest_todo = None
    if damaged:  # read as absent; the runs are still checked for soundness
        info["manifest"] = {"state": "bad", "detail": f"{damaged}; {REBUILD_FEATURES}"}
        manifest_todo = "manifest.json fails its checksum: `ur5fault campaign run` on the campaign rewrites it"
    elif not manifest and holder is None and (runs_dir(out).is_dir() or any(
            (out / name).exists() for name in ("features.parquet", "inspections.parquet"))):
        # runs or a table without the manifest that says which campaign they are: they cannot be checked
        why = "absent" if not (out / "manifest.json").exists() else "unreadable as a campaign manifest"
        info["manifest"] = {"state": "missing" if why == "absent" else "bad", "detail": why}
        manifest_todo = f"manifest.json {why}: {REWRITE_MANIFEST} (the stored runs are verified and kept)"
    if manifest and manifest.get("kind") != "life" and not manifest_todo:
        try:  # what CampaignResult reads of it (a manifest without its sidecar is read unverified)
            check_manifest_fields(out / "manifest.json", manifest)
        except ConfigFileError as exc:
            info["manifest"] = {"state": "bad", "detail": str(exc)}
            manifest_todo = f"manifest.json lacks what its readers take: {REWRITE_MANIFEST}"
    if manifest.get("kind") == "life":  # a fleet run to failure (issue 20): inspections, not runs
        from ..health.prognostics.life_status import life_status

        info = life_status(out, manifest, info)
        from ..health.prognostics.life_store import SUBFOLDERS as LIFE_SUBFOLDERS

        info["ignored"] = info.get("ignored", []) + _temporaries(out, holder is not None, LIFE_SUBFOLDERS)
        ins = info.get("inspections") or {}
        info["sound"], info["advice"] = _advice(info, ins.get("bad", 0), ins.get("changed", 0), manifest_todo,
                                                table_key="inspections_table", what="inspection",
                                                rerun=None if damaged else rerun_command(manifest, out))
        return info
    camp = None
    try:
        camp = recorded_campaign(manifest, out)
    except Ur5FaultError as exc:
        info["campaign_error"] = str(exc)
        manifest_todo = manifest_todo or ("manifest.json's campaign does not validate with this ur5fault (the "
                                          f"runs were checked for soundness only): {REWRITE_MANIFEST}")
    else:
        if camp is None:
            info["campaign_error"] = "manifest.json absent or without the campaign: files checked for soundness only"
            if manifest and not damaged:  # readable, but it does not say which campaign the runs are
                manifest_todo = manifest_todo or f"manifest.json does not record its campaign: {REWRITE_MANIFEST}"
    problems: list[str] = []
    if camp is not None:
        ids = Identities(camp)
        s = scan(out, camp, ids, bool(manifest.get("save_timeseries", False)))
        info["n_runs_expected"] = len(camp.runs)
        info["runs"] = s.counts()
        problems += [f"runs/{rid}.parquet: bad: {why}" for rid, why in s.bad]
        problems += [f"runs/{rid}.parquet: made under other settings: {why}" for rid, why in s.changed]
        info["ignored"] = _listed([f"runs/{name}: not a run of this campaign (stray)" for name in s.stray]
                                  + [f"runs/{name}: a checksum whose run file is gone" for name in s.orphan_checksums]
                                  + _temporaries(out, holder is not None, SUBFOLDERS))
        info["features"] = _check_features(out, {rc.run_id: ids.identity(rc) for rc in camp.runs})
    else:
        counts = {"ok": 0, "bad": 0, "changed": 0}
        for p in sorted(runs_dir(out).glob("*.parquet")) if runs_dir(out).is_dir() else []:
            c = check_run_file(p)
            counts[c.state] = counts.get(c.state, 0) + 1
            if c.state != "ok":
                problems.append(f"runs/{p.name}: {c.state}: {c.detail}")
        info["runs"] = counts
    info["problems"] = _listed(problems)
    runs = info.get("runs") or {}
    info["sound"], info["advice"] = _advice(info, runs.get("bad", 0), runs.get("changed", 0), manifest_todo,
                                            rerun=None if damaged or camp is None else rerun_command(manifest, out))
    return info


def _temporaries(out: Path, held: bool, subfolders: tuple[str, ...]) -> list[str]:
    """The temporary files of writers stopped mid-write in ``out`` and the ``subfolders`` the run clears (none while
    a running campaign holds the lock: its writers own them); the next ``campaign run`` removes them."""
    if held:
        return []
    found = [p for d in (out, *(out / f for f in subfolders)) if d.is_dir() for p in sorted(d.glob(TEMP_GLOB))]
    return [f"{p.relative_to(out)}: a temporary file of a writer stopped mid-write (the next `ur5fault campaign run` "
            "removes it)" for p in found]


def rerun_command(manifest: dict[str, Any], out: Path) -> str | None:
    """The ``campaign run`` command that made the folder, its command-line options (``--model``, ``--duration-s``)
    repeated (a quick trial's ``--duration-s`` left out makes another campaign, which is refused) and ``--yes`` where
    the campaign needed it, or None where the manifest does not say which file it ran."""
    import shlex

    file = manifest.get("campaign_file")
    if not isinstance(file, str) or not file:
        return None
    options = manifest.get("command_options")
    options = options if isinstance(options, dict) else {}
    # the file as the manifest recorded it (an absolute path: status may run from another folder), every
    # argument quoted for a shell, a duration in full (a rounded one is another campaign, refused)
    cmd = f"ur5fault campaign run {shlex.quote(file)} --out {shlex.quote(str(out))}"
    if isinstance(options.get("model"), str):
        cmd += f" --model {shlex.quote(options['model'])}"
    if isinstance(options.get("duration_s"), (int, float)) and not isinstance(options.get("duration_s"), bool):
        cmd += f" --duration-s {float(options['duration_s'])!r}"
    if _large(manifest):  # without it the command is refused before it resumes anything
        cmd += " --yes"
    return cmd


def _large(manifest: dict[str, Any]) -> bool:
    """Whether the campaign a manifest records needed ``--yes`` (:func:`.limits.confirmation_needed`'s bounds on its
    runs and steps; a life campaign's, which its manifest does not record, on the fleet it records, as
    ``campaign run`` decides it: prognostics.spec.life_confirmation_needed)."""
    from .limits import beyond_confirmation

    if manifest.get("kind") == "life":
        from ..health.prognostics.spec import build_life, life_confirmation_needed

        try:
            return life_confirmation_needed(build_life(manifest.get("campaign_data"), "manifest.json",
                                                       str(manifest.get("campaign_text", "")))) is not None
        except (Ur5FaultError, AttributeError, TypeError):  # no fleet to size: life_status names the problem
            return False

    def number(v) -> float:  # a manifest edited by hand: a value that is no count counts as none
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else 0.0

    return beyond_confirmation(number(manifest.get("n_runs")), number(manifest.get("n_steps_total")))


def _advice(info: dict[str, Any], bad: int, changed: int, manifest_todo: str | None, table_key: str = "features",
            what: str = "run", rerun: str | None = None) -> tuple[bool, str | None]:
    """Whether everything the folder holds is sound now (a ``complete`` state says only that the campaign ran to
    its end), and what to do where it is not (``manifest_todo``: what to do about a damaged or missing manifest)."""
    todo = []
    if bad:
        todo.append(f"{bad} damaged {what} file(s): `ur5fault campaign run` on the campaign again simulates them")
    if changed:
        todo.append(f"{changed} {what} file(s) made under other settings: `campaign run --replace-changed` "
                    "simulates them again with the campaign's (without it they are kept and the run refused)")
    if manifest_todo:
        todo.append(manifest_todo)
    if info.get("state") == "complete" and (info.get(table_key) or {}).get("state") not in (None, "ok"):
        todo.append(f"the {table_key.replace('_table', '')} table does not hold the stored {what}s: `ur5fault "
                    "campaign run` rebuilds it from them")
    sound = not todo  # of the files stored; an interrupted campaign's are sound, it only has more to make
    missing = (info.get("runs") or {}).get("missing", 0) if what == "run" else 0
    if info.get("state") == "complete" and missing:
        todo.append(f"{missing} run file(s) of the finished campaign are gone (the feature table keeps their rows): "
                    "`ur5fault campaign run` on the campaign simulates them again")
    if info.get("state") == "interrupted":
        todo.append(f"the campaign stopped before its end: `ur5fault campaign run` with the same campaign and --out "
                    f"resumes it (the {what}s made are kept)")
    if todo and rerun:
        todo.append(f"the command: `{rerun}`")
    return sound, "; ".join(todo) or None


def _check_features(out: Path, identities: dict[str, str]) -> dict[str, Any]:
    table, recorded, state = read_consolidated(out / "features.parquet")
    if state is not None:
        return state
    if "run_id" not in table.column_names:
        return {"state": "bad", "detail": "no run_id column"}
    df = table.select([c for c in ("run_id", "status") if c in table.column_names]).to_pandas()
    exact = (len(df) == len(identities) and set(df["run_id"]) == set(identities))
    out_info: dict[str, Any] = {"state": "ok" if exact and recorded == digest(identities) else "stale",
                                "rows": int(len(df))}
    if "status" in df:
        out_info["status_counts"] = {str(k): int(v) for k, v in df["status"].value_counts().items()}
    return out_info
