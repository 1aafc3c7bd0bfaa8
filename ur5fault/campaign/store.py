"""The campaign store on disk, and what a folder holds.

- ``OUT/runs/<run_id>.parquet``: one file per finished run (one row), written atomically; its
  Parquet schema metadata (key ``ur5fault``) records the run's identity and the inputs behind it
  (:mod:`.identity`) and the column units.
- ``OUT/timeseries/<run_id>.parquet``: optional time series, with the identity in its metadata.
- ``OUT/features.parquet``: exactly the campaign's runs, gathered from verified per-run files.
- ``OUT/.lock``: held by the process writing the folder (:mod:`.lock`).

Every per-run file is verified before it is used (:func:`check_run_file`): readable as Parquet,
the feature schema, one row, the run_id of its name, and the identity the campaign expects.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from ..errors import ConfigFileError, Ur5FaultError
from ..health.features import FEATURE_UNITS
from ..health.twin_features import FEATURE_UNITS as TWIN_FEATURE_UNITS
from ..sim.effects import REGISTRY
from ..util.io import DAMAGED_PARQUET_ERRORS, checksum_path, verify_checksum, write_parquet_atomic
from .identity import digest, first_difference

META_KEY = b"ur5fault"
#: what to run when a campaign's consolidated table fails its checksum: the stored runs are verified and reused
REBUILD_FEATURES = ("run the campaign again into this folder (`ur5fault campaign run CAMPAIGN.yaml --out DIR`): it "
                    "verifies the stored runs, re-simulates only bad ones and rebuilds the table")
#: columns every per-run file has (the feature table's schema; others may be added)
REQUIRED_COLUMNS = ("run_id", "status", "twin_run_id", *FEATURE_UNITS)
#: units of the run-description columns (features: :data:`ur5fault.health.features.FEATURE_UNITS`)
COLUMN_UNITS = {
    "run_id": "-", "fault_joint": "-", "fault": "-", "backlash_deg": "deg", "seed": "-", "payload_kg": "kg",
    "temperature_C": "degC", "trajectory": "-", "backlash_deg_swept": "deg", "twin_run_id": "-", "status": "-",
    "reason": "-", "effects": "-", "wall_s_batch": "s", "batch_size": "-",
}


class CampaignChangedError(Ur5FaultError, ValueError):
    """Stored results were made under other settings than the campaign being run."""


class BadRunFilesError(CampaignChangedError):
    """Per-run files found unusable while gathering the feature table; ``bad``: (run_id, why) each."""

    def __init__(self, message: str, bad: list[tuple[str, str]]) -> None:
        super().__init__(message)
        self.bad = bad


@dataclasses.dataclass(frozen=True)
class FileCheck:
    """Verdict on one stored file: ``ok``, ``missing``, ``bad`` (unusable) or ``changed``
    (a sound file made under other settings); ``detail`` says why."""

    state: str
    detail: str = ""


#: the subfolders a campaign writes beside its table: where a writer stopped mid-write may leave temporaries, which
#: the next run clears and ``campaign status`` lists
SUBFOLDERS = ("runs", "timeseries")


def runs_dir(out: Path) -> Path:
    return Path(out) / "runs"


def run_path(out: Path, run_id: str) -> Path:
    return runs_dir(out) / f"{run_id}.parquet"


def timeseries_path(out: Path, run_id: str) -> Path:
    return Path(out) / "timeseries" / f"{run_id}.parquet"


def column_units(columns: Iterable[str]) -> dict[str, str]:
    """Unit of each known column (swept ``<effect>_<param>`` columns from the effect registry)."""
    units = {**COLUMN_UNITS, **FEATURE_UNITS, **TWIN_FEATURE_UNITS}
    out = {}
    for col in columns:
        if col in units:
            out[col] = units[col]
            continue
        for name, eff in REGISTRY.items():
            if col == f"{name}_joint":
                out[col] = "-"
            for p in eff.params:
                if col == f"{name}_{p.name}":
                    out[col] = p.unit
    return out


def _read_meta(schema) -> dict[str, Any] | None:
    raw = (schema.metadata or {}).get(META_KEY)
    try:
        meta = json.loads(raw) if raw else None
    except ValueError:
        return None
    return meta if isinstance(meta, dict) else None


def recorded_run_identities(table: Path) -> dict[str, str]:
    """run_id -> identity as a consolidated table's metadata records them (:func:`consolidate`); empty for a table
    without them or unreadable."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        ids = (_read_meta(pq.read_schema(table)) or {}).get("run_identities")
    except (OSError, pa.ArrowException):
        return {}
    return {str(k): str(v) for k, v in ids.items()} if isinstance(ids, dict) else {}


