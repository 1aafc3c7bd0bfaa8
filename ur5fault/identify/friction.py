"""Coulomb and viscous friction from the moving samples, and the torque constant.

On samples where a joint slides (target *and* measured speed above :data:`MIN_SPEED_RAD_S`, same
sign) the measured current is modelled as

    i = tau_model / K + F_c * sign(w) + F_v * w * theta(T) + c

with ``tau_model`` MuJoCo's inverse dynamics of the log's motion (gravity and inertia of the
links and the payload, plus the reflected rotor inertia; :mod:`.signals`), ``w`` the target
speed and ``theta(T) = exp(-coeff * (T - T_ref))`` the model's viscous temperature law (so F_v
is the value at the reference temperature, as ``ur5_drive.yaml`` stores it).  Standstill
samples are left out: at rest the current is whatever static friction happens to hold
(issue 10: with them J1 gives 0.38 A / 2.0 A*s/rad, without them 0.50 / 1.49).

Two steps, each with its reason:

1. ``K``, shared by the joints of one motor size (:mod:`.motor`), is fitted *without* ``c``: the
   structure the simulator implements.  On a log with one payload K is not separable from the
   gravity model (the shoulder's torque lever is its gravity), so K is an effective value, and
   a parameter overlay cannot carry ``c``: fitted beside ``c`` the shoulder's K comes out 7 %
   lower, and a replay with that K but without ``c`` reproduces the shoulder and elbow currents
   worse (docs/parameters.md).  That variant is reported as a check, not written.
2. ``F_c``, ``F_v`` per joint at that K, *with* ``c`` as a nuisance term: friction is odd in
   speed, a constant current is not friction, and the log's unequal time spent moving in each
   direction would otherwise leak it into F_c (J3, J4 carry 0.14-0.19 A of it).  ``c`` is
   reported as a check: a torque or current offset the model lacks.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..sim.params import RobotParams
from . import motor, payload
from .signals import LogSignals

#: a sample is "moving" above this speed [rad/s]: ~2.5x the noise of the speed differentiated from
#: the resolver (sigma 2.3e-5 rad * sqrt(2) / 8 ms = 4e-3 rad/s on the NIST log)
MIN_SPEED_RAD_S = 0.01
#: Coulomb and viscous friction separate only if the joint's speeds span a range: the moving
#: samples must reach this speed [rad/s] ...
MIN_TOP_SPEED_RAD_S = 0.2
#: ... and be this many
MIN_MOVING_SAMPLES = 500

#: names of the fitted vector: per joint K [N*m/A at the joint], F_c [A], F_v [A*s/rad], offset [A]
FIELDS = ("k_joint_Nm_per_A", "coulomb_A", "viscous_A_s_per_rad", "offset_A")


def moving_mask(sig: LogSignals) -> NDArray:
    """``(n, 6)``: the joint slides (target and measured speed above the threshold, same sign)."""
    wt, wa = sig.qd_target_rad_s, sig.qd_actual_rad_s
    return (np.abs(wt) > MIN_SPEED_RAD_S) & (np.abs(wa) > MIN_SPEED_RAD_S) & (np.sign(wt) == np.sign(wa))


def identifiable(sig: LogSignals, moving: NDArray) -> NDArray:
    """``(6,)``: the joint moves often and fast enough to separate Coulomb from viscous friction."""
    top = np.array([np.abs(sig.qd_target_rad_s[moving[:, j], j]).max(initial=0.0) for j in range(moving.shape[1])])
    return (moving.sum(axis=0) >= MIN_MOVING_SAMPLES) & (top >= MIN_TOP_SPEED_RAD_S)


def design_columns(sig: LogSignals, params: RobotParams, offset_term: bool) -> list[NDArray]:
    """Per joint the friction columns ``sign(w)``, ``w * theta(T)`` (and ``1`` with the offset term)."""
    f = params.friction
    theta = np.exp(-np.asarray(f.viscous_temp_coeff_per_K) * (sig.temperature_C - f.reference_temp_C))
    w = sig.qd_target_rad_s
    extra = [np.ones(sig.n)] if offset_term else []
    return [np.column_stack([np.sign(w[:, j]), w[:, j] * theta[:, j], *extra]) for j in range(w.shape[1])]


class FrictionFit:
    """The joint fit of torque constants and friction (and of the unknown payloads, :mod:`.payload`), as a
    function of the samples used.

    Args:
        sig: the log's derived signals.
        params: the model (reference temperature, viscous temperature law, fallback K).
        k_offset_term: fit the torque constant with a constant current offset (the check variant).
    """

    def __init__(self, sig: LogSignals, params: RobotParams, k_offset_term: bool = False) -> None:
        self.sig = sig
        self.moving = moving_mask(sig)
        self.ok = identifiable(sig, self.moving)
        self.cols_k = design_columns(sig, params, k_offset_term)
        self.cols = design_columns(sig, params, True)
        self.ratio = np.asarray(params.gear.ratio, float)
        self.k_prior = np.asarray(params.motor.torque_constant_Nm_per_A) * self.ratio
        lever = motor.torque_lever(sig.model_torque_Nm, self.moving)
        sizes = np.asarray(motor.MOTOR_SIZE)
        #: per motor size, the joints whose current carries the torque constant
        carries = self.ok & (lever >= motor.MIN_TORQUE_SPREAD_NM)
        self.k_groups = {int(s): [int(j) for j in np.flatnonzero((sizes == s) & carries)] for s in np.unique(sizes)}
        self.lever_Nm = lever
        #: the unknown payloads (None: every payload stated), :class:`.payload.PayloadUnknowns`
        self.payload = (payload.PayloadUnknowns.of(sig, self.moving, self.ok, self.cols, self.cols_k, self.k_groups)
                        if sig.payload_columns_Nm is not None else None)
        if self.payload is not None and not self.payload.k_identifiable:
            self.k_groups = {s: [] for s in self.k_groups}  # no log can separate a torque constant: the model's kept

    def __call__(self, idx: NDArray, torque: NDArray | None = None) -> NDArray:
        """Fit on the samples ``idx`` (repeats allowed); returns ``(4, 6)`` in the order of :data:`FIELDS`.

        ``torque`` replaces the model torque (e.g. UR's own target torque, as a cross-check; an unknown payload is
        then not fitted).
        """
        return self.solve(idx, torque)[0]

    def solve(self, idx: NDArray, torque: NDArray | None = None) -> tuple[NDArray, NDArray]:
        """:meth:`__call__` and the unknown payloads' sizes ``(p,)`` (:attr:`payload`; empty without)."""
        sig = self.sig
        tau = sig.model_torque_Nm if torque is None else torque
        pl = self.payload if torque is None else None
        rows = [idx[self.moving[idx, j]] for j in range(self.moving.shape[1])]
        sizes = np.asarray(motor.MOTOR_SIZE)
        k = self.k_prior.copy()
        theta = np.zeros(0 if pl is None else pl.n_unknowns)
        k_rows = rows if pl is None else [r[pl.k_rows[r]] for r in rows]
        for s in sorted(self.k_groups, key=lambda s: s != payload.WEIGHING_SIZE):  # the payload's joints first
            joints = self.k_groups[s]
            if not joints:
                continue
            shared = pl.anchored_Nm if pl is not None and s == payload.WEIGHING_SIZE else None
            beta, phi = motor.pooled_inverse_gain(sig.current_A, tau, self.cols_k, k_rows, joints, shared)
            k[sizes == s] = 1.0 / beta
            if shared is not None:
                theta[pl.anchored] = phi / beta  # type: ignore[union-attr]
                tau = tau + np.tensordot(theta, pl.columns_Nm, axes=1)  # type: ignore[union-attr]
        if pl is not None:
            fixed = pl.fit_at_k(rows, tau, k)  # the payloads the torque constants were not fitted beside
            theta = theta + fixed
            tau = tau + np.tensordot(fixed, pl.columns_Nm, axes=1)
        out = np.full((len(FIELDS), k.size), np.nan)
        out[0] = k
        for j in np.flatnonzero(self.ok):
            r = rows[j]
            y = sig.current_A[r, j] - tau[r, j] / k[j]
            out[1:, j] = np.linalg.lstsq(self.cols[j][r], y, rcond=None)[0]
        return out, theta
