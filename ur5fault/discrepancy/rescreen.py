"""A dropped finding gives its joint's place back: the joint's library effects are screened again.

The per-joint budget (``--max-effects``) is spent when a finding enters refinement.  A finding dropped later
(on the held-out part, or at the final check once refined) leaves its joint with the residual it was chosen
for but without a place for another effect: on the real NIST log with the base's Coulomb friction x 1.79 the
library named the Coulomb scale, discovery put a Stribeck-like term (v_s = 0.2 rad/s) in its place, and the
final check dropped the term as unstable across time blocks, so the joint ended with nothing although its
held-out current residual was 0.37 A (docs/discrepancy.md, *Hidden effects in the real logs*).

Here every joint left with a free place by a drop gets it back: its library effects other than those dropped
are selected afresh on the screened part's linearised problem (the library's own columns, beside the drift),
against the residual of the final model; each one chosen is simulated once over the whole log beside the kept
findings (its secant is the column), sized on the whole fitting part beside the drift, judged there with the
same tests as every finding and on the held-out part, and, when it passes, the model is simulated once more
at the judged sizes.

A dropped robot-wide finding (a payload mass) frees every joint with a free place, not only the robot-wide one:
it acts on every joint, and beside it the joints' own effects were not chosen (the NIST log with the elbow's
current offset by -0.15 A: the payload mass took the elbow's gravity-shaped change at screening, was dropped on
the held-out part, and the elbow was never offered again).  On such a joint a current gain, a torque constant
and an offset are nearly one shape on the fitting part, and which one the selection takes is decided by the
model's own error; so the best MAX_RIVALS other effects that pass every test in the chosen one's place are
simulated too, and each that passes the held-out check and leaves the joint's held-out residual no worse by
MIN_DELTA_BIC is listed as an indistinguishable alternative (``rivals.py``, the same rule every named finding's
rivals are judged by).  The rivals are chosen on the screened part with the effects, but simulated only for the
effects that are kept after the whole-log checks, in the batch that re-simulates the final model: the rivals of a
dropped one would be judged against nothing (its replays do not depend on the batch they are simulated in, so
what is listed is the same).

Last, every effect kept here must stand out of the scatter of the model's own replays under other noise seeds
(``replay_noise.py``), as every finding of the final check; one that does not is dropped and the model simulated
again without it.  The others keep the sizes and rivals fitted beside it: effects named on different joints act
on different channels, so the drop hardly moves them (two on one joint, ``--max-effects`` 2, could move more).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..twin.replay import LogReplay, Replayed
from .candidates import Candidate
from .drift import Drift
from .judging import Finding, SearchStep, channels
from .replay_noise import scatter_of, with_scatter
from .rivals import MAX_RIVALS, Rival, current_channel, differ_most, in_place, indistinguishable_held_out, judge_rival
from .search import backward, columns_of, forward, judge
from .statistics import MIN_Z, BlockGram, below, generalisation, rss_of, weighted
from .weighting import OwnVariance, per_channel

__all__ = ["MAX_RIVALS", "freed_joints", "indistinguishable_held_out", "rescreen", "rivals_of", "select_on_freed"]

#: a second simulation at the judged sizes is spared when every size is within this share of the simulated one
SIZE_RTOL = 0.01


@dataclasses.dataclass(frozen=True)
class RescreenRecord:
    """The findings named on freed joints (kept, or dropped with their reasons), the trace, and the final model
    (``after``: unchanged when nothing was named)."""

    findings: list[Finding]
    trace: list[SearchStep]
    after: Replayed


def freed_joints(findings: Sequence[Finding], max_effects: int) -> list[int | None]:
    """Joints (None: robot-wide) where a finding was dropped and fewer than ``max_effects`` library findings
    are kept: each has a place for another library effect."""
    out: list[int | None] = []
    for f in findings:
        if f.kept or f.within_scatter:  # a residual within the model's own replay scatter frees nothing
            continue
        # a robot-wide finding (a payload) acts on every joint: beside it the joints' own effects were not chosen
        for j in [f.candidate.joint] if f.candidate.joint is not None else [None, *range(N_JOINTS)]:
            n_kept = sum(1 for g in findings if g.kept and g.candidate.source == "library" and g.candidate.joint == j)
            if j not in out and n_kept < max_effects:
                out.append(j)
    return out


def rivals_of(X: NDArray, e: NDArray, candidates: Sequence[Candidate], cols: list[list[int]],
              findings: Sequence[Finding], chosen: Sequence[tuple[int, NDArray]], own_variance: OwnVariance = False
              ) -> list[tuple[int, int, NDArray]]:
    """For each candidate chosen on a freed joint, the other offered candidates on that joint that pass every
    test in its place (at most MAX_RIVALS, by improvement): ``(position in chosen, k, theta)``."""
    out = []
    taken = {f.candidate.label for f in findings} | {candidates[k].label for k, _ in chosen}
    for pos, (k, _) in enumerate(chosen):
        out += [(pos, r, th) for r, th in in_place(X, e, e, candidates, cols, taken, candidates[k].joint,
                                                   share=0.0, robot_wide=False, own_variance=own_variance)]
    return out


def offered(candidates: Sequence[Candidate], findings: Sequence[Finding], joint: int | None) -> list[int]:
    """Indices of the library candidates on ``joint`` that are neither kept nor dropped findings."""
    taken = {f.candidate.label for f in findings}
    return [k for k, c in enumerate(candidates) if c.joint == joint and c.label not in taken]


def select_on_freed(X: NDArray, e: NDArray, candidates: Sequence[Candidate], cols: list[list[int]],
                    findings: Sequence[Finding], max_effects: int, own_variance: OwnVariance = False
                    ) -> tuple[list[tuple[int, NDArray]], list]:
    """Forward selection, joint by joint, among the library candidates offered on each freed joint.

    Args:
        X: the library's linearised columns on the screened part ``(n_columns, n, n_channels)``.
        e: the weighted residual of the final model there (both with the drift projected out).

    Returns:
        ``(k, theta)`` of each candidate chosen (indices into ``candidates``), and the verdicts of the trace.
    """
    chosen, trace = [], []
    for j in freed_joints(findings, max_effects):
        ks = offered(candidates, findings, j)
        if not ks:
            continue
        sub = [candidates[k] for k in ks]
        idx = [c for k in ks for c in cols[k]]
        Xs, e_j, _ = per_channel(X[idx], e, own_variance)  # each channel its own variance (statistics.py)
        scols = columns_of(sub)
        bg = BlockGram.build(Xs, e_j)
        budget = max_effects - sum(1 for f in findings if f.kept and f.candidate.source == "library"
                                   and f.candidate.joint == j)
        sel = forward(bg, e_j, Xs, sub, scols, budget, per_joint=budget)
        trace += sel.trace
        G, g, ee = bg.total()
        th = rss_of(G, g, ee, [c for k in sel.chosen for c in scols[k]])[1]
        i = 0
        for k in sel.chosen:
            n = sub[k].n_coef
            chosen.append((ks[k], th[i : i + n]))
            i += n
    return chosen, trace


def rescreen(rp: LogReplay, lib_X: NDArray, lib_drift: Drift | None, candidates: Sequence[Candidate],
             findings: Sequence[Finding], after: Replayed, n_scr: int, n_fit: int, drift: Drift | None,
             max_effects: int, progress: Callable[[float], None] | None = None, own_variance: OwnVariance = False
             ) -> RescreenRecord:
    """Name library effects on the joints that dropped findings freed (module docstring).

    Args:
        lib_X: the library's columns on the screened part (drift removed); ``candidates`` their candidates.
        findings: every finding so far, kept and dropped; ``after``: the replay of the kept ones.
        drift: the drift of the fitting part (``n_fit`` samples).
    """
    cols = columns_of(candidates)
    meas = rp.measured(rp.n_samples)
    e_after = weighted(meas, after.y, rp.sigma)
    e_scr = e_after[:n_scr] if lib_drift is None else lib_drift.remove(e_after[:n_scr])
    chosen, lin_trace = select_on_freed(lib_X, e_scr, candidates, cols, findings, max_effects, own_variance)
    trace = [SearchStep.of("re-screened joint", v) for v in lin_trace]
    if not chosen:
        return RescreenRecord([], trace, after)
    kept_specs = tuple(f.spec() for f in findings if f.kept)
    new = [(candidates[k], th) for k, th in chosen]
    rivals = rivals_of(lib_X, e_scr, candidates, cols, findings, chosen, own_variance)
    sims = rp.run([kept_specs + (c.spec(th),) for c, th in new], rp.n_samples, progress)
    # each one's secant beside the kept findings: the change of the weighted readings per unit multiple of its
    # linearised size (a coefficient pair keeps its direction)
    ok = [s.ok for s in sims]
    J = np.stack([e_after - weighted(meas, s.y, rp.sigma) if s.ok else np.zeros_like(e_after) for s in sims])
    J_fit, e_fit = J[:, :n_fit], e_after[:n_fit]
    if drift is not None:
        J_fit, e_fit = drift.remove(J_fit), drift.remove(e_fit)
    names = [c for c, _ in new]
    scaled = [_Scaled(c, th) for c, th in new]
    one = [[i] for i in range(len(new))]
    J_fit, e_fit, scale = per_channel(J_fit, e_fit, own_variance)  # each channel its own variance (statistics.py)
    bg = BlockGram.build(J_fit, e_fit)
    G, g, ee = bg.total()
    keep, _, gone = backward(bg, e_fit, J_fit, scaled, one, [i for i in range(len(new)) if ok[i]])
    out: list[Finding] = []
    for v in gone:
        i = next(i for i, c in enumerate(names) if c.label == v.label)
        out.append(_finding(names[i], new[i][1], v.theta[0], v, kept=False,
                            reason=f"explains nothing the kept findings do not ({v.reason})"))
    e_held = e_after[n_fit:]
    while keep:
        a = rss_of(G, g, ee, keep)[1]
        with_all = e_held - np.tensordot(a, J[keep, n_fit:], axes=1)
        worst, gens = None, {}
        for i, ai in zip(keep, a):
            ch = channels(names[i], len(rp.signals))
            gens[i] = gen = generalisation(with_all[:, ch], (with_all + ai * J[i, n_fit:])[:, ch])
            why = names[i].range_problem(new[i][1] * ai)
            if why or (not gen.passes and (worst is None or gen.ratio < gens[worst].ratio)):
                worst = i
                if why:
                    break
        if worst is None:
            break
        v = judge(bg, e_fit, J_fit, scaled, one, [o for o in keep if o != worst], worst)
        ai = float(a[keep.index(worst)])
        why = names[worst].range_problem(new[worst][1] * ai) or (
            f"does not generalise: on the held-out part it removes {100 * gens[worst].ratio:.0f} % of the change it "
            "makes")
        out.append(_finding(names[worst], new[worst][1], ai, v, held_out=gens[worst], kept=False, reason=why))
        keep.remove(worst)
    if not keep:
        trace += [SearchStep.of("re-screened joint, whole log", dataclasses.replace(f.verdict, accepted=False,
                                                                                    reason=f.reason)) for f in out]
        return RescreenRecord(out, trace, after)
    a = rss_of(G, g, ee, keep)[1]
    named = []
    for i, ai in zip(keep, a):
        v = judge(bg, e_fit, J_fit, scaled, one, [o for o in keep if o != i], i)
        named.append(_finding(names[i], new[i][1], float(ai), v, held_out=gens[i]))
    # the final model (when the judged sizes moved) and the rivals of the kept effects only, in one batch
    again = not (len(keep) == 1 and abs(float(a[0]) - 1.0) <= SIZE_RTOL)
    wanted = [(pos, k, th) for pos, k, th in rivals if pos in keep]
    sets = (([kept_specs + tuple(f.spec() for f in named)] if again else [])
            + [kept_specs + (candidates[k].spec(th),) for _, k, th in wanted])
    runs = rp.run(sets, rp.n_samples, progress) if sets else []
    final = runs[0] if again else sims[keep[0]]
    rival_sims = runs[1:] if again else runs
    for f, i in zip(named, keep):
        f.rivals = _rivals_held_out(rp, e_after, J, keep, a, i, n_fit, drift,
                                    [(candidates[k], th, s) for (pos, k, th), s in zip(wanted, rival_sims)
                                     if pos == i and s.ok], after.torque_gear_Nm, names[i])
        f.alternatives = [(r.candidate, r.theta) for r in f.rivals]
    # as every kept finding: its estimate must stand out of the scatter of the model's own replays (the model
    # ``final`` was simulated with: at the linearised size when it was not simulated again)
    final_specs = (kept_specs + tuple(f.spec() for f in named) if again
                   else kept_specs + (names[keep[0]].spec(new[keep[0]][1]),))
    scatter = scatter_of(rp, final_specs, final, n_fit, J_fit, [[i] for i in keep], scale, own_variance, drift,
                         progress)
    for f, i, sc in zip(named, keep, scatter):
        if sc is None:
            continue
        v, lin = f.verdict, np.abs(np.ravel(new[i][1]))  # v: in the candidate's coefficients (_finding)
        k = int(np.argmax(lin))
        a_i, se_i = float(a[keep.index(i)]), float(np.hypot(v.se[k] / lin[k], sc[0]))  # in multiples of lin
        z = abs(a_i) / se_i if se_i > 0 else 0.0
        f.replay_scatter = np.abs(np.asarray(new[i][1], dtype=float)) * sc[0]
        f.se = with_scatter(f.se, f.replay_scatter)
        f.within_scatter = v.accepted and z < MIN_Z
        f.verdict = dataclasses.replace(v, se=tuple(float(x) for x in f.se), z=z, accepted=v.accepted and z >= MIN_Z)
        if f.within_scatter:
            f.kept, f.rivals, f.alternatives = False, [], []
            f.reason = (f"within the scatter of the model's own replays (z {below(z, MIN_Z)} < {MIN_Z:g} with the "
                        f"scatter of its replays under other noise seeds, {v.z:.1f} without)")
    if any(f.within_scatter for f in named):
        rest = kept_specs + tuple(f.spec() for f in named if f.kept)
        final = rp.run([rest], rp.n_samples, progress)[0] if len(rest) > len(kept_specs) else after
    trace += [SearchStep.of("re-screened joint, whole log", dataclasses.replace(f.verdict, accepted=f.kept,
                                                                                reason=f.reason))
              for f in named + out]
    return RescreenRecord(named + out, trace, final)


def _rivals_held_out(rp: LogReplay, e_after: NDArray, J: NDArray, keep: list[int], a: NDArray, i: int, n_fit: int,
                     drift: Drift | None, rivals: list[tuple[Candidate, NDArray, Replayed]], torque: NDArray,
                     finding: Candidate) -> list[Rival]:
    """The rivals of re-screened finding ``i`` that the held-out part cannot tell from it: each sized on the
    fitting part in its place beside the other kept re-screened findings (its secant is its column), it must
    pass the held-out check itself and leave the joint's held-out residual no worse than ``i`` does by
    MIN_DELTA_BIC (:func:`ur5fault.discrepancy.rivals.judge_rival`).  On a joint whose current is gravity of one
    sign a current gain, a torque constant and an offset are nearly one shape on the fitting part, and which of
    them the selection takes there is decided by the model's own error; the report must then name them all."""
    meas = rp.measured(rp.n_samples)
    others = [o for o in keep if o != i]
    named = e_after - np.tensordot(a, J[keep], axes=1)
    e_place = named + a[keep.index(i)] * J[i]
    out = []
    for cand, th, sim in rivals:
        ch = channels(cand, len(rp.signals))
        col = e_after - weighted(meas, sim.y, rp.sigma)
        got = judge_rival(e_after, col, named, n_fit, ch, drift, J[others])
        if got is None or cand.range_problem(th * got[0]):
            continue
        b, ratio, dbic = got
        j = finding.joint
        hint = "" if j is None else differ_most(rp.log, rp.n_samples, torque,
                                                (e_place - named)[:, current_channel(rp.signals, j)],
                                                b * col[:, current_channel(rp.signals, j)], j)
        out.append(Rival(cand, np.asarray(th, dtype=float) * b, ratio, dbic, hint))
    return out


