"""Replay a measured log through the model: the log's target trajectory, payload, tool offset and joint
temperatures, simulated under a model overlay (parameter overrides and effects), sampled where the log was.

This is the one path from a log to the model: ``ur5fault identify`` (bandwidth sweep, friction choices),
``ur5fault discrepancy`` and the tests against the real log all replay through :class:`LogReplay`.
Several logs of one robot are several :class:`LogReplay` under one overlay, each with its own payload, tool
and temperatures; the discrepancy workflow lays them on one sample axis (:mod:`ur5fault.discrepancy.multilog`).

Residual signals (the log's readings that the model predicts), stacked on a signal axis so that every
array of a replay is ``(n_samples, n_signals, 6)``:

* ``current_A``: motor current reading;
* ``position_rad``: joint position reading (resolver);
* ``mismatch_rad``: motor-encoder angle / gear ratio - joint reading, when the log has motor encoders.
"""

from __future__ import annotations

import copy
import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..logs import MeasuredLog
from ..sim.axes import JOINT_NAMES
from ..sim.effects import EffectSpec
from ..sim.engine import PROTECTIVE_STOP_RAD, RunSpec, Simulator
from ..sim.params import JOINT_TEMPERATURE_RANGE_C, RobotParams, deep_merge, load_params
from ..sim.terms import sensor_temperature_term

#: every signal a replay computes, in order; a replay keeps the first two, and the third when the log has
#: motor encoders
SIGNALS = ("current_A", "position_rad", "mismatch_rad")
#: the effects that set a log's payload (its mass, its centre of mass): the log's, never a model overlay's
PAYLOAD_EFFECTS = ("payload", "payload_com")


def log_overrides(log: MeasuredLog) -> dict:
    """The parameter overrides a log itself carries: its tool offset and its mean joint temperatures
    (clipped to the params' ``JOINT_TEMPERATURE_RANGE_C``; a log whose median is outside it is refused by its
    reader). A log whose tool is unknown is refused in one line (:meth:`MeasuredLog.require_payload`)."""
    over: dict = {"tcp_offset_m": list(log.require_payload().tcp_offset_m)}
    if log.temperature_C is not None:
        over["joint_temperature_C"] = np.clip(log.temperature_C.mean(axis=0), *JOINT_TEMPERATURE_RANGE_C).tolist()
    return over


def replay_params(log: MeasuredLog, params_overrides: dict | None = None) -> RobotParams:
    """The packaged parameters under ``params_overrides`` (the robot's model), then the log's own overrides
    (:func:`log_overrides`), which win: the tool and the measured temperatures belong to the log, not to the robot
    (an overlay's ``joint_temperature_C`` stands for a log that logs none; an overlay's tool is refused where the
    workflows start, :func:`refuse_log_owned`)."""
    return load_params(overrides=deep_merge(dict(params_overrides or {}), log_overrides(log)))


def refuse_log_owned(params_overrides: dict | None, effects: Sequence[EffectSpec], logs: Sequence[MeasuredLog]
                     ) -> None:
    """What a model overlay may not set because the log carries it, refused in one line where the workflows that
    replay logs under an overlay start (discrepancy, monitor, diagnose):

    * a ``payload`` or ``payload_com`` effect (:data:`PAYLOAD_EFFECTS`): the payload is each log's (stated, or fitted
      where unknown) and the fit, the report and the statistics are the log's, so the overlay's was ignored without a
      word, then copied into discrepancy's model.yaml, which ``simulate --model`` applies;
    * a ``tcp_offset_m`` that differs from a log's stated tool: the log's tool is the one replayed
      (:func:`replay_params`) and reported, so the overlay's would be ignored without a word.  Logs whose tool is not
      stated (an unknown payload's centre of mass, fitted) are not compared."""
    for e in effects:
        if e.name in PAYLOAD_EFFECTS:
            raise ParameterError(f"the model overlay holds a {e.name} effect, but the payload is the log's "
                                 "(--payload-kg and --tcp-offset-m, a manifest's payload_kg, or the log's layout; "
                                 "fitted where unknown), not the robot's model; leave it out of the overlay")
    over = dict(params_overrides or {})
    if "tcp_offset_m" not in over:
        return
    tool = load_params(overrides={"tcp_offset_m": over["tcp_offset_m"]}, where="the model overlay: params")
    for log in logs:
        if log.tcp_offset_m is not None and not np.allclose(tool.tcp_offset_m, log.tcp_offset_m, rtol=0.0,
                                                            atol=1e-9):
            raise ParameterError(f"the model overlay sets params.tcp_offset_m = {list(tool.tcp_offset_m)} m, but "
                                 f"{log.source}'s tool offset is {list(log.tcp_offset_m)} m: the tool is the log's "
                                 "(--tcp-offset-m, a manifest's tcp_offset_m or the log's layout), not the robot's "
                                 "model; leave it out of the overlay")