def check_run_file(path: Path, expected: Mapping[str, Any] | None = None) -> FileCheck:
    """Verify a per-run file; ``expected``: the record (run_id, identity, inputs) it must carry."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    path = Path(path)
    if not path.is_file():
        return FileCheck("missing")
    try:
        pf = pq.ParquetFile(path)
        schema, n_rows = pf.schema_arrow, pf.metadata.num_rows
        missing = [c for c in REQUIRED_COLUMNS if c not in schema.names]
        if missing:
            return FileCheck("bad", f"column {missing[0]!r} missing" + (f" (and {len(missing) - 1} more)"
                                                                          if len(missing) > 1 else ""))
        if n_rows != 1:
            return FileCheck("bad", f"{n_rows} rows, expected 1")
        rid = pf.read(columns=["run_id"]).column(0)[0].as_py()
    except (*DAMAGED_PARQUET_ERRORS, pa.ArrowException) as exc:
        return FileCheck("bad", f"unreadable as Parquet ({' '.join(str(exc).split())[:120]})")
    if rid != path.stem:
        return FileCheck("bad", f"holds run {rid!r}, not {path.stem!r}")
    corrupt = verify_checksum(path)  # before the identity: a flipped byte is damage, not other settings
    if corrupt:
        return FileCheck("bad", corrupt)
    meta = _read_meta(schema)
    if not meta or not isinstance(meta.get("identity"), str):
        return FileCheck("changed", "no recorded run identity (written before identities were recorded)")
    if expected is not None and meta["identity"] != expected["identity"]:
        diff = first_difference(meta.get("inputs"), expected["inputs"]) or "the run identity differs"
        return FileCheck("changed", diff)
    return FileCheck("ok")


def check_timeseries_file(path: Path, identity: str, n_rows: int | None) -> FileCheck:
    """Verify a time-series file: readable, ``n_rows`` samples (None: not checked; the identity fixes the duration
    and log period anyway), its checksum, the run identity in its metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if not Path(path).is_file():
        return FileCheck("missing")
    try:
        pf = pq.ParquetFile(path)
        schema, rows = pf.schema_arrow, pf.metadata.num_rows
    except (*DAMAGED_PARQUET_ERRORS, pa.ArrowException) as exc:
        return FileCheck("bad", f"unreadable as Parquet ({' '.join(str(exc).split())[:120]})")
    if "t_s" not in schema.names:
        return FileCheck("bad", "no t_s column: not a run's time series")
    if n_rows is not None and rows != n_rows:
        return FileCheck("bad", f"{rows} samples, expected {n_rows}")
    corrupt = verify_checksum(path)
    if corrupt:
        return FileCheck("bad", corrupt)
    meta = _read_meta(schema) or {}
    if meta.get("run_identity") != identity:
        return FileCheck("changed", "time series of a run made under other settings")
    return FileCheck("ok")


def write_run_file(out: Path, row: Mapping[str, Any], record: Mapping[str, Any]) -> Path:
    """Write one run's row atomically, its identity record and column units in the schema metadata."""
    meta = {**record, "units": column_units(row)}
    return write_parquet_atomic(pd.DataFrame([dict(row)]), run_path(out, str(row["run_id"])),
                                {"ur5fault": json.dumps(meta, sort_keys=True)}, checksum=True)


