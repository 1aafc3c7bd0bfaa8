"""Atomic file writers: every output is written to a temporary file in the target folder and
renamed over the target, so a crash never leaves a half-written file.  Files are made readable
by the group and others (0644), as ordinary tools would write them.

A file written with ``checksum=True`` gets a sidecar ``<name>.sha256`` in ``sha256sum`` format,
computed from the bytes on disk before the file is renamed into place (so ``sha256sum -c``
checks it too); :func:`verify_checksum` detects any changed byte, where Parquet's own page
checksums (off by default, and not covering the footer) would not.  The sidecar is written first:
a crash between the two renames leaves a file whose checksum does not match, which readers treat
as bad, never as sound.  :func:`check_stored` is the check every reader of a stored result makes
before using it: one line naming the file and the command that writes it again.

The temporary file is flushed to disk (``fsync``) before it is renamed, and the folder after, so that
a power cut cannot leave a renamed but empty file (the rename reaching the disk before the data).
A process killed mid-write leaves only a temporary ``.<name>.<random>.tmp`` beside the target,
never a damaged target; :func:`remove_stale_temporaries` clears them."""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from ..errors import Ur5FaultError

FILE_MODE = 0o644
CHECKSUM_SUFFIX = ".sha256"
#: glob of the temporary files :func:`_atomic` writes (``tempfile.mkstemp(prefix=".<name>.", suffix=".tmp")``)
TEMP_GLOB = ".*.tmp"
#: age [s] past which a temporary file in a folder no lock protects is taken as left by a killed writer (an
#: assumption: no single file ur5fault writes takes an hour; a younger one may belong to a running process)
STALE_TEMP_S = 3600.0


class OutputError(Ur5FaultError, OSError):
    """An output file or folder cannot be written (also an :class:`OSError`)."""


class StoredFileError(Ur5FaultError, ValueError):
    """A stored result fails its checksum (changed on disk since it was written) or cannot be read back."""


def check_writable(path: str | Path, *, folder: bool = False) -> Path:
    """Fail before any work when ``path`` (a file, or a ``folder``) cannot be written.

    Nothing is created: the nearest existing ancestor must be a folder in which a probe file can
    be made (and removed again), and an existing ``path`` must be of the right kind.
    """
    path = Path(path)
    if path.exists() and folder and not path.is_dir():
        raise OutputError(f"{path}: exists and is not a folder; choose another output folder")
    if path.exists() and not folder and path.is_dir():
        raise OutputError(f"{path}: is a folder; give a file name for the output")
    probe = path if folder else path.parent
    probe = probe.absolute()
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{path}: cannot be created, {probe} is a file and not a folder")
    try:
        fd, tmp = tempfile.mkstemp(prefix=".ur5fault-probe-", dir=probe)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write in {probe} ({exc.strerror or exc})") from None
    return path


def checksum_path(path: str | Path) -> Path:
    """The sidecar holding ``path``'s SHA-256."""
    path = Path(path)
    return path.with_name(path.name + CHECKSUM_SUFFIX)


