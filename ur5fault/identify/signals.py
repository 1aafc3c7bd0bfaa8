"""Signals derived once from a measured log for every identification step.

Speeds and accelerations of the *target* come from central differences of the target
positions (the setpoints are smooth: on the NIST log this matches UR's own target-velocity
column to 3e-5 rad/s); the actual speed from central differences of the measured positions.
The model torque is MuJoCo's inverse dynamics of the target motion plus the rotor inertia
reflected through the gear (J_rotor * N^2 * qdd): the motor current drives both.

A log whose payload is unknown (``payload_kg`` ``None``) gets its model torque without a payload (tool at its
stated offset, else the flange) and the payload's torque columns (:func:`ur5fault.twin.payload.payload_torque_columns`:
the mass, and the first moments where the centre of mass is unknown too), which :mod:`.friction` fits beside
the torque constants (:mod:`.payload`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..errors import ParameterError
from ..logs import MeasuredLog
from ..logs.measured import same_period
from ..sim.inverse_dynamics import inverse_dynamics_Nm, payload_model
from ..sim.params import RobotParams
from ..twin.payload import payload_torque_columns

#: a target speed below this is a still target [rad/s]: the setpoints are exactly constant at rest, so
#: only rounding passes (the residual conditions' looser "at rest" is ur5fault.twin.residuals')
STILL_TARGET_RAD_S = 1e-6


@dataclasses.dataclass(frozen=True)
class LogSignals:
    """Arrays ``(n_samples, 6)`` in SI units, joint-positive current, plus the sample period."""

    period_s: float
    q_target_rad: NDArray
    qd_target_rad_s: NDArray
    qdd_target_rad_s2: NDArray
    q_actual_rad: NDArray
    qd_actual_rad_s: NDArray
    current_A: NDArray
    temperature_C: NDArray
    model_torque_Nm: NDArray
    target_torque_Nm: NDArray | None
    target_current_A: NDArray | None = None
    #: first row of each log when several logs are laid end to end (:func:`derive_all`); a rest or a start
    #: from rest never spans two logs
    log_starts: tuple[int, ...] = (0,)
    #: ``(n,)`` the rows the robot wrote (``None``: all; the others were filled in a gap by the reader)
    logged: NDArray | None = None
    #: ``(p, n, 6)`` joint torque per unit of each unknown of the unknown payloads [N*m per kg, per kg*m], zero
    #: outside its log's rows (``None``: every payload stated)
    payload_columns_Nm: NDArray | None = None
    #: per column of ``payload_columns_Nm``, the index of its log (in ``log_starts``)
    payload_owner: tuple[int, ...] = ()

    def same_log(self, a: int, b: int) -> bool:
        """Rows ``a <= b`` belong to one log."""
        return not any(a < s <= b for s in self.log_starts)

    @property
    def n(self) -> int:
        return self.q_target_rad.shape[0]

    def at_rest(self) -> NDArray:
        """``(n, 6)``: the joint's target is not moving."""
        return np.abs(self.qd_target_rad_s) < STILL_TARGET_RAD_S


def derive(log: MeasuredLog, params: RobotParams, model_path: str | Path) -> LogSignals:
    """Speeds, accelerations and the model torque of ``log`` (see the module docstring)."""
    dt = log.period_s
    qd_t = np.gradient(log.q_target_rad, dt, axis=0)
    qdd_t = np.gradient(qd_t, dt, axis=0)
    qd_a = np.gradient(log.q_actual_rad, dt, axis=0)
    known = log.payload_known
    model = payload_model(model_path, log.payload_kg if known else 0.0, log.tcp_offset_m or (0.0, 0.0, 0.0))
    tau = inverse_dynamics_Nm(model, log.q_target_rad, qd_t, qdd_t)
    cols = None if known else payload_torque_columns(model, log.q_target_rad, qd_t, qdd_t, log.tcp_offset_m)
    n_gear = np.asarray(params.gear.ratio)
    tau = tau + np.asarray(params.motor.rotor_inertia_kgm2) * n_gear**2 * qdd_t
    temp = (log.temperature_C if log.temperature_C is not None
            else np.tile(np.asarray(params.joint_temperature_C, float), (log.t_s.size, 1)))
    return LogSignals(dt, log.q_target_rad, qd_t, qdd_t, log.q_actual_rad, qd_a, log.current_A, temp, tau,
                      log.target_torque_Nm, log.target_current_A, logged=log.logged_rows(), payload_columns_Nm=cols,
                      payload_owner=() if cols is None else (0,) * cols.shape[0])


def derive_all(logs: Sequence[MeasuredLog], params: RobotParams, model_path: str | Path) -> LogSignals:
    """:func:`derive` of every log (each differentiated on its own), laid end to end; optional columns only when
    every log has them. The logs must share one sample period."""
    parts = [derive(log, params, model_path) for log in logs]
    if len(parts) == 1:
        return parts[0]
    period = parts[0].period_s
    for log, p in zip(logs, parts):
        if not same_period(p.period_s, period):
            raise ParameterError(f"{log.source}: sample period {p.period_s:g} s differs from {logs[0].source}'s "
                                 f"{period:g} s; a joint identification needs one")
    kw = {}
    for f in dataclasses.fields(LogSignals):
        vals = [getattr(p, f.name) for p in parts]
        if f.name == "period_s":
            kw[f.name] = period
        elif f.name == "log_starts":
            kw[f.name] = tuple(int(x) for x in np.cumsum([0] + [p.n for p in parts[:-1]]))
        elif f.name == "payload_columns_Nm":
            kw[f.name] = _payload_columns(parts)
        elif f.name == "payload_owner":
            kw[f.name] = tuple(i for i, p in enumerate(parts) for _ in p.payload_owner)
        else:
            kw[f.name] = None if any(v is None for v in vals) else np.concatenate(vals)
    return LogSignals(**kw)


def _payload_columns(parts: Sequence[LogSignals]) -> NDArray | None:
    """Every log's payload columns on the rows of all logs laid end to end (zero outside their own log)."""
    k = sum(len(p.payload_owner) for p in parts)
    if k == 0:
        return None
    out = np.zeros((k, sum(p.n for p in parts), parts[0].q_target_rad.shape[1]))
    col = row = 0
    for p in parts:
        if p.payload_columns_Nm is not None:
            out[col : col + p.payload_columns_Nm.shape[0], row : row + p.n] = p.payload_columns_Nm
            col += p.payload_columns_Nm.shape[0]
        row += p.n
    return out