@dataclasses.dataclass(frozen=True)
class Replayed:
    """One replay at log samples ``1..n``: readings ``y`` ``(n, n_signals, 6)`` in the replay's signal
    order, and the simulated states the dictionary of terms is built from, ``(n, 6)`` each."""

    status: str
    y: NDArray
    q_rad: NDArray  # true joint angle
    q_motor_rad: NDArray  # true motor angle
    current_true_A: NDArray  # motor current before the sensor
    torque_gear_Nm: NDArray
    #: the twin fits' payload centre-of-mass columns ``(n, 6, 3)`` [A/m] (health/twin_regressors.py), when built
    com_A_per_m: NDArray | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def failure(self) -> str:
        """What a failed replay's status means, for the one line that refuses it ("" when it is ok)."""
        if self.ok:
            return ""
        if self.status == "protective_stop":
            return (f"protective stop: the simulated arm fell more than {PROTECTIVE_STOP_RAD:g} rad behind the log's "
                    "targets, a payload or effect its drives cannot carry through this motion (check --payload-kg and "
                    "the model) or targets that jump")
        if self.status == "diverged":
            return "diverged: the simulation ran away (a model or effect outside the range it holds for)"
        return self.status

    @property
    def current_A(self) -> NDArray:
        """Simulated current reading ``(n, 6)``."""
        return self.y[:, 0]

    @property
    def position_rad(self) -> NDArray:
        """Simulated joint position reading ``(n, 6)``."""
        return self.y[:, 1]


def residual_sigma(params: RobotParams, signals: Sequence[str]) -> NDArray:
    """Sigma of each signal's measurement error ``(n_signals, 6)``: the sensor's white-noise sigma, but never
    below its rounding error ``step / sqrt(12)`` (uniform over one quantisation step).  The white noise
    identified from a log is the scatter of its quantised readings at rest, which already holds the rounding
    (so the two are not added); a quantised sensor whose readings are identical at rest (identified noise 0)
    is weighted by its step, never by 0.  A signal with neither noise nor step cannot be weighed: refused."""
    s = params.sensors
    resolver_step = 2 * np.pi / np.asarray(s.resolver_counts_per_rev, dtype=float)
    res = ("sensors.resolver_noise_rad", "sensors.resolver_counts_per_rev")
    parts = {"current_A": (s.current_noise_A, s.current_lsb_A, "sensors.current_noise_A", "sensors.current_lsb_A"),
             "position_rad": (s.resolver_noise_rad, resolver_step, *res),
             "mismatch_rad": (s.resolver_noise_rad, resolver_step, *res)}
    rows = []
    for name in signals:
        noise, step, key, step_key = parts[name]
        sigma = np.maximum(np.asarray(noise, dtype=float), np.asarray(step, dtype=float) / np.sqrt(12.0))
        if not np.all(sigma > 0):
            j = int(np.argmin(sigma))
            raise ParameterError(f"{key} and {step_key} are both 0 on {JOINT_NAMES[j]}: the {name} residual "
                                 "needs a noise level to be weighed; give either a positive value")
        rows.append(sigma)
    return np.array(rows, dtype=float)


