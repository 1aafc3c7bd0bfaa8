"""Every named finding with its rivals: the library effects this log cannot tell from it.

On a joint whose current hardly varies (gravity of one sign, a slow wrist) a current gain, a torque constant and
a current offset are nearly one shape, and which of them the selection takes is decided by the model's own
error there; the engineer who must open the joint on the strength of a finding needs them all, each with its
own size, and the motion that would tell them apart.

For a finding ``f`` of the final model:

1. *In its place, linearised* (:func:`in_place`): the residual ``f`` explains is the final model's residual plus
   ``f``'s change (its refinement secant times its size).  On the screened part the library candidates on
   ``f``'s joint and the robot-wide ones (not kept findings themselves) are judged alone against it by the
   tests every finding must pass; those that also take up at least :data:`RIVAL_SHARE` of ``f``'s own
   improvement are simulated, the best :data:`MAX_RIVALS` by improvement.
2. *Simulated, judged on the held-out part* (:func:`judge_rival`): each rival replaces ``f`` in the final model
   (one lockstep batch for all rivals of all findings); its secant is sized on the fitting part beside the
   drift; it is listed when it passes the held-out check itself, lies in its effect's range, and leaves the
   held-out residual of ``f``'s channels worse than ``f`` does by less than MIN_DELTA_BIC in effective samples
   (:func:`held_out_delta_bic`, the bar a finding must clear to be named at all).
3. *What tells them apart* (:func:`differ_most`): the operating condition where the two changes of the joint's
   current differ most, as a share of the finding's own change.

For a current-sensor gain named with a torque-constant loss among its alternatives, or the other way round
(:data:`NOISE_PAIR`: their changes of the current are the same shape), the finding's ``tell_apart`` also says what
the sensor's noise at rest says (:func:`noise_hints`): a gain scales the sensor's noise, a torque-constant loss
does not.

The re-screen of freed joints (``rescreen.py``) judges its own rivals with the same :func:`judge_rival`.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..sim.effects import EffectSpec
from ..twin.replay import LogReplay, Replayed
from ..twin.residuals import conditions, noise_ratio, stencils
from .candidates import Candidate
from .drift import Drift
from .judging import Finding, channels
from .search import columns_of, judge
from .statistics import MIN_DELTA_BIC, BlockGram, effective_n, generalisation, rss_of, weighted
from .weighting import OwnVariance, per_channel

#: rivals of one finding simulated (each one run of the whole log) at most
MAX_RIVALS = 2
#: share of a finding's improvement on the screened part a rival must take up to be simulated at all.  Cost
#: bound and assumption: on logs of thousands of samples 10 % less improvement than a finding that lowers BIC
#: by 100 or more is itself more than MIN_DELTA_BIC, so the held-out check would not list it
RIVAL_SHARE = 0.9
#: the library pair that only the sensor's noise tells apart (:func:`noise_hint`)
NOISE_PAIR = frozenset({"current_sensor_gain", "torque_constant"})
#: sum of the squared autocorrelations of white noise's second difference (1 + 2 (4/9 + 1/36)): the relative
#: variance of a mean of its squares is 2 * this / n, so the ratio of two independent RMS values has a relative
#: standard error of about sqrt(this / n)
D2_CORRELATION = 1.9444


@dataclasses.dataclass(frozen=True)
class Rival:
    """A library effect the held-out part cannot tell from a finding: its own coefficients in the finding's
    place, the share of its change it makes good there, how much worse it leaves the held-out residual of the
    finding's channels (effective-sample delta BIC; < MIN_DELTA_BIC by construction, negative: better), and
    what motion would tell the two apart ("" where the log shows none)."""

    candidate: Candidate
    theta: NDArray
    held_out_ratio: float
    held_out_delta_bic: float
    tell_apart: str = ""


def held_out_delta_bic(e_named: NDArray, e_rival: NDArray) -> float:
    """How much worse ``e_rival`` leaves the residual than ``e_named`` (both ``(n, n_channels)``), as a BIC
    difference in the named one's effective (autocorrelation-discounted) samples."""
    rss_n, rss_r = float(np.sum(e_named**2)), float(np.sum(e_rival**2))
    if rss_n <= 0.0:
        return 0.0 if rss_r <= 0.0 else math.inf
    return effective_n(e_named) * math.log(max(rss_r, 1e-300) / rss_n)