def file_sha256(path: str | Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def verify_checksum(path: str | Path) -> str | None:
    """None when ``path`` matches the SHA-256 recorded when it was written, else why not."""
    try:
        recorded = checksum_path(path).read_text().split()
    except FileNotFoundError:
        return "no checksum recorded (written before checksums were, or its write was interrupted)"
    except (OSError, UnicodeDecodeError) as exc:
        return f"its checksum file is unreadable ({getattr(exc, 'strerror', None) or exc})"
    try:
        actual = file_sha256(path)
    except OSError as exc:
        return f"unreadable ({exc.strerror or exc})"
    if not recorded or len(recorded[0]) != 64:
        return f"its checksum file {checksum_path(path).name} holds no SHA-256 (damaged, or its write was interrupted)"
    if recorded[0] != actual:
        return "its bytes differ from the checksum recorded when it was written (corrupted on disk)"
    return None


def check_stored(path: str | Path, remake: str) -> Path:
    """``path`` when its bytes match the SHA-256 sidecar written with it; else :class:`StoredFileError` naming
    the file and ``remake`` (what to run to write it again).  A file without a sidecar (written by an older
    ur5fault, or not by ur5fault) passes unverified: a changed byte cannot remove a sidecar."""
    path = Path(path)
    if not checksum_path(path).exists():
        return path
    why = verify_checksum(path)
    if why:
        raise StoredFileError(f"{path}: {why}; {remake}")
    return path


def read_json_stored(path: str | Path, remake: str) -> Any:
    """A JSON file checked by :func:`check_stored`, with one-line errors naming the file and ``remake``."""
    path = Path(path)
    check_stored(path, remake)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise StoredFileError(f"{path}: no such file; {remake}") from None
    except (OSError, ValueError) as exc:  # UnicodeDecodeError is a ValueError
        raise StoredFileError(f"{path}: unreadable as JSON ({' '.join(str(exc).split())[:120]}); {remake}") from None


#: what reading a damaged Parquet file raises besides pyarrow's own errors: IndexError, KeyError, UnicodeDecodeError,
#: OverflowError... from values a flipped byte made absurd (found by flipping every byte of a run file,
#: tests/campaign/test_integrity.py)
DAMAGED_PARQUET_ERRORS = (OSError, ValueError, LookupError, ArithmeticError, TypeError)


def read_parquet_stored(path: str | Path, remake: str) -> pd.DataFrame:
    """A Parquet table checked by :func:`check_stored`, with one-line errors naming the file and ``remake``."""
    import pyarrow as pa

    path = Path(path)
    if not path.is_file():
        raise StoredFileError(f"{path}: no such file; {remake}")
    check_stored(path, remake)
    try:
        return pd.read_parquet(path)
    except (*DAMAGED_PARQUET_ERRORS, pa.ArrowException) as exc:
        raise StoredFileError(f"{path}: unreadable as Parquet ({' '.join(str(exc).split())[:120]}); "
                              f"{remake}") from None


def remove_stale_temporaries(folder: str | Path, older_than_s: float = STALE_TEMP_S) -> list[Path]:
    """Remove the temporary files (:data:`TEMP_GLOB`) of writers killed mid-write from ``folder`` (not its
    subfolders): all of them (``older_than_s=0``) when the caller holds the folder's lock, else those older
    than ``older_than_s``, which no running writer can own.  Returns the files removed."""
    folder = Path(folder)
    removed = []
    if not folder.is_dir():
        return removed
    now = time.time()
    for p in folder.glob(TEMP_GLOB):
        try:
            if older_than_s <= 0 or now - p.stat().st_mtime > older_than_s:
                p.unlink()
                removed.append(p)
        except OSError:  # gone meanwhile, or a read-only folder: nothing to clear, nothing to fail over
            pass
    return removed


def remove_unwritten(folder: str | Path, pattern: str, written: list[Path]) -> list[Path]:
    """Remove the files of ``folder`` matching the glob ``pattern`` that are not in ``written``: the figures of an
    earlier result (``--replace``) that this one did not draw, so no figure beside a report belongs to another
    result.  Called once the new ones are written.  Returns the files removed."""
    keep = {Path(p).resolve() for p in written}
    removed = []
    for path in sorted(Path(folder).glob(pattern)):
        if path.resolve() not in keep and path.is_file():
            path.unlink(missing_ok=True)
            removed.append(path)
    return removed


def _fsync(path: str | Path, folder: bool = False) -> None:
    """Flush ``path`` (a file, or a ``folder``'s entries) to disk; a folder that cannot be flushed (some file
    systems refuse it) is left as it is."""
    try:
        fd = os.open(path, os.O_RDONLY | (os.O_DIRECTORY if folder else 0))
    except OSError:
        if folder:
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not folder:
            raise
    finally:
        os.close(fd)


def _atomic(path: str | Path, write: Callable[[str], None], checksum: bool = False) -> Path:
    """Call ``write(tmp_path)`` and rename the temporary file over ``path`` (its SHA-256 sidecar first
    when ``checksum``)."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
        os.close(fd)
    except OSError as exc:
        raise OutputError(f"{path}: cannot write ({exc.strerror or exc})") from None
    try:
        write(tmp)
        os.chmod(tmp, FILE_MODE)
        _fsync(tmp)
        if checksum:
            write_text_atomic(checksum_path(path), f"{file_sha256(tmp)}  {path.name}\n")
        os.replace(tmp, path)
        _fsync(path.parent, folder=True)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and not isinstance(exc, Ur5FaultError):
            raise OutputError(f"{path}: cannot write ({exc.strerror or exc})") from None
        raise
    return path


def write_parquet_atomic(df: pd.DataFrame, path: str | Path, metadata: Mapping[str, str] | None = None,
                         checksum: bool = False) -> Path:
    """Write ``df`` to Parquet atomically, ``metadata`` added to the file's schema metadata, with a
    SHA-256 sidecar when ``checksum``."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pa.Table.from_pandas(df, preserve_index=False)
    if metadata:
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), **metadata})
    return _atomic(path, lambda tmp: pq.write_table(table, tmp), checksum)


