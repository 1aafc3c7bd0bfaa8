"""Logs as robots write them: optional columns that end early, and rows missing from the time base.

*Optional columns with NaN at the ends.* A recorder that merges signal groups (the Kufieta runs of
``data/kufieta-ur5``) leaves optional columns a few rows shorter than the positions and currents. A
group of optional columns whose missing values sit only at the start and end of the log is kept, and
the log is cut to the rows where it is finite, if that costs at most :data:`MAX_CUT_S` seconds;
otherwise (or where values are missing in the middle) the group is not used. Each case is a note.

*Temperatures of exactly 0.* A recorder that fills a signal it did not record writes 0: joint temperatures of
exactly 0.0 degC on every joint in every row are taken as not recorded (a note; the model's temperature is then
assumed, as for a log without them): a real joint never reads exactly 0.0 on all six joints for a whole log, and
fitted as 0 degC they gave ``identify`` a viscous friction 39-43 % low. Any other value, anywhere, keeps them.

*Missing rows.* A UR controller samples on a fixed tick (8 ms on CB2/CB3); host time stamps jitter
around it by a fraction of a millisecond, and a recorder that drops rows leaves gaps of whole ticks
(Movement_No1-No3: every other step is 24 ms). The replay drives the model with the log's setpoints
on a uniform grid, so the log is put on the tick grid: each row goes to its nearest tick, the
setpoints of a missing tick are interpolated linearly between its neighbours (the setpoints are
smooth: at the 3.2 rad/s^2 of the fastest run the interpolation error over 24 ms is 2e-4 rad), and
so are the readings, which the replay needs at every tick; ``MeasuredLog.logged`` marks the ticks the
robot really wrote, and every RMS figure the workflows report counts only those.

*Values missing in required columns.* A row whose target position, position reading or current holds NaN or inf
is a tick the recorder lost a value of: up to as many rows in a row as a gap may miss
(:data:`.plausible.MAX_GAP_TICKS`) are dropped and so read as missing ticks, with a note
(:func:`unreadable_rows`); a longer stretch is refused in one line that names its column and rows and where to cut.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError

if TYPE_CHECKING:
    from .plausible import MinLength

#: longest stretch [s] cut from the start or end of a log so that an optional column group is complete
#: (1 s: the replay's own start-up transient is of that order, and it stays a small share of a 5 s log)
MAX_CUT_S = 1.0
#: UR controller ticks [s]: 125 Hz (CB2, CB3) and 500 Hz (e-Series)
CONTROLLER_TICKS_S = (0.008, 0.002)
#: a log whose mean tick is within this share of a controller tick was sampled on it (its own clock ran
#: at a slightly different rate: Movement_No1-No3 of data/kufieta-ur5 give 8.026-8.028 ms, 0.35 %)
MAX_CLOCK_RATE_DIFF = 0.01
#: otherwise the tick is the mean step rounded to this resolution [s]
TICK_RESOLUTION_S = 1e-5
#: a row lies on its tick when within this share of a period of it, counted on the log's own mean tick
#: (measured on the Kufieta runs: jitter and clock wander up to 2.1 ms of 8 ms)
MAX_JITTER_PERIODS = 0.4


def finite_span(arr: NDArray) -> tuple[int, int] | None:
    """``(first, stop)`` of the rows where every value of ``arr`` ``(n, k)`` is finite, when the missing rows
    are all at the ends; ``None`` when a value is missing between finite rows."""
    ok = np.all(np.isfinite(arr), axis=1)
    if ok.all():
        return 0, ok.size
    idx = np.flatnonzero(ok)
    if idx.size == 0 or not ok[idx[0]: idx[-1] + 1].all():
        return None
    return int(idx[0]), int(idx[-1]) + 1


def unreadable_rows(src: str, t: NDArray, required: Mapping[str, NDArray],
                    columns: Mapping[str, Sequence[str]] | None, max_ticks: int, length: MinLength,
                    notes: list[str]) -> tuple[slice, dict[str, NDArray], NDArray | None]:
    """Rows whose required value (a target, a reading, a current) is NaN or inf: a tick the recorder lost a value of.

    Returns the rows to keep (all but such rows at the end, within :data:`MAX_CUT_S`), the required arrays
    (name -> ``(n, k)``) with each missing value interpolated in time from its column's finite rows, and the mask of
    rows that had one (``None``: every value finite). The rows stay where they are (every row number said later is
    the file's, and the tick grid is the file's); :func:`on_ticks` marks them not logged. Refused in one line: a
    column with no value; a stretch of such rows that, with the ticks missing beside it, leaves more than
    ``max_ticks`` ticks in a row without a whole reading (as a gap of missing rows alone may not,
    :func:`.plausible.check_sampling`); such rows at the start (the replay starts from the first row), or at the end
    over more than :data:`MAX_CUT_S`, the message naming the rows to cut to where they are long enough
    (:func:`keep_rows`). ``columns``: name -> the file's column of each array column; ``length``: the least a log
    must cover (the parts a refusal advises to keep, :func:`keep_rows`, :func:`cut_in_two`). ``t`` increasing (else
    the interpolation is meaningless and the log refused after)."""
    labels = {k: list((columns or {}).get(k) or [f"{k}_{j}" for j in range(a.shape[1])]) for k, a in required.items()}
    missing = {k: ~np.isfinite(a) for k, a in required.items()}
    bad = np.any([m.any(axis=1) for m in missing.values()], axis=0)
    if not bad.any():
        return slice(0, t.size), dict(required), None
    for k, m in missing.items():
        for j in np.flatnonzero(m.all(axis=0)):
            raise LogFormatError(f"{src}: NaN or inf in {labels[k][j]} at data row 1 (every row)")

    def named(rows: slice) -> str:
        cols = [labels[k][j] for k, m in missing.items() for j in np.flatnonzero(m[rows].any(axis=0))]
        return ", ".join(cols[:3]) + (f" and {len(cols) - 3} more" if len(cols) > 3 else "")

    ok = np.flatnonzero(~bad)
    if ok.size == 0:  # every row lacks a value, in one column or another
        raise LogFormatError(f"{src}: NaN or inf in every data row (in {named(slice(None))}): no row holds a whole "
                             "reading")
    first, last = int(ok[0]), int(ok[-1])
    long_tail = t[-1] - t[last] > MAX_CUT_S
    if first > 0:  # the rest up to the tail, when that is not cut by itself
        raise LogFormatError(f"{src}: NaN or inf in {named(slice(0, first))} in data rows 1..{first}, the log's "
                             f"first: the replay starts from the first row's state; "
                             + keep_rows(t, first + 1, last + 1 if long_tail else t.size, length))
    if long_tail:
        raise LogFormatError(f"{src}: NaN or inf in {named(slice(last + 1, None))} in data rows {last + 2}..{t.size}, "
                             f"the log's last {t[-1] - t[last]:.3g} s (more than the {MAX_CUT_S:g} s cut by itself); "
                             + keep_rows(t, 1, last + 1, length))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], bad.astype(np.int8), [0]])))
    stretches = [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2]) if b <= last]  # the trailing one is cut
    tick = ticks(t)[0]
    for a, b in stretches:
        gap = int(tick[b] - tick[a - 1] - 1)  # the ticks between the readable rows around it
        if gap > max_ticks:
            beside = " (with the ticks missing beside them)" if gap > b - a else ""
            raise LogFormatError(f"{src}: NaN or inf in {named(slice(a, b))} in data rows {a + 1}..{b}: {gap} ticks in "
                                 f"a row without a whole reading{beside}, more than the {max_ticks} interpolated; "
                                 + cut_in_two(t, a, b + 1, length))
    keep = slice(0, last + 1)
    filled = {}
    for name, arr in required.items():
        arr = arr.copy()
        for j in np.flatnonzero(missing[name][keep].any(axis=0)):
            fin = np.isfinite(arr[keep, j])
            arr[keep, j] = np.interp(t[keep], t[keep][fin], arr[keep, j][fin])
        filled[name] = arr
    inside = bad[keep]
    if last + 1 < t.size:
        notes.append(f"{src}: NaN or inf in {named(slice(last + 1, None))} in the last {t.size - last - 1} data "
                     f"row(s); the log cut to rows 1..{last + 1}")
    if stretches:
        notes.append(f"{src}: {int(inside.sum())} data row(s) with NaN or inf in {named(keep)} (from data row "
                     f"{stretches[0][0] + 1}; at most {max(b - a for a, b in stretches)} in a row): values "
                     "interpolated for the replay, those ticks left out of every RMS figure")
    return keep, filled, inside if stretches else None


def _cover(t: NDArray, part: tuple[int, int], length: MinLength) -> tuple[float, bool]:
    """The span [s] of data rows ``part`` (1-based, both included) of a log of times ``t``, and whether that part is
    at least ``length`` long (:meth:`.plausible.MinLength.covered_by`, as :func:`.plausible.check_sampling` counts it,
    on the whole log's median period)."""
    period = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    cover = float(t[part[1] - 1] - t[part[0] - 1])
    return cover, length.covered_by(cover, part[1] - part[0] + 1, period)


def keep_rows(t: NDArray, lo: int, hi: int, length: MinLength) -> str:
    """The advice for a log of times ``t`` of which only data rows ``lo``..``hi`` (1-based, both included) can be used:
    to cut it to them where they are at least ``length`` long, else that no usable part remains (and why)."""
    cover, usable = _cover(t, (lo, hi), length)
    if usable:
        return f"cut the log to data rows {lo}..{hi}"
    return (f"the rest, data rows {lo}..{hi}, covers {cover:.3g} s in {hi - lo + 1} samples, too short to use "
            f"({length.why}): no usable part remains")


def cut_in_two(t: NDArray, a: int, b: int, length: MinLength, where: str = "there") -> str:
    """The advice for a log of times ``t`` with a stretch it cannot use between data rows ``a`` and ``b`` (1-based, the
    last row before it and the first after it): the parts to keep, those at least ``length`` long (:func:`_cover`); a
    part too short is named as such, to drop, and where neither is long enough that is said instead.  Both long
    enough: two logs the command takes together, or, for a command that reads one log (``length.one_log``:
    ``diagnose``), the longer part to keep, the other named as a log of its own."""
    parts = [(1, a), (b, t.size)]
    covered = {p: _cover(t, p, length) for p in parts}
    cover = {p: c for p, (c, _) in covered.items()}
    usable = [p for p in parts if covered[p][1]]

    def rows(p: tuple[int, int]) -> str:
        return f"{p[0]}..{p[1]}"

    if len(usable) == 2 and length.one_log:
        keep = max(parts, key=lambda p: cover[p])
        return (f"keep data rows {rows(keep)} (cut the log {where}), the longer part; data rows "
                f"{rows(parts[1 - parts.index(keep)])} are long enough to be read as a log of their own too")
    if len(usable) == 2:
        return (f"cut the log {where} into two logs (data rows {rows(parts[0])} and {rows(parts[1])}), which identify, "
                "discrepancy and monitor take together as logs of one robot")
    if usable:
        short = parts[1 - parts.index(usable[0])]
        return (f"keep data rows {rows(usable[0])} (cut the log {where}): data rows {rows(short)} cover "
                f"{cover[short]:.3g} s in {short[1] - short[0] + 1} samples, too short to use ({length.why})")
    return (f"neither side of it is long enough to use as a log of its own: data rows {rows(parts[0])} cover "
            f"{cover[parts[0]]:.3g} s and {rows(parts[1])} {cover[parts[1]]:.3g} s ({length.why})")


def complete_optional(src: str, t: NDArray, groups: Mapping[str, NDArray | None],
                      notes: list[str]) -> tuple[slice, dict[str, NDArray | None]]:
    """Rows to keep and the optional groups to use (see the module docstring); adds a note per group cut or
    dropped. ``groups``: name -> ``(n, k)`` array or ``None`` (absent)."""
    lo, hi = 0, t.size
    spans: dict[str, tuple[int, int] | None] = {}
    used: dict[str, NDArray | None] = {}
    for name, arr in groups.items():
        if arr is None:
            used[name] = None
            continue
        span = finite_span(arr)
        if span is not None and (t[span[0]] - t[0] > MAX_CUT_S or t[-1] - t[span[1] - 1] > MAX_CUT_S):
            span = None
        spans[name] = span
        if span is None:
            bad = int(np.flatnonzero(~np.all(np.isfinite(arr), axis=1))[0])
            notes.append(f"{src}: {name} missing from data row {bad + 1} on (not only within {MAX_CUT_S:g} s of "
                         "the ends); not used")
            used[name] = None
        else:
            used[name] = arr
            lo, hi = max(lo, span[0]), min(hi, span[1])
    cut = [name for name, s in spans.items() if s is not None and (s[0] > 0 or s[1] < t.size)]
    if cut:
        notes.append(f"{src}: {', '.join(cut)} end early (NaN there); the log cut to rows {lo + 1}..{hi} of "
                     f"{t.size} ({t[hi - 1] - t[lo]:.2f} s kept)")
    return slice(lo, hi), used


def unrecorded_temperature(src: str, temperature: NDArray | None, notes: list[str]) -> NDArray | None:
    """``temperature`` ``(n, 6)``, or ``None`` with a note where it reads exactly 0 degC on every joint in every row
    (a recorder's fill: see the module docstring)."""
    if temperature is None or temperature.size == 0 or np.any(temperature != 0.0):
        return temperature
    notes.append(f"{src}: the joint temperatures read exactly 0 degC on every joint in every row, as a recorder "
                 "fills a signal it did not record: taken as not recorded")
    return None


def ticks(t: NDArray) -> tuple[NDArray, float]:
    """Tick index of each row of increasing times ``t`` (steps counted in whole ticks of the shortest common
    step) and the mean tick [s] on the log's own clock."""
    dt = np.diff(t)
    p0 = float(np.median(dt[dt <= 1.5 * np.median(dt)]))
    k = np.concatenate([[0], np.cumsum(np.maximum(1, np.round(dt / p0)))]).astype(np.int64)
    return k, float((t[-1] - t[0]) / k[-1])


def controller_tick(mean_tick_s: float) -> float:
    """The controller's tick for a log whose mean tick is ``mean_tick_s``: a known UR tick within
    :data:`MAX_CLOCK_RATE_DIFF`, else the mean rounded to :data:`TICK_RESOLUTION_S`."""
    for tick in CONTROLLER_TICKS_S:
        if abs(mean_tick_s / tick - 1.0) <= MAX_CLOCK_RATE_DIFF:
            return tick
    return round(mean_tick_s / TICK_RESOLUTION_S) * TICK_RESOLUTION_S


def on_ticks(src: str, t: NDArray, arrays: dict[str, NDArray | None], notes: list[str],
             unread: NDArray | None = None) -> tuple[NDArray, dict[str, NDArray | None], NDArray | None]:
    """Put the rows of ``t`` (increasing, checked for gaps) on the controller tick grid.

    ``unread`` ``(n,)``: rows whose required values were interpolated (:func:`unreadable_rows`): not logged. Returns
    the grid times (from 0), every array on the grid (interpolated at missing ticks) and the mask of ticks the log
    really holds (``None`` when it holds all)."""
    k, mean = ticks(t)
    off = np.abs((t - t[0]) - k * mean)
    if off.max() > MAX_JITTER_PERIODS * mean:
        i = int(np.argmax(off))
        raise LogFormatError(f"{src}: data row {i + 1} (t = {t[i] - t[0]:.4f} s) is {off[i] * 1e3:.2g} ms off the "
                             f"controller's {mean * 1e3:.4g} ms tick (irregular time stamps)")
    p = controller_tick(mean)
    if abs(mean / p - 1.0) > 1e-4:
        notes.append(f"{src}: the log's clock gives a mean tick of {mean * 1e3:.4g} ms; replayed on the "
                     f"controller's {p * 1e3:.4g} ms tick (time scaled by {p / mean:.4f})")
    grid = np.arange(k[-1] + 1) * p
    logged = np.zeros(grid.size, dtype=bool)
    logged[k] = True if unread is None else ~unread
    if k.size < grid.size:
        missing = grid.size - k.size
        notes.append(f"{src}: {missing} of {grid.size} controller ticks ({p * 1e3:.3g} ms) missing in gaps of up to "
                     f"{int(np.diff(k).max()) - 1}; setpoints and readings interpolated there for the replay, "
                     "left out of every RMS figure")
        arrays = {name: None if a is None else _interp(grid, k * p, a) for name, a in arrays.items()}
    return grid, arrays, None if logged.all() else logged


def _interp(grid: NDArray, t: NDArray, a: NDArray) -> NDArray:
    return np.column_stack([np.interp(grid, t, a[:, j]) for j in range(a.shape[1])])
