"""The campaign store on disk: ``OUT/runs/<run_id>.parquet`` (one file per finished run, written
atomically), the ``OUT/.lock`` of the writing process, the consolidated ``OUT/features.parquet``,
and what a folder holds (:func:`status`)."""

from __future__ import annotations

import hashlib
import json
import os
import socket
from pathlib import Path
from typing import Any

import pandas as pd
import yaml

from ..errors import ConfigFileError, Ur5FaultError
from ..io import write_parquet_atomic
from .spec import Campaign, build_campaign


class CampaignLockedError(Ur5FaultError, RuntimeError):
    """Another campaign process is writing the same output folder."""


def runs_dir(out: Path) -> Path:
    return out / "runs"


def done_ids(out: Path) -> set[str]:
    d = runs_dir(out)
    return {p.stem for p in d.glob("r*.parquet")} if d.exists() else set()


class Lock:
    """``OUT/.lock`` holding the owner's host and pid; a stale lock (dead pid) is taken over."""

    def __init__(self, out: Path) -> None:
        self.path = out / ".lock"

    def __enter__(self) -> Lock:
        self.path.parent.mkdir(parents=True, exist_ok=True)
        me = f"{socket.gethostname()} {os.getpid()}"
        for _ in range(2):
            try:
                fd = os.open(self.path, os.O_CREAT | os.O_EXCL | os.O_WRONLY)
                os.write(fd, me.encode())
                os.close(fd)
                return self
            except FileExistsError:
                owner = self.path.read_text().split() if self.path.exists() else []
                if len(owner) == 2 and owner[0] == socket.gethostname() and not _alive(int(owner[1])):
                    self.path.unlink(missing_ok=True)  # stale: its process is gone
                    continue
                raise CampaignLockedError(
                    f"{self.path.parent}: another campaign is writing this folder (host {owner[0] if owner else '?'}, "
                    f"pid {owner[1] if len(owner) > 1 else '?'}); wait for it or choose another --out"
                ) from None
        raise CampaignLockedError(f"{self.path}: could not take the lock")

    def __exit__(self, *exc) -> None:
        self.path.unlink(missing_ok=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def file_sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def consolidate(out: Path, camp: Campaign | None = None) -> pd.DataFrame:
    """Gather the per-run files into ``OUT/features.parquet`` (atomic), ordered by run_id."""
    files = sorted(runs_dir(out).glob("r*.parquet"))
    if not files:
        raise ConfigFileError(f"{out}: no finished runs")
    df = pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)
    if camp is not None:
        wanted = {rc.run_id for rc in camp.runs}
        df = df[df["run_id"].isin(wanted)]
    df = df.sort_values("run_id", kind="stable").reset_index(drop=True)
    write_parquet_atomic(df, out / "features.parquet")
    return df


def status(out: Path) -> dict[str, Any]:
    """What is in a campaign folder: runs done, statuses, whether a process holds the lock."""
    out = Path(out)
    if not out.exists():
        raise ConfigFileError(f"{out}: no such campaign folder")
    manifest = json.loads((out / "manifest.json").read_text()) if (out / "manifest.json").exists() else {}
    done = done_ids(out)
    lock = (out / ".lock").read_text() if (out / ".lock").exists() else None
    info: dict[str, Any] = {"folder": str(out), "runs_done": len(done), "n_runs_expected": None, "lock": lock}
    if manifest.get("campaign_text"):
        try:
            camp = build_campaign(yaml.safe_load(manifest["campaign_text"]), "manifest", manifest["campaign_text"])
            info["n_runs_expected"] = len(camp.runs)
        except Ur5FaultError:
            pass
    if (out / "features.parquet").exists():
        df = pd.read_parquet(out / "features.parquet")
        info["status_counts"] = df["status"].value_counts().to_dict()
    return info