def indistinguishable_held_out(e_named: NDArray, e_rival: NDArray) -> bool:
    """Whether the held-out part cannot tell a rival from the named finding (:func:`held_out_delta_bic` below
    MIN_DELTA_BIC, the bar a finding must clear to be named at all)."""
    return held_out_delta_bic(e_named, e_rival) < MIN_DELTA_BIC


def judge_rival(e_place: NDArray, col: NDArray, e_named: NDArray, n_fit: int, ch: NDArray,
                drift: Drift | None = None, others: NDArray | None = None) -> tuple[float, float, float] | None:
    """A rival in a finding's place, sized and judged on the held-out part.

    Args:
        e_place: weighted residual of the model without the finding ``(n, n_channels)`` over the whole log.
        col: the rival's simulated change there (its secant at its linearised size), same shape.
        e_named: the residual with the finding (the final model's).
        n_fit: samples of the fitting part; the rest is held out.
        ch: flat channel mask of what the finding acts on.
        drift: the fitting part's drift, projected out before sizing.
        others: columns refitted beside the rival ``(k, n, n_channels)`` (other re-screened findings), or None.

    Returns:
        ``(multiple of the linearised size, held-out ratio, held-out delta BIC)`` when the rival passes the
        held-out check and the held-out part cannot tell it from the finding; None otherwise.
    """
    X = col[None] if others is None or not len(others) else np.concatenate([others, col[None]])
    X_fit, e_fit = X[:, :n_fit], e_place[:n_fit]
    if drift is not None:
        X_fit, e_fit = drift.remove(X_fit), drift.remove(e_fit)
    G, g, ee = BlockGram.build(X_fit, e_fit).total()
    b = rss_of(G, g, ee, list(range(X.shape[0])))[1]
    rival_held = e_place[n_fit:] - np.tensordot(b, X[:, n_fit:], axes=1)
    gen = generalisation(rival_held[:, ch], (rival_held + b[-1] * col[n_fit:])[:, ch])
    dbic = held_out_delta_bic(e_named[n_fit:][:, ch], rival_held[:, ch])
    if not gen.passes or dbic >= MIN_DELTA_BIC:
        return None
    return float(b[-1]), float(gen.ratio), float(dbic)


def differ_most(log, n: int, torque: NDArray, a: NDArray, b: NDArray, joint: int | None) -> str:
    """Where two changes ``a``, ``b`` of a joint's current (``(n,)``, samples 1..n) differ most: the operating
    condition with the largest RMS difference, as a share of ``a``'s own RMS; a motion with more of it would
    tell them apart ("" for a robot-wide effect or when no condition occurs)."""
    if joint is None:
        return ""
    masks = conditions(log, n, torque)
    scale = max(float(np.sqrt(np.mean(a**2))), 1e-12)
    by = {k: float(np.sqrt(np.mean((a - b)[m[:, joint]] ** 2))) / scale for k, m in masks.items() if m[:, joint].any()}
    if not by:
        return ""
    where = max(by, key=by.__getitem__)
    return (f"on this log they differ most {where} ({100 * by[where]:.0f} % of the effect); a motion with more "
            f"time {where} on this joint would tell them apart")


def sensor_scale(effect: str, value: float) -> float:
    """The factor a finding of ``effect`` with parameter ``value`` puts on the current sensor's noise: the gain of a
    current-sensor gain (the noise enters before the gain, as in the simulator's sensor), 1 for anything else."""
    return float(value) if effect == "current_sensor_gain" else 1.0


