"""The change test on a repeated task: a candidate estimated on the difference of residuals at the same point of
the task.

Where a monitored log repeats a baseline run's commanded motion (:mod:`.task`'s pairing, unchanged), the twin's
error repeats too, so the *difference* of the log's current residual and the paired baseline runs' residual at
the same point of the task holds what changed since, and not the model's motion-dependent error that dominates
a candidate fitted on the residual alone (:mod:`.changes`; docs/monitoring.md, "What the change test can
separate"). Physically: a current-sensor gain or torque-constant change is a residual proportional to the
current, an offset a constant, a friction change one proportional to the friction (sign of the speed, or the
speed); on a repeated task those shapes remain in the difference.

Each monitor candidate (:data:`.observe.MONITOR_KINDS`) is fitted alone to the difference on the paired,
logged samples of the screened part (a monitored log's first :data:`~ur5fault.discrepancy.model.SCREEN_S`; a
baseline run's whole length, :data:`.observe.BASELINE_SCREEN_S`, so its reference counts every paired block it
holds), with its sensitivity column taken on the log's own replay
(``Observed.X``, the current channels; the reference holds current residuals only), and judged by the
discrepancy workflow's test (:func:`ur5fault.discrepancy.search.judge`) as :mod:`.changes` does. Its reference
distribution is the same difference-estimate between healthy baseline runs paired with each other and with
their own repeats (never a run with its own samples), made per :data:`PAIRED_BLOCK_S` of paired samples
(:func:`block_estimates`): their mean, variance and effective number feed the same prediction interval
(:class:`.changes.Reference`) and Student's bar (:func:`.changes.bar`) as the unpaired test's.

*What ``k`` counts: each difference once.* Paired both ways, two repeats of a stretch give
``d_A = r_A - r_B`` and ``d_B = r_B - r_A = -d_A`` (a run paired with its own repeat at lag L: ``d(t + L) =
-d(t)``): one difference, two blocks. Counted as two, Student's bar at ``k - 1`` degrees of freedom is too low
where ``k`` is small. So ``k`` is the number of blocks the baseline gives with each run paired only with what
comes before it (the runs before it in the baseline and its own earlier repeats, :func:`baseline_references`
``one_way``, :func:`~.task.reference`): of ``m`` repeats of a stretch the j-th against the mean of the ``j - 1``
before it, ``m - 1`` differences, the number of independent ones (paired both ways, the ``m`` differences sum
to zero). The mean and variance stay those of the blocks paired both ways (:func:`baseline_spreads`): which of
two healthy runs comes first in the baseline is arbitrary, and a difference between them belongs in the
reference with either sign (paired one way only, a systematic difference between the earlier and the later runs
would read as a mean of one sign with a narrow spread, and the baseline's order would set it).
*Neighbouring blocks are not counted as independent* (they were before, with blocks of 2 s): the one-way
blocks of each run, in time order, give the design effect ``DE`` of their autocorrelation (:mod:`.effective`:
pooled over the runs about the both-way mean, the lags within one pairing stretch always counted, then Geyer's
initial positive sequence; or, where larger, the design effect of the runs as clusters, from the spread of the
runs' own mean blocks: :func:`.effective.run_design_effect`), and ``k_eff = k / DE`` independent blocks set
Student's bar; the variance is corrected for the bias the correlation puts in it. A difference that holds over
a whole run (a warmer run, an offset that drifted) is correlation at every lag of that run, so a baseline whose
runs each sit apart is worth about as many blocks as it has runs; one whose differences are the sensors' noise
and the task's repeatability is worth about all its blocks. Geyer's sum alone missed a run-long offset small
against one block's noise (its correlation at each lag under the estimates' noise, the sum cut off after a few
lags: on simulated runs with such an offset, 9-19 % of healthy logs outside a 95 % interval, the log's noise
counted once); the runs' means see it (:mod:`.effective`; ``tests/health/monitoring/test_change_coverage.py``:
4.5 and 9.8 %).

*Why the false-alarm rate holds.* The log's estimate over its ``n`` paired blocks is (to first order) a weighted
mean of the same candidate's estimates on its own short blocks. Under no change, blocks with the baseline's
autocorrelation make its variance that of one block times ``DE / n`` (never more than one block's): ``V =
var_b min(1, DE / n)``, the baseline's single-block spread ``var_b`` so scaled. ``theta - mean_b`` adds the
reference mean's ``var_b / k_eff``. How well ``var_b`` is known sets Student's quantile at the workflow's tail
with ``k_eff - 1`` degrees of freedom, which is why ``k_eff`` must not count correlated blocks as independent.
What it assumes: the log's healthy difference has the autocorrelation of the baseline's (a difference of the
log from the healthy runs that holds over the whole log, beyond what the baseline runs show between each other,
is not covered; with a single baseline run, its own cycles show only the differences within one session), and
the log is no longer than the baseline runs ``DE`` is measured on (an offset between healthy runs that holds
over a run enters ``DE`` as correlation over the run's ``m`` blocks, so ``var_b DE / n`` holds it about right
for a log of ``m`` blocks, overstates it for a shorter log and understates it for a longer one; a monitored log
is screened on its first 20 s, the baseline runs whole).

*The log's noise counted once.* A block's estimate is made on the difference of two healthy runs' residuals, so
``var_b`` holds both sides' noise; ``V`` is therefore already the variance of the log's whole estimate,
including the log's own noise and its reference's. The log's jackknife standard error ``se`` (the workflow's 10
blocks of the log) estimates part of the same variance from the log itself: the noise within its own jackknife
blocks, not a difference that holds over the whole log. So ``se^2 <= V`` in expectation where the log is like
the baseline, and their sum counts the log's noise twice (what this module did before, "a conservative width":
up to ``sqrt(2)`` too wide, where ``se^2`` is as large as ``V`` and the reference mean well known). The
prediction variance is ``max(se^2, V) + var_b / k_eff`` (:class:`.changes.Reference`): ``V`` where the log is
like the baseline, the log's own ``se`` where it is noisier than the baseline's blocks predict (another noise
level, fewer repeats in its reference).
Before the autocorrelation was counted, the interval used one block's spread unscaled (``min(1, DE / n)``
taken as 1), which asks a 20 s log's estimate to lie as far out as a single 2 s block's.

The estimate reads as the change *since the paired healthy runs* (a gain of 1.1: the current reads 10 %
more than on the same motion of the baseline).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ...sim.axes import N_JOINTS
from .changes import BLOCK_S, Estimate, Reference, fit_alone, spreads
from .effective import effective, run_design_effect
from .observe import Observed
from .task import CHUNK_S, reference

#: the paired samples a baseline's paired estimate is made on [s]: a quarter of the pairing's stretch
#: (:data:`~.task.CHUNK_S`), 62 samples at the robots' 125 Hz. The unpaired test's :data:`~.changes.BLOCK_S` must
#: hold several motions of each joint because a block's estimate absorbs the model's motion-dependent error there;
#: the paired difference holds none of it to average out (only the sensors' noise and the task's
#: repeatability). Shorter blocks give more of them, and Student's bar at the workflow's tail falls fast with
#: their number (125.6, 32.6, 9.8, 6.2 at 3, 4, 7, 12); neighbouring blocks are not independent, which their
#: autocorrelation accounts for (:mod:`.effective`; the four blocks of one stretch share its paired reference, so
#: the lags within it are always counted, :data:`MIN_LAG`). It was 2 s (the stretch) before.
PAIRED_BLOCK_S = CHUNK_S / 4
#: the lags of the block sequence always counted in the design effect (:func:`.effective.design_effect`): the
#: blocks of one pairing stretch share its reference runs and lag
MIN_LAG = int(round(CHUNK_S / PAIRED_BLOCK_S))
#: a log part is judged by the paired test only with at least this much of its screened part paired [s]: the
#: length of the unpaired test's blocks (:data:`~.changes.BLOCK_S`), several motions of each joint, so that the
#: log's own estimate holds them as its reference's do
MIN_PAIRED_S = BLOCK_S


def difference(obs: Observed, ref: NDArray) -> tuple[NDArray, NDArray]:
    """The weighted difference ``(m, n_channels)`` of the log's current residual and its paired reference ``ref``
    ``(n, 6)`` [A] on the screened part (the other channels 0), and the samples it holds ``(m,)`` (paired on
    every joint and logged)."""
    m = obs.e.shape[0]
    ok = np.isfinite(ref[:m]).all(axis=1) & obs.logged[:m]
    e = np.zeros_like(obs.e)
    if not ok.any():
        return e, ok
    if obs.current_sigma_A is None:
        raise ValueError(f"{obs.name}: replayed without the current residual's weights (current_sigma_A)")
    d = (obs.residual_A[:m] - np.where(ok[:, None], ref[:m], 0.0)) / obs.current_sigma_A
    e[:, :N_JOINTS] = np.where(ok[:, None], d, 0.0)
    return e, ok


def current_columns(obs: Observed) -> NDArray:
    """The candidates' weighted columns ``(p, m, n_channels)`` on the current channels alone (the others 0)."""
    X = np.zeros_like(obs.X)
    X[:, :, :N_JOINTS] = obs.X[:, :, :N_JOINTS]
    return X


