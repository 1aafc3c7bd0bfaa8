"""Judging the findings after re-simulation: what each explains that nothing else does, on the fitting
part and on the held-out part, and the findings' records (:class:`Finding`, :class:`SearchStep`)."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..sim.axes import N_JOINTS
from ..sim.effects import EffectSpec
from .candidates import Candidate
from .drift import Drift
from .refinement import FindingSet, Refined
from .replay_noise import in_metric, replay_scatter, with_scatter
from .search import Verdict, backward, columns_of, forward, judge
from .statistics import MIN_Z, Z_95, BlockGram, Generalisation, amplitude_z, below, generalisation, rss_of
from .weighting import OwnVariance, per_channel


@dataclasses.dataclass
class Finding:
    """A library effect or a discovered term the workflow adds to the model.

    Attributes:
        candidate: what it is (effect, joint, parameter or dictionary family).
        theta: its coefficients; ``se`` their block-jackknife standard errors.
        verdict: its final judgement against all the other findings.
        alternatives: candidates this log cannot tell from it, with their own coefficients.
        held_out: what it does on the held-out part (None if it was dropped before that check).
        kept: False when it was dropped; ``reason`` says why.
        tell_apart: what motion would tell it from a dictionary term it stood in for ("" when none).
        rivals: the library effects the held-out part cannot tell from it (``rivals.py``), each also among
            ``alternatives``.
    """

    candidate: Candidate
    theta: NDArray
    se: NDArray
    verdict: Verdict | None
    alternatives: list[tuple[Candidate, NDArray]] = dataclasses.field(default_factory=list)
    held_out: Generalisation | None = None
    kept: bool = True
    reason: str = ""
    tell_apart: str = ""
    rivals: list = dataclasses.field(default_factory=list)
    #: the RMS of its estimate on replays of the model under other noise seeds (``replay_noise.py``; None: not
    #: measured), added to ``se``; ``within_scatter``: dropped because it does not stand out of it
    replay_scatter: NDArray | None = None
    within_scatter: bool = False

    @property
    def label(self) -> str:
        """What it is, e.g. ``shoulder_lift_joint: torque_constant.scale``."""
        return self.candidate.label

    @property
    def values(self) -> dict[str, float]:
        """Its effect's parameter values as fitted; a dropped finding's may lie outside the effect's valid range."""
        return self.candidate.values(self.theta)

    def spec(self) -> EffectSpec:
        """The effect it adds to the model (a kept finding's is in ``model.yaml``). A finding dropped for an estimate
        outside its effect's valid range has none: refused with the reason (its fitted values: :attr:`values`)."""
        problem = self.candidate.range_problem(self.theta)
        if problem is not None:
            raise ParameterError(f"{self.label}: {problem}, so it is no effect of a model (dropped: {self.reason}); "
                                 "its fitted values are Finding.values")
        return self.candidate.spec(self.theta)

    def interval(self) -> tuple[NDArray, NDArray]:
        return self.theta - Z_95 * self.se, self.theta + Z_95 * self.se


@dataclasses.dataclass(frozen=True)
class SearchStep:
    """One judgement of the search trace: stage, candidate, estimate, the tests and the decision."""

    stage: str
    candidate: str
    estimate: tuple[float, ...]
    delta_bic: float
    z: float
    block_ratios: tuple[float, ...]
    accepted: bool
    reason: str

    @classmethod
    def of(cls, stage: str, v: Verdict) -> SearchStep:
        return cls(stage, v.label, v.theta, v.delta_bic, v.z, v.stability.ratios, v.accepted, v.reason)


def channels(c: Candidate, n_signals: int) -> NDArray:
    """Flat channel mask of what a finding acts on: its joint's signals, or every channel."""
    ch = np.zeros((n_signals, N_JOINTS), dtype=bool)
    if c.local:
        ch[:, c.joint] = True
    else:
        ch[:] = True
    return ch.ravel()


