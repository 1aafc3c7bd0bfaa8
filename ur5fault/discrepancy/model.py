"""The discrepancy estimator (scikit-learn manners: ``fit()`` returns self, fitted attributes end in ``_``).

1. *Find*: replay the log's target trajectory through the model; weighted residuals per signal and joint.
2. *Name (library)*: screen every effect of the registry in one lockstep batch (``library.py``), select
   by forward selection on the linearised problem, every step judged on significance, autocorrelation
   and stability in time blocks (``search.py``, ``statistics.py``).
3. *Discover*: fit what the library leaves by the same selection over a dictionary of physical terms of
   the replayed states (``discovery.py``).
4. *Refine and judge*: one batch of probes over the whole log gives the simulated Jacobian
   (``refinement.py``); every finding is judged against all the others and on the held-out part
   (``judging.py``): one that does not generalise is dropped and reported; the kept ones are polished;
   every kept finding gets its rivals, the library effects the held-out part cannot tell from it
   (``rivals.py``).
5. *Show*: before/after RMS per signal and joint on the held-out part; what stays unexplained.
"""

from __future__ import annotations

import dataclasses
import logging
import time
from collections.abc import Callable, Sequence

import numpy as np

from ..errors import ParameterError
from ..logs import MeasuredLog
from ..sim.axes import JOINT_NAMES, N_JOINTS
from ..sim.effects import EffectSpec
from ..twin.replay import LogReplay, Replayed, refuse_log_owned
from ..twin.residuals import FIT_FRACTION, conditions, fit_samples, localise, rms_table, unexplained
from ..util.parallel import runs_on_one_blas_thread
from . import steps
from .joint_check import joint_check
from .judging import Finding, SearchStep, final_verdicts
from .library import kinds as library_kinds
from .multilog import MultiReplay, per_log
from .payload import PAYLOAD_KINDS, payload_kinds_screened, resolve_payloads
from .refinement import FindingSet, Refined, polish
from .replay_noise import null_residuals
from .rescreen import rescreen
from .rivals import list_rivals, noise_hints, rival_plan
from .search import columns_of
from .stage_bar import StageBar
from .weighting import OwnVariance, VarianceGroups

logger = logging.getLogger(__name__)

#: the workflow's own sensor-noise stream of its replays, unrelated to any log
WORKFLOW_SEED = 20261121

FIT_FRACTION_RANGE = (0.2, 0.9)
#: the library is screened and the dictionary selected on at most this much of the fitting part [s]
#: (assumption: 20 s of a robot program hold its motions several times; refinement and judgement use all)
SCREEN_S = 20.0
#: the selections' Gaussian likelihood: each channel (signal x joint) its own residual variance, each channel its
#: own variance at rest and in motion (the joint's target speed; the model's own errors of friction and inertia act
#: in motion only), or one pooled variance for every channel (``statistics.py``; measured in docs/discrepancy.md,
#: *Each channel its own variance* and *At rest and in motion*)
LIKELIHOODS = ("per_channel", "per_condition", "pooled")
LIKELIHOOD = "pooled"
#: the current held at rest as a nuisance (``rest_hold.py``): off (measured in docs/discrepancy.md)
REST_HOLD = False


