"""How long a log ``identify`` and ``discrepancy`` take: memory grows with the samples replayed, so a
log above :data:`MAX_FIT_SAMPLES` is refused in seconds, before it is read in full, with the length it
has and the length that works (docs/discrepancy.md, "Log length and memory").

The limit is a measured figure, not a guess: peak resident memory of ``ur5fault discrepancy`` (the
larger of the two: ``identify`` peaks at 511 044 KiB on the whole NIST log, ``discrepancy`` at 794 520 KiB;
identify's bandwidth sweep replays a fixed 32 s window) on the 63 s NIST log and on its first 10 s,
``--jobs 1``, grows by
:data:`PEAK_BYTES_PER_SAMPLE` per sample over :data:`PEAK_BYTES_BASE`; the limit keeps that line below
:data:`MEMORY_BOUND_BYTES` (the 3 GB the project promises).  More worker processes split the same
replays between them and each adds its own interpreter (``ur5fault/sim/budget.py``), which the margin
below the bound covers at 2 jobs.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from ..errors import LogFormatError
from .measured import MeasuredLog
from .source import sniff

#: the memory a fit may take at most [bytes] (issue 23's goal: 3 GB)
MEMORY_BOUND_BYTES = 3.0e9
#: measured peak resident memory of ``ur5fault discrepancy LOG --format nist --jobs 1`` [KiB, GNU time's
#: "Maximum resident set size"] on the first 10 s of the NIST log (1250 samples) and on all of it (7905),
#: 2-core x86_64, Python 3.11: 461 640 KiB and 794 520 KiB.  The line through them is an upper bound
#: beyond 63 s: part of its slope is the library screening, which stops growing at 20 s (SCREEN_S).
MEASURED_PEAKS_KIB = ((1250, 461_640), (7905, 794_520))
(_n0, _p0), (_n1, _p1) = MEASURED_PEAKS_KIB
#: peak memory per log sample and at zero length [bytes] (about 51 kB and 0.41 GB)
PEAK_BYTES_PER_SAMPLE = (_p1 - _p0) * 1024 / (_n1 - _n0)
PEAK_BYTES_BASE = _p0 * 1024 - _n0 * PEAK_BYTES_PER_SAMPLE
#: share of the bound the line may reach (the rest: a second worker process's interpreter, 0.3 GB in
#: ur5fault/sim/budget.py, and other logs' shapes)
BOUND_SHARE = 0.8
#: samples a log (or the logs fitted together) may have for identify and discrepancy: 38 876, 311 s at 125 Hz
MAX_FIT_SAMPLES = int((BOUND_SHARE * MEMORY_BOUND_BYTES - PEAK_BYTES_BASE) / PEAK_BYTES_PER_SAMPLE)
#: sample period of a CB2/CB3 controller's log [s] (125 Hz), for lengths in seconds before the log is read
UR_TICK_S = 0.008
#: a CSV's row count is estimated from its first 64 kB; refuse early only beyond this factor of the limit
ESTIMATE_MARGIN = 1.2


def _too_long(names: Sequence[str], rows: float, seconds: float | None, period_s: float | None,
              command: str, simulated: bool = False) -> LogFormatError:
    """The one line that refuses logs of ``rows`` samples together: one log is cut into pieces; several logs
    are too many at once (each may be short: the limit holds for the samples fitted together); ``simulated`` logs
    sampled faster than a UR controller's 125 Hz (``simulate``'s 1 ms) can be written at that rate instead."""
    period = period_s or UR_TICK_S
    length = f" ({seconds:.0f} s)" if seconds else ""
    rate = "at this rate" if period_s else f"at {1 / UR_TICK_S:.0f} Hz"
    limit_s = MAX_FIT_SAMPLES * period
    what = (f"{names[0]}: about {rows:.4g} samples{length}" if len(names) == 1 else
            f"{len(names)} logs ({', '.join(names)})"[:200] + f": about {rows:.4g} samples together{length}")
    fix = (f"cut the log into pieces of at most {limit_s:.0f} s" if len(names) == 1 else
           "give fewer or shorter logs at once (the limit is for all of them together)")
    if simulated and period_s and period_s < 0.9 * UR_TICK_S:
        fix += (f", or log at a UR controller's {1 / UR_TICK_S:.0f} Hz (`ur5fault simulate --log-period-s "
                f"{UR_TICK_S:g}`: {MAX_FIT_SAMPLES * UR_TICK_S:.0f} s)")
    return LogFormatError(
        f"{what}; `ur5fault {command}` takes logs of up to {MAX_FIT_SAMPLES} samples ({limit_s:.0f} s {rate}) "
        f"to stay within {MEMORY_BOUND_BYTES / 1e9:g} GB of memory: {fix}")


def check_files_length(paths: Sequence[str | Path], command: str) -> None:
    """Refuse CSV logs clearly above the limit together, from their first 64 kB each (seconds, not the
    minutes reading an hour-long log takes)."""
    rows = 0
    for path in paths:
        p = Path(path)
        if p.is_file() and p.suffix != ".parquet":  # the reader names a missing file; a simulated log: below
            rows += sniff(p, p.name).rows_estimate
    if rows > ESTIMATE_MARGIN * MAX_FIT_SAMPLES:
        raise _too_long([Path(p).name for p in paths], rows, None, None, command)


def check_logs_length(logs: Sequence[MeasuredLog], command: str) -> None:
    """Refuse logs read in full that have more than :data:`MAX_FIT_SAMPLES` samples together."""
    n = sum(lg.t_s.size for lg in logs)
    if n > MAX_FIT_SAMPLES:
        seconds = sum(float(lg.t_s[-1] - lg.t_s[0]) + lg.period_s for lg in logs)
        raise _too_long([lg.source for lg in logs], n, seconds, logs[0].period_s, command,
                        all(lg.simulated for lg in logs))
