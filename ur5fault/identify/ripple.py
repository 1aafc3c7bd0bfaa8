"""Torque ripple periodic in the motor angle (the effect ``motor_harmonic``): period, amplitude and phase per joint.

The strain-wave gear turns the motor exactly ``N`` times per joint turn, so the motor angle is ``N q`` plus a
constant the log does not show: a ripple of ``k`` periods per motor turn is ``a sin(k N q) + b cos(k N q)`` in the
log's joint angle, its phase carried by ``(a, b)``.  On the moving samples (friction sliding, so it does not hold the
ripple as it does at rest) the current minus the model torque over the identified torque constant is regressed on
``sin, cos(k N q)`` together with the friction columns of :mod:`.friction` (Coulomb, viscous, offset) for each ``k``
in :data:`PERIODS_PER_REV`, on the samples where that ripple is slower than :data:`MAX_RIPPLE_HZ`; the largest is the
joint's ripple.  Measured this way, not assumed: on the NIST log
5 per motor turn on J2-J3 and 3 on the wrists, on the Kufieta robot 4 per turn on J3-J5 (docs/validation.md).

Below that frequency the speed loop answers a rotor torque ``T`` with ``-T / K_t`` of current (it rejects it;
checked in ``tests/sim/test_motor_harmonic.py``): the simulated loop passes 0.9-1.2x of it with a few degrees of
phase below 10 Hz (the shoulder highest) and 0.3-0.8x above 10 Hz, where it no longer rejects it.  So the torque
written is ``-K_t`` times the current's coefficients (motor side, ``K_t`` the identified torque constant).

Identifiable when the chosen period stands out of the joint's own spectrum: the lower bound of its amplitude
interval exceeds the largest amplitude at every other period searched (those are what noise, friction-model error
and aliasing leave at a period with no ripple).  Otherwise the estimate is "not identifiable" and no ripple is
written.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import JOINT_NAMES, N_JOINTS
from .friction import MIN_MOVING_SAMPLES, FrictionFit  # fewest samples for a ripple: the friction fit's own
from .stats import Estimate, bootstrap, fallback, interval

#: periods per motor turn searched (assumption: cogging, pole-pair and wave-generator orders are low; the logs
#: show 3 and 4)
PERIODS_PER_REV = tuple(range(1, 9))
#: highest ripple frequency used [Hz]: below it the simulated speed loop answers a rotor torque T with -T/K_t of
#: current to within 8 % on every joint (pick-and-place, k = 3; 1.2x near 8 Hz on J1-J2, 0.3-0.8x above 10 Hz,
#: where the loop no longer rejects it), so -K_t times the current's ripple is the torque
MAX_RIPPLE_HZ = 5.0


def columns(q_rad: NDArray, ratio: float, k: float) -> NDArray:
    """``(n, 2)``: ``sin, cos(k * ratio * q)``."""
    x = k * ratio * np.asarray(q_rad)
    return np.column_stack([np.sin(x), np.cos(x)])


def model_residual(fit: FrictionFit, full: NDArray, j: int) -> NDArray:
    """``(n,)``: the joint's current minus the model torque over the identified torque constant."""
    sig = fit.sig
    return sig.current_A[:, j] - sig.model_torque_Nm[:, j] / full[0, j]


def slow_rows(fit: FrictionFit, j: int, ratio: float, k: float, max_hz: float = MAX_RIPPLE_HZ) -> NDArray:
    """``(n,)`` bool: the joint slides and a ripple of ``k`` per motor turn is at most ``max_hz``."""
    w = np.abs(fit.sig.qd_target_rad_s[:, j])
    return fit.moving[:, j] & (k * ratio * w / (2.0 * np.pi) <= max_hz)


def _fit(fit: FrictionFit, y: NDArray, q: NDArray, ratio: float, j: int, k: float, rows: NDArray) -> NDArray:
    """sin and cos coefficients [A] of period ``k``, fitted on ``rows`` together with the joint's friction columns
    (Coulomb, viscous, offset: nuisance terms here, so a joint whose friction is not identifiable still gets them)."""
    X = np.column_stack([fit.cols[j][rows], columns(q[rows], ratio, k)])
    return np.linalg.lstsq(X, y[rows], rcond=None)[0][-2:]


