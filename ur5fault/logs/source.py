"""Reading log files defensively: compression, encoding and separator sniffed from the bytes,
a memory estimate before anything is loaded, and chunked reading of the needed columns only.

- Compression: gzip is recognised by its magic bytes (whatever the file name says).
- Encoding: UTF-8, with or without a byte-order mark (Excel and some recorders write one).
- Separator: tab, comma or semicolon when the header holds one, else runs of spaces (UR's own
  RTDE ``record.py`` writes space-separated columns), for plain and compressed files alike.
- Size: the rows a file holds are estimated from its (uncompressed) size and the length of its
  first lines, and the arrays it would need are checked against :data:`MAX_LOG_ARRAY_BYTES` and
  the memory available, before loading; the chunked reader stops past the limit whatever the
  estimate said (a gzip trailer only stores the size modulo 4 GiB).
- Damage: empty, header-only, binary, truncated or corrupt gzip, non-UTF-8, ragged rows and
  non-numeric cells each end in one :class:`~ur5fault.errors.LogFormatError` line.
"""

from __future__ import annotations

import dataclasses
import gzip
import io
import struct
import zlib
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from ..errors import LogFormatError
from ..sim.budget import MEMORY_FRACTION, available_memory_bytes, fmt_bytes

SNIFF_BYTES = 1 << 16
CHUNK_ROWS = 100_000
#: largest arrays one log may load (assumption: 2 GB is 8e6 samples x 34 columns, 18 hours at
#: 125 Hz, far beyond what the discrepancy workflow can simulate; and well inside a laptop's memory)
MAX_LOG_ARRAY_BYTES = 2e9
#: peak memory per loaded float while reading: the chunk pandas parses, its float copy and the
#: final concatenation (assumption, 3 copies of 8 bytes)
BYTES_PER_VALUE = 24
_GZIP_MAGIC = b"\x1f\x8b"
#: the estimate trusts a gzip trailer up to this compression ratio (numeric CSV compresses 3-10x;
#: the NIST log 3.4x); the chunked reader's row limit holds whatever the true size
MAX_GZIP_RATIO = 50


@dataclasses.dataclass(frozen=True)
class CsvLayout:
    """What sniffing found: separator (``None`` for whitespace), column names and size estimates."""

    sep: str | None
    columns: tuple[str, ...]
    compressed: bool
    rows_estimate: int


def _is_gzip(path: Path) -> bool:
    with open(path, "rb") as f:
        return f.read(2) == _GZIP_MAGIC


def _open_binary(path: Path):
    return gzip.open(path, "rb") if _is_gzip(path) else open(path, "rb")


def _damage(src: str, exc: BaseException) -> LogFormatError:
    """One line for whatever a damaged file raised while being decompressed, decoded or parsed."""
    if isinstance(exc, EOFError):
        return LogFormatError(f"{src}: truncated (the compressed stream ends early); copy the file again")
    if isinstance(exc, (gzip.BadGzipFile, zlib.error)):
        return LogFormatError(f"{src}: corrupt gzip data ({exc})")
    if isinstance(exc, UnicodeDecodeError):
        return LogFormatError(f"{src}: not UTF-8 text (byte {exc.start} of a block); is it a CSV log?")
    text = " ".join(str(exc).split())[:160]
    return LogFormatError(f"{src}: cannot read as CSV ({text})")


def _uncompressed_size(path: Path, compressed: bool, sample_len: int) -> int:
    size = path.stat().st_size
    if not compressed:
        return size
    with open(path, "rb") as f:  # gzip trailer: uncompressed size modulo 2**32 (garbage when truncated)
        f.seek(max(0, size - 4))
        isize = struct.unpack("<I", f.read(4).rjust(4, b"\0"))[0]
    return max(min(isize, MAX_GZIP_RATIO * size), sample_len)


#: what a CSV reader says of a Parquet file given for a log (a run of `ur5fault simulate`); a command that reads no
#: simulated run says it in its place (``read_entries.read_log_options``)
PARQUET_HINT = "; a Parquet file: --format sim reads a run of `ur5fault simulate`"