def judge_findings(found: Sequence[Candidate], ref: Refined, n_fit: int, n_signals: int,
                   alts: Sequence[tuple[int, Candidate, NDArray]] = (), drift: Drift | None = None,
                   own_variance: OwnVariance = False) -> tuple[list[Finding], list[SearchStep]]:
    """Judge the findings on the problem linearised by the probe batch ``ref``.

    On the fitting part they are selected afresh from among themselves (two that only cancel each other,
    e.g. a viscous scale and a negative viscous term beside a speed-squared drag, do not both stay) and
    each is checked against all the rest; on the held-out part, each kept finding's change there (from the
    simulated Jacobian) must move the model towards the measurement; the worst that does not is dropped
    and the rest judged again.

    ``drift``: the model's own drift on the fitting part (``drift.py``), fitted beside the findings there.

    Returns:
        The kept findings (then the dropped ones, with their reasons) and the trace of the drops.
    """
    found = list(found)
    cols = columns_of(found)
    J_fit = ref.J[:, :n_fit]
    e_pseudo = ref.e[:n_fit] + np.tensordot(ref.theta, J_fit, axes=1)  # the residual without the findings
    if drift is not None:
        J_fit, e_pseudo = drift.remove(J_fit), drift.remove(e_pseudo)
    J_w, e_pseudo, _ = per_channel(J_fit, e_pseudo, own_variance)  # each channel its own variance (statistics.py)
    bg = BlockGram.build(J_w, e_pseudo)
    G, g, ee = bg.total()
    again = forward(bg, e_pseudo, J_w, found, cols, len(found))
    kept, _, _ = backward(bg, e_pseudo, J_w, found, cols, again.chosen)
    dropped: list[Finding] = []
    for k in range(len(found)):
        if k not in kept:
            v = judge(bg, e_pseudo, J_w, found, cols, kept, k)
            reason = v.reason or "explains nothing the other findings do not"
            dropped.append(Finding(found[k], np.asarray(v.theta), np.asarray(v.se), v, kept=False,
                                   reason=f"explains nothing the others do not ({reason})"))
    e_held = ref.e[n_fit:] + np.tensordot(ref.theta, ref.J[:, n_fit:], axes=1)
    out: list[Finding] = []
    while kept:
        idx = [c for k in kept for c in cols[k]]
        theta = rss_of(G, g, ee, idx)[1]  # the kept findings refitted without the dropped ones
        with_all = e_held - np.tensordot(theta, ref.J[idx, n_fit:], axes=1)
        out, i, worst = [], 0, None
        for k in kept:
            c = found[k]
            th = theta[i : i + c.n_coef]
            change = np.tensordot(th, ref.J[cols[k], n_fit:], axes=1)
            i += c.n_coef
            ch = channels(c, n_signals)
            f = Finding(c, th, np.zeros(c.n_coef), None, held_out=generalisation(with_all[:, ch],
                                                                               (with_all + change)[:, ch]))
            out.append(f)
            if not f.held_out.passes and (worst is None or f.held_out.ratio < worst[1].held_out.ratio):
                worst = (k, f)
        # a value outside an effect's range cannot go into a model: dropped first, the rest refitted
        bad = next(((k, f, why) for k, f in zip(kept, out) if (why := f.candidate.range_problem(f.theta))), None)
        if worst is None and bad is None:
            break
        if bad is not None:
            k, f, why = bad
            f.kept, f.reason = False, why
        else:
            k, f = worst
            f.kept = False
            f.reason = (f"does not generalise: on the held-out part it removes {100 * f.held_out.ratio:.0f} % of "
                        "the change it makes")
        f.verdict = judge(bg, e_pseudo, J_w, found, cols, [o for o in kept if o != k], k)
        f.se = np.asarray(f.verdict.se)
        dropped.append(f)
        kept.remove(k)
        out = []
    trace = [SearchStep.of("held-out check" if f.held_out else "joint check",
                           dataclasses.replace(f.verdict, accepted=False, reason=f.reason)) for f in dropped]
    fs = FindingSet(found)
    for k, f in zip(kept, out):  # final verdicts and alternatives, against the kept findings
        f.verdict = judge(bg, e_pseudo, J_w, found, cols, [o for o in kept if o != k], k)
        f.se = np.asarray(f.verdict.se)
        f.alternatives = alternatives(fs, kept, k, ref, J_fit, cols, n_fit, alts)
    return out + dropped, trace


