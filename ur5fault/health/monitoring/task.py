"""A robot that repeats its task: pair a log's commanded motion with the baseline runs that repeat it, and take
the model's error there from the baseline.

Where a monitored log repeats a baseline run's commanded motion, the twin's error repeats too (the same speeds,
accelerations, poses and reversals at the same points of the task), so the log's residual is judged against the
paired baseline runs' residual *at the same point of the task* rather than against the spread of the model's
error over all motions (:mod:`.events`).

*Pairing* (:func:`matches`). The log is cut into chunks of :data:`CHUNK_S`; each chunk's joint targets, with
:data:`CONTEXT_S` of the log before and after it, are cross-correlated with every reference run's targets (the
sum of squared differences at every lag, through the correlation of the two). Every lag where the targets agree
within the controller's jitter -- the largest difference over the chunk and its context, all joints, at most
:data:`TARGET_JITTER_RAD` plus half a sample of the fastest target speed there (a lag is found to the nearest
sample) -- pairs the chunk with that stretch of the reference run; lags closer than half a chunk are one match,
and a chunk keeps at most :data:`MAX_MATCHES` of them per reference run, those of the smallest squared difference
(checked in that order, at most :data:`MAX_FAILED` failing the check), so its cost does not grow with the number of
its repeats.
The context is the span the transient's running level looks at around each sample, and the motion just before
a stretch shapes the model's error in it (a joint that stopped 0.1 s ago still settles; one that has stood for
0.6 s does not): the log's first and last :data:`CONTEXT_S` are not paired (what the arm did before the log
began, or would do after it ends, is unknown), the chunks cut the rest. A chunk with no such lag is not paired
(its motion is not in the baseline: a different task, a different pose, or the same path at another speed,
whose model error differs). A run that repeats its own motion (a cyclic task) pairs with itself at lags of at least
:data:`CHUNK_S` (never with the same samples).

*Standing still.* A chunk whose targets stand at one pose over it and its context (the arm stopped at least
:data:`CONTEXT_S` before: no speed, acceleration, reversal or settling in it) repeats every rest at that pose,
in the baseline and in the log itself: every lag passes, and checking them all made the pairing of a log that
idles for minutes take hours (its cost about cubic in the log's length). There the model's error has no phase:
it is the static error at the pose (gravity, payload, the current the joints hold), the same at every sample of
every rest there, so the reference is that error's mean over :data:`MAX_MATCHES` of those rests -- more would
only narrow the reference's own noise (1/K of its variance) at the log's length squared in cost. Among lags
whose squared differences are equal (to :data:`SSD_RESOLUTION`: NIST logs its targets at rest without jitter, and
the FFT's rounding alone would choose) the nearest in time comes first. Not told apart: the current a joint holds
at rest also depends on the friction it stopped against (the direction of the move before it, beyond the
context), which the targets at rest do not show; a rest after another approach pairs as well.

*Reference* (:func:`reference`): per sample the mean of the paired reference runs' residuals over all matches,
NaN where unpaired. Shapes: ``(n, 6)`` per sample and joint.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

#: the length of the stretches of a log paired one by one [s]: the length of the events' level window
#: (:data:`~.events.LEVEL_S`), so a reference is one stretch of task over the span a transient is judged against;
#: a cyclic task may repeat with pauses of another length, which a stretch of this length still finds
CHUNK_S = 2.0
#: the targets must agree this long before and after a chunk too [s]: half the running level's window
#: (:data:`~.events.LEVEL_S` / 2), the span each judged sample's transient looks at on either side
CONTEXT_S = 1.0
#: the joint targets' jitter between repeats of one commanded motion [rad]: the CB2 controller's targets at rest
#: wander by up to 3e-4 rad (bench/monitor_labels.py, START_MOVE_RAD's note; at rest a CB2 logs the previous
#: reading as its target, so this is the arm's own wander: docs/validation.md); measured between the Kufieta
#: robot's repeats of one task after the best lag, 1.6e-5 .. 4.4e-4 rad plus the sub-sample timing (docs)
TARGET_JITTER_RAD = 3e-4
#: the most repeats a chunk is paired with in one reference run, those of the smallest squared difference: the
#: reference is their residuals' mean, whose own noise adds 1/K of the residual's variance to the paired
#: difference (K = 16: its spread within 3 % of an infinite number of repeats'); a task repeated more often, or
#: a robot standing for minutes at one pose (every lag a repeat), is paired with the best 16, so the cost of a
#: chunk does not grow with the number of its repeats
MAX_MATCHES = 16
#: the most lags per chunk and reference run that may fail the largest-difference check (in the order of their
#: squared difference, skipping those within half a chunk of a kept one) before the rest are left unchecked: they
#: agree worse on average than 64 lags that already differ by more than the tolerance somewhere (a stretch standing
#: a fraction of the tolerance away from the chunk's pose passes the squared-difference bound at every lag)
MAX_FAILED = 64
#: squared differences closer than this fraction of the chunk's own sum of squares are equal [-]: 1000 times the
#: FFT's rounding seen on NIST's constant targets (3e-11 of 2.7e4 rad^2), an RMS difference of 3e-6 rad on a 4 s
#: chunk at 3 rad (1 % of the jitter)
SSD_RESOLUTION = 1e-12
#: lags checked at once (vectorised) [-]: a cost setting, no effect on the lags kept
CHECK_BATCH = 64


class _Correlator:
    """The sum of squared differences of chunks with every stretch of one reference run ``ref`` ``(m, 6)``, from
    their cross-correlation: the reference's spectrum and running sum of squares computed once, per chunk one
    forward and one inverse FFT (the joints summed in the frequency domain). ``max_len``: the longest chunk."""

    def __init__(self, ref: NDArray, max_len: int):
        from scipy import fft

        self.m = ref.shape[0]
        self.nfft = fft.next_fast_len(self.m + max_len - 1, real=True)
        self.spectrum = fft.rfft(ref, self.nfft, axis=0)
        self.csum = np.concatenate([[0.0], np.cumsum((ref**2).sum(axis=1))])

    def ssd(self, chunk: NDArray) -> NDArray:
        """``(m - L + 1,)``: the sum of squared differences of ``chunk`` ``(L, 6)`` with every stretch of the
        reference."""
        from scipy import fft

        L = chunk.shape[0]
        full = fft.irfft((self.spectrum * fft.rfft(chunk[::-1], self.nfft, axis=0)).sum(axis=1), self.nfft)
        return (chunk**2).sum() + (self.csum[L:] - self.csum[:-L]) - 2.0 * full[L - 1 : self.m]


def tolerance(chunk: NDArray, period_s: float) -> float:
    """The largest target difference [rad] a repeat of ``chunk`` ``(L, 6)`` may show: the controller's jitter plus
    half a sample at the chunk's fastest target speed (the lag is found to the nearest sample)."""
    speed = np.abs(np.diff(chunk, axis=0)).max() / period_s if chunk.shape[0] > 1 else 0.0
    return TARGET_JITTER_RAD + 0.5 * period_s * speed


