"""The steps of the discrepancy fit, each a function of explicit inputs that returns a record (the trace of
what it chose and why); :class:`ur5fault.discrepancy.model.DiscrepancyModel` only chains them.  No step
knows of the estimator.

1. :func:`screen_library`: every effect of the registry in one lockstep batch, selected forward on the
   linearised problem.
2. :func:`discover_terms`: the dictionary's terms on what the library leaves (library columns free).
3. :func:`.joint_check.joint_check` (its own module): the findings selected afresh among themselves (linear,
   free) so that library effects that only stood in for a term discovered later are not re-simulated.
4. :func:`refine`: one batch of probes over the whole log (the simulated Jacobian and first estimates).
5. :func:`judge`: every finding judged against the others on the fitting and the held-out part.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..twin.replay import LogReplay, Replayed
from . import discovery, library
from .candidates import Candidate, TermCandidate
from .drift import Drift
from .judging import Finding, SearchStep, judge_findings
from .judging import alternatives as judged_alternatives
from .refinement import FindingSet, Refined, probe_batch
from .rest_hold import of_log as rest_hold_of
from .rivals import current_channel, differ_most
from .search import backward, columns_of, forward
from .search import judge as judge_one
from .statistics import BlockGram, rss_of, weighted
from .weighting import OwnVariance, per_channel

#: residuals above this multiple of the noise floor (sqrt 2 sigma: model and log noise) get joint-local terms
FLOOR_FACTOR = 2.0
#: indistinguishable alternatives per finding simulated (for their own estimates) at most
MAX_ALTERNATIVES = 3

Alternatives = dict[Candidate, list[tuple[Candidate, NDArray]]]


@dataclasses.dataclass(frozen=True)
class LibraryRecord:
    """What screening the library chose: the nominal replay of the screened part, the library's columns,
    the weighted residual they were fitted to and the chosen effects with their alternatives."""

    base: Replayed
    X: NDArray            # (n_columns, n, n_channels) linearised library columns
    e0: NDArray           # weighted residual of the nominal model on the screened part
    candidates: list[Candidate]  # every screened candidate, its columns ``cols``
    cols: list[list[int]]
    chosen: list[Candidate]
    chosen_cols: list[int]
    alternatives: Alternatives
    trace: list[SearchStep]
    drift: Drift | None = None  # projected out of ``X`` and ``e0`` (and of the dictionary's columns)
    own_variance: OwnVariance = False  # each channel its own variance in every selection (weighting.per_channel)


@dataclasses.dataclass(frozen=True)
class DiscoveryRecord:
    """The library's findings (the screening's, and those named in place of a dictionary term that explained
    nothing more) and the dictionary's kept terms, their columns ``X[fixed]`` in that order; ``tell_apart``:
    per library finding that stood in for a term, what motion would tell the two apart."""

    X: NDArray
    fixed: list[int]
    library: list[Candidate]
    terms: list[Candidate]
    alternatives: Alternatives
    trace: list[SearchStep]
    tell_apart: dict[Candidate, str] = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class RefineRecord:
    found: list[Candidate]
    first: Refined | None  # None when nothing was found
    nominal: Replayed      # the whole log replayed through the starting model
    alts: list[tuple[int, Candidate, NDArray]]
    finding_set: FindingSet
    # each alternative's effects (in place of its finding, the others at their first estimates), replayed over the
    # fitting part once the findings are judged, for the kept findings only (:func:`alternatives_of_kept`)
    alt_sets: list[tuple] = dataclasses.field(default_factory=list)


@dataclasses.dataclass(frozen=True)
class JudgeRecord:
    findings: list[Finding]
    trace: list[SearchStep]


def drift_of(rp: LogReplay, n: int, rest_hold: bool = False) -> Drift:
    """The nuisance drift of the log's samples ``1..n`` (``drift.py``); ``rest_hold``: with one constant per rest
    interval of each joint's current beside it (``rest_hold.py``)."""
    hold = rest_hold_of(rp.log, n, rp.params.controller.position_bw_Hz) if rest_hold else None
    return Drift(n, rp.log.period_s, rp.signals, rp.log.temperature_C, hold)