def consolidate(out: Path, records: Mapping[str, Mapping[str, Any]],
                relabel: Callable[[pd.DataFrame], pd.DataFrame] | None = None) -> pd.DataFrame:
    """Gather exactly the runs of ``records`` (run_id -> record) into ``OUT/features.parquet``,
    ordered by run_id, each file verified first; stray or duplicate files never leak in.
    ``relabel`` may rewrite label columns (not results) before the table is written, e.g. the
    train/test split when the campaign's split rule changed since the runs were stored."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    frames, bad = [], []
    for rid in sorted(records):
        path = run_path(out, rid)
        check = check_run_file(path, records[rid])
        if check.state == "ok":
            try:
                frames.append(pq.read_table(path).to_pandas())
                continue
            except (*DAMAGED_PARQUET_ERRORS, pa.ArrowException) as exc:
                check = FileCheck("bad", f"unreadable as Parquet ({' '.join(str(exc).split())[:120]})")
        bad.append((rid, f"{check.state}{': ' + check.detail if check.detail else ''}"))
    if bad:
        raise BadRunFilesError(f"{run_path(out, bad[0][0])}: {bad[0][1]}"
                               + (f" (and {len(bad) - 1} more run files)" if len(bad) > 1 else "")
                               + "; run the campaign again to re-simulate it", bad)
    if not frames:
        raise ConfigFileError(f"{out}: the campaign has no runs")
    df = pd.concat(frames, ignore_index=True)
    if relabel is not None:
        df = relabel(df)
    identities = {rid: records[rid]["identity"] for rid in sorted(records)}
    meta = {"units": column_units(df.columns), "campaign_identity": digest(identities),
            "run_identities": identities}
    write_parquet_atomic(df, Path(out) / "features.parquet", {"ur5fault": json.dumps(meta, sort_keys=True)},
                         checksum=True)
    return df


def manifest_damage(out: Path) -> str | None:
    """Why ``OUT/manifest.json`` cannot be trusted (its bytes changed since it was written), else None (also
    when absent, or written before manifests had checksums)."""
    path = Path(out) / "manifest.json"
    return verify_checksum(path) if path.exists() and checksum_path(path).exists() else None


def read_manifest(out: Path) -> tuple[dict[str, Any], str | None]:
    """``(OUT/manifest.json as a mapping, why it cannot be trusted)``: ``({}, why)`` when it fails its checksum
    (:func:`manifest_damage`), ``({}, None)`` when absent or unreadable.  One hash of the file for both."""
    damaged = manifest_damage(out)
    if damaged:
        return {}, damaged
    try:
        m = json.loads((Path(out) / "manifest.json").read_text())
    except (OSError, ValueError):
        return {}, None
    return (m if isinstance(m, dict) else {}), None


#: the consolidated tables a campaign folder holds (:func:`check_table_of_manifest`)
CONSOLIDATED = ("features.parquet", "inspections.parquet")


def check_manifest_fields(path: Path, manifest: Any) -> None:
    """Refuse with one line a fault campaign's manifest (one without its checksum sidecar is read unverified, e.g.
    edited by hand) that lacks what its readers take: a JSON object with a positive ``threshold_mm`` and a list of
    ``swept_keys`` (``CampaignResult``; ``campaign status`` reports it as bad)."""
    if not isinstance(manifest, dict):
        raise ConfigFileError(f"{path}: not a campaign manifest (not a JSON object); {REBUILD_FEATURES}")
    thr = manifest.get("threshold_mm")
    if isinstance(thr, bool) or not isinstance(thr, (int, float)) or not math.isfinite(thr) or thr <= 0:
        raise ConfigFileError(f"{path}: threshold_mm {thr!r} is not a positive number of mm; {REBUILD_FEATURES}")
    keys = manifest.get("swept_keys", [])
    if not (isinstance(keys, list) and all(isinstance(k, str) for k in keys)):
        raise ConfigFileError(f"{path}: swept_keys {keys!r} is not a list of names; {REBUILD_FEATURES}")


def check_table_of_manifest(table: Path, remake: str, manifest: Mapping[str, Any] | None = None) -> None:
    """Refuse (:class:`~ur5fault.util.io.StoredFileError`, naming ``remake``) a campaign folder's consolidated table
    (:data:`CONSOLIDATED`) that is not the result of the campaign its ``manifest.json`` describes.  A rerun
    rewrites the manifest when it starts, so a rerun of a changed campaign that was killed before its end leaves
    the earlier campaign's table beside the new manifest, both sound by their checksums; a table copied in from
    another folder is sound too.  A fault campaign's table records the identity of its runs, the manifest that of
    the campaign's: they must be equal.  A life campaign's table is read only while its manifest says it is
    complete (each invocation writes it ``running`` first: the table beside it may be the earlier fleet's until the
    invocation ends).  Nothing to compare (another file name, no manifest beside the table, no identity or state
    recorded): passes; a manifest that fails its checksum is refused.  ``manifest``: the folder's, when already read and
    verified.  A table without its checksum beside a checksummed manifest is refused (what ``campaign status``
    calls bad)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ..util.io import StoredFileError

    if table.name not in CONSOLIDATED:
        return
    if manifest is None:
        manifest, damaged = read_manifest(table.parent)
        if damaged:
            raise StoredFileError(f"{table.parent / 'manifest.json'}: {damaged}; {remake}")
    if not manifest:
        return
    if checksum_path(table.parent / "manifest.json").exists() and not checksum_path(table).exists():
        # a folder whose manifest is checksummed was written by a ur5fault that checksums its tables: one without
        # is a write cut short or a checksum deleted, as `campaign status` reports it ("bad"), not a sound table
        raise StoredFileError(f"{table}: no checksum recorded beside it (its write was cut short, or the checksum "
                              f"file was deleted), so it cannot be verified; {remake}")
    state = manifest.get("state")
    if manifest.get("kind") == "life":
        if state is not None and state != "complete":  # a manifest recording no state (made by hand): nothing said
            raise StoredFileError(f"{table}: the life campaign in {table.parent} is not complete (its manifest says "
                                  f"{state!r}: a run into the folder is under way or stopped before its end), so "
                                  f"this table may be an earlier fleet's; {remake}")
        return
    try:
        recorded = (_read_meta(pq.read_schema(table)) or {}).get("campaign_identity")
    except (OSError, pa.ArrowException):
        return  # unreadable: the reader's own check names it
    expected = manifest.get("campaign_identity")
    if recorded is None or expected is None or recorded == expected:
        return
    why = ("a rerun of a changed campaign started and has not finished" if state != "complete" else
           "the table was written for another campaign")
    raise StoredFileError(f"{table}: not the result of the campaign {table.parent / 'manifest.json'} describes "
                          f"({why}); {remake}")


def read_consolidated(path: Path) -> tuple[Any, str | None, dict[str, Any] | None]:
    """A consolidated table (``features.parquet``, ``inspections.parquet``) read as a resume would trust it:
    ``(table, recorded campaign identity, None)``, or ``(None, None, state)`` with ``state`` ``{"state":
    "missing"}`` or ``{"state": "bad", "detail": ...}`` when it is absent, fails its checksum or is not Parquet."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    if not path.exists():
        return None, None, {"state": "missing"}
    corrupt = verify_checksum(path)
    if corrupt:
        return None, None, {"state": "bad", "detail": corrupt}
    try:
        table = pq.read_table(path)
    except (*DAMAGED_PARQUET_ERRORS, pa.ArrowException) as exc:
        return None, None, {"state": "bad", "detail": f"unreadable as Parquet ({' '.join(str(exc).split())[:120]})"}
    return table, (_read_meta(table.schema) or {}).get("campaign_identity"), None