def identify_ripple(fit: FrictionFit, full: NDArray, blocks, n_boot: int, seed: int,
                    max_hz: float = MAX_RIPPLE_HZ) -> list[Estimate]:
    """Per joint: ``ripple.periods_per_rev``, ``ripple.amplitude_A`` (with its interval) and the motor-side torque
    coefficients ``ripple.sin_Nm`` / ``ripple.cos_Nm`` of the effect ``motor_harmonic``; ``max_hz``: the fastest
    ripple used (``inf``: every moving sample, the variant ``bench/cross_robot.py`` also scores)."""
    sig = fit.sig
    out: list[Estimate] = []
    for j in range(N_JOINTS):
        ratio = float(fit.ratio[j])
        masks = [slow_rows(fit, j, ratio, k, max_hz) for k in PERIODS_PER_REV]
        ks = [k for k, m in zip(PERIODS_PER_REV, masks) if m.sum() >= MIN_MOVING_SAMPLES]  # the periods with data
        if len(ks) < 2:
            out += _absent(j, f"J{j + 1}: fewer than two periods with {MIN_MOVING_SAMPLES} moving samples whose "
                              f"ripple is below {max_hz:g} Hz (none to compare a ripple with)")
            continue
        masks = [m for k, m in zip(PERIODS_PER_REV, masks) if k in ks]
        y = model_residual(fit, full, j)
        q = sig.q_actual_rad[:, j]
        coef = np.array([_fit(fit, y, q, ratio, j, k, np.flatnonzero(m)) for k, m in zip(ks, masks)])
        amp = np.hypot(coef[:, 0], coef[:, 1])
        best = int(np.argmax(amp))
        k = ks[best]
        moving = masks[best]
        n_mv = int(moving.sum())

        def stat(idx: NDArray, k=k, j=j, y=y, q=q, ratio=ratio, moving=moving) -> NDArray:
            c = _fit(fit, y, q, ratio, j, k, idx[moving[idx]])
            return np.array([c[0], c[1], np.hypot(c[0], c[1])])

        lo, hi = interval(bootstrap(stat, blocks, n_boot, seed + j))
        floor = float(np.max(np.delete(amp, best)))
        kt = full[0, j] / ratio  # motor-side torque constant [N*m/A]
        how = (f"largest of {len(ks)} motor-angle periods in the current (model torque removed, "
               f"friction fitted alongside), {n_mv} moving samples with the ripple below {max_hz:g} Hz")
        if not lo[2] > floor:
            out += _absent(j, f"J{j + 1}: {k} per motor turn, {amp[best]:.3f} A (interval {lo[2]:.3f}..{hi[2]:.3f}) "
                              f"does not stand out of the other periods (up to {floor:.3f} A)")
            continue
        # a choice among the periods searched, not a measurement with a spread: no interval
        out.append(Estimate("ripple.periods_per_rev", j, float(k), float("nan"), float("nan"), how))
        out.append(Estimate("ripple.amplitude_A", j, float(amp[best]), float(lo[2]), float(hi[2]),
                            f"{how}; the other periods reach {floor:.3f} A"))
        # torque = -K_t * current coefficient (the loop rejects the ripple); the interval flips with the sign
        out.append(Estimate("ripple.sin_Nm", j, -kt * coef[best, 0], -kt * hi[0], -kt * lo[0],
                            "motor-side torque of sin(k N q): -K_t times the current's coefficient"))
        out.append(Estimate("ripple.cos_Nm", j, -kt * coef[best, 1], -kt * hi[1], -kt * lo[1],
                            "motor-side torque of cos(k N q): -K_t times the current's coefficient"))
    return out


def _absent(j: int, why: str) -> list[Estimate]:
    return [fallback("ripple.amplitude_A", j, 0.0, "no ripple written", why)]


def ripple_effects(estimates) -> list[dict]:
    """The identified ripples as ``motor_harmonic`` entries of a model overlay's ``effects`` list."""
    by = {(e.key, e.joint): e for e in estimates}
    out = []
    for j in range(N_JOINTS):
        k = by.get(("ripple.periods_per_rev", j))
        if k is None:
            continue
        out.append({"effect": "motor_harmonic", "joint": JOINT_NAMES[j],
                    "sin_Nm": round(float(by[("ripple.sin_Nm", j)].value), 6),
                    "cos_Nm": round(float(by[("ripple.cos_Nm", j)].value), 6), "periods_per_rev": float(k.value)})
    return out