def screen_library(rp: LogReplay, n_scr: int, payload_kg: float, kinds: Sequence[str] | None,
                   max_effects: int, progress: Callable[[float], None] | None = None,
                   own_variance: OwnVariance = False, rest_hold: bool = False) -> LibraryRecord:
    """``max_effects``: most library effects named per joint (robot-wide effects count as one more joint).
    ``own_variance``: each channel its own variance in the selections on the screened part, False: pooled.
    ``rest_hold``: the current held in each rest interval fitted beside the drift (``rest_hold.py``)."""
    cands = library.candidates(payload_kg, kinds=kinds, params=rp.params)
    base, X_lib, cands = library.screen(rp, n_scr, cands, progress=progress)
    drift = drift_of(rp, n_scr, rest_hold)
    e0 = drift.remove(weighted(rp.measured(n_scr), base.y, rp.sigma))
    X_lib = drift.remove(X_lib)
    X_w, e_w, _ = per_channel(X_lib, e0, own_variance)  # each channel its own variance (statistics.py)
    cols = columns_of(cands)
    sel = forward(BlockGram.build(X_w, e_w), e_w, X_w, cands, cols, max_effects * (N_JOINTS + 1),
                  per_joint=max_effects)
    alternatives = {cands[k]: [(cands[a], th) for a, th in alt][:MAX_ALTERNATIVES]
                    for k, alt in zip(sel.chosen, sel.alternatives)}
    return LibraryRecord(base, X_lib, e0, cands, cols, [cands[k] for k in sel.chosen],
                         [c for k in sel.chosen for c in cols[k]], alternatives,
                         [SearchStep.of("library", v) for v in sel.trace], drift, own_variance)


def joints_above_floor(e: NDArray, n_signals: int) -> list[int]:
    """Joints whose weighted residual RMS exceeds FLOOR_FACTOR x the noise floor in some signal."""
    rms = np.sqrt(np.mean(e**2, axis=0)).reshape(n_signals, N_JOINTS)
    return [j for j in range(N_JOINTS) if np.any(rms[:, j] > FLOOR_FACTOR * np.sqrt(2.0))]


def discover_terms(rp: LogReplay, lib: LibraryRecord, n_scr: int, max_terms: int) -> DiscoveryRecord:
    X_all, fixed = lib.X[lib.chosen_cols], list(range(len(lib.chosen_cols)))
    if max_terms <= 0:
        return DiscoveryRecord(X_all, fixed, lib.chosen, [], {}, [])
    e0 = lib.e0
    G, g, ee = BlockGram.build(lib.X, e0).total()
    e_lib = e0 - np.tensordot(rss_of(G, g, ee, lib.chosen_cols)[1], lib.X[lib.chosen_cols], axes=1)
    # offered where the library leaves a residual above the floor, and on the joints of the library's
    # findings: a library effect may stand in for a term outside the library (viscous and Coulomb
    # scales for a speed-squared drag); the joint check keeps what explains what the rest does not
    joints = sorted(set(joints_above_floor(e_lib, len(rp.signals)))
                    | {c.joint for c in lib.chosen if c.joint is not None})
    dcands, X_dict = discovery.dictionary(rp, lib.base, n_scr, joints)
    if lib.drift is not None and dcands:
        X_dict = lib.drift.remove(X_dict)
    if not dcands:
        return DiscoveryRecord(X_all, fixed, lib.chosen, [], {}, [])
    X_all = np.concatenate([X_all, X_dict])
    dcols = columns_of(dcands, start=len(lib.chosen_cols))
    X_w, e_w, _ = per_channel(X_all, e0, lib.own_variance)
    sel = forward(BlockGram.build(X_w, e_w), e_w, X_w, dcands, dcols, max_terms, fixed=fixed)
    alternatives = {dcands[k]: [(dcands[a], th) for a, th in alt][:MAX_ALTERNATIVES]
                    for k, alt in zip(sel.chosen, sel.alternatives)}
    trace = [SearchStep.of("dictionary", v) for v in sel.trace]
    if not sel.chosen:
        return DiscoveryRecord(X_all, fixed, lib.chosen, [], alternatives, trace)
    return prefer_library(rp, lib, dcands, X_dict, sel.chosen, alternatives, trace)