class DiscrepancyModel:
    """Fit the library's effects and the dictionary's terms to a measured log.

    Args:
        fit_fraction: share of the log (from its start) used for fitting; the rest is held out.
        max_effects: most library effects named per joint (robot-wide effects count as one more joint), so
            that one joint's findings cannot use up another's.
        max_terms: most dictionary terms added (0: no discovery).
        kinds: restrict the library's effect kinds (default: the whole registry).
        jobs: worker processes for lockstep batches.
        refiner: ``"secant"`` or ``"minimize"`` (see :func:`ur5fault.discrepancy.refinement.polish`).
        progress: show the progress (util/progress.py: a bar on a terminal, plain lines in a log).
        screen_s: length of the log's first part the library is screened and the dictionary selected on
            [s] (None: the whole fitting part); refinement and judgement use the whole fitting part.
        likelihood: ``"pooled"`` (one variance for every channel, the default), ``"per_channel"`` (each
            channel, signal x joint, its own residual variance in every selection; ``weighting.per_channel``) or
            ``"per_condition"`` (each channel its own variance while its joint is at rest and while it moves).
        rest_hold: fit one constant per rest interval of each joint's current as a nuisance beside the drift
            (``rest_hold.py``: the current static friction leaves held at rest), in every selection and judgement
            on the fitting part; an offset or gain is then seen in motion only.  Off by default (measured in
            docs/discrepancy.md, *The current held at rest as a nuisance*).
    """

    def __init__(self, fit_fraction: float = FIT_FRACTION, max_effects: int = 1, max_terms: int = 4,
                 kinds: Sequence[str] | None = None, jobs: int = 1, refiner: str = "secant",
                 progress: bool = False, screen_s: float | None = SCREEN_S, likelihood: str = LIKELIHOOD,
                 rest_hold: bool = REST_HOLD) -> None:
        lo, hi = FIT_FRACTION_RANGE
        if not lo <= fit_fraction <= hi:
            raise ParameterError(f"fit_fraction = {fit_fraction} is out of range [{lo}, {hi}]")
        for name, v, least in (("max_effects", max_effects, 0), ("max_terms", max_terms, 0), ("jobs", jobs, 1)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
                raise ParameterError(f"{name} = {v!r} must be a whole number >= {least}")
        if refiner not in ("secant", "minimize"):
            raise ParameterError(f"refiner = {refiner!r} is not valid; choose one of: secant, minimize")
        if likelihood not in LIKELIHOODS:
            raise ParameterError(f"likelihood = {likelihood!r} is not valid; choose one of: {', '.join(LIKELIHOODS)}")
        if not isinstance(rest_hold, (bool, np.bool_)):
            raise ParameterError(f"rest_hold = {rest_hold!r} must be True or False")
        self.likelihood, self.rest_hold = likelihood, bool(rest_hold)
        self.fit_fraction, self.max_effects, self.max_terms = fit_fraction, max_effects, max_terms
        self.kinds, self.jobs, self.refiner, self.progress = kinds, jobs, refiner, progress
        if screen_s is not None and screen_s <= 0:
            raise ParameterError(f"screen_s = {screen_s} must be a positive number of seconds (or None: the "
                                 "whole fitting part)")
        self.screen_s = screen_s

    # ------------------------------------------------------------------------------------------- fit
    @runs_on_one_blas_thread  # its Gram products (p x 3000 per block) waited on a 2nd BLAS thread the workers keep busy
    def fit(self, log: MeasuredLog | Sequence[MeasuredLog], params_overrides: dict | None = None,
            base_effects: Sequence[EffectSpec] = (), hold_out: Sequence[MeasuredLog] = (),
            on_payload: Callable[[str], None] | None = None) -> DiscrepancyModel:
        """Fit ``log`` (one log, or several runs of one robot fitted jointly), each split in time at
        ``fit_fraction``; ``hold_out``: further runs held out whole (judged and scored, never fitted).
        A log whose payload is unknown has it fitted first (:mod:`.payload`; ``payload_``), and ``on_payload``
        gets one line per such log."""
        t0 = time.perf_counter()
        logs = [log] if isinstance(log, MeasuredLog) else list(log)
        refuse_log_owned(params_overrides, base_effects, [*logs, *hold_out])
        t_payload = time.perf_counter()
        logs, hold_out, self.payload_ = resolve_payloads(logs, hold_out, self.fit_fraction, params_overrides,
                                                         base_effects, seed=WORKFLOW_SEED, say=on_payload)
        kinds = self.kinds
        screened, why = payload_kinds_screened(self.payload_)
        if not screened:
            kinds = [k for k in (kinds if kinds is not None else library_kinds()) if k not in PAYLOAD_KINDS]
            if why is not None:
                (on_payload or logger.warning)(why)
        t_payload = time.perf_counter() - t_payload
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
        stages = StageBar(self.progress)
        timings: dict[str, float] = {}
        if not all(r.known for r in self.payload_.values()):
            timings["payload fit"] = t_payload

        try:
            # the starting model over the whole log is the probe batch's first run whatever is found, and its first
            # samples are the screening's baseline: a worker starts it now, and it is simulated once
            rp.prefetch([()], n_all)
            t = time.perf_counter()
            own = self._variance(rp)
            lib = steps.screen_library(rp, n_scr, log.payload_kg, kinds, self.max_effects,
                                       stages.start("screening the library"), own, self.rest_hold)
            timings["library screening"] = time.perf_counter() - t
            logger.info("library screened in %.0f s: %s", timings["library screening"],
                        [c.label for c in lib.chosen] or "nothing")

            t = time.perf_counter()
            stages.start("discovering terms")
            disc = steps.discover_terms(rp, lib, n_scr, self.max_terms)
            timings["discovery"] = time.perf_counter() - t
            logger.info("dictionary selected in %.0f s: %s", timings["discovery"],
                        [c.label for c in disc.terms] or "nothing")

            t = time.perf_counter()
            check = joint_check(disc.library + disc.terms, disc.X, disc.fixed, lib.e0, list(disc.tell_apart),
                                      own)
            ref = steps.refine(rp, check.found, disc.X, check.fixed, lib.e0, {**lib.alternatives, **disc.alternatives},
                               n_fit, stages.start("refining the findings"), own)
            timings["refinement"] = time.perf_counter() - t
            logger.info("probe batch over the whole log in %.0f s (%d findings)", timings["refinement"], len(ref.found))

            # judged on the fitting and the held-out part; the kept ones polished by Gauss-Newton (the first
            # simulation of which is the final model when the estimate has converged)
            t = time.perf_counter()
            prog = stages.start("judging")
            drift = steps.drift_of(rp, n_fit, self.rest_hold)
            jr = steps.judge(ref, n_fit, len(rp.signals), drift, own)
            self.search_: list[SearchStep] = lib.trace + disc.trace + check.trace + jr.trace
            self.refinement_ = list(ref.first.steps) if ref.first is not None else []
            for f in jr.findings:
                f.tell_apart = disc.tell_apart.get(f.candidate, "")
            kept = [f for f in jr.findings if f.kept]
            # the kept findings' alternatives (over the fitting part) start on a worker beside the polish's replay
            rp.prefetch([ref.alt_sets[a] for a in steps.kept_alternatives(ref, kept)], n_fit)
            after = self._polish(rp, kept, ref.first, ref.finding_set, prog, drift) if kept else ref.nominal
            steps.alternatives_of_kept(rp, ref, kept, n_fit, drift, prog)
            # the rivals' replays as the final model stands: (n - 1) // 2 of the n start on a worker beside the
            # re-screen's replay, taken below when the re-screen leaves that model as it is; list_rivals simulates
            # the rest over both processes, of which the worker gets one more: never more than its share when the
            # re-screen replays nothing
            plan = rival_plan(rp, lib.X, lib.drift, lib.candidates, jr.findings, ref.first.J if ref.first else None,
                              ref.found, after, n_scr, own_variance=own)
            rp.prefetch(plan.effect_sets[: (len(plan.effect_sets) - 1) // 2], rp.n_samples)
            # a finding dropped on the held-out part or at the final check gives its joint's place back
            again = rescreen(rp, lib.X, lib.drift, lib.candidates, jr.findings, after, n_scr, n_fit, drift,
                             self.max_effects, prog, own)
            jr.findings.extend(again.findings)
            self.search_ += again.trace
            after = again.after
            # every finding of the final model with the library effects the held-out part cannot tell from it
            list_rivals(rp, lib.X, lib.drift, lib.candidates, jr.findings, ref.first.J if ref.first else None,
                        ref.found, after, n_scr, n_fit, drift, skip=again.findings, progress=prog, own_variance=own)
            noise_hints(rp, after, jr.findings)  # a current gain told from a torque constant by the sensor's noise
            self._results(rp, ref.nominal, after, n_fit, n_all)
        finally:  # an exception or an interruption: the prefetched replays' worker stops with the fit
            rp.close()
        timings["judging"] = time.perf_counter() - t
        logger.info("judged and polished in %.0f s: kept %s", timings["judging"],
                    [f.candidate.label for f in jr.findings if f.kept] or "nothing")
        stages.close()
        self.findings_ = jr.findings
        self.timings_s_ = timings
        self.wall_s_ = time.perf_counter() - t0
        self.n_simulated_runs_ = rp.n_simulated
        self.simulated_s_ = rp.simulated_s
        return self

    # --------------------------------------------------------------------------------- pieces
    def _variance(self, rp: LogReplay | MultiReplay) -> OwnVariance:
        """What the selections' likelihood gives its own variance (``weighting.per_channel``): nothing (pooled),
        each channel, or each channel at rest and in motion (its joint's target speed, the residual conditions'
        "at rest", over the replayed samples ``1..n``)."""
        if self.likelihood != "per_condition":
            return self.likelihood == "per_channel"
        n = rp.n_samples
        rest = conditions(rp.log, n, np.zeros((n, N_JOINTS)))["at rest"]
        return VarianceGroups(np.tile(rest.astype(np.int8), len(rp.signals)),
                              lambda k: steps.drift_of(rp, k, self.rest_hold))

    def _polish(self, rp: LogReplay, kept: list[Finding], first: Refined, fs: FindingSet, progress,
                drift) -> Replayed:
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
        # the polished model under other noise seeds: the scatter its findings' estimates must stand out of
        nulls = null_residuals(rp, kfs.specs(pol.theta), pol.sim.y, self.n_fit_, progress) if pol.sim.ok else []
        failed = final_verdicts(kept, pol, self.n_fit_, drift, self._variance(rp), nulls)
        for f in failed:
            f.kept = False
            f.within_scatter = f.within_scatter and not f.candidate.range_problem(f.theta)  # the reason it is given
            f.reason = (f.candidate.range_problem(f.theta)
                        or (f"within the scatter of the model's own replays ({f.verdict.reason})" if f.within_scatter
                            else f"explains nothing the others do not once refined ({f.verdict.reason})"))
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
        ``discrepancy --model`` accept: the starting overlay plus every kept finding but those of the job's payload
        (its mass and centre of mass, ``payload.PAYLOAD_KINDS``: reported, not the robot's; in a campaign's overlay a
        payload is refused, and on another log it would replace that log's stated payload)."""
        def entry(e: EffectSpec) -> dict:
            return {"effect": e.name, **({"joint": JOINT_NAMES[e.joint]} if e.joint is not None else {}),
                    **dict(e.values)}

        effects = [entry(e) for e in self.base_effects_] + [entry(f.spec()) for f in self.findings_
                                                            if f.kept and f.spec().name not in PAYLOAD_KINDS]
        return {"params": self.params_overrides_, "effects": effects}