def chunks(n: int, period_s: float) -> list[tuple[int, int]]:
    """``[(start, stop)]`` cutting ``n`` samples into stretches of :data:`CHUNK_S` (the last one up to twice as
    long); one stretch when the log is shorter."""
    L = max(2, int(round(CHUNK_S / period_s)))
    starts = list(range(0, max(n - L, 0) + 1, L)) or [0]
    return [(a, starts[i + 1] if i + 1 < len(starts) else n) for i, a in enumerate(starts)]


def _ranked(cand: NDArray, primary: NDArray, secondary: NDArray):
    """``cand`` in the order of ``(primary, secondary)``, in two parts: the :data:`CHECK_BATCH` ``* 16`` of the
    smallest primary key (with all that tie with the last) sorted at once, the rest only if they are needed (a
    full sort of every lag costs more than the checks a chunk needs)."""
    first = CHECK_BATCH * 16
    if cand.size > first:
        cut = np.partition(primary, first - 1)[first - 1]
        head = primary <= cut
        yield cand[head][np.lexsort((secondary[head], primary[head]))]
        cand, primary, secondary = cand[~head], primary[~head], secondary[~head]
    yield cand[np.lexsort((secondary, primary))]


def _agreeing(ch: NDArray, ref_target: NDArray, ssd: NDArray, ok: NDArray, tol: float, half: int, own: int,
              counter: Counter | None) -> list[int]:
    """The lags ``k`` (up to :data:`MAX_MATCHES`) at which ``ref_target[k : k + len(ch)]`` agrees with ``ch``
    within ``tol`` on every sample and joint: the candidates ``ok`` in order of ``ssd`` (equal to
    :data:`SSD_RESOLUTION`: the nearest to ``own``, the chunk's own start, first), a candidate closer than ``half``
    to a lag already kept skipped, the rest checked in batches (:data:`CHECK_BATCH`, vectorised) until
    :data:`MAX_MATCHES` are kept or :data:`MAX_FAILED` failed the check. ``counter``: ``checked`` and ``kept``
    are added to it."""
    L = ch.shape[0]
    windows = np.lib.stride_tricks.sliding_window_view(ref_target, L, axis=0)  # (m - L + 1, 6, L), a view
    cand = np.flatnonzero(ok)
    # equal squared differences (to SSD_RESOLUTION) rank by the nearest point in time: a chunk standing at a pose
    # logged without jitter (NIST's targets at rest are identical) matches every rest there with an SSD of 0 but
    # for the FFT's rounding, which would otherwise choose
    resolution = max(SSD_RESOLUTION * float((ch**2).sum()), np.finfo(float).tiny)
    blocked = np.zeros(ssd.size, bool)  # within half of a kept lag
    found: list[int] = []
    failed = checked = 0
    for tier in _ranked(cand, np.floor(ssd[cand] / resolution), np.abs(cand - own)):
        pos = 0  # the candidates before pos are checked or skipped
        while pos < tier.size and len(found) < MAX_MATCHES and failed < MAX_FAILED:
            rest = tier[pos:]
            free = np.flatnonzero(~blocked[rest])[:CHECK_BATCH]
            if free.size == 0:
                break
            batch = rest[free]
            pos += int(free[-1]) + 1
            agree = np.abs(windows[batch] - ch.T[None]).max(axis=(1, 2)) <= tol
            for k, good in zip(batch, agree):
                if blocked[k]:  # a lag kept earlier in this batch is within half
                    continue
                checked += 1
                if good:
                    found.append(int(k))
                    blocked[max(k - half + 1, 0) : k + half] = True
                    if len(found) == MAX_MATCHES:
                        break
                else:
                    failed += 1
                    if failed == MAX_FAILED:
                        break
        if len(found) == MAX_MATCHES or failed == MAX_FAILED:
            break
    if counter is not None:
        counter["checked"] += checked
        counter["kept"] += len(found)
    return found