def noise_hint(rest: NDArray, meas_A: NDArray, named_A: NDArray, joint: int, named: tuple[str, float],
               rival: tuple[str, float]) -> str:
    """What the sensor's noise says between a named finding and its rival when they are a current-sensor gain and a
    torque-constant loss (:data:`NOISE_PAIR`; "" otherwise or when the joint rests for too few samples).

    ``meas_A``, ``named_A``: the measured current reading and the replay's with the finding, ``(n, 6)``; ``rest``:
    ``(n, 6)`` where the joint's target is at rest; ``named``, ``rival``: each one's effect and parameter value.
    The ratio of the measured reading's noise to the replay's (:func:`ur5fault.twin.residuals.noise_ratio`: RMS of
    the second difference at rest) is 1 for the model whose sensor is as loud as the robot's; the rival's replay
    has the finding's sensor noise times ``sensor_scale(rival) / sensor_scale(named)``.  This assumes the model's
    current noise is the robot's healthy sensor's (as ``identify`` measures it on the robot's own logs)."""
    if {named[0], rival[0]} != NOISE_PAIR:
        return ""
    r_named = float(noise_ratio(meas_A, named_A, rest)[joint])
    n = int(stencils(rest)[:, joint].sum())
    if not np.isfinite(r_named):
        return ""
    r_rival = r_named * sensor_scale(*named) / sensor_scale(*rival)
    se = math.sqrt(D2_CORRELATION / n)
    name_n, name_r = named[0].replace("_", " "), rival[0].replace("_", " ")
    text = (f"the current reading's noise at rest is x{r_named:.3f} the model's with the {name_n} and "
            f"x{r_rival:.3f} with the {name_r} ({n} samples, about +-{se:.3f}); a current-sensor gain scales the "
            "sensor's noise, a torque-constant loss does not")
    d_named, d_rival = abs(math.log(r_named)), abs(math.log(r_rival))
    if abs(d_named - d_rival) < 2 * se:
        return text + ": too close to tell on this log"
    better = name_n if d_named < d_rival else name_r
    return (text + f": the {better} fits the sensor's noise (if the model's current noise is this robot's healthy "
            "sensor's, as identify measures it)")


def noise_hints(rp: LogReplay, after: Replayed, findings: Sequence[Finding]) -> None:
    """Add :func:`noise_hint` to ``tell_apart`` of every kept finding of :data:`NOISE_PAIR` that has the other kind
    of the pair on its joint among its alternatives (``after``: the replay of the final model)."""
    if "current_A" not in rp.signals:
        return
    k, n = rp.signals.index("current_A"), rp.n_samples
    rest = conditions(rp.log, n, after.torque_gear_Nm)["at rest"]
    meas = rp.measured(n)[:, k]
    for f in findings:
        c = f.candidate
        if not f.kept or c.joint is None or c.effect not in NOISE_PAIR:
            continue
        for alt, th in f.alternatives:
            if alt.effect in NOISE_PAIR - {c.effect} and alt.joint == c.joint:
                hint = noise_hint(rest, meas, after.y[:, k], c.joint, (c.effect, c.value(f.theta)),
                                  (alt.effect, alt.value(th)))
                f.tell_apart = "; ".join(h for h in (f.tell_apart, hint) if h)
                break


def current_channel(signals: Sequence[str], joint: int) -> int:
    return signals.index("current_A") * N_JOINTS + joint if "current_A" in signals else joint


def in_place(X: NDArray, e_place: NDArray, e_named: NDArray, candidates: Sequence[Candidate],
             cols: list[list[int]], taken: set[str], joint: int | None,
             max_n: int = MAX_RIVALS, share: float = RIVAL_SHARE, robot_wide: bool = True,
             own_variance: OwnVariance = False) -> list[tuple[int, NDArray]]:
    """The library candidates on ``joint`` (and robot-wide ones unless not ``robot_wide``) not in ``taken`` that,
    judged alone against ``e_place`` (the residual without the finding, screened part, drift removed), pass every
    test and take up
    at least ``share`` of the finding's improvement ``|e_place|^2 - |e_named|^2``: ``(k, theta)``, the best
    ``max_n`` by improvement.  ``share=0``: any that passes."""
    ks = [k for k, c in enumerate(candidates)
          if (c.joint == joint or (robot_wide and c.joint is None)) and c.label not in taken]
    if not ks:
        return []
    sub = [candidates[k] for k in ks]
    scols = columns_of(sub)
    # each channel its own variance (statistics.py): the scale of what all these columns leave of e_place
    Xs, e_place, s = per_channel(X[[c for k in ks for c in cols[k]]], e_place, own_variance)
    e_named = e_named / s
    bg = BlockGram.build(Xs, e_place)
    G, g, ee = bg.total()
    own = float(np.sum(e_place**2) - np.sum(e_named**2))
    ranked = sorted(((ee - rss_of(G, g, ee, scols[i])[0], i) for i in range(len(ks))), reverse=True)
    out = []
    for gain, i in ranked:
        if len(out) == max_n or gain < share * own:
            break
        v = judge(bg, e_place, Xs, sub, scols, [], i)
        if v.accepted:
            out.append((ks[i], np.asarray(v.theta)))
    return out


