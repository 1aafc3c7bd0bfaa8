"""Persistent changes: the discrepancy workflow's library and statistics on a new log, against the baseline.

Every screened candidate (:mod:`.observe`) is fitted alone to the log's weighted residual and judged by the
discrepancy workflow's own test (:func:`ur5fault.discrepancy.search.judge`: BIC, block-jackknife z, stability in
time blocks). A candidate is a *change* when the log's estimate is significant and lies outside the prediction
interval of the baseline's estimates of the same candidate (:class:`Reference`):
``|theta - mean_b| / sqrt(max(se^2, V) + var_b / k) > t_{k-1}``, ``V`` the variance the baseline predicts for
the log's estimate under no change. The baseline's estimates are made per time block of :data:`BLOCK_S` of every
baseline run (:func:`block_estimates`), so ``var_b``, the variance of the ``k`` block estimates, holds both the
spread between healthy runs (the model's own motion-dependent error) and the drift within a run (a warming
motor's offset); ``t_{k-1}`` is Student's quantile at the tail probability of
:data:`~ur5fault.discrepancy.statistics.MIN_Z` standard errors (the discrepancy workflow's bar, corrected for the
few blocks a baseline has; the blocks of one run are counted as independent, an assumption that makes the bar
lower than if only runs were counted). A single block: its own jackknife variance as the mean's, the log's own
SE as its estimate's, and ``MIN_Z``.

*The log's noise counted once.* ``theta - mean_b`` has the variance of the log's estimate plus that of the
baseline's mean (``var_b / k``: independent runs). The log's estimate on its screened part (up to 20 s) is
predicted to vary no more than one block's (``V = var_b``, unscaled: the model's motion-dependent error need not
average out over a longer part as a block's noise does; a conservative choice), and ``var_b`` already holds a
block's own noise (each block estimate carries it). The log's jackknife standard error ``se`` is a second
estimate of part of the same variance, from the log itself: its noise within its own jackknife blocks, not the
model's error that a block's estimate absorbs. Added to ``V`` (as before) it counted the log's noise twice;
the larger of the two is taken instead: ``V`` where the log is like the baseline, its own ``se`` where it is
noisier than the baseline's blocks predict.

A push is an event, not a worn gear: a change must also hold on the samples outside the log's events (and
:data:`EVENT_GUARD_S` around them), or those samples must be unable to tell (their standard error larger than
the change over the bar) - a changed gain that itself leaves the event band on most of a joint's samples stays
a change.

*A joint the log holds still* (its target moving for less than :data:`MIN_OWN_MOTION_S` of the part the test
reads) is judged for a current-sensor offset and its gear stiffness only (:data:`NEEDS_OWN_MOTION`): its current is
its holding torque plus the static friction it stopped against, anywhere within the breakaway and set by the motion
before, which the log does not show, so a gain or torque constant (a scale of that current) cannot be told from it,
and friction and backlash are not exercised. Under an overlay with motor-angle ripples, Kufieta's Movement_No2
(wrist_3 never moves) read a wrist_3 torque-constant "change" of 0.36 against the baseline's 1.47 (0.07 +- 1.0
without the ripples: docs/monitoring.md).

Per joint the change with the largest distance is named; the others on that joint are its alternatives (a
current-sensor gain and a torque constant read alike in the current).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from ...discrepancy.candidates import LibraryCandidate
from ...discrepancy.model import SCREEN_S
from ...discrepancy.search import columns_of, judge
from ...discrepancy.statistics import MIN_Z, Z_95, BlockGram
from ...sim.axes import JOINT_NAMES
from .coverage import MIN_BEYOND_S
from .observe import Observed

#: samples this close to an event are left out of the change test [s] (the controller's recovery after a push)
EVENT_GUARD_S = 0.5
#: the time block of a baseline run a candidate is estimated on [s]: long enough to hold several motions of
#: each joint (the real runs reverse a joint every 2-5 s), short enough that the screened 20 s of a run give four
#: blocks, so a drift within the run shows as spread between its blocks
BLOCK_S = 5.0
#: the effects judged only on a joint the log moves (module docstring: a held joint's current is its holding torque
#: plus a static friction the log does not show; friction and backlash need the joint to slide and reverse)
NEEDS_OWN_MOTION = ("coulomb_friction", "viscous_friction", "backlash", "torque_constant", "current_sensor_gain")
#: a joint counts as moved by a log when its target moves this long within the part the change test reads [s]
#: (the coverage notes' least time beyond the baseline, :data:`.coverage.MIN_BEYOND_S`)
MIN_OWN_MOTION_S = MIN_BEYOND_S


@dataclasses.dataclass(frozen=True)
class Estimate:
    """One candidate fitted alone on one log part: coefficient, jackknife SE, and the workflow's verdict."""

    label: str
    theta: float
    se: float
    accepted: bool
    reason: str