def _finding(c: Candidate, theta: NDArray, a: float, v, **kw) -> Finding:
    """The finding of ``c`` at ``a`` x its linearised size ``theta``, its verdict (judged in multiples of that
    size) given in the candidate's own coefficients."""
    th, se = np.asarray(theta, dtype=float) * a, np.abs(np.asarray(theta, dtype=float)) * v.se[0]
    v = dataclasses.replace(v, theta=tuple(float(x) for x in th), se=tuple(float(x) for x in se))
    return Finding(c, th, se, v, **kw)


class _Scaled:
    """A candidate judged in units of a multiple of its linearised size ``theta`` (one coefficient):
    :func:`ur5fault.discrepancy.search.judge` asks each candidate for its label and valid bounds."""

    def __init__(self, c: Candidate, theta: NDArray) -> None:
        self.label, self.joint, self.n_coef = c.label, c.joint, 1
        lo, hi = (np.broadcast_to(np.asarray(b, dtype=float), np.shape(theta)) for b in c.bounds())
        th = np.asarray(theta, dtype=float)
        a_lo, a_hi = -np.inf, np.inf
        for t, low, high in zip(th.ravel(), lo.ravel(), hi.ravel()):
            if t > 0:
                a_lo, a_hi = max(a_lo, low / t), min(a_hi, high / t)
            elif t < 0:
                a_lo, a_hi = max(a_lo, high / t), min(a_hi, low / t)
        self._bounds = (np.array([a_lo]), np.array([a_hi]))

    def bounds(self) -> tuple[NDArray, NDArray]:
        return self._bounds
