"""The steps of the discrepancy fit, each a function of explicit inputs that returns a record (the trace of
what it chose and why); :class:`ur5fault.discrepancy.model.DiscrepancyModel` only chains them.  No step
knows of the estimator.

1. :func:`screen_library`: every effect of the registry in one lockstep batch, selected forward on the
   linearised problem.
2. :func:`discover_terms`: the dictionary's terms on what the library leaves (library columns free).
3. :func:`joint_check`: the findings selected afresh among themselves (linear, free) so that library effects
   that only stood in for a term discovered later are not re-simulated.
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
from .candidates import Candidate
from .judging import Finding, SearchStep, judge_findings
from .refinement import FindingSet, Refined, probe_batch
from .search import backward, columns_of, forward
from .search import judge as judge_one
from .statistics import BlockGram, rss_of, weighted

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
    chosen: list[Candidate]
    chosen_cols: list[int]
    alternatives: Alternatives
    trace: list[SearchStep]


@dataclasses.dataclass(frozen=True)
class DiscoveryRecord:
    """The library's chosen columns and the dictionary's chosen terms' columns (``X[fixed]``)."""

    X: NDArray
    fixed: list[int]
    terms: list[Candidate]
    alternatives: Alternatives
    trace: list[SearchStep]


@dataclasses.dataclass(frozen=True)
class JointCheckRecord:
    found: list[Candidate]
    fixed: list[int]      # columns of ``found`` in the discovery's ``X``
    trace: list[SearchStep]


@dataclasses.dataclass(frozen=True)
class RefineRecord:
    found: list[Candidate]
    first: Refined | None  # None when nothing was found
    nominal: Replayed      # the whole log replayed through the starting model
    alts: list[tuple[int, Candidate, NDArray]]
    finding_set: FindingSet


@dataclasses.dataclass(frozen=True)
class JudgeRecord:
    findings: list[Finding]
    trace: list[SearchStep]


def screen_library(rp: LogReplay, n_scr: int, payload_kg: float, kinds: Sequence[str] | None,
                   max_effects: int, progress: Callable[[float], None] | None = None) -> LibraryRecord:
    cands = library.candidates(payload_kg, kinds=kinds, params=rp.params)
    base, X_lib, cands = library.screen(rp, n_scr, cands, progress=progress)
    e0 = weighted(rp.measured(n_scr), base.y, rp.sigma)
    bg = BlockGram.build(X_lib, e0)
    cols = columns_of(cands)
    sel = forward(bg, e0, X_lib, cands, cols, max_effects)
    alternatives = {cands[k]: [(cands[a], th) for a, th in alt][:MAX_ALTERNATIVES]
                    for k, alt in zip(sel.chosen, sel.alternatives)}
    return LibraryRecord(base, X_lib, e0, [cands[k] for k in sel.chosen],
                         [c for k in sel.chosen for c in cols[k]], alternatives,
                         [SearchStep.of("library", v) for v in sel.trace])


def joints_above_floor(e: NDArray, n_signals: int) -> list[int]:
    """Joints whose weighted residual RMS exceeds FLOOR_FACTOR x the noise floor in some signal."""
    rms = np.sqrt(np.mean(e**2, axis=0)).reshape(n_signals, N_JOINTS)
    return [j for j in range(N_JOINTS) if np.any(rms[:, j] > FLOOR_FACTOR * np.sqrt(2.0))]


def discover_terms(rp: LogReplay, lib: LibraryRecord, n_scr: int, max_terms: int) -> DiscoveryRecord:
    X_all, fixed = lib.X[lib.chosen_cols], list(range(len(lib.chosen_cols)))
    if max_terms <= 0:
        return DiscoveryRecord(X_all, fixed, [], {}, [])
    e0 = lib.e0
    G, g, ee = BlockGram.build(lib.X, e0).total()
    e_lib = e0 - np.tensordot(rss_of(G, g, ee, lib.chosen_cols)[1], lib.X[lib.chosen_cols], axes=1)
    # offered where the library leaves a residual above the floor, and on the joints of the library's
    # findings: a library effect may stand in for a term outside the library (viscous and Coulomb
    # scales for a speed-squared drag); the joint check keeps what explains what the rest does not
    joints = sorted(set(joints_above_floor(e_lib, len(rp.signals)))
                    | {c.joint for c in lib.chosen if c.joint is not None})
    dcands, X_dict = discovery.dictionary(rp, lib.base, n_scr, joints)
    if not dcands:
        return DiscoveryRecord(X_all, fixed, [], {}, [])
    X_all = np.concatenate([X_all, X_dict])
    dcols = columns_of(dcands, start=len(lib.chosen_cols))
    sel = forward(BlockGram.build(X_all, e0), e0, X_all, dcands, dcols, max_terms, fixed=fixed)
    fixed = fixed + [c for k in sel.chosen for c in dcols[k]]
    alternatives = {dcands[k]: [(dcands[a], th) for a, th in alt][:MAX_ALTERNATIVES]
                    for k, alt in zip(sel.chosen, sel.alternatives)}
    return DiscoveryRecord(X_all, fixed, [dcands[k] for k in sel.chosen], alternatives,
                           [SearchStep.of("dictionary", v) for v in sel.trace])


def joint_check(found: list[Candidate], X: NDArray, fixed: list[int], e0: NDArray) -> JointCheckRecord:
    if len(found) <= 1:
        return JointCheckRecord(found, fixed, [])
    fcols = columns_of(found)
    Xf = X[fixed]
    bg = BlockGram.build(Xf, e0)
    again = forward(bg, e0, Xf, found, fcols, len(found))
    keep, _, _ = backward(bg, e0, Xf, found, fcols, again.chosen)
    trace = []
    for k in range(len(found)):
        if k not in keep:
            v = judge_one(bg, e0, Xf, found, fcols, keep, k)
            trace.append(SearchStep.of("linear joint check", dataclasses.replace(
                v, accepted=False, reason=v.reason or "explains nothing the other findings do not")))
    keep = sorted(keep)
    return JointCheckRecord([found[k] for k in keep], [fixed[c] for k in keep for c in fcols[k]], trace)


def refine(rp: LogReplay, found: list[Candidate], X: NDArray, fixed: list[int], e0: NDArray,
           alternatives: Alternatives, n_fit: int, progress=None) -> RefineRecord:
    fs = FindingSet(found)
    alts = [(i, a, th) for i, c in enumerate(found) for a, th in alternatives.get(c, [])]
    if not found:
        return RefineRecord(found, None, rp.run([()], rp.n_samples, progress)[0], alts, fs)
    G, g, ee = BlockGram.build(X[fixed], e0).total()
    theta0 = rss_of(G, g, ee, list(range(len(fixed))))[1]
    evaluate = fs.evaluator(rp, progress)
    first = probe_batch(evaluate, theta0, fs.probes(theta0), fs.bounds(), n_fit, alts, evaluate)
    return RefineRecord(found, first, first.sim0, alts, fs)


def judge(ref: RefineRecord, n_fit: int, n_signals: int) -> JudgeRecord:
    if not ref.found:
        return JudgeRecord([], [])
    findings, trace = judge_findings(ref.found, ref.first, n_fit, n_signals, ref.alts)
    return JudgeRecord(findings, list(trace))
