"""The discrepancy estimator (scikit-learn manners: ``fit()`` returns self, fitted attributes end in ``_``).

1. *Find*: replay the log's target trajectory through the model; weighted residuals per signal and joint.
2. *Name (library)*: screen every effect of the registry in one lockstep batch (``library.py``), select
   by forward selection on the linearised problem, every step judged on significance, autocorrelation
   and stability in time blocks (``search.py``, ``statistics.py``); refine the selected by re-simulation.
3. *Discover*: fit what the library leaves by the same selection over a dictionary of physical terms of
   the replayed states (``discovery.py``); refine library findings and terms together by re-simulation.
4. *Judge*: every finding against all the others (it must explain something nothing else does), then
   on the held-out part of the log by simulation: a finding that does not generalise is dropped and
   reported.
5. *Show*: before/after RMS per signal and joint on the held-out part; what stays unexplained.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..axes import JOINT_NAMES, N_JOINTS
from ..effects import EffectSpec
from ..errors import ParameterError
from ..logs import MeasuredLog
from . import discovery, library
from .candidates import Candidate
from .replay import Replay, Replayed
from .report import localise, rms_table, unexplained
from .search import Refined, Verdict, backward, columns_of, forward, judge, polish, probe_batch
from .statistics import Z_95, BlockGram, Generalisation, generalisation, rss_of, weighted

logger = logging.getLogger(__name__)

#: residuals above this multiple of the noise floor (sqrt 2 sigma: model and log noise) get joint-local terms
FLOOR_FACTOR = 2.0
FIT_FRACTION_RANGE = (0.2, 0.9)
#: the library is screened and the dictionary selected on at most this much of the fitting part [s]
#: (assumption: 20 s of a robot program hold its motions several times; refinement and judgement use all)
SCREEN_S = 20.0
#: indistinguishable alternatives per finding simulated (for their own estimates) at most
MAX_ALTERNATIVES = 3


@dataclasses.dataclass
class Finding:
    """A library effect or a discovered term the workflow adds to the model.

    Attributes:
        candidate: what it is (effect, joint, parameter or dictionary family).
        theta: its coefficients; ``se`` their block-jackknife standard errors.
        verdict: its final judgement against all the other findings.
        alternatives: candidates this log cannot tell from it, with their own coefficients.
        held_out: what it does on the held-out part (None until judged there).
        kept: False when it was dropped; ``reason`` says why.
    """

    candidate: Candidate
    theta: NDArray
    se: NDArray
    verdict: Verdict
    alternatives: list[tuple[Candidate, NDArray]] = dataclasses.field(default_factory=list)
    held_out: Generalisation | None = None
    kept: bool = True
    reason: str = ""

    def spec(self) -> EffectSpec:
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


#: bare MuJoCo steps timed to measure the machine's speed (about 0.1 s)
SPEED_PROBE_STEPS = 20000


def bare_mj_step_us(dt_s: float) -> float:
    """Wall time of one bare ``mujoco.mj_step`` of the packaged UR5 now [us] (no drive, no Python loop
    around it beyond this one)."""
    import mujoco

    from ..engine import DEFAULT_MODEL_PATH

    m = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    m.opt.timestep = dt_s
    d = mujoco.MjData(m)
    t = time.perf_counter()
    for _ in range(SPEED_PROBE_STEPS):
        mujoco.mj_step(m, d)
    return (time.perf_counter() - t) / SPEED_PROBE_STEPS * 1e6


class _Stages:
    """Progress of the workflow on one tqdm bar (``ur5fault.progress``): one unit per stage."""

    NAMES = ("screening the library", "discovering terms", "refining the findings", "judging")

    def __init__(self, enabled: bool) -> None:
        from .. import progress

        self.bar = progress.bar(len(self.NAMES), "discrepancy", "stage", enabled=enabled,
                                bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}")
        self.k = 0

    def start(self, name: str):
        self.k = self.NAMES.index(name)
        self.bar.set_description(f"discrepancy: {name}")
        self.bar.n = self.k
        self.bar.refresh()

        def frac(f: float) -> None:
            self.bar.n = round(self.k + min(max(f, 0.0), 1.0), 3)
            self.bar.refresh()

        return frac

    def close(self) -> None:
        self.bar.n = len(self.NAMES)
        self.bar.close()


class DiscrepancyModel:
    """Fit the library's effects and the dictionary's terms to a measured log.

    Args:
        fit_fraction: share of the log (from its start) used for fitting; the rest is held out.
        max_effects: most library effects named.
        max_terms: most dictionary terms added (0: no discovery).
        kinds: restrict the library's effect kinds (default: the whole registry).
        jobs: worker processes for lockstep batches.
        refiner: ``"secant"`` or ``"minimize"`` (see :func:`ur5fault.discrepancy.search.refine`).
        progress: show a progress bar (tqdm; silent when not interactive).
        screen_s: length of the log's first part the library is screened and the dictionary selected on
            [s] (None: the whole fitting part); refinement and judgement use the whole fitting part.
    """

    def __init__(self, fit_fraction: float = 0.6, max_effects: int = 3, max_terms: int = 4,
                 kinds: Sequence[str] | None = None, jobs: int = 1, refiner: str = "secant",
                 progress: bool = False, screen_s: float | None = SCREEN_S) -> None:
        lo, hi = FIT_FRACTION_RANGE
        if not lo <= fit_fraction <= hi:
            raise ParameterError(f"fit_fraction = {fit_fraction} is out of range [{lo}, {hi}]")
        if refiner not in ("secant", "minimize"):
            raise ParameterError(f"refiner = {refiner!r} is not valid; choose one of: secant, minimize")
        self.fit_fraction, self.max_effects, self.max_terms = fit_fraction, max_effects, max_terms
        self.kinds, self.jobs, self.refiner, self.progress = kinds, jobs, refiner, progress
        if screen_s is not None and screen_s <= 0:
            raise ParameterError(f"screen_s = {screen_s} must be a positive number of seconds (or None: the "
                                 "whole fitting part)")
        self.screen_s = screen_s

    # ------------------------------------------------------------------------------------------- fit
    def fit(self, log: MeasuredLog, params_overrides: dict | None = None,
            base_effects: Sequence[EffectSpec] = ()) -> DiscrepancyModel:
        t0 = time.perf_counter()
        rp = Replay(log, params_overrides, base_effects, jobs=self.jobs)
        self.replay_ = rp
        self.base_effects_ = tuple(base_effects)
        self.params_overrides_ = dict(params_overrides or {})
        n_all = rp.n_samples
        n_fit = int(n_all * self.fit_fraction)
        n_scr = n_fit if self.screen_s is None else min(n_fit, max(2, round(self.screen_s / log.period_s)))
        self.n_fit_, self.n_all_, self.n_screen_ = n_fit, n_all, n_scr
        stages = _Stages(self.progress)
        self.search_: list[SearchStep] = []
        timings: dict[str, float] = {}

        # ---- 1. the library, screened in one batch and selected on the linearised problem
        t = time.perf_counter()
        cands = library.candidates(log.payload_kg, kinds=self.kinds)
        base, X_lib, cands = library.screen(rp, n_scr, cands, progress=stages.start("screening the library"))
        e0 = weighted(rp.measured(n_scr), base.y, rp.sigma)
        bg = BlockGram.build(X_lib, e0)
        cols = columns_of(cands)
        sel = forward(bg, e0, X_lib, cands, cols, self.max_effects)
        self.search_ += [SearchStep.of("library", v) for v in sel.trace]
        lib = [cands[k] for k in sel.chosen]
        lib_cols = [c for k in sel.chosen for c in cols[k]]
        # a finding's indistinguishable alternatives with their linear estimates (simulated later)
        alternatives = {cands[k]: [(cands[a], th) for a, th in alt][:MAX_ALTERNATIVES]
                        for k, alt in zip(sel.chosen, sel.alternatives)}
        timings["library screening"] = time.perf_counter() - t

        # ---- 2. discovery: the dictionary's terms on what the library leaves (library columns free to readjust)
        t = time.perf_counter()
        stages.start("discovering terms")
        terms: list[Candidate] = []
        X_all, fixed = X_lib[lib_cols], list(range(len(lib_cols)))
        if self.max_terms > 0:
            G, g, ee = bg.total()
            e_lib = e0 - np.tensordot(rss_of(G, g, ee, lib_cols)[1], X_lib[lib_cols], axes=1)
            dcands, X_dict = discovery.dictionary(rp, base, n_scr, self._joints_above_floor(e_lib, len(rp.signals)))
            if dcands:
                X_all = np.concatenate([X_all, X_dict])
                dcols = columns_of(dcands, start=len(lib_cols))
                bg2 = BlockGram.build(X_all, e0)
                sel2 = forward(bg2, e0, X_all, dcands, dcols, self.max_terms, fixed=fixed)
                self.search_ += [SearchStep.of("dictionary", v) for v in sel2.trace]
                terms = [dcands[k] for k in sel2.chosen]
                fixed += [c for k in sel2.chosen for c in dcols[k]]
                for k, alt in zip(sel2.chosen, sel2.alternatives):
                    alternatives[dcands[k]] = [(dcands[a], th) for a, th in alt][:MAX_ALTERNATIVES]
        timings["discovery"] = time.perf_counter() - t

        # ---- 3. every finding refined by re-simulating the whole log (one batch of probes), then judged;
        # first the findings selected afresh among themselves on the linearised problem (free), so that
        # library effects that only stood in for a term discovered later are not re-simulated
        t = time.perf_counter()
        found = lib + terms
        if len(found) > 1:
            fcols = columns_of(found)
            bg3 = BlockGram.build(X_all[fixed], e0)
            again = forward(bg3, e0, X_all[fixed], found, fcols, len(found))
            keep, _, _ = backward(bg3, e0, X_all[fixed], found, fcols, again.chosen)
            for k in range(len(found)):
                if k not in keep:
                    v = dataclasses.replace(judge(bg3, e0, X_all[fixed], fcols, keep, k), label=found[k].label)
                    self.search_.append(SearchStep.of("linear joint check", dataclasses.replace(
                        v, accepted=False, reason=v.reason or "explains nothing the other findings do not")))
            keep = sorted(keep)
            fixed = [fixed[c] for k in keep for c in fcols[k]]
            found = [found[k] for k in keep]
        prog = stages.start("refining the findings")
        self.refinement_ = []
        if found:
            G, g, ee = BlockGram.build(X_all[fixed], e0).total()
            theta0 = rss_of(G, g, ee, list(range(len(fixed))))[1]
            self._alts = [(i, a, th) for i, c in enumerate(found) for a, th in alternatives.get(c, [])]
            first = self._probe(rp, found, theta0, n_fit, prog, self._alts)
            self.refinement_ += first.steps
            nominal = first.sim0
        else:
            nominal = rp.run([()], n_all, prog)[0]
        timings["refinement"] = time.perf_counter() - t

        # ---- 4. judged on the fitting and the held-out part; the kept ones polished by Gauss-Newton (the
        # first simulation of which is the final model when the estimate has converged)
        t = time.perf_counter()
        prog = stages.start("judging")
        findings: list[Finding] = []
        after = nominal
        if found:
            findings = self._judge(found, first, n_fit)
            kept = [f for f in findings if f.kept]
            if kept:
                after = self._polish(rp, kept, first, found, n_fit, prog)
        self._results(rp, nominal, after, n_fit, n_all)
        self._results(rp, nominal, after, n_fit, n_all)
        timings["judging"] = time.perf_counter() - t
        stages.close()
        self.findings_ = findings
        self.timings_s_ = timings
        self.wall_s_ = time.perf_counter() - t0
        self.n_simulated_runs_ = rp.n_simulated
        self.simulated_s_ = rp.simulated_s
        # the machine's speed right now, for wall times that mean something on a shared machine
        self.bare_mj_step_us_ = bare_mj_step_us(rp.params.physics_dt_s)
        steps = rp.simulated_s / rp.params.physics_dt_s
        self.wall_over_mj_steps_ = self.wall_s_ / (steps * self.bare_mj_step_us_ * 1e-6) if steps else float("nan")
        return self

    # --------------------------------------------------------------------------------- pieces
    @staticmethod
    def _split(found: list[Candidate], theta: NDArray) -> list[NDArray]:
        return np.split(theta, np.cumsum([c.n_coef for c in found])[:-1])

    def _evaluator(self, rp: Replay, found: list[Candidate], progress):
        """``evaluate(thetas, extra=())``: replays of the whole log with ``found`` at each ``theta`` (and
        each extra ``(i, alternative, its coefficients)``: the alternative in place of finding ``i``, the
        others at ``thetas[1]``), with their weighted residuals."""
        n_all = rp.n_samples
        meas = rp.measured(n_all)

        def specs(theta: NDArray) -> tuple[EffectSpec, ...]:
            return tuple(c.spec(th) for c, th in zip(found, self._split(found, theta)) if np.any(th))

        def evaluate(thetas: list[NDArray], extra=()) -> list[tuple[Replayed, NDArray]]:
            sets = [specs(theta) for theta in thetas]
            for i, a, a_theta in extra:
                th = self._split(found, thetas[1])
                th[i] = np.zeros_like(th[i])
                sets.append(specs(np.concatenate(th)) + (a.spec(a_theta),))
            sims = rp.run(sets, n_all, progress)
            return [(s, weighted(meas, s.y, rp.sigma)) for s in sims]

        return evaluate

    def _bounds(self, found: list[Candidate]) -> tuple[NDArray, NDArray]:
        return (np.concatenate([c.bounds()[0] for c in found]), np.concatenate([c.bounds()[1] for c in found]))

    def _probe(self, rp: Replay, found: list[Candidate], theta0: NDArray, n_fit: int, progress,
               alts: Sequence[tuple[int, Candidate, NDArray]] = ()) -> Refined:
        """One batch over the whole log: the starting model, the linearised estimate, each finding removed
        (a sine-cosine pair also turned by a quarter period), whose secants give the simulated Jacobian,
        and each indistinguishable alternative in place of its finding (at its linear estimate)."""
        probes, off = [], 0
        for c in found:
            th_c = theta0[off : off + c.n_coef]
            for d in [-th_c] + ([np.array([-th_c[1], th_c[0]])] if c.n_coef == 2 else []):
                p = np.zeros_like(theta0)
                p[off : off + c.n_coef] = d
                probes.append(p)
            off += c.n_coef
        evaluate = self._evaluator(rp, found, progress)
        return probe_batch(evaluate, theta0, probes, self._bounds(found), n_fit, list(alts), evaluate)

    def _polish(self, rp: Replay, kept: list[Finding], first: Refined, found: list[Candidate], n_fit: int,
                progress) -> Replayed:
        """Gauss-Newton on the kept findings from their judged coefficients; their final coefficients and
        verdicts (a finding that fails now is dropped, and the final model simulated once more)."""
        cands = [f.candidate for f in kept]
        cols = columns_of(found)
        idx = [c for f in kept for c in cols[found.index(f.candidate)]]
        pol = polish(self._evaluator(rp, cands, progress), np.concatenate([f.theta for f in kept]), first.J[idx],
                     self._bounds(cands), n_fit, self.refiner)
        self.refinement_ += pol.steps
        for f, th in zip(kept, self._split(cands, pol.theta)):
            f.theta = th
        kcols = columns_of(cands)
        J_fit = pol.J[:, :n_fit]
        e_pseudo = pol.e[:n_fit] + np.tensordot(pol.theta, J_fit, axes=1)
        bg = BlockGram.build(J_fit, e_pseudo)
        failed = []
        for k, f in enumerate(kept):
            v = dataclasses.replace(judge(bg, e_pseudo, J_fit, kcols, [o for o in range(len(kept)) if o != k], k),
                                    label=f.candidate.label)
            f.verdict, f.se = v, np.asarray(v.se)
            if not v.accepted:
                failed.append(f)
        for f in failed:
            f.kept = False
            f.reason = f"explains nothing the others do not once refined ({f.verdict.reason})"
            self.search_.append(SearchStep.of("final check", dataclasses.replace(f.verdict, reason=f.reason)))
        if failed:
            rest = [f for f in kept if f.kept]
            return rp.run([tuple(f.spec() for f in rest)], rp.n_samples, progress)[0] if rest else first.sim0
        return pol.sim

    def _judge(self, found: list[Candidate], ref: Refined, n_fit: int) -> list[Finding]:
        """Every finding against all the others on the fitting part, linearised at the refined coefficients:
        selected afresh from the findings alone (so two that only cancel each other, e.g. a viscous scale
        and a negative viscous term beside a speed-squared drag, do not both stay), each checked against
        all the rest, then on the held-out part (a finding that does not generalise is dropped)."""
        cols = columns_of(found)
        J_fit, e_fit = ref.J[:, :n_fit], ref.e[:n_fit]
        e_pseudo = e_fit + np.tensordot(ref.theta, J_fit, axes=1)
        bg = BlockGram.build(J_fit, e_pseudo)
        G, g, ee = bg.total()
        again = forward(bg, e_pseudo, J_fit, found, cols, len(found))
        kept, verdicts, _ = backward(bg, e_pseudo, J_fit, found, cols, again.chosen)
        out: list[Finding] = []
        dropped: list[Finding] = []
        for k in range(len(found)):  # the dropped ones, judged against the kept
            if k not in kept:
                v = dataclasses.replace(judge(bg, e_pseudo, J_fit, cols, kept, k), label=found[k].label)
                reason = v.reason or "explains nothing the other findings do not"
                dropped.append(Finding(found[k], np.asarray(v.theta), np.asarray(v.se), v, kept=False,
                                       reason=f"explains nothing the others do not ({reason})"))
        # held-out part: the residual with the kept findings, and without each, from the simulated Jacobian
        e_held = ref.e[n_fit:] + np.tensordot(ref.theta, ref.J[:, n_fit:], axes=1)  # starting model, linearised
        while kept:
            idx = [c for k in kept for c in cols[k]]
            theta = rss_of(G, g, ee, idx)[1]  # the kept findings refitted without the dropped ones
            with_all = e_held - np.tensordot(theta, ref.J[idx, n_fit:], axes=1)
            out, i, worst = [], 0, None
            for k in kept:
                c = found[k]
                th = theta[i : i + c.n_coef]
                own = [idx.index(col) for col in cols[k]]
                i += c.n_coef
                ch = self._channels(c)
                gen = generalisation(with_all[:, ch], (with_all + np.tensordot(th, ref.J[[idx[o] for o in own], n_fit:],
                                                                                axes=1))[:, ch])
                f = Finding(c, th, np.zeros(c.n_coef), None, held_out=gen)
                out.append(f)
                if not gen.passes and (worst is None or gen.ratio < worst[1].held_out.ratio):
                    worst = (k, f)
            if worst is None:
                break
            k, f = worst
            f.kept = False
            f.reason = (f"does not generalise: on the held-out part it removes {100 * f.held_out.ratio:.0f} % of the "
                        "change it makes")
            f.verdict = dataclasses.replace(judge(bg, e_pseudo, J_fit, cols, [o for o in kept if o != k], k),
                                            label=found[k].label)
            f.se = np.asarray(f.verdict.se)
            dropped.append(f)
            kept.remove(k)
            out = []
        final = {k: f for k, f in zip(kept, out)}
        for f in dropped:
            self.search_.append(SearchStep.of("held-out check" if f.held_out else "joint check", dataclasses.replace(
                f.verdict, accepted=False, reason=f.reason)))
        for k, f in final.items():  # final verdicts and alternatives, against the kept findings
            f.verdict = dataclasses.replace(judge(bg, e_pseudo, J_fit, cols, [o for o in kept if o != k], k),
                                            label=found[k].label)
            f.se = np.asarray(f.verdict.se)
            f.alternatives = self._alternatives(found, kept, k, ref, J_fit, e_pseudo, cols, n_fit)
        return list(final.values()) + dropped

    def _channels(self, c: Candidate) -> NDArray:
        """Flat channel mask of what a finding acts on: its joint's signals, or everything."""
        S = len(self.replay_.signals)
        ch = np.zeros((S, N_JOINTS), dtype=bool)
        if c.local:
            ch[:, c.joint] = True
        else:
            ch[:] = True
        return ch.ravel()

    def _alternatives(self, found, kept, k, ref: Refined, J_fit, e_pseudo, cols, n_fit) -> list[tuple[Candidate,
                                                                                                    NDArray]]:
        """Each simulated alternative's own coefficients in place of finding ``k``, beside the other kept
        findings: its secant from the run with finding ``k`` removed (both with the others at their first
        estimates), fitted on the fitting part to what that run leaves (the others' columns take up
        their small differences)."""
        out = []
        others = [c for o in kept if o != k for c in cols[o]]
        ablation = sum(c.n_coef for c in found[:k])  # the first probe of finding k removes it
        e_without = ref.probe_e[ablation]
        for (i, cand, th0), e_alt in zip(self._alts, ref.extra_e):
            if i != k or e_alt is None or e_without is None:
                continue
            col = ((e_without - e_alt)[:n_fit] / np.linalg.norm(th0)).reshape((1,) + e_without[:n_fit].shape)
            u = th0 / np.linalg.norm(th0)  # a harmonic alternative keeps its phase; its size is fitted
            X = np.concatenate([J_fit[others], col])
            G, g, ee = BlockGram.build(X, e_without[:n_fit]).total()
            out.append((cand, rss_of(G, g, ee, list(range(X.shape[0])))[1][-1] * u))
        return out

    def _results(self, rp: Replay, nominal: Replayed, after: Replayed, n_fit: int, n_all: int) -> None:
        meas = rp.measured(n_all)
        held = slice(n_fit, n_all)
        self.sim_before_, self.sim_after_ = nominal, after
        self.residual_before_ = meas - nominal.y
        self.residual_after_ = meas - after.y
        self.rms_before_ = rms_table(rp.signals, meas, nominal.y, held)
        self.rms_after_ = rms_table(rp.signals, meas, after.y, held)
        self.rms_fit_before_ = rms_table(rp.signals, meas, nominal.y, slice(0, n_fit))
        self.rms_fit_after_ = rms_table(rp.signals, meas, after.y, slice(0, n_fit))
        # the robot controller's own current model where the log has it (target - actual current)
        tc = rp.log.target_current_A
        self.rms_controller_model_ = None if tc is None else {
            part: {JOINT_NAMES[j]: float(np.sqrt(np.mean((tc[1 : n_all + 1][sl, j] - meas[sl, 0, j]) ** 2)))
                   for j in range(N_JOINTS)} for part, sl in (("held_out", held), ("fit", slice(0, n_fit)))}
        self.unexplained_ = unexplained(rp, self.residual_after_, after.torque_gear_Nm, n_fit)
        self.localisation_ = localise(rp, self.residual_before_, nominal.torque_gear_Nm)

    @staticmethod
    def _joints_above_floor(e: NDArray, n_signals: int) -> list[int]:
        """Joints whose weighted residual RMS exceeds FLOOR_FACTOR x the noise floor in some signal."""
        rms = np.sqrt(np.mean(e**2, axis=0)).reshape(n_signals, N_JOINTS)
        return [j for j in range(N_JOINTS) if np.any(rms[:, j] > FLOOR_FACTOR * np.sqrt(2.0))]

    # ------------------------------------------------------------------------------------------ outputs
    @property
    def effects_(self) -> list[Finding]:
        """Kept findings of the library."""
        return [f for f in self.findings_ if f.kept and f.candidate.source == "library"]

    @property
    def terms_(self) -> list[Finding]:
        """Kept findings of the dictionary."""
        return [f for f in self.findings_ if f.kept and f.candidate.source == "dictionary"]

    @property
    def dropped_(self) -> list[Finding]:
        return [f for f in self.findings_ if not f.kept]

    def overlay(self) -> dict:
        """The model overlay (``params`` and ``effects``) that ``simulate``, ``campaign run`` and
        ``discrepancy --model`` accept: the starting overlay plus every kept finding."""
        def entry(e: EffectSpec) -> dict:
            return {"effect": e.name, **({"joint": JOINT_NAMES[e.joint]} if e.joint is not None else {}),
                    **dict(e.values)}

        effects = [entry(e) for e in self.base_effects_] + [entry(f.spec()) for f in self.findings_ if f.kept]
        return {"params": self.params_overrides_, "effects": effects}
