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
#: fewest second differences a noise ratio is taken from (assumption: below ~100 its relative standard error,
#: about 1.4/sqrt(n), exceeds the 10 % a current gain must reach to matter)
MIN_NOISE_SAMPLES = 100
#: a condition's window around a velocity reversal [s]
REVERSAL_WINDOW_S = 0.25
#: a joint whose target speed is at most this is "at rest" for the conditions [rad/s] (the target
#: trajectory's own speed; a log's interpolated target holds still well below it)
CONDITION_REST_SPEED_RAD_S = 1e-3
#: "at speed", "accelerating", "under high load": above this share of the joint's largest value
PEAK_SHARE = 0.5
#: temperature span above which the warmer half of the log is a condition [K]
WARM_SPAN_K = 0.5
#: width of the bins a joint's travel is split into to localise a residual in angle [deg] (assumption: two
#: bins over a worn region of ~10 deg of a gear's travel)
ANGLE_BIN_DEG = 5.0
#: a bin of the travel is judged only with at least this many samples: the RMS of pure noise over 25
#: independent samples lies within 0.7..1.3 of its true value at 95 % (chi distribution), far below the
#: UNEXPLAINED_FACTOR a region must exceed
MIN_BIN_SAMPLES = 25
#: a joint's gear torque "reverses" when it passes this share of its largest magnitude over the log on both sides
#: (assumption: a swing of 5 % of the joint's peak load each way takes the gear across its clearance; the
#: simulated gear torque is noise-free)
REVERSAL_TORQUE_SHARE = 0.05
#: a region of the travel stands out when its RMS exceeds this multiple of the median bin's (assumption: a
#: local effect, e.g. a worn region of a gear, at least half as large again as the joint's residual elsewhere)
REGION_FACTOR = 1.5


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
    return {**command_conditions(qd, qdd, period_s), "under high load": _peak(torque)}


def command_conditions(qd: NDArray, qdd: NDArray, period_s: float) -> dict[str, NDArray]:
    """The conditions of :func:`motion_conditions` that follow from the commanded motion alone ("at speed",
    "near velocity reversals", "accelerating", "at rest"): the same for every run of one trajectory."""
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
    return {"at speed": _peak(qd), "near velocity reversals": near, "accelerating": _peak(qdd), "at rest": ~moving}


def _peak(x: NDArray) -> NDArray:
    """Where ``|x|`` exceeds PEAK_SHARE of its joint's largest value."""
    return np.abs(x) > PEAK_SHARE * np.maximum(np.abs(x).max(axis=0), 1e-12)


def rms_by_condition(r: NDArray, masks: dict[str, NDArray], j: int) -> tuple[dict[str, float], str]:
    """RMS of one joint's residual ``r`` under each condition that occurs, and the largest one."""
    by = {k: float(np.sqrt(np.nanmean(r[m[:, j]] ** 2))) for k, m in masks.items() if m[:, j].any()}
    return by, max(by, key=by.__getitem__)


def rms_by_angle(r: NDArray, q_rad: NDArray, bin_deg: float = ANGLE_BIN_DEG) -> list[tuple[float, float, float]]:
    """RMS of one joint's residual ``r`` ``(n,)`` per bin of its angle ``q_rad`` ``(n,)``: ``(from_deg, to_deg,
    rms)`` for every bin holding at least MIN_BIN_SAMPLES finite samples, in order of angle."""
    deg = np.rad2deg(q_rad)
    ok = np.isfinite(r) & np.isfinite(deg)
    if not ok.any():
        return []
    k = np.floor(deg[ok] / bin_deg).astype(int)
    sq = r[ok] ** 2
    out = []
    for b in np.unique(k):
        sel = k == b
        if sel.sum() >= MIN_BIN_SAMPLES:
            out.append((float(b * bin_deg), float((b + 1) * bin_deg), float(np.sqrt(sq[sel].mean()))))
    return out


def angle_region(r: NDArray, q_rad: NDArray, level: float) -> dict[str, float] | None:
    """The region of the travel around the worst bin where the residual's RMS exceeds ``level`` and stands out
    of the joint's own residual (REGION_FACTOR x the median bin's RMS; adjacent such bins merged), with its RMS
    and the RMS elsewhere; None when no bin does."""
    bins = rms_by_angle(r, q_rad)
    if not bins:
        return None
    level = max(level, REGION_FACTOR * float(np.median([b[2] for b in bins])))
    if max(b[2] for b in bins) <= level:
        return None
    k = max(range(len(bins)), key=lambda i: bins[i][2])
    lo = hi = k
    while lo > 0 and bins[lo - 1][2] > level and bins[lo - 1][1] == bins[lo][0]:
        lo -= 1
    while hi + 1 < len(bins) and bins[hi + 1][2] > level and bins[hi + 1][0] == bins[hi][1]:
        hi += 1
    a, b = bins[lo][0], bins[hi][1]
    deg = np.rad2deg(q_rad)
    inside = (deg >= a) & (deg < b) & np.isfinite(r)
    outside = ~inside & np.isfinite(r)
    return {"from_deg": a, "to_deg": b, "rms": float(np.sqrt(np.mean(r[inside] ** 2))),
            "rms_elsewhere": float(np.sqrt(np.mean(r[outside] ** 2))) if outside.any() else float("nan")}


def joint_angles(log: MeasuredLog, n: int) -> NDArray:
    """The measured joint angles ``(n, 6)`` at samples 1..n."""
    return log.q_actual_rad[1 : n + 1]


