"""The search: forward selection over the candidates' columns of the linearised problem, every step
judged by :func:`judge` (a rejected candidate does not end the search: the next one is tried), a final
backward check of every finding against all the others (:func:`backward`), and refinement of the
found coefficients by re-simulation (:func:`refine`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from .candidates import Candidate
from .statistics import (
    MAX_COLLINEARITY,
    MIN_DELTA_BIC,
    MIN_Z,
    BlockGram,
    Stability,
    amplitude_z,
    bic,
    collinearity,
    effective_n,
    jackknife_se,
    rss_of,
    stability,
)

#: other candidates that achieve at least this share of the chosen one's improvement are reported with
#: it as indistinguishable in this log (e.g. a current-sensor gain g and a torque-constant change 1/g)
ALTERNATIVE_SHARE = 0.98
#: candidates judged per step at most, in order of improvement (the rest cannot beat them on BIC either)
MAX_TRIES_PER_STEP = 12
#: refinement rounds by re-simulation at most (each one lockstep batch) ...
REFINE_ROUNDS = 3
#: ... stopping early when the next Gauss-Newton step promises less than this share of the weighted RSS
REFINE_RTOL = 0.01


@dataclasses.dataclass(frozen=True)
class Verdict:
    """How one candidate fared against noise, autocorrelation and time blocks, given the others."""

    label: str
    theta: tuple[float, ...]
    se: tuple[float, ...]
    delta_bic: float
    z: float
    stability: Stability
    accepted: bool
    reason: str  # why it was rejected ("" when accepted)


def judge(bg: BlockGram, e_fit: NDArray, X: NDArray, cols: list[list[int]], others: list[int], cand: int,
          fixed: Sequence[int] = ()) -> Verdict:
    """Judge candidate ``cand`` in the joint fit with ``others`` (candidate indices) and ``fixed`` columns.

    Args:
        bg: block statistics of ``e ~ X theta``.
        e_fit: the weighted residual ``(n, n_channels)`` the statistics were built from.
        X: all columns ``(p, n, n_channels)``.
        cols: column indices of each candidate.
    """
    G, g, ee = bg.total()
    base = list(fixed) + [c for o in others for c in cols[o]]
    idx = base + cols[cand]
    rss0, th0 = rss_of(G, g, ee, base)
    rss1, th = rss_of(G, g, ee, idx)
    e_res = e_fit - np.tensordot(th, X[idx], axes=1)
    n_eff = effective_n(e_res)
    dbic = bic(rss1, n_eff, len(idx)) - bic(rss0, n_eff, len(base))
    own = list(range(len(base), len(idx)))
    se = jackknife_se(bg, idx)
    z = amplitude_z(th[own], se[own])
    stab = stability(bg, idx, own, th, rss1 / n_eff)
    reasons = []
    r2 = collinearity(G, base, cols[cand])
    if r2 > MAX_COLLINEARITY:
        reasons.append(f"collinear with the findings already in (r^2 {r2:.3f})")
    if dbic > -MIN_DELTA_BIC:
        reasons.append(f"delta BIC {dbic:.1f} > -{MIN_DELTA_BIC:g}")
    if z < MIN_Z:
        reasons.append(f"z {z:.1f} < {MIN_Z:g}")
    if not stab.stable:
        reasons.append("unstable across time blocks (" + ", ".join(f"{r:.2f}" for r in stab.ratios) + ")")
    return Verdict("", tuple(float(t) for t in th[own]), tuple(float(s) for s in se[own]), float(dbic), float(z),
                   stab, not reasons, "; ".join(reasons))


@dataclasses.dataclass
class Selection:
    """Result of a forward selection: chosen candidates (indices, in order), their joint coefficients,
    the indistinguishable alternatives of each, and the trace of every judgement."""

    chosen: list[int]
    verdicts: list[Verdict]
    alternatives: list[list[tuple[int, NDArray]]]
    trace: list[Verdict]

    def theta(self, bg: BlockGram, cols: list[list[int]], fixed: Sequence[int] = ()) -> NDArray:
        G, g, ee = bg.total()
        idx = list(fixed) + [c for k in self.chosen for c in cols[k]]
        return rss_of(G, g, ee, idx)[1][len(fixed):]


def columns_of(cands: Sequence[Candidate], start: int = 0) -> list[list[int]]:
    out, k = [], start
    for c in cands:
        out.append(list(range(k, k + c.n_coef)))
        k += c.n_coef
    return out


def forward(bg: BlockGram, e_fit: NDArray, X: NDArray, cands: Sequence[Candidate], cols: list[list[int]],
            max_n: int, fixed: Sequence[int] = (), labels: Callable[[int], str] | None = None) -> Selection:
    """Forward selection: at each step the candidates are tried in order of the improvement they add to the
    joint fit; the first one :func:`judge` accepts is taken.  Stops when no candidate can lower BIC enough
    or none of the :data:`MAX_TRIES_PER_STEP` best is accepted."""
    G, g, ee = bg.total()
    chosen: list[int] = []
    verdicts: list[Verdict] = []
    alts: list[list[tuple[int, NDArray]]] = []
    trace: list[Verdict] = []
    label = labels or (lambda k: cands[k].label)
    while len(chosen) < max_n:
        base = list(fixed) + [c for k in chosen for c in cols[k]]
        rss0, th0 = rss_of(G, g, ee, base)
        n_eff = effective_n(e_fit - np.tensordot(th0, X[base], axes=1)) if base else effective_n(e_fit)
        gains = []
        for k in range(len(cands)):
            if k in chosen:
                continue
            rss1, _ = rss_of(G, g, ee, base + cols[k])
            gains.append((rss0 - rss1, k))
        gains.sort(reverse=True)
        taken = None
        for gain, k in gains[:MAX_TRIES_PER_STEP]:
            # early rejection: even ignoring its extra parameters the gain cannot lower BIC enough
            if gain <= 0 or n_eff * math.log(max(rss0 - gain, 1e-300) / rss0) > -MIN_DELTA_BIC:
                break
            v = dataclasses.replace(judge(bg, e_fit, X, cols, chosen, k, fixed), label=label(k))
            trace.append(v)
            if v.accepted:
                taken = (k, v, gain)
                break
        if taken is None:
            break
        k, v, gain = taken
        alt = []
        for gain2, k2 in gains:  # as good in this log, and as credible on its own
            if k2 != k and gain2 >= ALTERNATIVE_SHARE * gain and judge(bg, e_fit, X, cols, chosen, k2, fixed).accepted:
                alt.append((k2, rss_of(G, g, ee, base + cols[k2])[1][len(base):]))
        chosen.append(k)
        verdicts.append(v)
        alts.append(alt)
    return Selection(chosen, verdicts, alts, trace)


def backward(bg: BlockGram, e_fit: NDArray, X: NDArray, cands: Sequence[Candidate], cols: list[list[int]],
             chosen: list[int], fixed: Sequence[int] = ()) -> tuple[list[int], list[Verdict], list[Verdict]]:
    """Judge every finding against all the others; drop the weakest failing one and repeat.

    Returns:
        The kept candidates, their final verdicts, and the verdicts of the dropped ones.
    """
    kept = list(chosen)
    dropped: list[Verdict] = []
    while kept:
        vs = [dataclasses.replace(judge(bg, e_fit, X, cols, [o for o in kept if o != k], k, fixed),
                                  label=cands[k].label) for k in kept]
        failing = [(v.delta_bic, i) for i, v in enumerate(vs) if not v.accepted]
        if not failing:
            return kept, vs, dropped
        _, i = max(failing)
        dropped.append(vs[i])
        kept.pop(i)
    return kept, [], dropped


# ------------------------------------------------------------------------------------------ refinement
@dataclasses.dataclass(frozen=True)
class RefineStep:
    """One simulated point of the refinement: coefficients, weighted RSS on the fitting part."""

    theta: tuple[float, ...]
    rss: float


@dataclasses.dataclass
class Refined:
    """Refined coefficients over the whole log.

    Attributes:
        theta: the best simulated coefficients (least weighted RSS on the fitting part).
        J: secant Jacobian there, ``(n_coef, n, n_channels)``: change of the weighted *simulated* readings
            per unit coefficient, over the whole log.
        sim, e: the replay at ``theta`` and its weighted residual ``(n, n_channels)``.
        sim0, e0: the replay with every coefficient zero (the starting model) and its weighted residual.
        steps: every simulated point.
    """

    theta: NDArray
    J: NDArray
    sim: object
    e: NDArray
    sim0: object
    e0: NDArray
    steps: list[RefineStep]
    probe_e: list[NDArray | None] = dataclasses.field(default_factory=list)  # residual of theta0 + each probe
    extra_e: list[NDArray | None] = dataclasses.field(default_factory=list)  # residual of each extra model


class _Evaluations:
    """Simulated points, the best one on the fitting rows, and a secant Jacobian (scaled coordinates)."""

    def __init__(self, evaluate, k: int, scale: NDArray, fit_rows: int) -> None:
        self.evaluate, self.scale, self.rows = evaluate, scale, fit_rows
        self.J: NDArray | None = None  # (N, k): e(theta) ~ e(0) - J theta
        self.best: tuple[NDArray, NDArray, object, float] | None = None
        self.last: tuple[NDArray, NDArray] | None = None
        self.steps: list[RefineStep] = []
        self.extra_e: list[NDArray | None] = []

    def fit_part(self, e: NDArray) -> NDArray:
        return e[: self.rows].ravel()

    def __call__(self, thetas: list[NDArray], update: bool = True, extra: Sequence[object] = (),
                 evaluate_extra=None) -> list[tuple[NDArray | None, float, object]]:
        """Simulate ``thetas`` (and ``extra`` models, whose residuals go to ``extra_e``) in one batch;
        ``update``: the Jacobian takes the secant of each new point from the one before."""
        out = []
        results = self.evaluate(thetas) if not extra else evaluate_extra(thetas, extra)
        if extra:
            results, more = results[: len(thetas)], results[len(thetas):]
            self.extra_e = [e if sim.ok else None for sim, e in more]
        for th, (sim, e) in zip(thetas, results):
            ok = sim.ok and np.all(np.isfinite(e))
            f = self.fit_part(e) if ok else None
            rss = float(f @ f) if f is not None else math.inf
            self.steps.append(RefineStep(tuple(float(t) for t in th), rss))
            if ok and (self.best is None or rss < self.best[3]):
                self.best = (th.copy(), e, sim, rss)
            out.append((e if ok else None, rss, sim))
        if update:
            for th, (e, _, _) in zip(thetas, out):
                if e is not None:
                    if self.last is not None:
                        self._secants(self.last[0], self.last[1], [(th, e)])
                    self.last = (th.copy(), e)
        return out

    def _secants(self, th0: NDArray, e0: NDArray, points: list[tuple[NDArray, NDArray]]) -> None:
        """Make ``J`` reproduce the secants from ``(th0, e0)`` to ``points`` (least change, scaled norm)."""
        if self.J is None:
            self.J = np.zeros((e0.size, th0.size))
        if points:
            P = np.stack([(th - th0) / self.scale for th, _ in points], axis=1)  # (k, m)
            if np.any(P):
                D = np.stack([(e0 - e).ravel() for _, e in points], axis=1)  # (N, m)
                Js = self.J * self.scale
                Js += (D - Js @ P) @ np.linalg.pinv(P)
                self.J = Js / self.scale
        self.last = (th0.copy(), e0)

    def step(self, e: NDArray) -> tuple[NDArray, float]:
        """Gauss-Newton step on the fitting rows and the drop of the weighted RSS it promises."""
        Jf = self.J.reshape(e.shape[0], -1, self.J.shape[1])[: self.rows].reshape(-1, self.J.shape[1])
        f = self.fit_part(e)
        step = np.linalg.lstsq(Jf, f, rcond=None)[0]
        return step, float((Jf @ step) @ f)


def probe_batch(evaluate, theta0: NDArray, probes: Sequence[NDArray], bounds: tuple[NDArray, NDArray],
                fit_rows: int, extra: Sequence[object] = (), evaluate_extra=None) -> Refined:
    """Re-simulate the whole log once for the starting model (all coefficients zero), ``theta0`` and
    ``theta0`` + each of ``probes``, in one lockstep batch.  When the probes span every coefficient (each
    finding removed, a sine-cosine pair also turned by a quarter period), their secants anchored at
    ``theta0`` give the whole simulated Jacobian.

    Args:
        evaluate: ``evaluate(list of theta) -> list of (replay, weighted residual (n, n_channels))``.
        theta0: the linearised estimate.
        probes: perturbations of ``theta0``.
        bounds: coefficient bounds (the effects' valid ranges).
        fit_rows: samples of the fitting part (the rest is held out).
        extra, evaluate_extra: other models simulated in the same batch (``evaluate_extra(thetas, extra)``
            returns the replays of both), e.g. a finding's indistinguishable alternatives.
    """
    lo, hi = bounds
    k = theta0.size
    ev = _Evaluations(evaluate, k, np.maximum(np.abs(theta0), 1e-9), fit_rows)
    theta = np.clip(theta0, lo, hi)
    pts = [np.zeros(k), theta] + [np.clip(theta + p, lo, hi) for p in probes]
    first = ev(pts, update=False, extra=extra, evaluate_extra=evaluate_extra)
    e0, sim0 = first[0][0], first[0][2]
    if e0 is None:
        raise RuntimeError("the starting model failed to replay the log")
    anchor = 1 if first[1][0] is not None else 0  # at zero if theta0 itself failed
    ev._secants(pts[anchor], first[anchor][0],
                [(pts[i], first[i][0]) for i in range(len(pts)) if i != anchor and first[i][0] is not None])
    n, C = e0.shape
    return Refined(pts[anchor], ev.J.T.reshape(-1, n, C), first[anchor][2], first[anchor][0], sim0, e0, ev.steps,
                   [r[0] for r in first[2:]], ev.extra_e)


def polish(evaluate, theta: NDArray, J: NDArray, bounds: tuple[NDArray, NDArray], fit_rows: int,
           method: str = "secant") -> Refined:
    """Gauss-Newton rounds on the fitting part from ``theta`` (its Jacobian ``J`` ``(k, n, n_channels)``
    from :func:`probe_batch`); the first simulation is ``theta`` itself, so a converged estimate costs one.

    Args:
        method: ``"secant"`` (steps on the secant-updated Jacobian, one simulation each, until the next
            promises less than :data:`REFINE_RTOL` of the weighted RSS; at most :data:`REFINE_ROUNDS`
            simulations) or ``"minimize"`` (``mujoco.minimize.least_squares``: Levenberg-Marquardt with
            bounds, finite differences of :data:`FD_STEP` in coordinates scaled by ``theta``).
    """
    lo, hi = bounds
    k = theta.size
    scale = np.maximum(np.abs(theta), 1e-9)
    ev = _Evaluations(evaluate, k, scale, fit_rows)
    ev.J = J.reshape(k, -1).T.copy()
    theta = np.clip(theta, lo, hi)
    if method == "secant":
        (e, _, _), = ev([theta], update=False)
        if e is None:
            raise RuntimeError("the refined model failed to replay the log")
        ev.last = (theta.copy(), e)
        for _ in range(REFINE_ROUNDS - 1):
            step, gain = ev.step(ev.best[1])
            if gain < REFINE_RTOL * ev.best[3]:
                break
            trial = np.clip(ev.best[0] + step, lo, hi)
            (e, rss, _), = ev([trial])
            if e is None or rss > ev.best[3]:  # worse than the best point: try half the step once
                ev([np.clip(ev.best[0] + 0.5 * step, lo, hi)])
    elif method == "minimize":
        from mujoco import minimize

        def residual(z: NDArray) -> NDArray:
            outs = ev([col * scale for col in z.T])
            size = ev.J.shape[0] // (J.shape[1]) * fit_rows  # channels x fitting rows
            return np.stack([ev.fit_part(e) if e is not None else np.full(size, 1e6) for e, _, _ in outs], axis=1)

        minimize.least_squares(theta / scale, residual, bounds=(lo / scale, hi / scale), eps=FD_STEP,
                               max_iter=REFINE_ROUNDS - 1, verbose=0)
    else:
        raise ValueError(f"method = {method!r}; choose secant or minimize")
    if ev.best is None:
        raise RuntimeError("the refined model failed to replay the log")
    th, e, sim, _ = ev.best
    n = e.shape[0]
    return Refined(th, ev.J.T.reshape(k, n, -1), sim, e, None, None, ev.steps)


#: finite-difference step of the ``minimize`` refinement, relative to each coefficient's first estimate
#: (large enough that the quantised, noisy readings change by more than their resolution)
FD_STEP = 0.05