def prefer_library(rp: LogReplay, lib: LibraryRecord, dcands: list[TermCandidate], X_dict: NDArray,
                   chosen: list[int], alternatives: Alternatives, trace: list[SearchStep]) -> DiscoveryRecord:
    """A dictionary term is kept only for what no library effect explains: for each chosen term, the library
    effect on its joint that best takes its place beside the other findings is judged; when that effect is
    significant and in range and the term, judged beside it, adds nothing, the library effect is named in its
    place and the term listed as indistinguishable from it on this log (a physical parameter
    with a meaning and a range over a free shape)."""
    X = np.concatenate([lib.X, X_dict])
    X_w, e0, _ = per_channel(X, lib.e0, lib.own_variance)  # each channel its own variance (statistics.py)
    cands: list[Candidate] = [*lib.candidates, *dcands]
    cols = lib.cols + columns_of(dcands, start=lib.X.shape[0])
    bg = BlockGram.build(X_w, e0)
    G, g, ee = bg.total()
    n_lib = len(lib.candidates)
    current = [lib.candidates.index(c) for c in lib.chosen] + [n_lib + k for k in chosen]
    # first every finding judged against all the others (a library effect that only stood in for a term
    # found later leaves, as in the joint check), so that what is left is what a library effect may replace
    current, _, gone = backward(bg, e0, X_w, cands, cols, current)
    trace = trace + [SearchStep.of("linear joint check", dataclasses.replace(
        v, accepted=False, reason=v.reason or "explains nothing the other findings do not")) for v in gone]
    named: list[int] = []
    hints: dict[Candidate, str] = {}
    for t in [o for o in current if o >= n_lib]:
        term = cands[t]
        others = [o for o in current if o != t]
        base = [c for o in others for c in cols[o]]
        options = [k for k in range(n_lib) if k not in current and term.joint is not None
                   and cands[k].joint == term.joint]
        if not options:
            continue
        best = v_lib = None
        # in order of how much of the residual they take up beside the others, the first library effect that
        # is significant and in range (its stability across time blocks is not asked here: the term it
        # replaces varied with the same residual, the model's own error on the joint, and the held-out
        # judgement after refinement drops a finding that does not generalise) and leaves the term nothing
        for k in sorted(options, key=lambda k: rss_of(G, g, ee, base + cols[k])[0]):
            v = judge_one(bg, e0, X_w, cands, cols, others, k)
            if not (v.accepted or v.reason.startswith("unstable across time blocks")):
                continue
            v_term = judge_one(bg, e0, X_w, cands, cols, others + [k], t)
            if not v_term.accepted:
                best, v_lib = k, v
                break
        if best is None:
            continue
        th_term = rss_of(G, g, ee, base + cols[t])[1][len(base):]
        current = [best if o == t else o for o in current]
        named.append(best)
        alternatives[cands[best]] = [(term, th_term), *alternatives.pop(term, [])][:MAX_ALTERNATIVES]
        hints[cands[best]] = tell_apart(rp, lib, X[cols[best]], v_lib.theta, X[cols[t]], th_term, term.joint)
        trace.append(SearchStep.of("library preferred", dataclasses.replace(
            v_term, accepted=False, reason=f"explains nothing {cands[best].label} does not: the library effect is "
                                           f"named, the term listed as indistinguishable")))
    library_found = [cands[o] for o in current if o < n_lib]
    terms = [cands[o] for o in current if o >= n_lib]
    idx = [c for o in current if o < n_lib for c in cols[o]] + [c for o in current if o >= n_lib for c in cols[o]]
    return DiscoveryRecord(X[idx], list(range(len(idx))), library_found, terms, alternatives, trace, hints)


