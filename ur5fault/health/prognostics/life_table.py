"""The inspections table of a life-campaign folder as ``ur5fault prognose`` reads it: its columns, its manifest and
their checksums (one-line refusals), what to do where there is none, and the values every label and estimator reads
checked finite."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ...campaign.store import check_table_of_manifest, read_manifest
from ...errors import ConfigFileError
from ...util.io import StoredFileError, read_parquet_stored
from .spec import Failure

NEEDED = ("unit_id", "inspection", "cycles", "split", "rul_cycles", "eol_cycles", "censored", "failed")
#: columns every inspection of a fleet holds a finite value in (its duty cycles and true clearances)
RECORDED_COLUMNS = ("cycles", *(f"backlash_deg_j{j}" for j in range(1, 7)))


def load_inspections(folder: Path) -> tuple[pd.DataFrame, dict[str, Any]]:
    """The inspections table and manifest of a life-campaign folder (one-line errors)."""
    path = Path(folder) / "inspections.parquet"
    if not path.is_file():
        raise ConfigFileError(f"{path}: not found; {_what_is_there(Path(folder))}")
    remake = f"run the life campaign into {folder} again (`ur5fault campaign run CAMPAIGN.yaml --out DIR`)"
    df = read_parquet_stored(path, remake)
    missing = [c for c in NEEDED if c not in df.columns]
    if missing:
        raise ConfigFileError(f"{path}: column {missing[0]!r} missing; not the inspections of a life campaign")
    manifest, damaged = read_manifest(Path(folder))
    if damaged:  # a manifest that changed on disk would give a wrong wear law and inputs: refused
        raise StoredFileError(f"{Path(folder) / 'manifest.json'}: {damaged}; {remake}")
    check_table_of_manifest(path, remake, manifest)  # an earlier fleet's table left by a rerun that stopped
    return df, manifest


def refuse_other_folder(folder: Path) -> None:
    """Refuse an existing folder without an inspections table (a fault campaign's, an unfinished life campaign's)
    with what it holds, as :func:`load_inspections` does: cheap, so said before the output place is checked."""
    if Path(folder).is_dir() and not (Path(folder) / "inspections.parquet").is_file():
        raise ConfigFileError(f"{Path(folder) / 'inspections.parquet'}: not found; {_what_is_there(Path(folder))}")


def _what_is_there(folder: Path) -> str:
    """What to do about a folder without an inspections table, from what its manifest says it holds."""
    from ...campaign.store import read_manifest

    m = read_manifest(folder)[0]
    if not m:  # nothing ran here (or not ur5fault, or a manifest that fails its checksum)
        return (f"run a life campaign into {folder} first (a shipped one: `ur5fault campaign run prognostics --out "
                f"{folder} --yes`, or prognostics_small)")
    name, campaign = m.get("name", "?"), m.get("campaign_file") or "its campaign file"
    if m.get("kind") != "life":
        return (f"{folder} holds the fault campaign {name!r}, not a life campaign; run one into another folder "
                "(`ur5fault campaign run prognostics --out NEW_DIR --yes`)")
    from ...campaign.verify import rerun_command

    # the command `campaign status` advises, --yes in it exactly where `campaign run` asks it of this fleet
    again = rerun_command(m, folder)
    how = (f"`{again}`" if again else f"`ur5fault campaign run {campaign} --out {folder}` (with --yes for a fleet "
           "that could take over 1000 runs or 2e9 steps)")
    return (f"the life campaign {name!r} in {folder} has not finished (state {m.get('state', '?')!r}): resume it "
            f"with {how} (`ur5fault campaign status {folder}` shows how far it got)")


def check_recorded(folder: Path, df: pd.DataFrame, failure: Failure) -> None:
    """Refuse an inspections table ``df`` (of ``folder``) with a gap in what the benchmark reads: the criterion every
    label is read off, and the fleet's own record of each inspection (its cycles and true wear, which every
    inspection has): a gap is no fleet's as the campaign wrote it (a table edited by hand)."""
    ok = df[df["status"] == "ok"] if "status" in df else df  # a stopped run has failed whatever its features
    checked = [(failure.feature, ok, "the failure criterion's feature", "the labels are read off it")]
    checked += [(c, df, "the fleet's record", "the estimators read it") for c in RECORDED_COLUMNS]
    for col, rows, what, why in checked:
        bad = int((~np.isfinite(pd.to_numeric(rows[col], errors="coerce"))).sum()) if col in rows else 0
        if bad:
            raise ConfigFileError(f"{folder}: {what} {col} is missing (NaN) or infinite in {bad} inspection(s); "
                                  f"{why}: run the life campaign again into this folder (it verifies the stored "
                                  "inspections and rebuilds the table)")