class LogReplay:
    """Simulates one log's target trajectory under a model (parameter overrides + effects).

    Args:
        log: the measured log.
        params_overrides: robot-parameter overrides of the model overlay (under the log's own tool and measured
            temperatures, :func:`replay_params`).
        base_effects: effects of the model overlay, carried by every replay.
        seed: sensor-noise seed of the replays.
        jobs: worker processes for batches of replays.
    """

    def __init__(self, log: MeasuredLog, params_overrides: dict | None = None,
                 base_effects: Sequence[EffectSpec] = (), *, seed: int, jobs: int = 1) -> None:
        self.log = log.require_payload()
        self.jobs = max(1, int(jobs))
        self.params: RobotParams = replay_params(log, params_overrides)
        self.traj = log.to_trajectory()
        self.base = tuple(base_effects)
        self.seed = seed
        steps = log.period_s / self.params.physics_dt_s
        if abs(steps - round(steps)) > 1e-6:
            raise ParameterError(f"{log.source}: sample period {log.period_s:g} s is not a multiple of the physics "
                                 f"step {self.params.physics_dt_s:g} s")
        self.signals: tuple[str, ...] = SIGNALS[:3 if log.q_motor_rad is not None else 2]
        #: sensor-noise sigma per signal and joint ``(n_signals, 6)``: the residual weights
        self.sigma: NDArray = residual_sigma(self.params, self.signals)
        self.gear_ratio = np.asarray(self.params.gear.ratio, dtype=float)
        self.n_simulated = 0  # replays run so far
        self.simulated_s = 0.0  # simulated seconds so far, summed over replays
        #: prefetched replays by content (:meth:`prefetch`): samples, and the replay or its future
        self._held: dict[str, tuple[int, object]] = {}

    @property
    def n_samples(self) -> int:
        """Samples that can be replayed (every sample after the first)."""
        return self.log.t_s.size - 1

    def _n(self, n: int | None) -> int:
        if n is None:
            return self.n_samples
        if not 1 <= n <= self.n_samples:
            raise ParameterError(f"{self.log.source}: cannot replay {n} samples; the log has {self.n_samples} "
                                 "after its first")
        return int(n)

    def measured(self, n: int | None = None) -> NDArray:
        """The log's readings at samples ``1..n`` (default: all), ``(n, n_signals, 6)``."""
        n = self._n(n)
        L = self.log
        out = [L.current_A[1 : n + 1], L.q_actual_rad[1 : n + 1]]
        if L.q_motor_rad is not None:
            out.append(L.q_motor_rad[1 : n + 1] / self.gear_ratio - L.q_actual_rad[1 : n + 1])
        return np.stack(out, axis=1)

    def run(self, effect_sets: Sequence[Sequence[EffectSpec]], n: int | None = None, progress=None
            ) -> list[Replayed]:
        """Replay samples ``1..n`` (default: all) once per effect set, in the order of ``effect_sets``: one
        lockstep batch, or with ``jobs > 1`` one task per run spread over ``jobs`` processes
        (:func:`simulate_requests`)."""
        return self.run_batches([(effect_sets, n)], progress)[0]

    def run_batches(self, batches: Sequence[tuple[Sequence[Sequence[EffectSpec]], int | None]], progress=None
                    ) -> list[list[Replayed]]:
        """Several batches ``(effect sets, n)`` of different lengths at once, each replay equal to :meth:`run`'s:
        with ``jobs > 1`` their runs are spread over the processes together, balanced by simulated seconds, so
        that a short batch fills a core a long one would leave idle."""
        reqs = [[(self, tuple(e), self._n(n)) for e in sets] for sets, n in batches]
        flat = simulate_requests([r for rs in reqs for r in rs], self.jobs, progress)
        k = len(self.signals)  # _simulate returns every signal of SIGNALS: keep those the log has
        out, i = [], 0
        for (sets, _), rs in zip(batches, reqs):
            out.append([self._with_log_temperature(dataclasses.replace(r, y=r.y[:, :k]), e)
                        for r, e in zip(flat[i : i + len(rs)], sets)])
            i += len(rs)
        return out

    def run_seeds(self, effects: Sequence[EffectSpec], n: int | None, seeds: Sequence[int], progress=None
                  ) -> list[Replayed]:
        """Replay samples ``1..n`` of one effect set once per sensor-noise seed in ``seeds`` (not this replay's own
        seed): the model's own scatter, which a finding's estimate must stand out of (``discrepancy/replay_noise.py``).
        Spread over the processes as :meth:`run_batches`; counted among this replay's runs."""
        n = self._n(n)
        others = [self._reseeded(s) for s in seeds]
        flat = simulate_requests([(o, tuple(effects), n) for o in others], self.jobs, progress)
        self.n_simulated += sum(o.n_simulated for o in others)
        self.simulated_s += sum(o.simulated_s for o in others)
        k = len(self.signals)
        return [self._with_log_temperature(dataclasses.replace(r, y=r.y[:, :k]), effects) for r in flat]

    def _reseeded(self, seed: int) -> LogReplay:
        """This replay on another noise seed: the same log and model, no prefetched replays, no runs counted."""
        other = copy.copy(self)
        other.seed, other._held, other.n_simulated, other.simulated_s = int(seed), {}, 0, 0.0
        return other

    def prefetch(self, effect_sets: Sequence[Sequence[EffectSpec]], n: int | None = None) -> None:
        """Start replays that a later :meth:`run` will ask for on a worker process now (``jobs > 1``), so that
        they are simulated while this process does other work; a later run of the same effects over at most
        ``n`` samples takes them from here instead of simulating them again (the first samples of a replay do not
        depend on how far it goes on; its status does: see :meth:`held`).  With ``jobs = 1`` nothing is started and
        the later run simulates them.  :meth:`close` drops them."""
        if self.jobs <= 1:
            return
        from ..util.parallel import submit

        n = self._n(n)
        for e in effect_sets:
            key = self._key(tuple(e))
            if key in self._held and self._held[key][0] >= n:
                continue
            fut = submit(_simulate, (self.params, self.traj, [RunSpec("c0", self.seed, self.base + tuple(e))],
                                     self.log.period_s, n), self.jobs)
            self._held[key] = (n, fut)
            self.n_simulated += 1
            self.simulated_s += n * self.log.period_s

    def _key(self, effects: tuple[EffectSpec, ...]) -> str:
        return repr(self.base + effects)  # by content; repr tells -0.0 from 0.0 and a numpy float from a float

    def holds(self, effects: tuple[EffectSpec, ...], n: int) -> bool:
        """Whether a prefetched replay of ``effects`` reaches sample ``n`` (finished or not)."""
        got = self._held.get(self._key(effects))
        return got is not None and got[0] >= n

    def held(self, effects: tuple[EffectSpec, ...], n: int) -> Replayed | None:
        """The prefetched replay of ``effects`` over samples ``1..n`` (all signals; :meth:`holds` must be true),
        waiting for the worker if it is not finished; None when it is longer than ``n`` samples and not ok: its
        status is the whole run's (it may have diverged after sample ``n``, where the ``n``-sample run is ok),
        so the caller simulates the ``n``-sample run, as it would without the prefetch."""
        m, r = self._held[self._key(effects)]
        if not isinstance(r, Replayed):  # a future: wait for the worker
            r = r.result()[0]
            self._held[self._key(effects)] = (m, r)
        return _prefix(r, n) if n == m or r.ok else None

    def close(self) -> None:
        """Drop the prefetched replays (later runs simulate what they need).  One still on a worker has the
        workers stopped (:func:`ur5fault.util.parallel.stop_workers`): nothing goes on replaying a log that no one
        will read, and an exiting interpreter does not wait for it.  For a caller that leaves early (an
        exception, an interruption) and at the end of a workflow."""
        from ..util.parallel import stop_workers

        running = [r for _, r in self._held.values() if not isinstance(r, Replayed) and not r.done()]
        self._held.clear()
        if running:
            stop_workers(self.jobs)

    def _with_log_temperature(self, r: Replayed, effects: Sequence[EffectSpec]) -> Replayed:
        """A temperature term was evaluated at the run's constant temperature (the log's mean);
        replace that by the log's temperature series."""
        drift = [e for e in (*self.base, *effects) if e.name == "current_temperature_drift"]
        if not drift or self.log.temperature_C is None:
            return r
        n = r.y.shape[0]
        t_log = self.log.temperature_C[1 : n + 1]
        t_run = np.asarray(self.params.joint_temperature_C)
        y = r.y.copy()
        for e in drift:
            c = e.value("coeff_A_per_K")
            y[:, 0, e.joint] += sensor_temperature_term(c, t_log[:, e.joint], t_run[e.joint])
        return dataclasses.replace(r, y=y)