def tell_apart(rp: LogReplay, lib: LibraryRecord, X_a: NDArray, th_a, X_b: NDArray, th_b, joint: int | None) -> str:
    """Where two fitted shapes differ most on the joint's current (the operating condition with the largest
    RMS difference, as a share of their own RMS): a motion with more of it would tell them apart."""
    if joint is None:
        return ""
    n = lib.e0.shape[0]
    ch = current_channel(rp.signals, joint)
    a = np.tensordot(np.asarray(th_a), X_a, axes=1)[:, ch]
    b = np.tensordot(np.asarray(th_b), X_b, axes=1)[:, ch]
    return differ_most(rp.log, n, lib.base.torque_gear_Nm, a, b, joint)


def refine(rp: LogReplay, found: list[Candidate], X: NDArray, fixed: list[int], e0: NDArray,
           alternatives: Alternatives, n_fit: int, progress=None, own_variance: OwnVariance = False) -> RefineRecord:
    fs = FindingSet(found)
    alts = [(i, a, th) for i, c in enumerate(found) for a, th in alternatives.get(c, [])]
    if not found:
        return RefineRecord(found, None, rp.run([()], rp.n_samples, progress)[0], alts, fs)
    G, g, ee = BlockGram.build(*per_channel(X[fixed], e0, own_variance)[:2]).total()
    theta0 = rss_of(G, g, ee, list(range(len(fixed))))[1]
    first = probe_batch(fs.evaluator(rp, progress), theta0, fs.probes(theta0), fs.bounds(), n_fit)
    # the alternatives are sized beside the others at the probe batch's estimate (clipped to the ranges, as there)
    return RefineRecord(found, first, first.sim0, alts, fs, fs.alternative_sets(np.clip(theta0, *fs.bounds()), alts))


def kept_alternatives(ref: RefineRecord, kept: Sequence[Finding]) -> list[int]:
    """Positions in ``ref.alts`` of the alternatives of the ``kept`` findings (those the judgement kept): the only
    ones :func:`ur5fault.discrepancy.judging.alternatives` sizes."""
    cands = {f.candidate for f in kept}
    return [a for a, (i, _, _) in enumerate(ref.alts) if ref.found[i] in cands]


def alternatives_of_kept(rp: LogReplay, ref: RefineRecord, kept: Sequence[Finding], n_fit: int,
                         drift: Drift | None = None, progress=None) -> None:
    """The indistinguishable alternatives of each finding the judgement kept (``kept``, in its order) with their own
    coefficients (``f.alternatives``), as :func:`ur5fault.discrepancy.judging.alternatives` sizes them from the probe
    batch.  Each is replayed over the fitting part here (or taken from a prefetch the caller started,
    :func:`kept_alternatives`), not in the probe batch: those of a finding the judgement drops are never sized, so
    they are not replayed, and a replay does not depend on the batch it is simulated in.  A finding dropped later
    (at the final check) keeps the alternatives it had when judged, as before."""
    which = kept_alternatives(ref, kept)
    if not which:
        return
    sims = rp.run([ref.alt_sets[a] for a in which], n_fit, progress)
    meas = rp.measured(rp.n_samples)[:n_fit]
    extra_e: list[NDArray | None] = [None] * len(ref.alts)
    for a, s in zip(which, sims):
        extra_e[a] = weighted(meas, s.y, rp.sigma) if s.ok else None
    first = dataclasses.replace(ref.first, extra_e=extra_e)
    found = list(ref.found)
    J_fit = ref.first.J[:, :n_fit]
    if drift is not None:
        J_fit = drift.remove(J_fit)
    idx = [found.index(f.candidate) for f in kept]
    for f, k in zip(kept, idx):
        f.alternatives = judged_alternatives(ref.finding_set, idx, k, first, J_fit, columns_of(found), n_fit, ref.alts)


def judge(ref: RefineRecord, n_fit: int, n_signals: int, drift: Drift | None = None,
          own_variance: OwnVariance = False) -> JudgeRecord:
    """``drift``: the nuisance drift of the fitting part, projected out before the findings are judged there."""
    if not ref.found:
        return JudgeRecord([], [])
    findings, trace = judge_findings(ref.found, ref.first, n_fit, n_signals, ref.alts, drift, own_variance)
    return JudgeRecord(findings, list(trace))