def moved_s(obs: Observed, rows: int | None = None) -> NDArray:
    """``(6,)``: how long each joint's target moves over the logged samples of the first ``rows`` (all: None) [s]."""
    return (obs.moving[:rows] & obs.logged[:rows, None]).sum(axis=0) * obs.period_s


def still_joints(obs: Observed) -> NDArray:
    """``(6,)``: the joints whose target moves for less than :data:`MIN_OWN_MOTION_S` of the logged samples of the
    screened part (the samples the change test reads)."""
    return moved_s(obs, obs.e.shape[0]) < MIN_OWN_MOTION_S


def keep_mask(obs: Observed, over: NDArray) -> NDArray:
    """Samples of the screened part ``(m,)`` outside every exceedance (``over`` ``(n, 6)``) by
    :data:`EVENT_GUARD_S`, and logged."""
    m = obs.e.shape[0]
    bad = over[:m].any(axis=1)
    guard = int(round(EVENT_GUARD_S / obs.period_s))
    if bad.any() and guard:
        bad = np.convolve(bad.astype(float), np.ones(2 * guard + 1), mode="same") > 0
    return ~bad & obs.logged[:m]


def fit_alone(cands: Sequence[LibraryCandidate], X: NDArray, e: NDArray, keep: NDArray) -> dict[str, Estimate]:
    """Each of ``cands`` (columns ``X`` ``(p, m, n_channels)``) fitted alone to ``e`` ``(m, n_channels)`` on the
    samples ``keep`` ``(m,)``, judged by the discrepancy workflow's test."""
    if not cands:
        return {}
    e = np.where(keep[:, None], e, 0.0)
    X = np.where(keep[None, :, None], X, 0.0)
    bg = BlockGram.build(X, e)
    cols = columns_of(cands)
    out = {}
    for k, c in enumerate(cands):
        v = judge(bg, e, X, cands, cols, [], k)
        out[c.label] = Estimate(c.label, v.theta[0], v.se[0], v.accepted, v.reason)
    return out


def estimates(obs: Observed, keep: NDArray) -> dict[str, Estimate]:
    """Each candidate of ``obs`` fitted alone on the samples ``keep`` ``(m,)``."""
    return fit_alone(obs.cands, obs.X, obs.e, keep)


def block_estimates(obs: Observed) -> list[dict[str, Estimate]]:
    """Each candidate fitted alone on each :data:`BLOCK_S` block of the screened part's first
    :data:`~ur5fault.discrepancy.model.SCREEN_S` (the last block joins the one before when shorter than half a
    block); one block when that is shorter than two. Not past it where a baseline run is screened whole (for the
    paired test, :data:`.observe.BASELINE_SCREEN_S`): the blocks are the reference of a monitored log's estimate
    on its own first :data:`~ur5fault.discrepancy.model.SCREEN_S`, and stay the same stretch of each run."""
    m = min(obs.e.shape[0], max(2, round(SCREEN_S / obs.period_s)))
    n = max(1, int(round(m * obs.period_s / BLOCK_S)))
    edges = np.linspace(0, m, n + 1).round().astype(int)
    out = []
    for a, b in zip(edges[:-1], edges[1:]):
        keep = obs.logged[: obs.e.shape[0]].copy()
        keep[:a] = False
        keep[b:] = False
        out.append(estimates(obs, keep))
    return out