def estimates(obs: Observed, ref: NDArray, keep: NDArray) -> dict[str, Estimate]:
    """Each candidate of ``obs`` fitted alone to the paired difference on the paired samples among ``keep``
    ``(m,)``."""
    if not obs.cands:
        return {}
    e, ok = difference(obs, ref)
    return fit_alone(obs.cands, current_columns(obs), e, keep & ok)


def paired_seconds(obs: Observed, ref: NDArray) -> float:
    """The screened part's paired, logged seconds."""
    return float(difference(obs, ref)[1].sum() * obs.period_s)


def _groups(obs: Observed, ok: NDArray) -> list[NDArray]:
    """The paired samples ``ok`` ``(m,)`` cut into consecutive groups of about :data:`PAIRED_BLOCK_S` (stretches
    joined in time order; the groups as even as the count allows); none when under half a block is paired."""
    idx = np.flatnonzero(ok)
    n = int(round(idx.size * obs.period_s / PAIRED_BLOCK_S))
    return np.array_split(idx, n) if n >= 1 else []


def block_estimates(obs: Observed, ref: NDArray) -> list[dict[str, Estimate]]:
    """Each candidate fitted alone to the paired difference on each group of :data:`PAIRED_BLOCK_S` of the
    screened part's paired samples (:func:`_groups`), in time order. Each fit sees only its group's span (the
    same estimate as on the whole part with the rest left out, at a fraction of the cost)."""
    if not obs.cands:
        return []
    e, ok = difference(obs, ref)
    X = current_columns(obs)
    out = []
    for part in _groups(obs, ok):
        lo, hi = int(part[0]), int(part[-1]) + 1
        keep = np.zeros(hi - lo, bool)
        keep[part - lo] = True
        out.append(fit_alone(obs.cands, X[:, lo:hi], e[lo:hi], keep))
    return out


