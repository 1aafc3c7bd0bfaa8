"""Stored results are verified on read and no failed write leaves a damaged or half-written file: the shared
helpers of ``ur5fault/util/io.py`` (checksummed writes, :func:`check_stored`, the temporary-file sweep), each
case against a file changed by hand here, never against a value the code under test computed."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ur5fault.util import io


def _flip(path: Path, at: int) -> None:
    b = bytearray(path.read_bytes())
    b[at] ^= 0x01
    path.write_bytes(bytes(b))


def test_a_checksummed_json_matches_sha256sum_and_a_changed_digit_is_refused_naming_the_file(tmp_path):
    p = io.write_json_atomic(tmp_path / "m.json", {"threshold_mm": 1.25}, checksum=True)
    # the sidecar is sha256sum's format, of the bytes on disk (hashed here independently)
    assert io.checksum_path(p).read_text() == f"{hashlib.sha256(p.read_bytes()).hexdigest()}  m.json\n"
    assert io.read_json_stored(p, "run X again") == {"threshold_mm": 1.25}
    text = p.read_text()
    p.write_text(text.replace("1.25", "1.75"))  # still valid JSON: read silently before the check
    assert json.loads(p.read_text())["threshold_mm"] == 1.75
    with pytest.raises(io.StoredFileError) as e:
        io.read_json_stored(p, "run X again")
    msg = str(e.value)
    assert msg.startswith(f"{p}: ") and "checksum" in msg and msg.endswith("; run X again") and "\n" not in msg


def test_a_file_without_sidecar_passes_and_a_sidecar_without_its_file_is_refused(tmp_path):
    p = tmp_path / "old.json"
    p.write_text('{"a": 1}')  # an older ur5fault's file, or a user's own: nothing recorded to verify against
    assert io.read_json_stored(p, "r") == {"a": 1}
    q = io.write_json_atomic(tmp_path / "q.json", {"a": 1}, checksum=True)
    q.unlink()
    with pytest.raises(io.StoredFileError, match="unreadable"):
        io.check_stored(q, "r")


def test_a_changed_byte_in_a_parquet_table_changes_values_silently_unless_checked(tmp_path):
    """The reason for the check: some single-bit flips leave a readable table with other numbers."""
    df = pd.DataFrame({"run_id": [f"r{i}" for i in range(8)], "x": np.linspace(0.0, 1.0, 8)})
    p = io.write_parquet_atomic(df, tmp_path / "features.parquet", checksum=True)
    good = p.read_bytes()
    silent = None
    for at in range(4, len(good) - 8):
        p.write_bytes(good)
        _flip(p, at)
        try:
            back = pd.read_parquet(p)
        except Exception:  # noqa: BLE001 - a flip that breaks the file is not the silent case sought
            continue
        if back.shape == df.shape and not back.equals(df):
            silent = at
            break
    assert silent is not None, "no single-bit flip read back silently (the premise of the check)"
    with pytest.raises(io.StoredFileError, match="features.parquet: its bytes differ"):
        io.read_parquet_stored(p, "rebuild it")
    p.write_bytes(good)
    pd.testing.assert_frame_equal(io.read_parquet_stored(p, "rebuild it"), df)


def test_no_space_left_mid_write_leaves_the_old_file_its_sidecar_and_no_temporary(tmp_path, monkeypatch):
    p = io.write_json_atomic(tmp_path / "b.json", {"v": 1}, checksum=True)
    before = (p.read_bytes(), io.checksum_path(p).read_bytes())

    def full(self, data, *a, **k):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(io.OutputError, match="b.json: cannot write .No space left on device"):
        io.write_json_atomic(p, {"v": 2}, checksum=True)
    monkeypatch.undo()
    assert (p.read_bytes(), io.checksum_path(p).read_bytes()) == before
    assert io.read_json_stored(p, "r") == {"v": 1}
    assert sorted(x.name for x in tmp_path.iterdir()) == ["b.json", "b.json.sha256"]


def test_no_space_left_for_the_sidecar_keeps_the_pair_consistent(tmp_path, monkeypatch):
    """The data written, the sidecar's own write fails: neither is renamed into place."""
    df = pd.DataFrame({"x": [1.0, 2.0]})
    p = io.write_parquet_atomic(df, tmp_path / "t.parquet", checksum=True)
    real = io.write_text_atomic

    def full(path, text):
        raise io.OutputError(f"{path}: cannot write (No space left on device)")

    monkeypatch.setattr(io, "write_text_atomic", full)
    with pytest.raises(io.OutputError):
        io.write_parquet_atomic(pd.DataFrame({"x": [3.0]}), p, checksum=True)
    monkeypatch.setattr(io, "write_text_atomic", real)
    pd.testing.assert_frame_equal(io.read_parquet_stored(p, "r"), df)
    assert not list(tmp_path.glob(io.TEMP_GLOB))


def test_the_data_and_the_folder_are_flushed_before_and_after_the_rename(tmp_path, monkeypatch):
    synced = []
    real = os.fsync

    def spy(fd):
        synced.append(os.readlink(f"/proc/self/fd/{fd}"))
        return real(fd)

    monkeypatch.setattr(io.os, "fsync", spy)
    p = io.write_text_atomic(tmp_path / "a.txt", "x")
    assert len(synced) == 2 and Path(synced[0]).name.startswith(".a.txt.") and synced[1] == str(tmp_path)
    assert p.read_text() == "x"


def test_temporaries_of_a_killed_writer_are_swept_old_ones_only_unless_locked(tmp_path):
    old, young, other = tmp_path / ".f.json.abc.tmp", tmp_path / ".g.json.def.tmp", tmp_path / "keep.tmp"
    for f in (old, young, other):
        f.write_text("partial")
    t = time.time() - 2 * io.STALE_TEMP_S
    os.utime(old, (t, t))
    assert io.remove_stale_temporaries(tmp_path) == [old]
    assert young.exists() and other.exists()
    assert io.remove_stale_temporaries(tmp_path, 0) == [young]  # the caller holds the folder's lock
    assert other.exists()  # not a name ur5fault's writer makes
    assert io.remove_stale_temporaries(tmp_path / "absent") == []


def test_a_replaced_results_figures_that_the_new_one_did_not_draw_are_removed(tmp_path):
    """With --replace, an earlier result's residual_*.png of a signal the new result has not must not stay beside
    the new report; the new figures and files of other names stay."""
    from ur5fault.util.io import remove_unwritten

    for name in ("residual_current_A.png", "residual_position_rad.png", "notes.png", "report.md"):
        (tmp_path / name).write_text("earlier")
    written = [tmp_path / "residual_current_A.png"]
    removed = remove_unwritten(tmp_path, "residual_*.png", written)
    assert removed == [tmp_path / "residual_position_rad.png"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.png", "report.md", "residual_current_A.png"]