def sniff(path: Path, src: str) -> CsvLayout:
    """Header, separator and row estimate of a CSV log (plain or gzip), from its first 64 kB."""
    try:
        compressed = _is_gzip(path)
        with _open_binary(path) as f:
            sample = f.read(SNIFF_BYTES)
            more = bool(f.read(1))
    except (OSError, EOFError, zlib.error) as exc:
        if isinstance(exc, OSError) and not isinstance(exc, gzip.BadGzipFile):
            raise LogFormatError(f"{src}: cannot read ({exc.strerror or exc})") from None
        raise _damage(src, exc) from None
    nul = sample.find(b"\0")
    if nul >= 0:
        parquet = sample[:4] == b"PAR1"  # e.g. a simulated run written by `ur5fault simulate`
        raise LogFormatError(f"{src}: binary data, not a text log (a NUL byte at offset {nul})"
                             + (PARQUET_HINT if parquet else ""))
    cut = sample if not more else sample[: sample.rfind(b"\n") + 1] or sample
    try:
        text = cut.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise _damage(src, exc) from None
    lines = [ln for ln in text.splitlines() if ln.strip()]
    if not lines:
        raise LogFormatError(f"{src}: empty file (no header, no data)")
    header = lines[0]
    sep = next((s for s in ("\t", ",", ";") if s in header), None)
    columns = tuple(c.strip() for c in (header.split(sep) if sep else header.split()))
    twice = sorted({c for c in columns if c and columns.count(c) > 1})
    if twice:  # a reader would rename the second and then miss a column it needs, or read the wrong one
        raise LogFormatError(f"{src}: column {twice[0]!r} appears {columns.count(twice[0])} times in the header")
    if len(lines) < 2:
        raise LogFormatError(f"{src}: header only, no data rows")
    data = lines[1:]
    bytes_per_row = max(1.0, sum(len(ln) + 1 for ln in data) / len(data))
    rows = int(_uncompressed_size(path, compressed, len(sample)) / bytes_per_row) + 1
    return CsvLayout(sep, columns, compressed, rows)


def check_log_memory(src: str, rows: int, n_columns: int) -> int:
    """Refuse a log whose arrays would not fit; return the largest row count allowed."""
    need = rows * n_columns * BYTES_PER_VALUE
    limit = min(MAX_LOG_ARRAY_BYTES, MEMORY_FRACTION * available_memory_bytes())
    if need > limit:
        raise LogFormatError(f"{src}: about {rows:.3g} rows x {n_columns} columns need about {fmt_bytes(need)} "
                             f"to load, above the limit of {fmt_bytes(limit)}; cut the log into shorter pieces")
    return int(limit / (n_columns * BYTES_PER_VALUE))


def read_columns(path: Path, src: str, layout: CsvLayout, columns: Sequence[str]) -> dict[str, NDArray]:
    """Stream ``columns`` of a CSV log into float arrays (chunked; bounded by the memory limit)."""
    max_rows = check_log_memory(src, layout.rows_estimate, len(columns))
    parts: dict[str, list[NDArray]] = {c: [] for c in columns}
    n = 0
    sep_kw = {"sep": layout.sep} if layout.sep else {"sep": r"\s+"}
    try:
        with _open_binary(path) as raw:
            text = _FieldCountCheck(io.TextIOWrapper(raw, encoding="utf-8-sig"), layout.sep, len(layout.columns), src)
            reader = pd.read_csv(text, usecols=list(columns), chunksize=CHUNK_ROWS, skipinitialspace=True,
                                 engine="c", dtype=str, keep_default_na=False, **sep_kw)
            for chunk in reader:
                for c in columns:
                    parts[c].append(_to_float(chunk[c].to_numpy(), c, n, src))
                n += len(chunk)
                if n > max_rows:
                    raise LogFormatError(f"{src}: more than {max_rows} rows, above the memory limit of "
                                         f"{fmt_bytes(max_rows * len(columns) * BYTES_PER_VALUE)}; cut the log")
    except LogFormatError:
        raise
    except (OSError, EOFError, zlib.error, UnicodeDecodeError, ValueError, pd.errors.ParserError) as exc:
        raise _damage(src, exc) from None
    if n == 0:
        raise LogFormatError(f"{src}: header only, no data rows")
    return {c: np.concatenate(parts[c]) for c in columns}


class _FieldCountCheck:
    """A text stream for pandas that refuses a line with more or fewer fields than the header
    (pandas, reading selected columns, would silently drop extra fields of a ragged line)."""

    def __init__(self, text: io.TextIOBase, sep: str | None, n_fields: int, src: str) -> None:
        self._text, self._sep, self._n, self._src = text, sep, n_fields, src
        self._line = 0

    def read(self, size: int = -1) -> str:
        lines = self._text.readlines(size if size and size > 0 else -1)
        for ln in lines:
            self._line += 1
            if not ln.strip():
                continue
            n = ln.count(self._sep) + 1 if self._sep else len(ln.split())
            if n != self._n:
                raise LogFormatError(f"{self._src}: line {self._line} has {n} fields, the header {self._n}")
        return "".join(lines)

    def __iter__(self):  # pandas checks for a file-like object by these attributes
        return self

    def __next__(self) -> str:
        line = self.read(1)
        if not line:
            raise StopIteration
        return line


def _to_float(cells: NDArray, column: str, row0: int, src: str) -> NDArray:
    """Float values of one column chunk; an empty cell or ``nan`` is NaN (caught later as missing
    data), any other non-numeric cell is named with its row."""
    values = pd.to_numeric(pd.Series(cells), errors="coerce").to_numpy(float)
    bad = np.isnan(values)
    if bad.any():
        text = pd.Series(cells[bad]).str.strip().str.lower()
        wrong = ~text.isin(["", "nan", "na", "null", "-nan", "+nan"]).to_numpy()
        if wrong.any():
            k = int(np.flatnonzero(bad)[np.argmax(wrong)])
            raise LogFormatError(f"{src}: non-numeric value {str(cells[k])[:40]!r} in column {column!r} "
                                 f"at data row {row0 + k + 1}")
    return values
