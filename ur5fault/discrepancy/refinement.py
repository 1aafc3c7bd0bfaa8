"""Refinement by re-simulating the whole log: one lockstep batch of probes gives the simulated Jacobian
of the findings (:func:`probe_batch`), Gauss-Newton rounds polish the kept ones (:func:`polish`), and
:class:`FindingSet` turns coefficient vectors into the effects a replay carries.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..sim.effects import EffectSpec
from ..twin.replay import LogReplay, Replayed
from .candidates import Candidate
from .statistics import weighted

#: refinement rounds by re-simulation at most (each one lockstep batch) ...
REFINE_ROUNDS = 3
#: ... stopping early when the next Gauss-Newton step promises less than this share of the weighted RSS
REFINE_RTOL = 0.01


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
    # residual of each extra model, over the rows the evaluator replays them (the workflow: the fitting part)
    extra_e: list[NDArray | None] = dataclasses.field(default_factory=list)


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

        # every residual is a simulation: a regulariser that grows tenfold per rejected step (not 10^0.1,
        # which may spend a hundred simulations near an optimum the noise makes flat)
        minimize.least_squares(theta / scale, residual, bounds=(lo / scale, hi / scale), eps=FD_STEP,
                               max_iter=REFINE_ROUNDS - 1, mu_factor=MU_FACTOR, verbose=0)
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
#: growth of the ``minimize`` refinement's Levenberg-Marquardt regulariser per rejected step
MU_FACTOR = 10.0


class FindingSet:
    """A list of findings as one coefficient vector: effects of a replay, bounds, probes.

    Args:
        found: the candidates, in the order of their coefficients.
    """

    def __init__(self, found: Sequence[Candidate]) -> None:
        self.found = list(found)

    def split(self, theta: NDArray) -> list[NDArray]:
        """Per-candidate coefficients of ``theta``."""
        return np.split(theta, np.cumsum([c.n_coef for c in self.found])[:-1])

    def specs(self, theta: NDArray) -> tuple[EffectSpec, ...]:
        """Effects at ``theta`` (a candidate at all-zero coefficients is absent)."""
        return tuple(c.spec(th) for c, th in zip(self.found, self.split(theta)) if np.any(th))

    def bounds(self) -> tuple[NDArray, NDArray]:
        return (np.concatenate([c.bounds()[0] for c in self.found]),
                np.concatenate([c.bounds()[1] for c in self.found]))

    def probes(self, theta0: NDArray) -> list[NDArray]:
        """Each finding removed, and a sine-cosine pair also turned by a quarter period: perturbations of
        ``theta0`` that span every coefficient."""
        out, off = [], 0
        for c in self.found:
            th_c = theta0[off : off + c.n_coef]
            for d in [-th_c] + ([np.array([-th_c[1], th_c[0]])] if c.n_coef == 2 else []):
                p = np.zeros_like(theta0)
                p[off : off + c.n_coef] = d
                out.append(p)
            off += c.n_coef
        return out

    def first_probe(self, k: int) -> int:
        """Index among :meth:`probes` of the one that removes finding ``k``."""
        return sum(c.n_coef for c in self.found[:k])

    def alternative_sets(self, theta: NDArray, extra: Sequence[tuple[int, Candidate, NDArray]]
                         ) -> list[tuple[EffectSpec, ...]]:
        """The effects of each alternative ``(i, alternative, its coefficients)`` in place of finding ``i``, the
        others at ``theta``."""
        out = []
        for i, alt, alt_theta in extra:
            th = self.split(theta)
            th[i] = np.zeros_like(th[i])
            out.append(self.specs(np.concatenate(th)) + (alt.spec(alt_theta),))
        return out

    def evaluator(self, rp: LogReplay, progress=None, extra_rows: int | None = None):
        """``evaluate(thetas, extra=())``: replays of the whole log at each ``theta`` (and, for each extra
        ``(i, alternative, its coefficients)``, the alternative in place of finding ``i``, the others at
        ``thetas[1]``), with their weighted residuals.  ``extra_rows``: the extra models are replayed over the
        first ``extra_rows`` samples only (an alternative is sized on the fitting part alone,
        :func:`ur5fault.discrepancy.judging.alternatives`), in the same batch as the rest."""
        n_all = rp.n_samples
        n_extra = n_all if extra_rows is None else int(extra_rows)
        meas = rp.measured(n_all)

        def evaluate(thetas: list[NDArray], extra=()) -> list[tuple[Replayed, NDArray]]:
            sets = [self.specs(theta) for theta in thetas]
            alt_sets = self.alternative_sets(thetas[1], extra) if extra else []
            sims, alt_sims = rp.run_batches([(sets, n_all), (alt_sets, n_extra)], progress)
            return ([(s, weighted(meas, s.y, rp.sigma)) for s in sims]
                    + [(s, weighted(meas[:n_extra], s.y, rp.sigma)) for s in alt_sims])

        return evaluate
