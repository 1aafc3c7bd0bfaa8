"""Sensor noise at rest and the resolver's resolution.

*At rest* means every joint's target has been constant for :data:`SETTLE_S` already (the
joints have settled; what remains in the readings is sensor noise and the servo's own
dither).  Each rest segment's readings are detrended by a straight line (a holding current
still creeping as an integrator winds up is not noise), and the noise sigma is the pooled
RMS of the detrended readings; its interval comes from resampling whole rest segments.

The resolver resolution is the quantum of the measured joint positions, per joint: the small non-zero
sample-to-sample steps are integer multiples of it, so it is the least-squares slope of the
steps on their multiples (smallest step as a first guess). Only the rows the robot wrote count (a tick the
reader filled in a gap is interpolated, and its half-steps are not the encoder's), and each joint has its own
(the second UR5 logs steps of about 9.5 urad on J1-J3 and 16.3 urad on J4-J6: one quantum pooled over all
joints fits neither).

Readings identical throughout every rest segment have a noise of exactly 0 (the white noise is below the
quantisation step, and the simulator's quantiser then reproduces identical readings); the weight of such a
sensor is its step (:func:`ur5fault.twin.replay.residual_sigma`), never 0.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from .signals import LogSignals
from .stats import Estimate, bootstrap, fallback, interval

#: settling time after the last joint stopped before samples count as "at rest" [s]
SETTLE_S = 0.5
#: a rest segment needs at least this many samples after settling
MIN_REST_SAMPLES = 20
#: fewer rest segments than this give a value but no interval (resampling them says nothing)
MIN_SEGMENTS_FOR_INTERVAL = 2
#: valid range of an encoder's counts per revolution (``sensors.resolver_counts_per_rev`` in sim/params.py)
MIN_COUNTS_PER_REV, MAX_COUNTS_PER_REV = 2.0, 2.0**32
#: steps up to this many quanta are used to fit the quantum (larger ones may be motion)
MAX_QUANTA = 5
#: a step cluster smaller than this share of the largest among its multiples is not the quantum's first guess
#: (assumption: a moving joint steps by one quantum at least a tenth as often as by its most frequent multiple)
MIN_CLUSTER_SHARE = 0.1
#: ... nor one seen fewer times than this (a lone step)
MIN_REPEATS = 3


def rest_segments(sig: LogSignals) -> list[NDArray]:
    """Index arrays of the settled rest segments (all six targets constant)."""
    rest = np.all(sig.at_rest(), axis=1)
    starts = np.array([s for s in sig.log_starts if s > 0], dtype=int)
    edges = np.union1d(np.flatnonzero(np.diff(rest.astype(int))) + 1, starts).astype(int)
    settle = int(round(SETTLE_S / sig.period_s))
    out = []
    for seg in np.split(np.arange(sig.n), edges):
        if rest[seg[0]] and seg.size - settle >= MIN_REST_SAMPLES:
            out.append(seg[settle:])
    return out


def _detrended_ss(x: NDArray, segments: list[NDArray]) -> tuple[NDArray, NDArray]:
    """Per segment: sum of squared residuals about a straight line ``(n_seg, 6)`` and sample counts."""
    ss = np.empty((len(segments), x.shape[1]))
    for s, seg in enumerate(segments):
        t = np.arange(seg.size, dtype=float)
        a = np.column_stack([t - t.mean(), np.ones_like(t)])
        y = x[seg]
        coef = np.linalg.lstsq(a, y, rcond=None)[0]
        ss[s] = np.sum((y - a @ coef) ** 2, axis=0)
    counts = np.array([seg.size - 2 for seg in segments], float)  # two fitted parameters per segment
    return ss, counts


def noise_at_rest(sig: LogSignals, n_boot: int, seed: int, prior: dict[str, NDArray]) -> list[Estimate]:
    """Current and position noise sigma per joint at rest.

    Without a settled rest segment the log cannot give them: ``prior`` (key -> the model's values) is
    kept and marked not identifiable.  From a single rest segment the value stands but has no interval
    (resampling one segment gives back the same value: a zero-width interval would claim a certainty
    the log does not hold).
    """
    segs = rest_segments(sig)
    keys = (("sensors.current_noise_A", sig.current_A, "current"),
            ("sensors.resolver_noise_rad", sig.q_actual_rad, "joint position"))
    if not segs:
        why = (f"no settled rest segment (all six targets constant for {SETTLE_S:g} s plus {MIN_REST_SAMPLES} "
               "samples); a log with the robot standing still for a second would give it")
        return [fallback(key, j, float(prior[key][j]), "kept the model's value", why)
                for key, x, _ in keys for j in range(x.shape[1])]
    out = []
    for key, x, method in keys:
        ss, counts = _detrended_ss(x, segs)

        def stat(idx: NDArray, ss=ss, counts=counts) -> NDArray:
            return np.sqrt(ss[idx].sum(axis=0) / counts[idx].sum())

        value = stat(np.arange(len(segs)))
        identical = np.array([all(np.ptp(x[seg, j]) == 0.0 for seg in segs) for j in range(x.shape[1])])
        value[identical] = 0.0  # not the detrending's rounding (1e-16)
        if len(segs) >= MIN_SEGMENTS_FOR_INTERVAL:
            lo, hi = interval(bootstrap(stat, [np.array([s]) for s in range(len(segs))], n_boot, seed))
            note = ""
        else:
            lo = hi = np.full(x.shape[1], np.nan)
            note = (f"no interval: {len(segs)} rest segment(s), resampling needs at least "
                    f"{MIN_SEGMENTS_FOR_INTERVAL}")
        lo[identical] = hi[identical] = np.where(np.isnan(lo[identical]), np.nan, 0.0)
        for j in range(x.shape[1]):
            quantised = value[j] == 0.0
            out.append(Estimate(key, j, float(value[j]), float(lo[j]), float(hi[j]),
                                f"{method} sigma at rest, {len(segs)} settled rest segments, detrended",
                                note=note or ("readings identical at rest: the white noise is below the "
                                              "quantisation step (weighed by the step where used)" if quantised
                                              else "")))
    return out


def position_quantum(q_rad: NDArray) -> tuple[float, NDArray]:
    """The quantum [rad] of measured positions and the small steps it was fitted on.

    First guess: the smallest step whose cluster (steps within 10 % of it) holds at least :data:`MIN_REPEATS` steps
    and :data:`MIN_CLUSTER_SHARE` of the largest cluster among the steps up to :data:`MAX_QUANTA` times it: a rare
    odder step is not the quantum (the second UR5's J1-J3 log 10 steps of 4-5 urad against 1,000 of 9-10 urad
    and their multiples, e.g. at an irregular tick; its odd multiples of 4.75 urad are as rare). Then the
    least-squares quantum over the steps of 1..:data:`MAX_QUANTA` quanta (steps below half a quantum left out)."""
    steps = np.abs(np.diff(q_rad, axis=0)).ravel()
    steps = np.sort(steps[steps > 0])
    if steps.size == 0:
        raise ValueError("positions never change")
    near = np.searchsorted(steps, 1.1 * steps, side="right") - np.searchsorted(steps, 0.9 * steps, side="left")
    i, quantum = 0, float(steps[0])
    while i < steps.size:
        top = int(np.searchsorted(steps, (MAX_QUANTA + 0.5) * steps[i], side="right"))
        if near[i] >= MIN_REPEATS and near[i] >= MIN_CLUSTER_SHARE * near[i:top].max():
            quantum = float(steps[i])
            break
        i = int(np.searchsorted(steps, 1.1 * steps[i], side="right"))  # the next cluster
    else:
        quantum = float(steps[0])  # no cluster qualifies (a few steps only): the smallest
    for _ in range(2):  # refine: the first guess may sit at the low edge of its cluster
        small = steps[(steps >= 0.5 * quantum) & (steps < (MAX_QUANTA + 0.5) * quantum)]
        quanta = np.maximum(np.round(small / quantum), 1.0)
        quantum = float(small.sum() / quanta.sum())
    return quantum, small


def resolver_resolution(sig: LogSignals, n_boot: int, seed: int, prior_counts) -> list[Estimate]:
    """Counts per revolution of each joint's encoder (2 pi / quantum of its logged positions), with a bootstrap
    over steps; the model's ``prior_counts`` (per joint), marked not identifiable, where the positions never change
    or show no quantisation step."""
    q = sig.q_actual_rad if sig.logged is None else sig.q_actual_rad[sig.logged]
    prior = np.broadcast_to(np.asarray(prior_counts, float), (q.shape[1],))
    return [_joint_resolution(q[:, [j]], j, n_boot, seed, float(prior[j])) for j in range(q.shape[1])]


def _joint_resolution(q: NDArray, j: int, n_boot: int, seed: int, prior_counts: float) -> Estimate:
    key = "sensors.resolver_counts_per_rev"
    try:
        quantum, small = position_quantum(q)
    except ValueError:
        return fallback(key, j, prior_counts, "kept the model's value",
                        "the measured positions never change (the joint did not move)")

    def stat(idx: NDArray) -> NDArray:
        s = small[idx]
        return np.array(2.0 * np.pi * np.maximum(np.round(s / quantum), 1.0).sum() / s.sum())

    counts = 2.0 * np.pi / quantum
    if not MIN_COUNTS_PER_REV <= counts <= MAX_COUNTS_PER_REV:  # no step at all: resampled or filtered positions
        return fallback(key, j, prior_counts, "kept the model's value",
                        f"the measured positions show no quantisation step (smallest step {quantum:.3g} rad, "
                        f"{counts:.3g} counts/rev, outside {MIN_COUNTS_PER_REV:g}..2^32): interpolated or filtered")
    lo, hi = interval(_resample_steps(stat, small.size, n_boot, seed))
    return Estimate(key, j, counts, float(lo), float(hi),
                    f"2 pi / quantum of the logged positions ({small.size} steps of 1..{MAX_QUANTA} quanta)")


def _resample_steps(stat, n_steps: int, n_boot: int, seed: int) -> NDArray:
    """:func:`.stats.bootstrap` with one group per step, without building a group array per step (the
    same random stream, so the same interval): an hour-long log has millions of steps, and concatenating
    as many one-element arrays 200 times once kept ``identify`` busy for minutes."""
    rng = np.random.default_rng(seed)
    out = np.full(n_boot, np.nan)
    for b in range(n_boot):
        out[b] = stat(rng.integers(0, n_steps, n_steps))
    return out
