"""An unknown payload in ``ur5fault identify``: one nuisance per log, fitted beside the torque constants.

A log that does not state its payload (an RTDE log without ``--payload-kg``, or ``unknown``) has its model
torque taken without a payload and, beside it, the payload's torque columns
(:func:`ur5fault.twin.payload.payload_torque_columns`: the mass, and its first moments where the tool offset is
unknown too; :mod:`.signals`). The payload is the log's, not the robot's: one set of unknowns per log, reported
(:class:`ur5fault.twin.payload.PayloadRecord`, ``"known": false``) and never written to the overlay.

Method: the measured current of the joints that weigh a payload (the motor size of J1-J3, whose gravity lever
carries it: the joints of that size that carry the torque constant, :mod:`.motor`) is
``(tau + C x) / K + friction``, bilinear in ``K`` and the payload ``x``; with ``phi = x / K`` it is linear, so
the payloads are fitted in the same pooled least squares as the shared torque constant and friction
(:func:`.motor.pooled_inverse_gain`), ``x = phi * K``. The other motor size and the per-joint friction are then
fitted with the payload's torque included. Intervals: the same block bootstrap as every other estimate of
``identify`` (the whole joint fit per resample), percentiles of ``x``, and of ``m c / m`` for the centre of
mass (reported only where the mass's interval stays above 0 kg, as ``ur5fault discrepancy`` does).
Linearised at the flange: the point mass's own inertia ``m c c^T`` is left out (at 0.1 m and 1.5 kg,
0.015 kg*m^2, acting only through the accelerations; gravity is exact).

Separability (decided per log, on that log's rows): the share r^2 of its mass column that the columns fitted
beside it explain (the shared torque-constant column, each weighing joint's Coulomb, viscous and constant
current) against :data:`ur5fault.discrepancy.statistics.MAX_COLLINEARITY`, the bar ``ur5fault discrepancy``
applies to its payload and every candidate. A log above it cannot tell its payload from the torque constant:
its rows are left out of the torque-constant fit, which is made on the logs whose payload is stated or separable,
and its payload is then fitted at that torque constant (said so). When no log is stated or separable, the torque
constants are not identifiable (the model's values are kept and marked) and every payload is fitted at them.
Why not fit them all jointly anyway: a mass that the log cannot separate from ``K`` would take up whatever
torque-constant error the model holds (the NIST log declared unknown, r^2 0.99: docs/validation.md), and the
torque constant written to the overlay would then depend on a nuisance the log cannot see.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ..discrepancy.statistics import MAX_COLLINEARITY
from ..errors import ParameterError
from ..logs import MeasuredLog
from ..sim.effects import REGISTRY
from ..twin.payload import PayloadRecord, com_in_range, share_explained
from . import motor
from .signals import LogSignals
from .stats import interval

#: the motor size whose joints weigh a payload: the shoulder's (J1-J3; a payload's gravity loads J2 and J3)
WEIGHING_SIZE = motor.MOTOR_SIZE[1]
#: the JSON key of a fitted payload's separability r^2 (what the mass column is regressed on)
R2_KEY = "r2_mass_vs_torque_constant_friction_offset"


@dataclasses.dataclass(frozen=True)
class PayloadUnknowns:
    """The unknown payloads of the logs of one identification, and which of them the torque constants are fitted
    beside (module docstring)."""

    #: ``(p, n, 6)`` torque per unit of each unknown [N*m per kg, per kg*m]
    columns_Nm: NDArray
    #: ``(p,)`` the log index of each column
    owner: NDArray
    #: ``(n,)`` the log index of each row
    log_of_row: NDArray
    #: the joints whose current weighs the payloads
    joints: tuple[int, ...]
    #: per unknown log: r^2 of its mass column on the columns fitted beside it (its rows)
    r2: dict[int, float]
    #: ``(n,)`` the rows the torque constants are fitted on (logs stated or separable)
    k_rows: NDArray
    #: ``(p,)`` the columns fitted beside the torque constants (separable logs); the others at the fitted K
    anchored: NDArray
    current_A: NDArray
    friction_cols: tuple[NDArray, ...]
    #: some joint of the weighing motor size carries the torque constant on these logs
    k_group: bool = True

    @classmethod
    def of(cls, sig: LogSignals, moving: NDArray, ok: NDArray, friction_cols: Sequence[NDArray],
           k_cols: Sequence[NDArray], k_groups: Mapping[int, list[int]]) -> PayloadUnknowns:
        """The unknowns of the logs ``sig`` from the friction fit's samples: ``moving`` (samples x joints) and
        identifiable joints ``ok``, its design columns per joint (with and without the torque-constant fit's
        variant) and the joints that carry each motor size's torque constant (:class:`.friction.FrictionFit`'s
        ``moving``, ``ok``, ``cols``, ``cols_k``, ``k_groups``)."""
        cols = sig.payload_columns_Nm
        owner = np.asarray(sig.payload_owner)
        log_of_row = np.searchsorted(np.asarray(sig.log_starts), np.arange(sig.n), side="right") - 1
        sizes = np.asarray(motor.MOTOR_SIZE)
        joints = k_groups[WEIGHING_SIZE] or [int(j) for j in np.flatnonzero(ok & (sizes == WEIGHING_SIZE))]
        if not joints:
            names = ", ".join(f"J{j + 1}" for j in np.flatnonzero(sizes == WEIGHING_SIZE))
            raise ParameterError(f"payload unknown, and none of {names} moves often and fast enough to weigh it: "
                                 "state it with --payload-kg and --tcp-offset-m")
        r2 = {}
        for u in np.unique(owner):
            rows = [np.flatnonzero(moving[:, j] & (log_of_row == u)) for j in joints]
            a = np.concatenate([cols[np.flatnonzero(owner == u)[0], r, j] for r, j in zip(rows, joints)])  # type: ignore[index]
            width = 1 + sum(friction_cols[j].shape[1] for j in joints)
            N = np.zeros((a.size, width))
            at, c = 0, 1
            for r, j in zip(rows, joints):
                N[at : at + r.size, 0] = sig.model_torque_Nm[r, j]
                m = friction_cols[j].shape[1]
                N[at : at + r.size, c : c + m] = friction_cols[j][r]
                at, c = at + r.size, c + m
            r2[int(u)] = share_explained(a, N) if a.size else 1.0
        separable = {u for u, v in r2.items() if v <= MAX_COLLINEARITY}
        anchor_logs = [i for i in range(len(sig.log_starts)) if i not in r2 or i in separable]
        # without a torque-constant group on J1-J3 every payload is fitted at the torque constants kept
        anchored = np.isin(owner, list(separable)) if k_groups[WEIGHING_SIZE] else np.zeros(owner.size, bool)
        return cls(cols, owner, log_of_row, tuple(joints), r2, np.isin(log_of_row, anchor_logs),  # type: ignore[arg-type]
                   anchored, sig.current_A, tuple(k_cols), bool(k_groups[WEIGHING_SIZE]))

    @property
    def n_unknowns(self) -> int:
        return int(self.owner.size)

    @property
    def anchored_Nm(self) -> NDArray | None:
        """The columns fitted beside the torque constants, or ``None``."""
        return self.columns_Nm[self.anchored] if self.anchored.any() else None

    @property
    def k_identifiable(self) -> bool:
        """Some log (stated, or its payload separable) carries the torque constants."""
        return bool(self.k_rows.any())

    def fit_at_k(self, rows: list[NDArray], tau_Nm: NDArray, k_joint: NDArray) -> NDArray:
        """The payloads not fitted beside the torque constants, each on its own log's moving ``rows`` at the joint
        torque constants ``k_joint`` with each weighing joint's friction and constant current free; ``(p,)``, zero on
        the anchored columns."""
        out = np.zeros(self.n_unknowns)
        for u in np.unique(self.owner[~self.anchored]):
            cu = np.flatnonzero(self.owner == u)
            sel = [r[self.log_of_row[r] == u] for r in (rows[j] for j in self.joints)]
            width = cu.size + sum(self.friction_cols[j].shape[1] for j in self.joints)
            X = np.zeros((sum(r.size for r in sel), width))
            y = np.zeros(X.shape[0])
            at, c = 0, cu.size
            for r, j in zip(sel, self.joints):
                X[at : at + r.size, : cu.size] = self.columns_Nm[cu][:, r, j].T / k_joint[j]
                m = self.friction_cols[j].shape[1]
                X[at : at + r.size, c : c + m] = self.friction_cols[j][r]
                y[at : at + r.size] = self.current_A[r, j] - tau_Nm[r, j] / k_joint[j]
                at, c = at + r.size, c + m
            out[cu] = np.linalg.lstsq(X, y, rcond=None)[0][: cu.size]
        return out


def records(logs: list[MeasuredLog], pl: PayloadUnknowns, theta: NDArray, boot: NDArray) -> list[PayloadRecord]:
    """One record per log: stated ones as they are, unknown ones with the fitted mass (and centre of mass), their
    bootstrap intervals ``boot`` ``(n_boot, p)``, the separability test and the values the log is replayed with."""
    mass = REGISTRY["payload"].param("mass_kg")
    out = []
    for i, log in enumerate(logs):
        if log.payload_known:
            out.append(PayloadRecord(log.source, True, float(log.payload_kg), log.tcp_offset_m,  # type: ignore[arg-type]
                                     replayed_kg=float(log.payload_kg),  # type: ignore[arg-type]
                                     replayed_com_m=log.tcp_offset_m))  # type: ignore[arg-type]
            continue
        cu = np.flatnonzero(pl.owner == i)
        m = float(theta[cu[0]])
        lo, hi = (float(v) for v in interval(boot[:, cu[0]]))
        r2 = pl.r2[i]
        separable = r2 <= MAX_COLLINEARITY
        joints = ", ".join(f"J{j + 1}" for j in pl.joints)
        if pl.anchored[cu[0]]:
            how = f"the moving samples of {joints}, jointly with the torque constants and friction"
        elif pl.k_identifiable and pl.k_group:
            how = f"the moving samples of {joints}, at the torque constants of the other logs, with friction"
        else:
            how = f"the moving samples of {joints}, at the model's torque constants, with friction"
        notes = []
        if not separable:
            where = ("the torque constants come from the logs whose payload is stated or separable" if
                     pl.k_identifiable else "no log can: the torque constants are not identifiable (the model's "
                     "values kept) and the payload is fitted at them")
            notes.append(f"this log cannot separate the payload from the torque constants: the torque constant, "
                         f"friction and constant current explain r^2 = {r2:.3f} of the mass column "
                         f"(> {MAX_COLLINEARITY:g}); {where}")
        elif not pl.anchored[cu[0]]:
            notes.append(f"no joint of {joints}'s motor size has the torque lever to carry a torque constant on these "
                         "logs: the payload is fitted at the model's")
        replay_kg = float(np.clip(m, mass.lo, mass.hi))
        if replay_kg != m:
            notes.append(f"the estimate is outside the payload's range [{mass.lo:g}, {mass.hi:g}] kg: the replays hold "
                         f"{replay_kg:g} kg")
        com, com_iv = log.tcp_offset_m, None
        if com is None:
            if lo > 0:
                c = theta[cu[1:]] / m
                ratio = boot[:, cu[1:]] / boot[:, cu[:1]]
                clo, chi = interval(ratio)
                com = tuple(float(x) for x in c)  # type: ignore[assignment]
                com_iv = tuple((float(a), float(b)) for a, b in zip(clo, chi))
            else:
                notes.append("centre of mass not determined (the mass's interval reaches 0 kg): the replays hold the "
                             "payload at the flange")
        replay_com = com if com is not None and (log.tcp_offset_m is not None or com_in_range(com)) else (0.0, 0.0, 0.0)
        if com is not None and replay_com != com:
            p = REGISTRY["payload_com"].param("dx_m")
            notes.append(f"the fitted centre of mass lies outside [{p.lo:g}, {p.hi:g}] m per axis (the payload_com "
                         "effect's range): the replays hold the payload at the flange")
        out.append(PayloadRecord(log.source, False, m, com, (lo, hi), com_iv,  # type: ignore[arg-type]
                                 log.tcp_offset_m is None and com is not None, how, r2, separable, replay_kg,
                                 tuple(replay_com), tuple(notes), r2_key=R2_KEY))  # type: ignore[arg-type]
    return out
