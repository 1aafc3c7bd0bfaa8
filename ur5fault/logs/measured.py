"""The measured (or simulated) robot log every reader returns: SI units, batch-free arrays."""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError
from ..sim.trajectories import Trajectory


@dataclasses.dataclass(frozen=True)
class MeasuredLog:
    """A measured (or simulated) robot log, SI units, batch-free ``(n_samples, 6)`` arrays.

    ``current_A`` is in joint-positive sense; optional arrays are ``None`` when absent.
    """

    source: str
    t_s: NDArray
    q_target_rad: NDArray
    q_actual_rad: NDArray
    current_A: NDArray
    target_current_A: NDArray | None = None
    temperature_C: NDArray | None = None
    tcp_m: NDArray | None = None
    q_motor_rad: NDArray | None = None
    payload_kg: float = 0.0
    tcp_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.15)
    #: UR's own inverse-dynamics joint torque of the target motion [N*m] (NIST ROBOT_TARGET_JOINT_TORQUES,
    #: RTDE target_moment), used as a cross-check by ``ur5fault identify``
    target_torque_Nm: NDArray | None = None

    @property
    def period_s(self) -> float:
        return float(np.median(np.diff(self.t_s)))

    def to_trajectory(self, name: str | None = None) -> Trajectory:
        """The log's target positions as a setpoint stream (payload held throughout)."""
        return Trajectory(name or self.source, self.period_s, self.q_target_rad, (), self.payload_kg > 0,
                          self.payload_kg)

    def window(self, t0_s: float, t1_s: float) -> MeasuredLog:
        """The part of the log with ``t0 <= t < t1`` (times relative to the log start), time re-zeroed."""
        t = self.t_s - self.t_s[0]
        sel = (t >= t0_s) & (t < t1_s)
        if sel.sum() < 2:
            raise LogFormatError(f"{self.source}: window [{t0_s}, {t1_s}) s holds fewer than 2 samples")
        kw = {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}
        for key, v in kw.items():
            if isinstance(v, np.ndarray) and v.shape[:1] == self.t_s.shape:
                kw[key] = v[sel]
        kw["t_s"] = kw["t_s"] - kw["t_s"][0]
        return MeasuredLog(**kw)
