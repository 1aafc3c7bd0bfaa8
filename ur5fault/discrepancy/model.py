"""The discrepancy estimator (scikit-learn manners: ``fit()`` returns self, fitted attributes end in ``_``).

1. *Find*: replay the log's target trajectory through the model; weighted residuals per signal and joint.
2. *Name (library)*: screen every effect of the registry in one lockstep batch (``library.py``), select
   by forward selection on the linearised problem, every step judged on significance, autocorrelation
   and stability in time blocks (``search.py``, ``statistics.py``).
3. *Discover*: fit what the library leaves by the same selection over a dictionary of physical terms of
   the replayed states (``discovery.py``).
4. *Refine and judge*: one batch of probes over the whole log gives the simulated Jacobian
   (``refinement.py``); every finding is judged against all the others and on the held-out part
   (``judging.py``): one that does not generalise is dropped and reported; the kept ones are polished.
5. *Show*: before/after RMS per signal and joint on the held-out part; what stays unexplained.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..logs import MeasuredLog
from ..sim.axes import JOINT_NAMES, N_JOINTS
from ..sim.effects import EffectSpec
from ..twin.replay import LogReplay, Replayed
from ..twin.residuals import FIT_FRACTION, fit_samples, localise, rms_table, unexplained
from . import discovery, library
from .candidates import Candidate
from .judging import Finding, SearchStep, final_verdicts, judge_findings
from .multilog import MultiReplay, per_log
from .refinement import FindingSet, Refined, polish, probe_batch
from .search import backward, columns_of, forward, judge
from .statistics import BlockGram, rss_of, weighted

logger = logging.getLogger(__name__)

#: the workflow's own sensor-noise stream of its replays, unrelated to any log
WORKFLOW_SEED = 20261121

#: residuals above this multiple of the noise floor (sqrt 2 sigma: model and log noise) get joint-local terms
FLOOR_FACTOR = 2.0
FIT_FRACTION_RANGE = (0.2, 0.9)
#: the library is screened and the dictionary selected on at most this much of the fitting part [s]
#: (assumption: 20 s of a robot program hold its motions several times; refinement and judgement use all)
SCREEN_S = 20.0
#: indistinguishable alternatives per finding simulated (for their own estimates) at most
MAX_ALTERNATIVES = 3


#: bare MuJoCo steps timed to measure the machine's speed (about 0.1 s)
SPEED_PROBE_STEPS = 20000


def bare_mj_step_us(dt_s: float) -> float:
    """Wall time of one bare ``mujoco.mj_step`` of the packaged UR5 now [us] (no drive, no Python loop
    around it beyond this one)."""
    import mujoco

    from ..sim.engine import DEFAULT_MODEL_PATH

    m = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    m.opt.timestep = dt_s
    d = mujoco.MjData(m)
    t = time.perf_counter()
    for _ in range(SPEED_PROBE_STEPS):
        mujoco.mj_step(m, d)
    return (time.perf_counter() - t) / SPEED_PROBE_STEPS * 1e6


class _Stages:
    """Progress of the workflow on one tqdm bar (``ur5fault.util.progress``): one unit per stage."""

    NAMES = ("screening the library", "discovering terms", "refining the findings", "judging")

    def __init__(self, enabled: bool) -> None:
        from ..util import progress

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
        refiner: ``"secant"`` or ``"minimize"`` (see :func:`ur5fault.discrepancy.refinement.polish`).
        progress: show a progress bar (tqdm; silent when not interactive).
        screen_s: length of the log's first part the library is screened and the dictionary selected on
            [s] (None: the whole fitting part); refinement and judgement use the whole fitting part.
    """

    def __init__(self, fit_fraction: float = FIT_FRACTION, max_effects: int = 3, max_terms: int = 4,
                 kinds: Sequence[str] | None = None, jobs: int = 1, refiner: str = "secant",
                 progress: bool = False, screen_s: float | None = SCREEN_S) -> None:
        lo, hi = FIT_FRACTION_RANGE
        if not lo <= fit_fraction <= hi:
            raise ParameterError(f"fit_fraction = {fit_fraction} is out of range [{lo}, {hi}]")
        for name, v, least in (("max_effects", max_effects, 0), ("max_terms", max_terms, 0), ("jobs", jobs, 1)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
                raise ParameterError(f"{name} = {v!r} must be a whole number >= {least}")
        if refiner not in ("secant", "minimize"):
            raise ParameterError(f"refiner = {refiner!r} is not valid; choose one of: secant, minimize")
        self.fit_fraction, self.max_effects, self.max_terms = fit_fraction, max_effects, max_terms
        self.kinds, self.jobs, self.refiner, self.progress = kinds, jobs, refiner, progress
        if screen_s is not None and screen_s <= 0:
            raise ParameterError(f"screen_s = {screen_s} must be a positive number of seconds (or None: the "
                                 "whole fitting part)")
        self.screen_s = screen_s

    # ------------------------------------------------------------------------------------------- fit
    def fit(self, log: MeasuredLog | Sequence[MeasuredLog], params_overrides: dict | None = None,
            base_effects: Sequence[EffectSpec] = (), hold_out: Sequence[MeasuredLog] = ()) -> DiscrepancyModel:
        """Fit ``log`` (one log, or several runs of one robot fitted jointly), each split in time at
        ``fit_fraction``; ``hold_out``: further runs held out whole (judged and scored, never fitted)."""
        t0 = time.perf_counter()
        logs = [log] if isinstance(log, MeasuredLog) else list(log)
        rp: LogReplay | MultiReplay
        if len(logs) == 1 and not hold_out:
            rp = LogReplay(logs[0], params_overrides, base_effects, seed=WORKFLOW_SEED, jobs=self.jobs)
            n_fit = fit_samples(rp.n_samples, self.fit_fraction)
        else:
            rp = MultiReplay(logs, hold_out, self.fit_fraction, params_overrides, base_effects, seed=WORKFLOW_SEED,
                             jobs=self.jobs)
            n_fit = rp.n_fit
        log = rp.log
        self.replay_ = rp
        self.base_effects_ = tuple(base_effects)
        self.params_overrides_ = dict(params_overrides or {})
        n_all = rp.n_samples
        n_scr = n_fit if self.screen_s is None else min(n_fit, max(2, round(self.screen_s / log.period_s)))
        self.n_fit_, self.n_all_, self.n_screen_ = n_fit, n_all, n_scr
        stages = _Stages(self.progress)
        self.search_: list[SearchStep] = []
        timings: dict[str, float] = {}

        # ---- 1. the library, screened in one batch and selected on the linearised problem
        t = time.perf_counter()
        cands = library.candidates(log.payload_kg, kinds=self.kinds, params=rp.params)
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
        logger.info("library screened in %.0f s: %s", timings["library screening"], [c.label for c in lib] or "nothing")

        # ---- 2. discovery: the dictionary's terms on what the library leaves (library columns free to readjust)
        t = time.perf_counter()
        stages.start("discovering terms")
        terms: list[Candidate] = []
        X_all, fixed = X_lib[lib_cols], list(range(len(lib_cols)))
        if self.max_terms > 0:
            G, g, ee = bg.total()
            e_lib = e0 - np.tensordot(rss_of(G, g, ee, lib_cols)[1], X_lib[lib_cols], axes=1)
            # offered where the library leaves a residual above the floor, and on the joints of the library's
            # findings: a library effect may stand in for a term outside the library (viscous and Coulomb
            # scales for a speed-squared drag); the joint check below keeps what explains what the rest does not
            joints = sorted(set(self._joints_above_floor(e_lib, len(rp.signals)))
                            | {c.joint for c in lib if c.joint is not None})
            dcands, X_dict = discovery.dictionary(rp, base, n_scr, joints)
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
        logger.info("dictionary selected in %.0f s: %s", timings["discovery"], [c.label for c in terms] or "nothing")

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
                    v = judge(bg3, e0, X_all[fixed], found, fcols, keep, k)
                    self.search_.append(SearchStep.of("linear joint check", dataclasses.replace(
                        v, accepted=False, reason=v.reason or "explains nothing the other findings do not")))
            keep = sorted(keep)
            fixed = [fixed[c] for k in keep for c in fcols[k]]
            found = [found[k] for k in keep]
        prog = stages.start("refining the findings")
        self.refinement_ = []
        fs = FindingSet(found)
        alts = [(i, a, th) for i, c in enumerate(found) for a, th in alternatives.get(c, [])]
        if found:
            G, g, ee = BlockGram.build(X_all[fixed], e0).total()
            theta0 = rss_of(G, g, ee, list(range(len(fixed))))[1]
            evaluate = fs.evaluator(rp, prog)
            first = probe_batch(evaluate, theta0, fs.probes(theta0), fs.bounds(), n_fit, alts, evaluate)
            self.refinement_ += first.steps
            nominal = first.sim0
        else:
            nominal = rp.run([()], n_all, prog)[0]
        timings["refinement"] = time.perf_counter() - t
        logger.info("probe batch over the whole log in %.0f s (%d findings)", timings["refinement"], len(found))

        # ---- 4. judged on the fitting and the held-out part; the kept ones polished by Gauss-Newton (the
        # first simulation of which is the final model when the estimate has converged)
        t = time.perf_counter()
        prog = stages.start("judging")
        findings: list[Finding] = []
        after = nominal
        if found:
            findings, trace = judge_findings(found, first, n_fit, len(rp.signals), alts)
            self.search_ += trace
            kept = [f for f in findings if f.kept]
            if kept:
                after = self._polish(rp, kept, first, fs, prog)
        self._results(rp, nominal, after, n_fit, n_all)
        timings["judging"] = time.perf_counter() - t
        logger.info("judged and polished in %.0f s: kept %s", timings["judging"],
                    [f.candidate.label for f in findings if f.kept] or "nothing")
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
    def _polish(self, rp: LogReplay, kept: list[Finding], first: Refined, fs: FindingSet, progress) -> Replayed:
        """Gauss-Newton on the kept findings from their judged coefficients, then their final verdicts (one
        that fails now is dropped and the final model simulated once more)."""
        cols = columns_of(fs.found)
        kfs = FindingSet([f.candidate for f in kept])
        idx = [c for f in kept for c in cols[fs.found.index(f.candidate)]]
        pol = polish(kfs.evaluator(rp, progress), np.concatenate([f.theta for f in kept]), first.J[idx],
                     kfs.bounds(), self.n_fit_, self.refiner)
        self.refinement_ += pol.steps
        for f, th in zip(kept, kfs.split(pol.theta)):
            f.theta = th
        failed = final_verdicts(kept, pol, self.n_fit_)
        for f in failed:
            f.kept = False
            f.reason = (f.candidate.range_problem(f.theta)
                        or f"explains nothing the others do not once refined ({f.verdict.reason})")
            self.search_.append(SearchStep.of("final check", dataclasses.replace(f.verdict, reason=f.reason)))
        if failed:
            rest = tuple(f.spec() for f in kept if f.kept)
            return rp.run([rest], rp.n_samples, progress)[0] if rest else first.sim0
        return pol.sim

    def _results(self, rp: LogReplay, nominal: Replayed, after: Replayed, n_fit: int, n_all: int) -> None:
        meas = rp.measured(n_all)
        # RMS figures only on the ticks the robot logged (a gap's interpolated readings are left out)
        logged = rp.log.logged_rows()[1 : n_all + 1]
        scored = np.where(logged[:, None, None], meas, np.nan)
        held = slice(n_fit, n_all)
        self.sim_before_, self.sim_after_ = nominal, after
        self.residual_before_ = meas - nominal.y
        self.residual_after_ = meas - after.y
        self.rms_before_ = rms_table(rp.signals, scored, nominal.y, held)
        self.rms_after_ = rms_table(rp.signals, scored, after.y, held)
        self.rms_fit_before_ = rms_table(rp.signals, scored, nominal.y, slice(0, n_fit))
        self.rms_fit_after_ = rms_table(rp.signals, scored, after.y, slice(0, n_fit))
        # the robot controller's own current model where the log has it (target - actual current)
        tc = rp.log.target_current_A
        self.rms_controller_model_ = None if tc is None else {
            part: {JOINT_NAMES[j]: float(np.sqrt(np.nanmean((tc[1 : n_all + 1][sl, j] - scored[sl, 0, j]) ** 2)))
                   for j in range(N_JOINTS)} for part, sl in (("held_out", held), ("fit", slice(0, n_fit)))}
        self.per_log_ = per_log(rp, scored, nominal.y, after.y, n_fit, n_all)
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