@dataclasses.dataclass(frozen=True)
class RivalPlan:
    """The rivals :func:`list_rivals` simulates: per rival its finding, the finding's change, the candidate and its
    linearised coefficients, and the effect set replayed (the final model with the rival in the finding's place)."""

    rows: tuple[tuple[Finding, NDArray, Candidate, NDArray], ...] = ()
    effect_sets: tuple[tuple[EffectSpec, ...], ...] = ()
    #: the log's readings and the final model's weighted residual over the whole log (None without rows)
    meas: NDArray | None = None
    e_after: NDArray | None = None


def rival_plan(rp: LogReplay, lib_X: NDArray, lib_drift: Drift | None, candidates: Sequence[Candidate],
               findings: Sequence[Finding], first_J: NDArray | None, found: Sequence[Candidate], after: Replayed,
               n_scr: int, skip: Sequence[Finding] = (), own_variance: OwnVariance = False) -> RivalPlan:
    """Step 1 of the module docstring for every kept finding (but those in ``skip``): the rivals to simulate.  A
    pure function of its arguments, so the plan made before the re-screen is the one :func:`list_rivals` makes
    after it when the re-screen leaves the final model as it is (its replays can then start early, prefetched)."""
    kept = [f for f in findings if f.kept]
    if first_J is None or not kept:
        return RivalPlan()
    meas = rp.measured(rp.n_samples)
    e_after = weighted(meas, after.y, rp.sigma)
    fcols = columns_of(found)
    lcols = columns_of(candidates)
    taken = {f.candidate.label for f in kept}
    plan: list[tuple[Finding, NDArray, Candidate, NDArray]] = []
    for f in kept:
        if any(f is s for s in skip) or f.candidate not in found:
            continue
        k = list(found).index(f.candidate)
        change = np.tensordot(np.asarray(f.theta, dtype=float), first_J[fcols[k]], axes=1)
        e_place = e_after + change
        e_s, n_s = e_place[:n_scr], e_after[:n_scr]
        if lib_drift is not None:
            e_s, n_s = lib_drift.remove(e_s), lib_drift.remove(n_s)
        listed = taken | {a.label for a, _ in f.alternatives}
        for r, th in in_place(lib_X, e_s, n_s, candidates, lcols, listed, f.candidate.joint,
                              own_variance=own_variance):
            plan.append((f, change, candidates[r], th))
    specs = {id(f): tuple(g.spec() for g in kept if g is not f) for f in kept}
    return RivalPlan(tuple(plan), tuple(specs[id(f)] + (c.spec(th),) for f, _, c, th in plan), meas, e_after)


def list_rivals(rp: LogReplay, lib_X: NDArray, lib_drift: Drift | None, candidates: Sequence[Candidate],
                findings: Sequence[Finding], first_J: NDArray | None, found: Sequence[Candidate], after: Replayed,
                n_scr: int, n_fit: int, drift: Drift | None, skip: Sequence[Finding] = (),
                progress: Callable[[float], None] | None = None, own_variance: OwnVariance = False) -> None:
    """Give every kept finding (but those in ``skip``, judged already) its rivals (module docstring): each
    listed one goes to ``f.rivals`` and to ``f.alternatives``.

    Args:
        lib_X: the library's columns on the screened part (drift removed); ``candidates`` their candidates.
        first_J: the refinement's secant Jacobian ``(n_coef, n, n_channels)`` of the candidates ``found``.
        after: the replay of the final model.
    """
    plan = rival_plan(rp, lib_X, lib_drift, candidates, findings, first_J, found, after, n_scr, skip, own_variance)
    if not plan.rows:
        return
    meas, e_after = plan.meas, plan.e_after
    sims = rp.run(plan.effect_sets, rp.n_samples, progress)
    torque = after.torque_gear_Nm
    for (f, change, cand, th), sim in zip(plan.rows, sims):
        if not sim.ok:
            continue
        e_place = e_after + change
        col = e_place - weighted(meas, sim.y, rp.sigma)
        ch = channels(f.candidate, len(rp.signals))
        got = judge_rival(e_place, col, e_after, n_fit, ch, drift)
        if got is None or cand.range_problem(th * got[0]):
            continue
        a, ratio, dbic = got
        j = f.candidate.joint
        hint = "" if j is None else differ_most(rp.log, rp.n_samples, torque, change[:, current_channel(rp.signals, j)],
                                                a * col[:, current_channel(rp.signals, j)], j)
        theta = np.asarray(th, dtype=float) * a
        f.rivals.append(Rival(cand, theta, ratio, dbic, hint))
        f.alternatives.append((cand, theta))
