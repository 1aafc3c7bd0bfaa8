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
from .search import Refined, Verdict, backward, columns_of, forward, judge, refine
from .statistics import Z_95, BlockGram, Generalisation, generalisation, rss_of, weighted

logger = logging.getLogger(__name__)

#: residuals above this multiple of the noise floor (sqrt 2 sigma: model and log noise) get joint-local terms
FLOOR_FACTOR = 2.0
FIT_FRACTION_RANGE = (0.2, 0.9)


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


class _Stages:
    """Progress of the workflow on one tqdm bar (``ur5fault.progress``): one unit per stage."""

    NAMES = ("screening the library", "refining library findings", "discovering terms", "refining all findings",
             "held-out check")

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
    """

    def __init__(self, fit_fraction: float = 0.6, max_effects: int = 3, max_terms: int = 4,
                 kinds: Sequence[str] | None = None, jobs: int = 1, refiner: str = "secant",
                 progress: bool = False) -> None:
        lo, hi = FIT_FRACTION_RANGE
        if not lo <= fit_fraction <= hi:
            raise ParameterError(f"fit_fraction = {fit_fraction} is out of range [{lo}, {hi}]")
        if refiner not in ("secant", "minimize"):
            raise ParameterError(f"refiner = {refiner!r} is not valid; choose one of: secant, minimize")
        self.fit_fraction, self.max_effects, self.max_terms = fit_fraction, max_effects, max_terms
        self.kinds, self.jobs, self.refiner, self.progress = kinds, jobs, refiner, progress

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
        self.n_fit_, self.n_all_ = n_fit, n_all
        meas = rp.measured(n_fit)
        stages = _Stages(self.progress)
        self.search_: list[SearchStep] = []
        self.refinement_: dict[str, list] = {}
        timings: dict[str, float] = {}

        # ---- 1. the library, screened in one batch and selected on the linearised problem
        t = time.perf_counter()
        cands = library.candidates(log.payload_kg, kinds=self.kinds)
        base, X_lib, cands = library.screen(rp, n_fit, cands, progress=stages.start("screening the library"))
        e0 = weighted(meas, base.y, rp.sigma)
        bg = BlockGram.build(X_lib, e0)
        cols = columns_of(cands)
        sel = forward(bg, e0, X_lib, cands, cols, self.max_effects)
        self.search_ += [SearchStep.of("library", v) for v in sel.trace]
        timings["library screening"] = time.perf_counter() - t
        lib = [cands[k] for k in sel.chosen]
        alternatives = {cands[k]: [(cands[a], th) for a, th in alt] for k, alt in zip(sel.chosen, sel.alternatives)}
        sim_lib, e_lib, J_lib, th_lib = base, e0, np.zeros((0,) + e0.shape), np.zeros(0)
        t = time.perf_counter()
        if lib:
            th0 = sel.theta(bg, cols)
            ref = self._refine(rp, n_fit, meas, lib, e0, th0, X_lib[[c for k in sel.chosen for c in cols[k]]],
                               stages.start("refining library findings"))
            self.refinement_["library"] = ref.steps
            if ref.sim is not None:
                sim_lib, e_lib, J_lib, th_lib = ref.sim, ref.e, ref.J, ref.theta
        timings["library refinement"] = time.perf_counter() - t

        # ---- 2. discovery on what the library leaves, library findings free to readjust
        t = time.perf_counter()
        stages.start("discovering terms")
        terms: list[Candidate] = []
        if self.max_terms > 0:
            joints = self._joints_above_floor(e_lib, rp.sigma.shape[0])
            dcands, X_dict = discovery.dictionary(rp, sim_lib, n_fit, joints)
            if len(dcands):
                X_all = np.concatenate([J_lib, X_dict]) if len(J_lib) else X_dict
                e_pseudo = e_lib + np.tensordot(th_lib, J_lib, axes=1) if len(J_lib) else e_lib
                fixed = list(range(len(J_lib)))
                dcols = columns_of(dcands, start=len(J_lib))
                bg2 = BlockGram.build(X_all, e_pseudo)
                sel2 = forward(bg2, e_pseudo, X_all, dcands, dcols, self.max_terms, fixed=fixed)
                self.search_ += [SearchStep.of("dictionary", v) for v in sel2.trace]
                terms = [dcands[k] for k in sel2.chosen]
                for k, alt in zip(sel2.chosen, sel2.alternatives):
                    alternatives[dcands[k]] = [(dcands[a], th) for a, th in alt]
        timings["discovery"] = time.perf_counter() - t

        # ---- 3. everything refined together, then judged against all the others
        t = time.perf_counter()
        found = lib + terms
        refined: Refined | None = None
        if terms:
            tcols = [c for k in sel2.chosen for c in dcols[k]]
            G2, g2, ee2 = bg2.total()
            th0 = rss_of(G2, g2, ee2, fixed + tcols)[1]  # library and term coefficients, jointly
            J0 = X_all[fixed + tcols]
            # the terms' quasi-static columns are replaced by their simulated response: each term is also
            # simulated removed (and, for a sine-cosine pair, turned by a quarter period) in the first batch
            probes, off = [], len(fixed)
            for c in terms:
                th_c = th0[off : off + c.n_coef]
                for d in ([-th_c] + ([np.array([-th_c[1], th_c[0]])] if c.n_coef == 2 else [])):
                    p = np.zeros_like(th0)
                    p[off : off + c.n_coef] = d
                    probes.append(p)
                off += c.n_coef
            refined = self._refine(rp, n_fit, meas, found, e0, th0, J0, stages.start("refining all findings"),
                                   probes)
            self.refinement_["all"] = refined.steps
        elif lib and sim_lib is not base:
            refined = Refined(th_lib, J_lib, sim_lib, e_lib, [])
        timings["joint refinement"] = time.perf_counter() - t
        findings = self._judge(found, refined, alternatives) if refined is not None and refined.sim is not None else []
        if found and (refined is None or refined.sim is None):
            self.search_.append(SearchStep("refinement", ", ".join(c.label for c in found), (), 0.0, 0.0, (), False,
                                           "re-simulation does not confirm the linearised estimate"))

        # ---- 4. held-out check by simulation over the whole log
        t = time.perf_counter()
        stages.start("held-out check")
        self._held_out(rp, findings, n_fit, n_all)
        timings["held-out check"] = time.perf_counter() - t
        stages.close()
        self.findings_ = findings
        self.timings_s_ = timings
        self.wall_s_ = time.perf_counter() - t0
        self.n_simulated_runs_ = rp.n_simulated
        self.simulated_s_ = rp.simulated_s
        return self

    # --------------------------------------------------------------------------------- pieces
    def _refine(self, rp: Replay, n: int, meas: NDArray, found: list[Candidate], e0: NDArray, theta0: NDArray,
                J0: NDArray, progress, probes: Sequence[NDArray] = ()) -> Refined:
        sizes = [c.n_coef for c in found]
        splits = np.cumsum(sizes)[:-1]

        def evaluate(thetas: list[NDArray]) -> list[tuple[Replayed, NDArray]]:
            sets = [tuple(c.spec(th) for c, th in zip(found, np.split(theta, splits))) for theta in thetas]
            sims = rp.run(sets, n, progress)
            return [(s, weighted(meas, s.y, rp.sigma)) for s in sims]

        lo = np.concatenate([c.bounds()[0] for c in found])
        hi = np.concatenate([c.bounds()[1] for c in found])
        return refine(evaluate, e0, theta0, J0, (lo, hi), self.refiner, probes)

    def _judge(self, found: list[Candidate], ref: Refined, alternatives) -> list[Finding]:
        """Every finding against all the others, on the problem linearised at the refined coefficients:
        selected afresh from the findings alone (so two that only cancel each other, e.g. a viscous scale
        and a negative viscous term beside a speed-squared drag, do not both stay), then each checked
        against all the rest."""
        cols = columns_of(found)
        e_pseudo = ref.e + np.tensordot(ref.theta, ref.J, axes=1)
        bg = BlockGram.build(ref.J, e_pseudo)
        again = forward(bg, e_pseudo, ref.J, found, cols, len(found))
        kept, verdicts, _ = backward(bg, e_pseudo, ref.J, found, cols, again.chosen)
        G, g, ee = bg.total()
        idx = [c for k in kept for c in cols[k]]
        theta = rss_of(G, g, ee, idx)[1]  # the kept findings refitted without the dropped ones
        out, i = [], 0
        for k, v in zip(kept, verdicts):
            c = found[k]
            th = theta[i : i + c.n_coef]
            i += c.n_coef
            out.append(Finding(c, th, np.asarray(v.se), v, alternatives.get(c, [])))
        for k in range(len(found)):  # the dropped ones, judged against the kept
            if k not in kept:
                v = dataclasses.replace(judge(bg, e_pseudo, ref.J, cols, kept, k), label=found[k].label)
                reason = v.reason or "explains nothing the other findings do not"
                self.search_.append(SearchStep.of("joint check", dataclasses.replace(v, accepted=False,
                                                                                     reason=reason)))
                out.append(Finding(found[k], np.asarray(v.theta), np.asarray(v.se), v, alternatives.get(found[k], []),
                                   kept=False, reason=f"explains nothing the others do not ({reason})"))
        return out

    def _held_out(self, rp: Replay, findings: list[Finding], n_fit: int, n_all: int) -> None:
        """Simulate the whole log without findings, with all, and without each; drop findings that do not
        generalise to the held-out part, and keep the replays for the report."""
        findings = [f for f in findings if f.kept]
        specs = [f.spec() for f in findings]
        sets = [(), tuple(specs)] + ([tuple(s for s in specs if s is not x) for x in specs] if len(specs) > 1 else [])
        sims = rp.run(sets, n_all)
        meas = rp.measured(n_all)
        held = slice(n_fit, n_all)
        nominal, full = sims[0], sims[1]
        without = sims[2:] if len(specs) > 1 else [nominal]
        S = len(rp.signals)
        for f, w in zip(findings, without):
            ch = np.zeros((S, N_JOINTS), dtype=bool)
            if f.candidate.local:
                ch[:, f.candidate.joint] = True
            else:
                ch[:] = True
            e_with = weighted(meas[held], full.y[held], rp.sigma)[:, ch.ravel()]
            e_without = weighted(meas[held], w.y[held], rp.sigma)[:, ch.ravel()]
            f.held_out = generalisation(e_with, e_without)
            if not f.held_out.passes:
                f.kept = False
                f.reason = (f"does not generalise: on the held-out part it removes {100 * f.held_out.ratio:.0f} % "
                            "of the change it makes")
        dropped = [i for i, f in enumerate(findings) if not f.kept]
        if len(dropped) == 1 and len(specs) > 1:
            after = without[dropped[0]]
        elif dropped:
            after = rp.run([tuple(f.spec() for f in findings if f.kept)], n_all)[0]
        else:
            after = full
        self.meas_all_ = meas
        self.sim_before_, self.sim_after_ = nominal, after
        self.residual_before_ = meas - nominal.y
        self.residual_after_ = meas - after.y
        self.rms_before_ = rms_table(rp.signals, meas, nominal.y, held)
        self.rms_after_ = rms_table(rp.signals, meas, after.y, held)
        self.rms_fit_before_ = rms_table(rp.signals, meas, nominal.y, slice(0, n_fit))
        self.rms_fit_after_ = rms_table(rp.signals, meas, after.y, slice(0, n_fit))
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