def localise(rp: LogReplay, residual: NDArray, torque: NDArray, top: int = 3) -> list[dict[str, Any]]:
    """The largest residuals (signal, joint) with their RMS under each operating condition."""
    n = residual.shape[0]
    masks = conditions(rp.log, n, torque)
    q = joint_angles(rp.log, n)
    rms = np.sqrt(np.nanmean(residual**2, axis=0))  # (S, 6)
    ranked = sorted(((rms[i, j] / rp.sigma[i, j], i, j) for i in range(len(rp.signals)) for j in range(N_JOINTS)),
                    reverse=True)[:top]
    out = []
    for ratio, i, j in ranked:
        by, worst = rms_by_condition(residual[:, i, j], masks, j)
        bins = rms_by_angle(residual[:, i, j], q[:, j])
        worst_bin = max(bins, key=lambda b: b[2]) if bins else None
        out.append({"signal": rp.signals[i], "joint": JOINT_NAMES[j], "rms": float(rms[i, j]),
                    "rms_over_noise": float(ratio), "rms_by_condition": by, "largest_where": worst,
                    "largest_angle_deg": None if worst_bin is None else [worst_bin[0], worst_bin[1]],
                    "rms_largest_angle": None if worst_bin is None else worst_bin[2]})
    return out


def unexplained(rp: LogReplay, residual: NDArray, torque: NDArray, n_fit: int) -> list[dict[str, Any]]:
    """Signal/joint pairs whose held-out residual stays above UNEXPLAINED_FACTOR x the noise floor, over the
    whole held-out part or over a region of the joint's travel (a local effect, e.g. a worn region of a
    gear, sits far above the floor there and may vanish in the joint's overall RMS)."""
    out = []
    n = residual.shape[0]
    masks = conditions(rp.log, n, torque)
    q = joint_angles(rp.log, n)
    for i, s in enumerate(rp.signals):
        for j in range(N_JOINTS):
            floor = math.sqrt(2.0) * rp.sigma[i, j]
            held = residual[n_fit:, i, j]
            rms = float(np.sqrt(np.nanmean(held**2)))
            region = angle_region(held, q[n_fit:, j], UNEXPLAINED_FACTOR * floor)
            if rms > UNEXPLAINED_FACTOR * floor or region is not None:
                where, worst = rms_by_condition(residual[:, i, j], masks, j)
                if rms <= UNEXPLAINED_FACTOR * floor:
                    worst = f"between {region['from_deg']:g} and {region['to_deg']:g} deg of its travel"
                fit = residual[:n_fit, i, j]
                rms_fit = float(np.sqrt(np.nanmean(fit**2))) if np.isfinite(fit).any() else float("nan")
                # the fitted part shows it neither overall nor (for an entry found in a region) in a region
                held_only = bool(rms_fit <= UNEXPLAINED_FACTOR * floor) and (
                    region is None or angle_region(fit, q[:n_fit, j], UNEXPLAINED_FACTOR * floor) is None)
                out.append({"signal": s, "joint": JOINT_NAMES[j], "rms_held_out": rms, "noise_floor": floor,
                            "rms_by_condition": where, "largest_where": worst, "angle_region": region,
                            "rms_fit": rms_fit, "held_out_only": held_only,
                            "gear_reverses": gear_reversals(torque[:n, j], n_fit)})
    return out


def gear_reversals(torque: NDArray, n_fit: int) -> dict[str, bool]:
    """Whether a joint's gear torque ``(n,)`` reverses (passes :data:`REVERSAL_TORQUE_SHARE` of its largest
    magnitude on both sides) in the fitted part (samples before ``n_fit``) and in the held-out part: a backlash, or
    anything else that acts where the gear crosses its clearance, shows only where it reverses."""
    t = np.asarray(torque, float)
    peak = float(np.nanmax(np.abs(t))) if np.isfinite(t).any() else 0.0
    level = REVERSAL_TORQUE_SHARE * peak

    def reverses(part: NDArray) -> bool:
        return bool(peak > 0 and np.any(part > level) and np.any(part < -level))

    return {"fitted": reverses(t[:n_fit]), "held_out": reverses(t[n_fit:])}


def stencils(mask: NDArray) -> NDArray:
    """``(n - 2, 6)``: where a second difference's three-sample stencil lies wholly inside ``mask`` ``(n, 6)``."""
    return mask[2:] & mask[1:-1] & mask[:-2]


def noise_ratio(meas_A: NDArray, twin_A: NDArray, mask: NDArray | None = None) -> NDArray:
    """Per joint ``(6,)``: RMS of the second difference of the current reading ``meas_A`` ``(n, 6)`` over that of
    the twin's reading ``twin_A``, over the samples whose three-sample stencil lies where ``mask`` ``(n, 6)`` is
    true (None: everywhere) and both readings are finite; NaN where fewer than :data:`MIN_NOISE_SAMPLES`
    differences remain or the twin's reading has no noise."""
    m2, t2 = np.diff(meas_A, 2, axis=0), np.diff(twin_A, 2, axis=0)
    ok = np.isfinite(m2) & np.isfinite(t2)
    if mask is not None:
        ok &= stencils(mask)
    n = ok.sum(axis=0)
    num = np.sqrt(np.sum(np.where(ok, m2, 0.0) ** 2, axis=0))
    den = np.sqrt(np.sum(np.where(ok, t2, 0.0) ** 2, axis=0))
    out = np.full(m2.shape[1], np.nan)
    good = (n >= MIN_NOISE_SAMPLES) & (den > 0)
    out[good] = num[good] / den[good]
    return out
