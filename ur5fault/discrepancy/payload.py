"""A log's unknown payload, fitted before the workflow and said so.

An RTDE recording does not carry the payload the robot held. Omitting ``--payload-kg`` (or giving
``unknown``) makes the payload of that log an unknown of the fit, never a silent 0 kg: its mass and, with the
tool offset omitted too, its centre of mass in the flange frame. The payload is the job's, not the robot's, so
it is one unknown per log (runs of one robot may hold different parts; a manifest states the logs that share a
known payload) and it never enters the model overlay; it is a nuisance fitted once per log before the library
is screened, not a finding that competes for a joint's place (the library's own ``payload`` and
``payload_com`` candidates are left out of such a fit).

Method (per log): replay the log's fitting part (a held-out run: the whole run; its payload is the job's, the
robot model is still never fitted on it) at 0 kg; regress the measured - simulated motor current of all six
joints on the payload's current columns (:func:`ur5fault.twin.payload.payload_current_columns`: gravity and
inertia, linear in ``m`` and ``m*c``) beside the workflow's zero-mean current drift (:mod:`.drift`, the nuisance
every candidate is fitted beside), weighted by each joint's current noise sigma; then once more about that
estimate (:data:`GAUSS_NEWTON_STEPS`). The 95 % interval is a block jackknife over :data:`JACKKNIFE_BLOCKS`
contiguous time blocks with Student's t (it carries the residual's autocorrelation and the model's own errors
that vary over the log). The centre of mass is ``m*c / m``, reported only where the mass's interval stays above
0 kg. The library then screens what the fitted payload leaves: a torque constant or a current offset is named
only where the residual still calls for one. Per-joint current gains and offsets are not fitted beside the
payload: the residual they would take up is left to the library, which would otherwise name it a second time
(measured on a simulated log whose only error was the payload: with them beside it, the library then named a
current offset and a torque constant the log did not hold).

Separability: a payload on the flange and a torque-constant error both scale the gravity current of the
shoulder and elbow. The test is the share of the mass column (weighted, all joints) that per-joint current
gains, offsets and the drift explain, r^2; above :data:`ur5fault.discrepancy.statistics.MAX_COLLINEARITY` the log
cannot separate the payload from the torque constants and says so, with the mass and interval it would have
with those gains and offsets free (``gains_free_kg``) beside the interval as it is.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray
from scipy import stats

from ..logs import MeasuredLog
from ..sim.effects import REGISTRY, EffectSpec
from ..twin.payload import PayloadRecord, com_in_range, payload_current_columns, share_explained
from ..twin.replay import PAYLOAD_EFFECTS, LogReplay
from ..twin.residuals import fit_samples
from .drift import basis
from .statistics import MAX_COLLINEARITY

#: contiguous time blocks of the jackknife interval (as the workflow's findings: statistics.JACKKNIFE_BLOCKS)
JACKKNIFE_BLOCKS = 10
#: linearised fits: about 0 kg, then once about the first estimate (the current columns come from the target
#: motion's inverse dynamics, the replay from the closed loop: the second step removes what that leaves)
GAUSS_NEWTON_STEPS = 2
#: the library's candidates that an unknown payload's fit replaces
PAYLOAD_KINDS = PAYLOAD_EFFECTS


def _design(r: NDArray, cols: NDArray, gain: NDArray, drift: list[NDArray], sigma: NDArray, keep: NDArray
            ) -> tuple[NDArray, NDArray, int, int]:
    """The weighted least-squares problem over the kept rows: ``y`` ``(m*6,)`` and ``X`` with the payload's ``k``
    columns first, then every joint's drift basis (up to column ``d``), then per joint a current offset and a
    current gain (each zero on the other joints' rows)."""
    n, nj = r.shape
    k = cols.shape[0]
    groups = [[drift[j] for j in range(nj)], [np.column_stack([np.ones(n), gain[:, j]]) for j in range(nj)]]
    width = k + sum(b.shape[1] for g in groups for b in g)
    X = np.zeros((n, nj, width))
    X[:, :, :k] = np.moveaxis(cols, 0, -1)
    at = k
    ends = []
    for g in groups:
        for j, b in enumerate(g):
            X[:, j, at : at + b.shape[1]] = b
            at += b.shape[1]
        ends.append(at)
    X = X / sigma[None, :, None]
    y = r / sigma[None, :]
    return y[keep].reshape(-1), X[keep].reshape(-1, width), k, ends[0]


def _solve(G: NDArray, g: NDArray) -> NDArray:
    """Least squares from the normal equations (a minimum-norm solution where a nuisance is empty)."""
    return np.linalg.lstsq(G, g, rcond=None)[0]


def _step(log: MeasuredLog, n: int, at_kg: float, at_com: tuple[float, float, float], com_known: bool,
          params_overrides: dict | None, base_effects: Sequence[EffectSpec], seed: int):
    """One linearised fit about a replay holding ``at_kg`` at ``at_com``: the increment of the payload's unknowns,
    its jackknife replicates ``(B, k)`` and the r^2 of the mass column on the nuisances."""
    trial = dataclasses.replace(log, payload_kg=at_kg, tcp_offset_m=at_com)
    rp = LogReplay(trial, params_overrides, base_effects, seed=seed)
    sim = rp.run([()], n)[0]
    r = rp.measured(n)[:, 0] - sim.current_A
    cols = payload_current_columns(rp.params, log.q_target_rad, log.period_s,
                                   at_com if com_known else None)[:, 1 : n + 1]
    drift = basis(n, log.period_s, log.temperature_C)
    keep = log.logged_rows()[1 : n + 1] & np.all(np.isfinite(r), axis=1)
    y, X, k, d = _design(r, cols, sim.current_true_A, drift, rp.sigma[0], keep)
    # block jackknife over contiguous time blocks: each block's normal equations, the fit without it
    rows = np.flatnonzero(keep)
    edges = np.linspace(0, n, JACKKNIFE_BLOCKS + 1).astype(int)
    part = np.repeat(np.searchsorted(edges, rows, side="right") - 1, r.shape[1])
    Gs = np.array([X[part == b].T @ X[part == b] for b in range(JACKKNIFE_BLOCKS)])
    gs = np.array([X[part == b].T @ y[part == b] for b in range(JACKKNIFE_BLOCKS)])
    G, g = Gs.sum(axis=0), gs.sum(axis=0)
    out = []
    for w in (d, X.shape[1]):  # beside the drift; and with every joint's current gain and offset free too
        delta = _solve(G[:w, :w], g[:w])[:k]
        reps = np.array([_solve((G - Gs[b])[:w, :w], (g - gs[b])[:w])[:k] for b in range(JACKKNIFE_BLOCKS)])
        out.append((delta, reps))
    return out, share_explained(X[:, 0], X[:, k:])


def _jackknife_se(reps: NDArray) -> NDArray:
    """Block-jackknife standard error from the leave-one-block-out replicates ``(B, ...)`` (about their mean)."""
    B = reps.shape[0]
    return np.sqrt((B - 1) / B * np.sum((reps - reps.mean(axis=0)) ** 2, axis=0))


def fit_payload(log: MeasuredLog, n: int, fitted_on: str, params_overrides: dict | None = None,
                base_effects: Sequence[EffectSpec] = (), *, seed: int) -> PayloadRecord:
    """Fit the unknown payload of ``log`` on its samples ``1..n`` (module docstring); ``log.tcp_offset_m``
    given: the mass at that centre of mass, else mass and centre of mass. Linearised at 0 kg, then once more
    (Gauss-Newton) about the first estimate where it is a payload the model can hold."""
    com_known = log.tcp_offset_m
    mass = REGISTRY["payload"].param("mass_kg")
    at = np.zeros(1 if com_known else 4)
    at_com = com_known or (0.0, 0.0, 0.0)
    for _ in range(GAUSS_NEWTON_STEPS):
        fits, r2 = _step(log, n, float(at[0]), at_com, com_known is not None, params_overrides, base_effects, seed)
        (delta, reps_a), (delta_free, reps_free) = fits
        theta, reps_a = at + delta, at + reps_a
        c = tuple(float(x) for x in (com_known or theta[1:] / theta[0])) if theta[0] > 0 else None
        if not (mass.lo < theta[0] <= mass.hi) or c is None or not com_in_range(c):
            break  # no payload the model can hold to linearise about
        at, at_com = theta, c  # type: ignore[assignment]
    B = JACKKNIFE_BLOCKS
    se = _jackknife_se(reps_a)
    tq = float(stats.t.ppf(0.975, B - 1))
    m, m_se = float(theta[0]), float(se[0])
    lo, hi = m - tq * m_se, m + tq * m_se
    m_free = float(at[0] + delta_free[0])
    se_free = float(_jackknife_se(reps_free[:, 0]))
    free = (m_free, m_free - tq * se_free, m_free + tq * se_free)
    separable = r2 <= MAX_COLLINEARITY
    notes = []
    if not separable:
        notes.append(f"this log cannot separate the payload from the robot's torque constants: per-joint current "
                     f"gains, offsets and the drift explain r^2 = {r2:.3f} of the mass column (> {MAX_COLLINEARITY:g}, "
                     f"the workflow's collinearity limit); with them free the mass is {free[0]:.3g} kg (95 % "
                     f"{free[1]:.3g}..{free[2]:.3g}); the interval is reported as it is")
    replay_kg = float(np.clip(m, mass.lo, mass.hi))
    if replay_kg != m:
        notes.append(f"the estimate is outside the payload's range [{mass.lo:g}, {mass.hi:g}] kg: the replays hold "
                     f"{replay_kg:g} kg")
    com: tuple[float, float, float] | None = com_known
    com_iv = None
    if com_known is None:
        if lo > 0:
            ratio = reps_a[:, 1:] / reps_a[:, :1]
            c = theta[1:] / theta[0]
            c_se = _jackknife_se(ratio)
            com = tuple(float(x) for x in c)  # type: ignore[assignment]
            com_iv = tuple((float(a - tq * s), float(a + tq * s)) for a, s in zip(c, c_se))
        else:
            notes.append("centre of mass not determined (the mass's interval reaches 0 kg): the replays hold the "
                         "payload at the flange")
    replay_com = com if com is not None and (com_known or com_in_range(com)) else (0.0, 0.0, 0.0)
    if com is not None and replay_com != com:
        p = REGISTRY["payload_com"].param("dx_m")
        notes.append(f"the fitted centre of mass lies outside the range a payload's may take ([{p.lo:g}, {p.hi:g}] m "
                     "per axis in the flange frame, the payload_com effect's): the replays hold the payload at the "
                     "flange")
    return PayloadRecord(log.source, False, m, com, (lo, hi), com_iv, com_known is None and com is not None,
                         fitted_on, r2, separable, replay_kg, tuple(replay_com), tuple(notes), free)


def resolve_payloads(logs: Sequence[MeasuredLog], hold_out: Sequence[MeasuredLog], fit_fraction: float,
                     params_overrides: dict | None = None, base_effects: Sequence[EffectSpec] = (), *, seed: int,
                     say: Callable[[str], None] | None = None
                     ) -> tuple[list[MeasuredLog], list[MeasuredLog], dict[str, PayloadRecord]]:
    """Every log with its payload known: the stated ones as they are, the unknown ones fitted
    (:func:`fit_payload`; a fitted log on its fitting part, a held-out run whole) and replayed at the fit.
    Returns the logs, the held-out logs and a record per log; ``say`` gets each fitted payload's line."""
    records: dict[str, PayloadRecord] = {}

    def one(log: MeasuredLog, held: bool) -> MeasuredLog:
        if log.payload_known:
            records[log.source] = PayloadRecord(log.source, True, float(log.payload_kg),  # type: ignore[arg-type]
                                                log.tcp_offset_m, replayed_kg=float(log.payload_kg),  # type: ignore[arg-type]
                                                replayed_com_m=log.tcp_offset_m)  # type: ignore[arg-type]
            return log
        n_all = log.t_s.size - 1
        n = n_all if held else fit_samples(n_all, fit_fraction)
        how = ("the whole held-out run (its payload is the job's; the robot model is not fitted on it)" if held
               else f"the log's fitting part (first {100 * fit_fraction:.0f} %)")
        rec = fit_payload(log, n, how, params_overrides, base_effects, seed=seed)
        records[log.source] = rec
        if say is not None:
            say(rec.line())
        return dataclasses.replace(log, payload_kg=rec.replayed_kg, tcp_offset_m=rec.replayed_com_m)

    fitted = [one(g, False) for g in logs]
    held = [one(g, True) for g in hold_out]
    return fitted, held, records


def payload_kinds_screened(records: dict[str, PayloadRecord]) -> tuple[bool, str | None]:
    """Whether the library screens the job's payload (:data:`PAYLOAD_KINDS`) as a finding, and why not.

    Not when a payload was fitted (a nuisance of the job, not a discrepancy of the robot), nor when the logs state
    different masses: the library's payload candidate is one mass, so it would replace each log's own (a 2 kg run
    replayed at the 0 kg run's mass), and its text would name one log's payload as the one stated."""
    if not all(r.known for r in records.values()):
        return False, None
    masses = sorted({r.mass_kg for r in records.values()})
    if len(masses) > 1:
        return False, ("the payload is not screened as a finding: the logs state different payloads ("
                       + ", ".join(f"{m:g}" for m in masses) + " kg), and one mass would replace each log's own")
    return True, None
