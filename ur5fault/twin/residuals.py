"""The residual of a replay (measured - simulated): operating conditions of the log, RMS tables, where the
residual is largest and what stays above the noise floor.

Shapes: a residual is ``(n_samples, n_signals, 6)`` in a replay's signal order (:mod:`.replay`); a
condition mask is ``(n_samples, 6)``; samples are the log's ``1..n`` (sample 0 is the initial state).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..logs import MeasuredLog
from ..sim.axes import JOINT_NAMES, N_JOINTS

if TYPE_CHECKING:  # pragma: no cover
    from .replay import LogReplay

#: share of a log (from its start) that is fitted; the rest is held out for checking (assumption: 60 % of a
#: robot program repeats its motions several times and leaves a part long enough to test on)
FIT_FRACTION = 0.6
#: a held-out residual above this multiple of the noise floor is reported as unexplained
UNEXPLAINED_FACTOR = 3.0
#: a condition's window around a velocity reversal [s]
REVERSAL_WINDOW_S = 0.25
#: a joint whose target speed is at most this is "at rest" for the conditions [rad/s] (the target
#: trajectory's own speed; a log's interpolated target holds still well below it)
CONDITION_REST_SPEED_RAD_S = 1e-3
#: "at speed", "accelerating", "under high load": above this share of the joint's largest value
PEAK_SHARE = 0.5
#: temperature span above which the warmer half of the log is a condition [K]
WARM_SPAN_K = 0.5


def rms_table(signals: tuple[str, ...], meas: NDArray, sim: NDArray, sl: slice) -> dict[str, dict[str, float]]:
    """RMS of measured - simulated per signal and joint over samples ``sl``."""
    return {s: {JOINT_NAMES[j]: float(np.sqrt(np.nanmean((meas[sl, i, j] - sim[sl, i, j]) ** 2)))
                for j in range(N_JOINTS)} for i, s in enumerate(signals)}


def masked_rms(x: NDArray, mask: NDArray) -> NDArray:
    """RMS per joint of ``x`` ``(n, 6)`` over the samples in ``mask`` ``(n, 6)``; NaN for a joint with
    none (e.g. no velocity reversal)."""
    count = mask.sum(axis=0)
    sq = np.where(mask, x, 0.0) ** 2
    return np.where(count > 0, np.sqrt(sq.sum(axis=0) / np.maximum(count, 1)), np.nan)


def fit_samples(n: int, fit_fraction: float = FIT_FRACTION) -> int:
    """How many of a log's ``n`` replayed samples are fitted: the first ``fit_fraction`` of them (at least one);
    the rest are held out.  The one definition of the time split, used by ``identify``, ``discrepancy`` and the
    twin: logs are read onto a regular tick grid (``logs/regular.py``), so a share of samples is the same
    share of time."""
    return max(1, int(n * fit_fraction))


def held_out_mask(n: int, fit_fraction: float = FIT_FRACTION) -> NDArray:
    """The held-out samples of ``n`` replayed ones (:func:`fit_samples`), as a mask ``(n, 6)``."""
    held = np.arange(n) >= fit_samples(n, fit_fraction)
    return np.broadcast_to(held[:, None], (n, N_JOINTS))


def conditions(log: MeasuredLog, n: int, torque: NDArray) -> dict[str, NDArray]:
    """Boolean masks ``(n, 6)`` of operating conditions of ``log`` at samples 1..n."""
    q = log.q_target_rad[: n + 2]
    qd_all = np.gradient(q, log.period_s, axis=0)
    qd = qd_all[1 : n + 1]
    qdd = np.gradient(qd_all, log.period_s, axis=0)[1 : n + 1]
    out = motion_conditions(qd, qdd, torque[:n], log.period_s)
    if log.temperature_C is not None and np.ptp(log.temperature_C) > WARM_SPAN_K:
        temp = log.temperature_C[1 : n + 1]
        out["warmer half"] = temp > np.median(temp, axis=0)
    return out


def motion_conditions(qd: NDArray, qdd: NDArray, torque: NDArray, period_s: float) -> dict[str, NDArray]:
    """Boolean masks ``(n, 6)`` of the motion conditions ("at speed", "near velocity reversals",
    "accelerating", "at rest", "under high load") from the target speed ``qd`` [rad/s], acceleration
    ``qdd`` [rad/s^2] and a torque ``(n, 6)``, sampled every ``period_s``."""
    win = max(1, round(REVERSAL_WINDOW_S / period_s))
    near = np.zeros_like(qd, dtype=bool)
    moving = np.abs(qd) > CONDITION_REST_SPEED_RAD_S
    sign = np.sign(np.where(moving, qd, 0.0))
    for j in range(N_JOINTS):
        last = 0.0
        for k in np.flatnonzero(sign[:, j]):
            if last != 0 and sign[k, j] != last:
                near[max(0, k - win) : k + win, j] = True
            last = sign[k, j]

    def peak(x: NDArray) -> NDArray:
        return np.abs(x) > PEAK_SHARE * np.maximum(np.abs(x).max(axis=0), 1e-12)

    return {"at speed": peak(qd), "near velocity reversals": near, "accelerating": peak(qdd),
            "at rest": ~moving, "under high load": peak(torque)}


def rms_by_condition(r: NDArray, masks: dict[str, NDArray], j: int) -> tuple[dict[str, float], str]:
    """RMS of one joint's residual ``r`` under each condition that occurs, and the largest one."""
    by = {k: float(np.sqrt(np.nanmean(r[m[:, j]] ** 2))) for k, m in masks.items() if m[:, j].any()}
    return by, max(by, key=by.__getitem__)


def localise(rp: LogReplay, residual: NDArray, torque: NDArray, top: int = 3) -> list[dict[str, Any]]:
    """The largest residuals (signal, joint) with their RMS under each operating condition."""
    n = residual.shape[0]
    masks = conditions(rp.log, n, torque)
    rms = np.sqrt(np.nanmean(residual**2, axis=0))  # (S, 6)
    ranked = sorted(((rms[i, j] / rp.sigma[i, j], i, j) for i in range(len(rp.signals)) for j in range(N_JOINTS)),
                    reverse=True)[:top]
    out = []
    for ratio, i, j in ranked:
        by, worst = rms_by_condition(residual[:, i, j], masks, j)
        out.append({"signal": rp.signals[i], "joint": JOINT_NAMES[j], "rms": float(rms[i, j]),
                    "rms_over_noise": float(ratio), "rms_by_condition": by, "largest_where": worst})
    return out


def unexplained(rp: LogReplay, residual: NDArray, torque: NDArray, n_fit: int) -> list[dict[str, Any]]:
    """Signal/joint pairs whose held-out residual stays above UNEXPLAINED_FACTOR x the noise floor."""
    out = []
    masks = conditions(rp.log, residual.shape[0], torque)
    for i, s in enumerate(rp.signals):
        for j in range(N_JOINTS):
            floor = math.sqrt(2.0) * rp.sigma[i, j]
            rms = float(np.sqrt(np.nanmean(residual[n_fit:, i, j] ** 2)))
            if rms > UNEXPLAINED_FACTOR * floor:
                where, worst = rms_by_condition(residual[:, i, j], masks, j)
                out.append({"signal": s, "joint": JOINT_NAMES[j], "rms_held_out": rms, "noise_floor": floor,
                            "rms_by_condition": where, "largest_where": worst})
    return out