def write_csv_atomic(df: pd.DataFrame, path: str | Path) -> Path:
    """Write ``df`` to CSV (no index) atomically."""
    return _atomic(path, lambda tmp: df.to_csv(tmp, index=False))


def write_text_atomic(path: str | Path, text: str) -> Path:
    """Write ``text`` atomically."""
    return _atomic(path, lambda tmp: Path(tmp).write_text(text))


def write_bytes_atomic(path: str | Path, data: bytes, checksum: bool = False) -> Path:
    """Write ``data`` atomically, with a SHA-256 sidecar when ``checksum``."""
    return _atomic(path, lambda tmp: Path(tmp).write_bytes(data), checksum)


def finite_json(data: Any) -> Any:
    """``data`` with every non-finite number (NaN, inf: "no value") as ``None`` and numpy values as Python's, so that
    ``json.dumps(..., allow_nan=False)`` writes JSON every parser reads (a bare ``NaN`` is Python's extension;
    JavaScript's ``JSON.parse`` refuses it)."""
    if isinstance(data, Mapping):
        return {k: finite_json(v) for k, v in data.items()}
    if isinstance(data, (list, tuple)):
        return [finite_json(v) for v in data]
    if hasattr(data, "tolist") and not isinstance(data, (str, bytes)):  # numpy arrays and scalars
        return finite_json(data.tolist())
    if isinstance(data, float) and not math.isfinite(data):
        return None
    return data


def json_text(data: Any, indent: int | None = 2) -> str:
    """``data`` as strict JSON text (:func:`finite_json`: no value is ``null``, never ``NaN``)."""
    return json.dumps(finite_json(data), indent=indent, allow_nan=False, default=str)


def json_float(value: Any) -> float:
    """A number read back from a file :func:`write_json_atomic` wrote: ``null`` (no value, :func:`finite_json`)
    as NaN, anything else through ``float``."""
    return math.nan if value is None else float(value)


def write_json_atomic(path: str | Path, data: Mapping[str, Any], checksum: bool = False, *,
                      strict: bool = True) -> Path:
    """Write ``data`` as indented JSON atomically, with a SHA-256 sidecar when ``checksum``.

    ``strict`` (the default): every non-finite number as ``null`` (:func:`json_text`), so that every JSON parser
    reads the file (JavaScript's ``JSON.parse``, ``jq``; a bare ``NaN`` is Python's extension); its readers take
    ``null`` back as NaN (:func:`json_float`).  ``strict=False`` keeps Python's ``NaN`` / ``Infinity`` for a
    file only ur5fault reads where an infinite value means something other than none."""
    text = json_text(data) if strict else json.dumps(data, indent=2, default=str)
    return _atomic(path, lambda tmp: Path(tmp).write_text(text), checksum)


#: resolution of every PNG figure ur5fault writes [dots per inch]
FIGURE_DPI = 110


def write_figure_atomic(fig: Any, path: str | Path, dpi: float = FIGURE_DPI) -> Path:
    """A matplotlib figure as PNG at ``path`` (no backend needed: ``Figure.savefig``)."""
    return _atomic(path, lambda tmp: fig.savefig(tmp, dpi=dpi, format="png"))