def baseline_references(healthy: Sequence[Observed], refs: Sequence[tuple[NDArray, NDArray]],
                        one_way: bool = False) -> list[NDArray]:
    """Per baseline run, its paired reference ``(n, 6)`` from the other runs and its own repeats (never its own
    samples); ``one_way``: from the runs before it and its own earlier repeats only, each pair of repeats
    compared once (module docstring, what ``k`` counts)."""
    return [reference(o.target_rad, refs, o.period_s, self_index=k, one_way=one_way)[0]
            for k, o in enumerate(healthy)]


def independent_blocks(healthy: Sequence[Observed], refs: Sequence[tuple[NDArray, NDArray]]) -> int:
    """The number of paired blocks the baseline runs give with each pair of repeats compared once
    (:func:`baseline_references` ``one_way``), before their autocorrelation is accounted for."""
    return sum(len(_groups(o, difference(o, ref)[1]))
               for o, ref in zip(healthy, baseline_references(healthy, refs, one_way=True)))


def baseline_spreads(healthy: Sequence[Observed], refs: Sequence[tuple[NDArray, NDArray]]
                     ) -> dict[str, tuple[float, float, float, float]]:
    """``{label: (mean, variance, k_eff, DE)}`` of each candidate's paired estimates over the baseline runs (module
    docstring): mean and variance of its blocks paired both ways (either sign of each difference between healthy
    runs); ``DE`` the design effect of its one-way blocks (each pair of repeats compared once): of their
    autocorrelation within each run, about that mean, the lags within one pairing stretch always counted, or of
    the runs as clusters where larger (:func:`.effective.run_design_effect`); ``k_eff = k / DE`` the independent
    blocks they are worth, and the variance
    corrected for the bias the correlation puts in it (:func:`.effective.effective`). A candidate whose blocks
    are worth fewer than 2 independent ones has no paired statistics."""
    both = spreads(block for o, ref in zip(healthy, baseline_references(healthy, refs))
                   for block in block_estimates(o, ref))
    if not both:
        return {}
    one_way = [block_estimates(o, ref) for o, ref in zip(healthy, baseline_references(healthy, refs, one_way=True))]
    out = {}
    for label, (mean, var, _) in both.items():
        seqs = [np.array([b[label].theta for b in run if label in b and np.isfinite(b[label].se)]) for run in one_way]
        k = sum(s.size for s in seqs)
        if k < 2:
            continue
        de = run_design_effect(seqs, mean, var, MIN_LAG)
        got = effective(var, k, de)
        if got is not None:
            out[label] = (mean, got[0], got[1], de)
    return out


def for_log(stats: dict[str, tuple[float, float, float, float]], paired_s: float) -> dict[str, Reference]:
    """The :class:`.changes.Reference` of a log's estimate on ``paired_s`` seconds of paired samples per candidate
    of the baseline's ``{label: (mean, variance, k_eff, DE)}``, as :func:`.changes.find_changes` takes it.

    The log's estimate is (to first order) a weighted mean of its ``n = paired_s / PAIRED_BLOCK_S`` blocks'
    estimates, so under no change its variance is that of one block times ``min(1, DE / n)`` (``DE`` the
    baseline's design effect: ``n`` blocks of that autocorrelation are worth ``n / DE`` independent ones, and
    never less than one; a weighted mean's variance is at most the equal-weight mean's for blocks of unequal
    information): the reference's ``log_var``, which the log's own standard error replaces only where larger
    (module docstring, the log's noise counted once). The reference mean's variance is ``variance / k_eff``;
    Student's bar counts ``k_eff``."""
    n = max(paired_s / PAIRED_BLOCK_S, 1.0)
    return {label: Reference(mean, var * min(1.0, de / n), var / k, k) for label, (mean, var, k, de) in stats.items()}