def matches(target: NDArray, ref_target: NDArray, period_s: float, same_run: bool = False,
            counter: Counter | None = None) -> list[tuple[int, int, list[int]]]:
    """``[(start, stop, [offset, ...])]``: per chunk of ``target`` ``(n, 6)`` the offsets ``o`` at which
    ``ref_target[start + o : stop + o]`` repeats it, with its context (module docstring). ``same_run``: the
    reference is the log itself; offsets under :data:`CHUNK_S` are excluded. ``counter``: the lags checked and
    kept over all chunks are added to it (``checked``, ``kept``)."""
    n = target.shape[0]
    min_self = int(round(CHUNK_S / period_s))
    ctx = int(round(CONTEXT_S / period_s))
    if n <= 2 * ctx + 1:
        return [(0, n, [])]
    out = [(0, ctx, [])]  # the log's first and last CONTEXT_S: their context reaches past its ends
    cut = chunks(n - 2 * ctx, period_s)
    corr = _Correlator(ref_target, max(b - a for a, b in cut) + 2 * ctx)
    for a, b in cut:
        a, b = a + ctx, b + ctx
        lo, hi = a - ctx, b + ctx
        ch = target[lo:hi]
        L = hi - lo
        if L > ref_target.shape[0] or not np.isfinite(ch).all():
            out.append((a, b, []))
            continue
        ssd = corr.ssd(ch)
        tol = tolerance(ch, period_s)
        lags = np.arange(ssd.size)
        ok = ssd <= L * ch.shape[1] * tol**2  # necessary for a largest difference under tol
        if same_run:
            ok &= np.abs(lags - lo) >= min_self
        found = _agreeing(ch, ref_target, ssd, ok, tol, (b - a) // 2, lo, counter)
        out.append((a, b, [k - lo for k in sorted(found)]))
    return out + [(n - ctx, n, [])]


def reference(target: NDArray, refs: Sequence[tuple[NDArray, NDArray]], period_s: float,
              self_index: int | None = None, one_way: bool = False) -> tuple[NDArray, NDArray]:
    """The paired reference residual ``(n, 6)`` (NaN where no reference run repeats the motion) and which
    reference runs are paired with each sample ``(len(refs), n)``. ``refs``: ``(target (m, 6), residual (m, 6))``
    of each reference run, the residual NaN where the robot did not log the tick (a filled gap is no reference);
    ``self_index``: the entry of ``refs`` that is this log itself (paired only at lags of at least
    :data:`CHUNK_S`). ``one_way`` (with ``self_index``): paired only with what comes before it, the runs of
    ``refs`` before ``self_index`` and its own earlier repeats, so that when every run of ``refs`` is paired so,
    each pair of repeats is compared once (:func:`.paired.baseline_references`)."""
    n = target.shape[0]
    total = np.zeros((n, target.shape[1]))
    count = np.zeros(n, int)
    matched = np.zeros((len(refs), n), bool)
    for i, (rt, rr) in enumerate(refs):
        if one_way and self_index is not None and i > self_index:
            continue
        for a, b, offs in matches(target, rt, period_s, same_run=i == self_index):
            for o in offs:
                if one_way and i == self_index and o > 0:
                    continue
                rows = rr[a + o : b + o]
                ok = np.isfinite(rows).all(axis=1)
                total[a:b][ok] += rows[ok]
                count[a:b][ok] += 1
                matched[i, a:b] |= ok
    ref = np.full_like(total, np.nan)
    ref[count > 0] = total[count > 0] / count[count > 0, None]
    return ref, matched


def paired_transient(target: NDArray, residual_A: NDArray, refs: Sequence[tuple[NDArray, NDArray]],
                     period_s: float, self_index: int | None = None) -> tuple[NDArray, NDArray, NDArray]:
    """The transient (:func:`~.events.transient`) of the residual less its paired reference ``(n, 6)``, the
    samples it holds for ``(n,)`` (paired, with the whole smoothing window paired and inside the log; elsewhere
    the difference is filled with its median over the paired samples, so the running level stays defined, and
    not judged here), and which reference runs are paired with each sample ``(len(refs), n)``."""
    from .events import SMOOTH_S, transient

    ref, matched = reference(target, refs, period_s, self_index)
    paired = matched.any(axis=0)
    d = residual_A - ref
    if paired.any():
        d[~paired] = np.median(d[paired], axis=0)
    else:
        d[:] = 0.0
    half = int(round(SMOOTH_S / period_s)) // 2 + 1
    inner = paired.copy()
    for k in range(1, half + 1):
        inner[k:] &= paired[:-k]
        inner[:-k] &= paired[k:]
    inner[:half] = inner[-half:] = False  # the log's ends: smoothed over a shorter window than the spread's fit
    return transient(d, period_s), inner, matched