def spread(thetas: list[float], ses: list[float] | None = None) -> tuple[float, float, int]:
    """Mean, variance and count of a candidate's block estimates (one block: its SE squared, from ``ses``)."""
    th = np.asarray(thetas, dtype=float)
    if th.size >= 2:
        return float(th.mean()), float(th.var(ddof=1)), int(th.size)
    se = np.asarray(ses if ses is not None else [np.nan], dtype=float)
    return float(th[0]), float(se[0] ** 2), 1


def spreads(blocks: Iterable[dict[str, Estimate]]) -> dict[str, tuple[float, float, int]]:
    """``{label: (mean, variance, n)}`` of each candidate's block estimates (:func:`spread`)."""
    per: dict[str, tuple[list[float], list[float]]] = {}
    for block in blocks:
        for label, est in block.items():
            if np.isfinite(est.se):
                per.setdefault(label, ([], []))[0].append(est.theta)
                per[label][1].append(est.se)
    return {k: spread(th, se) for k, (th, se) in per.items()}


@dataclasses.dataclass(frozen=True)
class Reference:
    """What a log's estimate of one candidate is judged against (module docstring): the baseline's ``mean``;
    ``log_var``, the variance the baseline predicts for the log's estimate under no change (0: it predicts none,
    the log's own standard error stands alone); ``mean_var``, the variance of ``mean``; ``k``, the (effective)
    number of blocks Student's bar counts (:func:`bar`: ``k - 1`` degrees of freedom); ``run_var``, the variance
    of a difference between healthy runs that holds over the log's whole run, which its own standard error does
    not see (:mod:`.components`; 0: none predicted)."""

    mean: float
    log_var: float
    mean_var: float
    k: float
    run_var: float = 0.0

    def __post_init__(self) -> None:
        if not (np.isfinite(self.mean) and self.log_var >= 0.0 and self.mean_var >= 0.0 and self.k >= 1.0
                and self.run_var + self.mean_var >= 0.0):
            raise ValueError(f"reference mean {self.mean}, variances {self.log_var} / {self.mean_var}, k {self.k}: "
                             f"need a finite mean, variances >= 0 and k >= 1")

    def variance(self, se: float) -> float:
        """The prediction variance of ``theta - mean`` for a log's estimate of standard error ``se``: the larger of
        the baseline's and the log's own estimate of the log's variance (two estimates of the same noise, so never
        their sum), plus its run's offset's and the mean's."""
        return max(se**2, self.log_var) + self.run_var + self.mean_var

    def z(self, theta: float, se: float) -> float:
        """``|theta - mean|`` in prediction standard deviations (:meth:`variance`)."""
        return abs(theta - self.mean) / float(np.sqrt(self.variance(se)))


def block_reference(stats: dict[str, tuple[float, float, int]]) -> dict[str, Reference]:
    """The block test's :class:`Reference` per candidate from the baseline's ``{label: (mean, variance, n)}``
    (:func:`spreads`): the log's estimate predicted to vary as one block's, ``variance``, and the mean by
    ``variance / n``; a single block (``variance`` its jackknife SE squared): no prediction for the log, the
    block's variance the mean's."""
    return {label: (Reference(mean, var, var / n, n) if n >= 2 else Reference(mean, 0.0, var, 1))
            for label, (mean, var, n) in stats.items()}


def bar(n_segments: float, share: float = 1.0) -> float:
    """The distance in prediction standard deviations a change must exceed for ``n_segments`` (effective)
    blocks: Student's quantile at ``n_segments - 1`` degrees of freedom, the normal's for a single block.
    ``share``: the fraction of the workflow's tail probability (that of :data:`MIN_Z` standard errors) this test
    may spend: where two tests judge one log and a change is flagged when either does, each at half (Bonferroni:
    the probability that either raises a false alarm is at most the sum), its bar raised to match (z 4 -> 4.16
    for one block)."""
    from scipy import stats

    if not 0.0 < share <= 1.0:
        raise ValueError(f"share {share}: must be in (0, 1]")
    tail = float(stats.norm.sf(MIN_Z)) * share
    if n_segments < 2:
        return MIN_Z if share == 1.0 else float(stats.norm.isf(tail))
    return float(stats.t.isf(tail, n_segments - 1))


