"""Load-dependent gear friction (the effect ``load_friction``): the coefficient ``mu`` per joint, as a check.

A strain-wave gear's Coulomb friction grows with the torque it carries, ``T_c + mu |tau|`` (docs/model.md).  On
the samples where a joint slides above the Stribeck range (``|w| > 3 / stribeck_rate``, where eq. (2)'s Stribeck
part is below 0.5 % of its excess) the current minus the model torque over the identified torque constant is
regressed on the friction columns of :mod:`.friction` (Coulomb, viscous, offset), ``tau / K`` (a correction of the
torque constant on this joint: fitted without this term, ``K`` absorbs part of it, 2 % of ``K`` and a quarter of
``mu`` on a simulated log with ``mu`` = 0.1) and ``sgn(w) |tau| / K``; the last coefficient is ``mu`` [N*m of
friction per N*m carried], positive when physical.  Measured on the NIST motion simulated with ``load_friction`` on
shoulder_lift (``tests/identify/test_loadfriction.py``): 0.075 (95 % 0.069..0.101) for a simulated 0.10, and
-0.002 (-0.005..0.006) for none.  The estimate reads a quarter low; the cause is not established (the effect scales
the simulated gear torque, friction and controller dynamics included, where this regression has the rigid-body
model torque of the target motion), so read it as a lower bound of the size and a test of its sign.

Reported as ``check.load_friction_coeff``, never written to the overlay: the Coulomb level and the breakaway the
overlay carries are fitted without it (they hold the load's average share), so writing ``mu`` beside them would
count that share twice; and on both real robots a fitted ``mu`` barely moves the held-out current
(docs/validation.md, "Load-dependent gear friction").  Not identifiable where the joint's friction is not, where
fewer than :data:`~.friction.MIN_MOVING_SAMPLES` samples are at speed, or where the load column, once the
friction and torque columns are projected out of it, spreads by less than :data:`~.motor.MIN_TORQUE_SPREAD_NM`
(the load then hardly varies within a direction of motion, and ``mu`` is Coulomb friction or a torque-constant
error under another name).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from .friction import MIN_MOVING_SAMPLES, FrictionFit
from .motor import MIN_TORQUE_SPREAD_NM
from .stats import Estimate, bootstrap, fallback, interval

KEY = "check.load_friction_coeff"


def at_speed(fit: FrictionFit, j: int, stribeck_rate_s_per_rad: float) -> NDArray:
    """``(n,)`` bool: joint ``j`` slides above the Stribeck range (three Stribeck speeds; a law without a
    Stribeck term, rate 0, has no such range: every moving sample)."""
    above = 3.0 / stribeck_rate_s_per_rad if stribeck_rate_s_per_rad > 0 else 0.0
    return fit.moving[:, j] & (np.abs(fit.sig.qd_target_rad_s[:, j]) > above)


def load_column_Nm(fit: FrictionFit, j: int) -> NDArray:
    """``(n,)``: ``sgn(w) |tau|`` of the model torque [N*m]."""
    return np.sign(fit.sig.qd_target_rad_s[:, j]) * np.abs(fit.sig.model_torque_Nm[:, j])


def nuisance_columns(fit: FrictionFit, j: int) -> NDArray:
    """``(n, 4)``: the friction columns (Coulomb, viscous, offset) and the model torque [N*m]."""
    return np.column_stack([fit.cols[j], fit.sig.model_torque_Nm[:, j]])


def lever_Nm(fit: FrictionFit, j: int, rows: NDArray) -> float:
    """RMS of the load column on ``rows`` once the nuisance columns are projected out of it [N*m]."""
    X, x = nuisance_columns(fit, j)[rows], load_column_Nm(fit, j)[rows]
    return float(np.sqrt(np.mean((x - X @ np.linalg.lstsq(X, x, rcond=None)[0]) ** 2))) if rows.size else 0.0


def identify_load_friction(fit: FrictionFit, full: NDArray, blocks, n_boot: int, seed: int,
                           stribeck_rate_s_per_rad: float) -> list[Estimate]:
    """``check.load_friction_coeff`` per joint, with its 95 % block-bootstrap interval."""
    out: list[Estimate] = []
    for j in range(N_JOINTS):
        fast = at_speed(fit, j, stribeck_rate_s_per_rad)
        rows = np.flatnonzero(fast)
        if not fit.ok[j]:
            out.append(fallback(KEY, j, 0.0, "not fitted", f"J{j + 1}: its friction is not identifiable"))
            continue
        if rows.size < MIN_MOVING_SAMPLES:
            out.append(fallback(KEY, j, 0.0, "not fitted", f"J{j + 1}: {rows.size} samples above the Stribeck "
                                f"range, fewer than the {MIN_MOVING_SAMPLES} needed"))
            continue
        lever = lever_Nm(fit, j, rows)
        if lever < MIN_TORQUE_SPREAD_NM:
            out.append(fallback(KEY, j, 0.0, "not fitted", f"J{j + 1}: the load varies by {lever:.2f} N*m within "
                                f"a direction of motion, less than the {MIN_TORQUE_SPREAD_NM:g} N*m that separate "
                                "it from Coulomb friction and the torque constant"))
            continue
        k = full[0, j]
        y = fit.sig.current_A[:, j] - fit.sig.model_torque_Nm[:, j] / k
        X = np.column_stack([nuisance_columns(fit, j), load_column_Nm(fit, j)]) / np.array([1, 1, 1, k, k])

        def stat(idx: NDArray, X=X, y=y, fast=fast) -> NDArray:
            r = idx[fast[idx]]
            return np.linalg.lstsq(X[r], y[r], rcond=None)[0][-1:]

        mu = float(stat(rows)[0])
        lo, hi = interval(bootstrap(stat, blocks, n_boot, seed + j))
        out.append(Estimate(KEY, j, mu, float(lo[0]), float(hi[0]),
                            f"coefficient of sgn(w)|tau|/K beside Coulomb, viscous, offset and tau/K on {rows.size} "
                            f"samples above the Stribeck range (load lever {lever:.1f} N*m); reported, not written"))
    return out
