"""Several logs of one robot fitted jointly: one replay per log, their samples laid end to end on one axis.

The discrepancy workflow works on one sample axis split in two: samples ``1..n_fit`` are fitted, samples
``n_fit+1..n_all`` judged (held out). :class:`MultiReplay` stands in for :class:`~ur5fault.twin.LogReplay` with the
samples of several logs in this order:

1. the fitting part of every fitted log (its first ``fit_fraction`` of samples), log by log;
2. the rest of every fitted log (the time split's held-out part);
3. every held-out log whole (``--hold-out``: runs the fit never sees).

Each log is simulated by its own :class:`~ur5fault.twin.LogReplay` (its trajectory, payload, tool offset and
temperatures; the model overlay shared), and a run over the first ``n`` samples of the axis simulates each
log only as far as those samples reach. :attr:`MultiReplay.log` is the logs' rows in the same order (one
:class:`~ur5fault.logs.MeasuredLog`, a first row of the first log in front, times continued), for what the
workflow reads from "the log": operating conditions, temperatures, target currents, the logged-tick mask.
What uses one payload for all logs (the payload candidate's linearisation point and the gravity columns of
the dictionary) takes the first fitted log's; every size is then refined by re-simulating each log with its
own payload.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..logs import MeasuredLog
from ..logs.measured import same_period
from ..sim.effects import EffectSpec
from ..twin.replay import LogReplay, Replayed, simulate_requests
from ..twin.residuals import fit_samples

ROLES = ("fit", "held_out")


@dataclasses.dataclass(frozen=True)
class Segment:
    """Log samples ``start..stop-1`` (1-based rows of log ``log``) at axis positions ``at..at+stop-start-1``
    (0-based rows of a replay's arrays)."""

    log: int
    start: int
    stop: int
    at: int

    @property
    def rows(self) -> slice:
        return slice(self.at, self.at + self.stop - self.start)


def _names(logs: Sequence[MeasuredLog]) -> list[str]:
    names = [log.source for log in logs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ParameterError(f"two logs named {dup[0]!r}: give each log its own name")
    return names


class MultiReplay:
    """Fitted logs ``logs`` (time split at ``fit_fraction``) and whole held-out logs ``hold_out`` under one
    model overlay; the interface of :class:`~ur5fault.twin.LogReplay` on the joint sample axis (module
    docstring)."""

    def __init__(self, logs: Sequence[MeasuredLog], hold_out: Sequence[MeasuredLog], fit_fraction: float,
                 params_overrides: dict | None = None, base_effects: Sequence[EffectSpec] = (),
                 *, seed: int, jobs: int = 1) -> None:
        if not logs:
            raise ParameterError("a joint fit needs at least one log to fit (every log given is held out)")
        self.names = _names([*logs, *hold_out])
        self.roles = ["fit"] * len(logs) + ["held_out"] * len(hold_out)
        self.jobs = max(1, int(jobs))
        self.seed = seed
        self.replays = [LogReplay(log, params_overrides, base_effects, seed=seed, jobs=self.jobs)
                        for log in (*logs, *hold_out)]
        first = self.replays[0]
        for r in self.replays[1:]:
            if r.signals != first.signals:
                raise ParameterError(f"{r.log.source}: its signals {r.signals} differ from {first.log.source}'s "
                                     f"{first.signals}; a joint fit needs the same signals in every log")
            if not same_period(r.log.period_s, first.log.period_s):
                raise ParameterError(f"{r.log.source}: sample period {r.log.period_s:g} s differs from "
                                     f"{first.log.source}'s {first.log.period_s:g} s")
        self.params, self.signals, self.sigma, self.gear_ratio = first.params, first.signals, first.sigma, \
            first.gear_ratio
        segs: list[Segment] = []
        at = 0
        split = [fit_samples(r.n_samples, fit_fraction) for r in self.replays[: len(logs)]]
        for i, f in enumerate(split):
            segs.append(Segment(i, 1, f + 1, at))
            at += f
        self.n_fit = at
        for i, f in enumerate(split):
            if f < self.replays[i].n_samples:
                segs.append(Segment(i, f + 1, self.replays[i].n_samples + 1, at))
                at += self.replays[i].n_samples - f
        for k in range(len(logs), len(self.replays)):
            segs.append(Segment(k, 1, self.replays[k].n_samples + 1, at))
            at += self.replays[k].n_samples
        self.segments = tuple(segs)
        self.n_samples = at
        self.log = self._joint_log()

    # -------------------------------------------------------------------------------- the joint axis
    def _joint_log(self) -> MeasuredLog:
        logs = [r.log for r in self.replays]
        first = logs[0]
        kw = {}
        for f in dataclasses.fields(MeasuredLog):
            v0 = getattr(first, f.name)
            if isinstance(v0, np.ndarray) and v0.shape[:1] == first.t_s.shape or f.name == "logged":
                parts = [getattr(log, f.name) for log in logs]
                if f.name == "logged":
                    parts = [log.logged_rows() for log in logs]
                elif any(p is None for p in parts):
                    kw[f.name] = None
                    continue
                kw[f.name] = np.concatenate([parts[0][:1]] + [parts[s.log][s.start : s.stop] for s in self.segments])
        kw["t_s"] = np.arange(self.n_samples + 1) * first.period_s
        kw["source"] = " + ".join(self.names)
        kw["notes"] = tuple(n for log in logs for n in log.notes)
        for name in ("payload_kg", "tcp_offset_m"):
            kw[name] = getattr(first, name)
        return MeasuredLog(**kw)

    def measured(self, n: int) -> NDArray:
        """The readings at axis samples ``1..n``, ``(n, n_signals, 6)``."""
        parts = [r.measured(r.n_samples) for r in self.replays]
        return np.concatenate([parts[s.log][s.start - 1 : s.stop - 1] for s in self.segments])[:n]

    def rows(self, k: int, role: str | None = None) -> NDArray:
        """0-based axis rows of log ``k``; ``role="fit"``: its fitting part only, ``"held_out"``: the rest."""
        segs = [s for s in self.segments if s.log == k]
        if role == "fit":
            segs = [s for s in segs if s.at < self.n_fit]
        elif role == "held_out":
            segs = [s for s in segs if s.at >= self.n_fit]
        return np.concatenate([np.arange(s.rows.start, s.rows.stop) for s in segs]) if segs else np.zeros(0, int)

    @property
    def n_simulated(self) -> int:
        return sum(r.n_simulated for r in self.replays)

    @property
    def simulated_s(self) -> float:
        return sum(r.simulated_s for r in self.replays)

    def _need(self, n: int) -> list[int]:
        """Per log, how many of its samples the axis samples ``1..n`` reach (0: none)."""
        need = [0] * len(self.replays)
        for s in self.segments:
            if s.at < n:
                need[s.log] = max(need[s.log], min(s.stop - 1, s.start - 1 + n - s.at))
        return need

    def run(self, effect_sets: Sequence[Sequence[EffectSpec]], n: int, progress=None) -> list[Replayed]:
        """Replay axis samples ``1..n`` once per effect set; each log simulated as far as those samples reach."""
        return self.run_batches([(effect_sets, n)], progress)[0]

    def run_batches(self, batches: Sequence[tuple[Sequence[Sequence[EffectSpec]], int]], progress=None
                    ) -> list[list[Replayed]]:
        """Several batches ``(effect sets, n)`` at once, each equal to :meth:`run`'s; every (log, effect set) is one
        run, all of them spread over ``jobs`` processes together, balanced by simulated seconds
        (:func:`~ur5fault.twin.replay.simulate_requests`)."""
        reqs: list[tuple[LogReplay, tuple[EffectSpec, ...], int]] = []
        where: list[list[dict[int, int]]] = []  # per batch and effect set: log -> its request's position
        for sets, n in batches:
            need = self._need(n)
            where.append([])
            for e in sets:
                where[-1].append({})
                for k, m in enumerate(need):
                    if m:
                        where[-1][-1][k] = len(reqs)
                        reqs.append((self.replays[k], tuple(e), m))
        flat = simulate_requests(reqs, self.jobs, progress)
        out = []
        for (sets, n), at in zip(batches, where):
            res = []
            for e, idx in zip(sets, at):
                res.append(self._assembled(flat, idx, e, n))
            out.append(res)
        return out

    def _assembled(self, flat: Sequence[Replayed], idx: dict[int, int], effects: Sequence[EffectSpec], n: int
                   ) -> Replayed:
        """The joined replay of one effect set from the flat results ``flat`` of its logs' requests (``idx``: log ->
        position in ``flat``): each log's signals cut to the axis' and its temperature recorded, then joined."""
        return self._joined({k: self.replays[k]._with_log_temperature(
            dataclasses.replace(flat[i], y=flat[i].y[:, : len(self.signals)]), effects) for k, i in idx.items()}, n)

    def _joined(self, per: dict[int, Replayed], n: int) -> Replayed:
        """One replay on the axis from each log's replay."""
        pieces = [(s, per[s.log]) for s in self.segments if s.at < n]
        status = next((r.status for _, r in pieces if not r.ok), "ok")
        fields = {}
        for name in ("y", "q_rad", "q_motor_rad", "current_true_A", "torque_gear_Nm"):
            fields[name] = np.concatenate([getattr(r, name)[s.start - 1 : s.stop - 1] for s, r in pieces])[:n]
        return Replayed(status, **fields)

    def run_seeds(self, effects: Sequence[EffectSpec], n: int, seeds: Sequence[int], progress=None
                  ) -> list[Replayed]:
        """:meth:`LogReplay.run_seeds` on the joint axis: one replay of ``effects`` per noise seed, every log's
        runs spread over the processes together."""
        need = self._need(n)
        reqs, where, src = [], [], []
        for seed in seeds:
            where.append({})
            for k, m in enumerate(need):
                if m:
                    where[-1][k] = len(reqs)
                    reqs.append((self.replays[k]._reseeded(seed), tuple(effects), m))
                    src.append(self.replays[k])
        flat = simulate_requests(reqs, self.jobs, progress)
        for (other, _, _), rp in zip(reqs, src):
            rp.n_simulated += other.n_simulated
            rp.simulated_s += other.simulated_s
        return [self._assembled(flat, idx, effects, n) for idx in where]

    def prefetch(self, effect_sets: Sequence[Sequence[EffectSpec]], n: int) -> None:
        """:meth:`LogReplay.prefetch` of every log as far as axis samples ``1..n`` reach."""
        for k, m in enumerate(self._need(n)):
            if m:
                self.replays[k].prefetch(effect_sets, m)

    def close(self) -> None:
        """:meth:`LogReplay.close` of every log."""
        for r in self.replays:
            r.close()


def per_log(rp: LogReplay | MultiReplay, scored: NDArray, before: NDArray, after: NDArray, n_fit: int, n_all: int
            ) -> dict[str, dict]:
    """Per log: its role, and the RMS of measured - simulated on its held-out samples (a fitted log's time split,
    a held-out log whole) before and after the fit, and of UR's own current model (``target_current``) where the
    log has it. ``scored``: the readings ``(n_all, n_signals, 6)``, NaN where a tick was not logged."""
    from ..sim.axes import JOINT_NAMES, N_JOINTS

    if isinstance(rp, MultiReplay):
        items = [(name, role, rp.rows(k, "held_out"), rp.replays[k].log)
                 for k, (name, role) in enumerate(zip(rp.names, rp.roles))]
    else:
        items = [(rp.log.source, "fit", np.arange(n_fit, n_all), rp.log)]
    tc = rp.log.target_current_A
    out: dict[str, dict] = {}
    for name, role, rows, log in items:
        def rms(sim: NDArray, i: int, j: int, rows=rows) -> float | None:
            e = scored[rows, i, j] - sim[rows, i, j]
            return float(np.sqrt(np.nanmean(e**2))) if np.isfinite(e).any() else None

        entry: dict = {"role": role, "n_samples": int(rows.size)}
        for key, sim in (("rms_before", before), ("rms_after", after)):
            entry[key] = {s: {JOINT_NAMES[j]: rms(sim, i, j) for j in range(N_JOINTS)}
                          for i, s in enumerate(rp.signals)}
        if log.target_current_A is not None and tc is not None:
            ur = tc[1 : n_all + 1]
            entry["rms_controller_model_current_A"] = {
                JOINT_NAMES[j]: float(np.sqrt(np.nanmean((ur[rows, j] - scored[rows, 0, j]) ** 2)))
                for j in range(N_JOINTS)} if rows.size else None
        out[name] = entry
    return out