def _simulate(params: RobotParams, traj, runs: list[RunSpec], period_s: float, n: int, progress=None
              ) -> list[Replayed]:
    res = Simulator(params).run(traj, runs, log_period_s=period_s, duration_s=n * period_s, progress=progress)
    ratio = np.asarray(params.gear.ratio, dtype=float)
    out = []
    for i in range(res.n_runs):
        y = [res["i_FB_A"][i], res["q_FB_rad"][i], res["q_M_FB_rad"][i] / ratio - res["q_FB_rad"][i]]
        out.append(Replayed(res.status[i], np.stack(y, axis=1), res["q_rad"][i], res["q_M_rad"][i], res["i_q_A"][i],
                            res["T_gear_Nm"][i]))
    return out


def _prefix(r: Replayed, n: int) -> Replayed:
    """Samples ``1..n`` of a longer replay that is ok (an ok run is ok over its first samples too)."""
    return Replayed(r.status, r.y[:n], r.q_rad[:n], r.q_motor_rad[:n], r.current_true_A[:n], r.torque_gear_Nm[:n])


def simulate_requests(reqs: Sequence[tuple[LogReplay, tuple[EffectSpec, ...], int]], jobs: int, progress=None
                      ) -> list[Replayed]:
    """Replays ``(log replay, effects, n)`` with every signal of :data:`SIGNALS`, in order: those prefetched taken
    from their log replay (:meth:`LogReplay.held`), the rest simulated.  ``jobs = 1``: one lockstep batch per log
    replay and length, here; else one task per run over this process and ``jobs - 1`` workers, the longest first
    and the split decided as they go (:func:`ur5fault.util.parallel.map_balanced`).  A run's replay does not
    depend on the batch it is simulated in, nor on the process, nor on whether it was prefetched."""
    out: list[Replayed | None] = [None] * len(reqs)
    todo = [i for i, (rp, e, n) in enumerate(reqs) if not rp.holds(e, n)]
    _simulate_todo(reqs, todo, out, jobs, progress)
    for i, (rp, e, n) in enumerate(reqs):  # taken after this process's own share: a prefetch may be on a worker
        if out[i] is None:
            out[i] = rp.held(e, n)
    # a longer prefetched run that is not ok cannot stand for the shorter run: simulated now
    _simulate_todo(reqs, [i for i, r in enumerate(out) if r is None], out, jobs, None)
    return out