def alternatives(fs: FindingSet, kept: list[int], k: int, ref: Refined, J_fit: NDArray, cols: list[list[int]],
                 n_fit: int, alts: Sequence[tuple[int, Candidate, NDArray]]) -> list[tuple[Candidate, NDArray]]:
    """Each simulated alternative's own coefficients in place of finding ``k``: its secant from the run with
    finding ``k`` removed (both with the others at their first estimates), fitted on the fitting part to
    what that run leaves (the other kept findings' columns take up their small differences)."""
    out = []
    others = [c for o in kept if o != k for c in cols[o]]
    e_without = ref.probe_e[fs.first_probe(k)]
    for (i, cand, th0), e_alt in zip(alts, ref.extra_e):
        if i != k or e_alt is None or e_without is None:
            continue
        size = float(np.linalg.norm(th0))
        col = ((e_without[:n_fit] - e_alt[:n_fit]) / size)[None]  # e_alt: the fitting part only (refinement.py)
        X = np.concatenate([J_fit[others], col])
        G, g, ee = BlockGram.build(X, e_without[:n_fit]).total()
        out.append((cand, rss_of(G, g, ee, list(range(X.shape[0])))[1][-1] * th0 / size))  # a pair keeps its phase
    return out


def final_verdicts(kept: list[Finding], pol: Refined, n_fit: int, drift: Drift | None = None,
                   own_variance: OwnVariance = False, nulls: Sequence[NDArray] = ()) -> list[Finding]:
    """Each kept finding judged against the others once more, linearised at the polished coefficients (beside
    the ``drift``); returns those that fail now.  ``nulls``: weighted residuals of the polished model's replays
    under other noise seeds over the fitting part (``replay_noise.py``): each finding's estimate must also stand
    out of the scatter they give it, else it fails as ``within_scatter``."""
    cands = [f.candidate for f in kept]
    cols = columns_of(cands)
    J_fit = pol.J[:, :n_fit]
    e_pseudo = pol.e[:n_fit] + np.tensordot(pol.theta, J_fit, axes=1)
    if drift is not None:
        J_fit, e_pseudo = drift.remove(J_fit), drift.remove(e_pseudo)
    J_fit, e_pseudo, s = per_channel(J_fit, e_pseudo, own_variance)  # each channel its own variance (statistics.py)
    scatter = replay_scatter(J_fit, in_metric(nulls, s, own_variance, drift), cols)
    bg = BlockGram.build(J_fit, e_pseudo)
    failed = []
    for k, f in enumerate(kept):
        v = judge(bg, e_pseudo, J_fit, cands, cols, [o for o in range(len(kept)) if o != k], k)
        f.replay_scatter = scatter[k]
        if scatter[k] is not None:
            se = with_scatter(np.asarray(v.se), scatter[k])
            z = amplitude_z(np.asarray(v.theta), se)
            f.within_scatter = v.accepted and z < MIN_Z
            why = (f"z {below(z, MIN_Z)} < {MIN_Z:g} with the scatter of its replays under other noise seeds "
                   f"({v.z:.1f} without)" if z < MIN_Z else "")
            v = dataclasses.replace(v, se=tuple(float(x) for x in se), z=z, accepted=v.accepted and z >= MIN_Z,
                                    reason=v.reason or why)
        f.verdict = v
        f.se = np.asarray(v.se)
        if not f.verdict.accepted or f.candidate.range_problem(f.theta):
            failed.append(f)
    return failed