def _distance(e: Estimate, ref: Reference, share: float = 1.0) -> float:
    """How far ``e`` lies from the baseline's estimates, in multiples of the bar (>= 1: a change)."""
    return ref.z(e.theta, e.se) / bar(ref.k, share)


def find_changes(obs: Observed, est: dict[str, Estimate], outside: dict[str, Estimate],
                 base: dict[str, Reference], reference: str = "blocks", share: float = 1.0) -> list[dict]:
    """Changes of ``obs`` against the baseline's ``{label: Reference}``, one per joint (module docstring):
    ``est`` on every logged sample, ``outside`` on those outside the events. ``reference``: what ``base`` holds,
    written into each change (``"blocks"``: the baseline runs' block estimates; ``"paired"``: the paired
    difference-estimates of :mod:`.paired`). ``share``: the fraction of the false-alarm probability this test
    spends (:func:`bar`)."""
    flagged = []
    still = still_joints(obs)
    for c in obs.cands:
        e, o = est[c.label], outside[c.label]
        if c.label not in base or not e.accepted or not np.isfinite(e.se):
            continue
        if c.joint is not None and still[c.joint] and c.effect in NEEDS_OWN_MOTION:
            continue
        d = _distance(e, base[c.label], share)
        if d < 1.0:
            continue
        mean = base[c.label].mean
        limit = bar(base[c.label].k, share)
        holds = (o.accepted and _distance(o, base[c.label], share) >= 1.0) or not np.isfinite(o.se) \
            or o.se > abs(e.theta - mean) / limit
        if holds:
            flagged.append((d, c, e, mean))
    out = []
    for j in sorted({c.joint for _, c, _, _ in flagged}, key=lambda j: -1 if j is None else j):
        mine = sorted((f for f in flagged if f[1].joint == j), key=lambda f: -f[0])
        z, c, e, mean = mine[0]
        lo, hi = sorted((c.value(e.theta - Z_95 * e.se), c.value(e.theta + Z_95 * e.se)))
        alts = [{"effect": a.effect, "parameter": a.param, "value": a.value(ea.theta), "baseline_value": a.value(am)}
                for _, a, ea, am in mine[1:]]
        out.append({"joint": JOINT_NAMES[j] if j is not None else None, "effect": c.effect, "parameter": c.param,
                    "value": c.value(e.theta), "interval": [lo, hi], "baseline_value": c.value(mean),
                    "distance": z, "alternatives": alts, "reference": reference})
    return out


def strongest(*lists: list[dict]) -> list[dict]:
    """Per joint the change furthest beyond its bar among ``lists`` (e.g. the paired and the unpaired test's)."""
    best: dict = {}
    for ch in (c for lst in lists for c in lst):
        if ch["joint"] not in best or ch["distance"] > best[ch["joint"]]["distance"]:
            best[ch["joint"]] = ch
    order = {None: -1, **{j: i for i, j in enumerate(JOINT_NAMES)}}
    return sorted(best.values(), key=lambda c: order[c["joint"]])


def sentence(ch: dict) -> str:
    """One line per change, as the discrepancy workflow names a finding."""
    lo, hi = ch["interval"]
    alt = "".join(f"; or {a['effect']}.{a['parameter']} = {a['value']:.4g}" for a in ch["alternatives"])
    how = (" (on the difference from the baseline runs repeating its task)" if ch.get("reference") == "paired"
           else "")
    return (f"{ch['joint']}: {ch['effect']}.{ch['parameter']} = {ch['value']:.4g} ({lo:.4g}..{hi:.4g}), "
            f"baseline {ch['baseline_value']:.4g}, {ch['distance']:.1f}x the bar away{how}{alt}")