def _simulate_todo(reqs, todo: list[int], out: list, jobs: int, progress) -> None:
    """Simulate requests ``todo`` into ``out`` (:func:`simulate_requests`)."""
    for i in todo:
        rp, _, n = reqs[i]
        rp.n_simulated += 1
        rp.simulated_s += n * rp.log.period_s
    if jobs > 1 and len(todo) > 1:
        from ..util.parallel import map_balanced

        tasks = [(rp.params, rp.traj, [RunSpec(f"c{i}", rp.seed, rp.base + e)], rp.log.period_s, n)
                 for rp, e, n in (reqs[i] for i in todo)]
        for i, (r,) in zip(todo, map_balanced(_simulate, tasks, jobs, cost=[reqs[i][2] * reqs[i][0].log.period_s
                                                                            for i in todo])):
            out[i] = r
        return
    groups: dict[tuple[int, int], list[int]] = {}
    for i in todo:
        groups.setdefault((id(reqs[i][0]), reqs[i][2]), []).append(i)
    for idx in groups.values():
        rp, _, n = reqs[idx[0]]
        runs = [RunSpec(f"c{i}", rp.seed, rp.base + reqs[i][1]) for i in idx]
        for i, r in zip(idx, _simulate(rp.params, rp.traj, runs, rp.log.period_s, n,
                                       progress if len(groups) == 1 else None)):
            out[i] = r
