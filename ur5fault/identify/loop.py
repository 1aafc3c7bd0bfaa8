"""Position loop: the tracking lag, the velocity feed-forward it implies, and the loop bandwidth.

*Lag.*  Per joint the tracking error ``e = q_target - q_actual`` is regressed on the target
speed (with a constant): the slope is the lag tau [s].  Identifiable only where the joint moves
(:data:`MIN_TOP_SPEED_RAD_S`) and the speed explains a real share of the error
(R^2 >= :data:`MIN_LAG_R2`); on the NIST log J5 (max 0.15 rad/s, R^2 = 0.005) and J6 (still) are not.

*Feed-forward.*  A P position loop of gain ``K_p = 2 pi f_p`` with a feed-forward share ``ff``
of the setpoint speed lags by ``(1 - ff) / K_p``, so ``ff = 1 - tau * 2 pi f_p``.

*Bandwidth.*  No closed form: the log is replayed through the simulator for each candidate
f_p (with its own ff from the lag and every other identified value applied), over its first
``window_s`` only (the rest of the log stays for checking), and scored by
``sum_j ln^2(RMS e_sim / RMS e_meas)`` over the joints that move.  The interval is the spread of
the arg-min when the score is recomputed on time blocks resampled with replacement.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from ..logs import MeasuredLog
from ..sim.params import deep_merge
from ..twin.replay import LogReplay
from .signals import LogSignals
from .stats import BLOCK_S, N_BOOT, Estimate, block_indices, bootstrap, interval

#: the lag counts as identified when the target speed explains this share of the tracking error
MIN_LAG_R2 = 0.05
#: a joint whose target never moves faster than this [rad/s] has no lag and no place in the bandwidth score
MIN_TOP_SPEED_RAD_S = 0.05
BANDWIDTHS_HZ = (1.0, 1.5, 2.0, 3.0)
SWEEP_WINDOW_S = 32.0
#: noise seed of the sweep's replays
SWEEP_SEED = 1


def _lag_fit(e: NDArray, w: NDArray) -> tuple[float, float]:
    a = np.column_stack([w, np.ones_like(w)])
    coef = np.linalg.lstsq(a, e, rcond=None)[0]
    r = e - a @ coef
    return float(coef[0]), float(1.0 - r.var() / e.var()) if e.var() > 0 else 0.0


def tracking_lag(sig: LogSignals, n_boot: int, seed: int) -> tuple[list[Estimate], NDArray]:
    """Lag per joint [s] (with interval) and which joints it is identifiable on ``(6,)``."""
    e = sig.q_target_rad - sig.q_actual_rad
    w = sig.qd_target_rad_s
    blocks = block_indices(sig.n, int(round(BLOCK_S / sig.period_s)))
    out, ok = [], np.zeros(e.shape[1], bool)
    for j in range(e.shape[1]):
        lag, r2 = _lag_fit(e[:, j], w[:, j])
        top = float(np.abs(w[:, j]).max())
        ok[j] = r2 >= MIN_LAG_R2 and top >= MIN_TOP_SPEED_RAD_S
        if not ok[j]:
            why = (f"the target speed explains {100 * r2:.1f} % of the tracking error (< {100 * MIN_LAG_R2:.0f} %)"
                   if top >= MIN_TOP_SPEED_RAD_S else f"the joint does not move (top speed {top:.2g} rad/s)")
            out.append(Estimate("controller.tracking_lag_s", j, lag, float("nan"), float("nan"),
                                "slope of tracking error on target speed", False, why))
            continue
        boot = bootstrap(lambda idx, j=j: np.array(_lag_fit(e[idx, j], w[idx, j])[0]), blocks, n_boot, seed)
        lo, hi = interval(boot)
        out.append(Estimate("controller.tracking_lag_s", j, lag, float(lo), float(hi),
                            f"slope of tracking error on target speed over the whole log (R^2 = {r2:.2f})"))
    return out, ok


def feedforward(lag_s: NDArray, position_bw_Hz: float) -> NDArray:
    """Feed-forward share that leaves a P position loop of ``position_bw_Hz`` lagging by ``lag_s``."""
    return 1.0 - np.asarray(lag_s) * 2.0 * np.pi * position_bw_Hz


@dataclasses.dataclass(frozen=True)
class Sweep:
    """Result of the bandwidth sweep."""

    bandwidths_Hz: tuple[float, ...]
    scores: tuple[float, ...]
    best_Hz: float
    lo_Hz: float
    hi_Hz: float
    joints: tuple[int, ...]
    window_s: float
    rms_sim_rad: NDArray  # (n_candidates, 6)
    rms_meas_rad: NDArray  # (6,)


def _score(sq_sim: NDArray, sq_meas: NDArray, idx: NDArray, joints: Sequence[int]) -> NDArray:
    """Scores of every candidate from squared errors ``(n_cand, n, 6)`` and ``(n, 6)`` on rows ``idx``."""
    ratio = np.sqrt(sq_sim[:, idx].mean(axis=1) / sq_meas[idx].mean(axis=0))
    return np.sum(np.log(ratio[:, list(joints)]) ** 2, axis=1)


def sweep_joints(log: MeasuredLog, window_s: float = SWEEP_WINDOW_S) -> tuple[int, tuple[int, ...]]:
    """The samples the sweep replays (the log's first ``window_s``, at most the whole log) and the joints it scores
    there: those whose target reaches ``MIN_TOP_SPEED_RAD_S`` (none: the sweep cannot tell the bandwidths
    apart)."""
    n = min(int(round(window_s / log.period_s)), log.t_s.size - 1)
    speed = np.abs(np.gradient(log.q_target_rad[: n + 1], log.period_s, axis=0)).max(axis=0) if n > 1 else \
        np.zeros(log.q_target_rad.shape[1])
    return n, tuple(int(j) for j in np.flatnonzero(speed >= MIN_TOP_SPEED_RAD_S))


def bandwidth_sweep(log: MeasuredLog, base_overrides: dict, lag_s: NDArray, lag_ok: NDArray,
                    ff_fallback: NDArray, bandwidths_Hz: Sequence[float] = BANDWIDTHS_HZ,
                    window_s: float = SWEEP_WINDOW_S, n_boot: int = N_BOOT, seed: int = 0,
                    progress: Callable[[str], None] | None = None) -> Sweep:
    """Replay the log's first ``window_s`` for each candidate bandwidth and pick the best.

    Args:
        log: the measured log.
        base_overrides: parameter overrides of every replay (the identified values; the log's tool and
            temperatures are the replay's own).
        lag_s, lag_ok: the identified lag per joint and where it is identifiable.
        ff_fallback: feed-forward of the joints without an identifiable lag.
    """
    n, joints = sweep_joints(log, window_s)
    meas = log.q_target_rad[1 : n + 1] - log.q_actual_rad[1 : n + 1]
    sq_sim = []
    for f in bandwidths_Hz:
        if progress is not None:
            progress(f"replaying {n * log.period_s:.0f} s of the log at a {f:g} Hz position loop")
        ff = np.where(lag_ok, feedforward(lag_s, f), ff_fallback)
        over = deep_merge(base_overrides, {"controller": {"position_bw_Hz": float(f),
                                                          "velocity_feedforward": [float(x) for x in ff]}})
        sim = LogReplay(log, over, seed=SWEEP_SEED).run([()], n)[0]
        e = log.q_target_rad[1 : n + 1] - sim.position_rad
        sq_sim.append(e**2)
    sq_sim = np.array(sq_sim)
    sq_meas = meas**2
    rows = np.arange(n)
    scores = _score(sq_sim, sq_meas, rows, joints)
    blocks = block_indices(n, int(round(BLOCK_S / log.period_s)))
    bw = np.asarray(bandwidths_Hz, float)
    boot = bootstrap(lambda idx: np.array(bw[np.argmin(_score(sq_sim, sq_meas, idx, joints))]), blocks, n_boot, seed)
    lo, hi = interval(boot)
    return Sweep(tuple(float(f) for f in bw), tuple(float(s) for s in scores), float(bw[np.argmin(scores)]),
                 float(lo), float(hi), joints, n * log.period_s, np.sqrt(sq_sim.mean(axis=1)),
                 np.sqrt(sq_meas.mean(axis=0)))


def sweep_estimate(s: Sweep, source: str = "the log") -> Estimate:
    """The sweep as an estimate; ``source``: the log it replayed (of several, the first whose window moves a joint).
    A best bandwidth at an end of the candidates is said to be there: the best may lie beyond it, and the interval
    says only that the resamples chose the same end."""
    scores = ", ".join(f"{f:g} Hz: {v:.2f}" for f, v in zip(s.bandwidths_Hz, s.scores))
    joints = ", ".join(f"J{j + 1}" for j in s.joints)
    edge = ""
    if len(s.bandwidths_Hz) > 1 and s.best_Hz in (min(s.bandwidths_Hz), max(s.bandwidths_Hz)):
        side = "highest" if s.best_Hz == max(s.bandwidths_Hz) else "lowest"
        edge = f"; the {side} candidate: the best may lie beyond it"
    return Estimate("controller.position_bw_Hz", None, s.best_Hz, s.lo_Hz, s.hi_Hz,
                    f"replay of the first {s.window_s:.0f} s of {source}, score sum over {joints} of "
                    f"ln^2(sim/measured tracking RMS): {scores}{edge}")


