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
sample) -- pairs the chunk with that stretch of the reference run; lags closer than half a chunk are one match.
The context is the span the transient's running level looks at around each sample, and the motion just before
a stretch shapes the model's error in it (a joint that stopped 0.1 s ago still settles; one that has stood for
0.6 s does not): the log's first and last :data:`CONTEXT_S` are not paired (what the arm did before the log
began, or would do after it ends, is unknown), the chunks cut the rest. A chunk with no such lag is not paired
(its motion is not in the baseline: a different task, a different pose, or the same path at another speed,
whose model error differs). A run that repeats its own motion (a cyclic task) pairs with itself at lags of at least
:data:`CHUNK_S` (never with the same samples).

*Reference* (:func:`reference`): per sample the mean of the paired reference runs' residuals over all matches,
NaN where unpaired. Shapes: ``(n, 6)`` per sample and joint.
"""

from __future__ import annotations

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
#: wander by up to 3e-4 rad (bench/monitor_labels.py, START_MOVE_RAD's note); measured between the Kufieta
#: robot's repeats of one task after the best lag, 1.6e-5 .. 4.4e-4 rad plus the sub-sample timing (docs)
TARGET_JITTER_RAD = 3e-4


def _ssd(chunk: NDArray, ref: NDArray) -> NDArray:
    """``(m - L + 1,)``: the sum of squared differences of ``chunk`` ``(L, 6)`` with every stretch of ``ref``
    ``(m, 6)``, from their cross-correlation (FFT)."""
    from scipy.signal import fftconvolve

    L = chunk.shape[0]
    cross = sum(fftconvolve(ref[:, j], chunk[::-1, j], mode="valid") for j in range(chunk.shape[1]))
    csum = np.concatenate([[0.0], np.cumsum((ref**2).sum(axis=1))])
    return (chunk**2).sum() + (csum[L:] - csum[:-L]) - 2.0 * cross


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


def matches(target: NDArray, ref_target: NDArray, period_s: float, same_run: bool = False
            ) -> list[tuple[int, int, list[int]]]:
    """``[(start, stop, [offset, ...])]``: per chunk of ``target`` ``(n, 6)`` the offsets ``o`` at which
    ``ref_target[start + o : stop + o]`` repeats it, with its context (module docstring). ``same_run``: the
    reference is the log itself; offsets under :data:`CHUNK_S` are excluded."""
    n = target.shape[0]
    min_self = int(round(CHUNK_S / period_s))
    ctx = int(round(CONTEXT_S / period_s))
    if n <= 2 * ctx + 1:
        return [(0, n, [])]
    out = [(0, ctx, [])]  # the log's first and last CONTEXT_S: their context reaches past its ends
    for a, b in chunks(n - 2 * ctx, period_s):
        a, b = a + ctx, b + ctx
        lo, hi = a - ctx, b + ctx
        ch = target[lo:hi]
        L = hi - lo
        if L > ref_target.shape[0] or not np.isfinite(ch).all():
            out.append((a, b, []))
            continue
        ssd = _ssd(ch, ref_target)
        tol = tolerance(ch, period_s)
        lags = np.arange(ssd.size)
        ok = ssd <= L * ch.shape[1] * tol**2  # necessary for a largest difference under tol
        if same_run:
            ok &= np.abs(lags - lo) >= min_self
        found: list[int] = []
        for k in lags[ok][np.argsort(ssd[ok])]:
            if any(abs(k - f) < (b - a) // 2 for f in found):
                continue
            if np.abs(ref_target[k : k + L] - ch).max() <= tol:
                found.append(int(k))
        out.append((a, b, [k - lo for k in sorted(found)]))
    return out + [(n - ctx, n, [])]


def reference(target: NDArray, refs: Sequence[tuple[NDArray, NDArray]], period_s: float,
              self_index: int | None = None) -> tuple[NDArray, NDArray]:
    """The paired reference residual ``(n, 6)`` (NaN where no reference run repeats the motion) and which
    reference runs are paired with each sample ``(len(refs), n)``. ``refs``: ``(target (m, 6), residual (m, 6))``
    of each reference run, the residual NaN where the robot did not log the tick (a filled gap is no reference);
    ``self_index``: the entry of ``refs`` that is this log itself (paired only at lags of at least
    :data:`CHUNK_S`)."""
    n = target.shape[0]
    total = np.zeros((n, target.shape[1]))
    count = np.zeros(n, int)
    matched = np.zeros((len(refs), n), bool)
    for i, (rt, rr) in enumerate(refs):
        for a, b, offs in matches(target, rt, period_s, same_run=i == self_index):
            for o in offs:
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
