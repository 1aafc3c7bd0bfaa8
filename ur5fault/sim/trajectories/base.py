"""The setpoint stream of a motion and UR-style joint moves, at the CB3 controller rate (125 Hz)
as the real controller sends them.

A :class:`Trajectory` is the stream of joint setpoints ``q_set`` sampled every
``setpoint_period_s`` plus the payload events (grip, release).  The joint servo
interpolates linearly between consecutive setpoints (assumption: the drive holds the
next setpoint one period ahead, which is what makes the real log's target and actual
positions line up in time; docs/parameters.md) and feeds the interpolation slope
forward as the velocity setpoint.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from ..axes import N_JOINTS

CB3_SETPOINT_PERIOD_S = 0.008  # 125 Hz (ur5-facts.md)
UR_DEFAULT_SPEED_RAD_S = 1.047  # controller default joint speed (ur5-facts.md)
UR_DEFAULT_ACCEL_RAD_S2 = 1.396  # controller default joint acceleration (ur5-facts.md)
UR_MAX_SPEED_RAD_S = np.pi  # the UR5's maximum joint speed, 180 deg/s (ur5-facts.md)
#: the fastest a fixed motion may be scaled: the UR5's maximum joint speed over the controller default, 3.0
MAX_SPEED_SCALE = UR_MAX_SPEED_RAD_S / UR_DEFAULT_SPEED_RAD_S
MIN_SPEED_SCALE = 0.05


@dataclasses.dataclass(frozen=True)
class Trajectory:
    """Setpoint stream of one motion.

    Attributes:
        name: identifier written to outputs.
        setpoint_period_s: spacing of the setpoints [s].
        q_set_rad: setpoints, shape ``(n_setpoints, 6)`` [rad].
        payload_events: ``(time_s, gripped)`` pairs, sorted by time; the payload mass is
            attached from an event with ``gripped=True`` until the next release.
        payload_gripped_at_start: whether the payload is held at ``t = 0``.
        default_payload_kg: payload mass used when a run does not set one [kg].
    """

    name: str
    setpoint_period_s: float
    q_set_rad: NDArray[np.float64]
    payload_events: tuple[tuple[float, bool], ...] = ()
    payload_gripped_at_start: bool = False
    default_payload_kg: float = 0.0

    def __post_init__(self) -> None:
        q = np.asarray(self.q_set_rad, dtype=float)
        if q.ndim != 2 or q.shape[1] != N_JOINTS or q.shape[0] < 2:
            raise ParameterError(f"trajectory {self.name!r}: q_set_rad must have shape (n >= 2, 6), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ParameterError(f"trajectory {self.name!r}: q_set_rad contains NaN or inf")
        if not self.setpoint_period_s > 0:
            raise ParameterError(f"trajectory {self.name!r}: setpoint_period_s must be > 0")
        q.setflags(write=False)
        object.__setattr__(self, "q_set_rad", q)

    @property
    def duration_s(self) -> float:
        """Time from the first to the last setpoint [s]."""
        return (self.q_set_rad.shape[0] - 1) * self.setpoint_period_s

    def interpolate(self, t_s: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Servo-side setpoint at times ``t_s``: linear interpolation and its slope.

        Returns ``(q_set [rad], qd_set [rad/s])``, each ``(len(t_s), 6)``; beyond the end
        the last setpoint is held with zero velocity.
        """
        t = np.asarray(t_s, dtype=float)
        n = self.q_set_rad.shape[0]
        x = t / self.setpoint_period_s
        k = np.clip(np.floor(x + 1e-9).astype(int), 0, n - 2)
        frac = np.clip(x - k, 0.0, 1.0)[:, None]
        q0, q1 = self.q_set_rad[k], self.q_set_rad[k + 1]
        slope = (q1 - q0) / self.setpoint_period_s
        slope = np.where((x >= n - 1)[:, None], 0.0, slope)
        return q0 + frac * (q1 - q0), slope

    def gripped(self, t_s: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether the payload is held at each time in ``t_s``."""
        t = np.asarray(t_s, dtype=float)
        state = np.full(t.shape, self.payload_gripped_at_start)
        for te, g in self.payload_events:
            state = np.where(t >= te, g, state)
        return state


def movej(q0: NDArray, q1: NDArray, v_max: float, a_max: float, period_s: float) -> NDArray[np.float64]:
    """UR-style joint move: a trapezoidal speed profile shared by all joints (they start and
    stop together), limited by the joint with the largest displacement.

    Returns setpoints from ``q0`` (excluded) to ``q1`` (included), ``(n, 6)`` [rad].
    """
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    dist = float(np.max(np.abs(q1 - q0)))
    if dist == 0.0:
        return q1[None, :]
    if dist > v_max * v_max / a_max:  # trapezoid
        t_acc = v_max / a_max
        total = dist / v_max + t_acc
    else:  # triangle
        t_acc = np.sqrt(dist / a_max)
        total = 2.0 * t_acc
    v_peak = a_max * t_acc
    n = int(np.ceil(total / period_s))
    t = np.arange(1, n + 1) * (total / n)
    s = np.where(
        t < t_acc,
        0.5 * a_max * t**2,
        np.where(
            t <= total - t_acc,
            0.5 * a_max * t_acc**2 + v_peak * (t - t_acc),
            dist - 0.5 * a_max * (total - t) ** 2,
        ),
    )
    # resample on the fixed setpoint grid: total/n differs from period_s by < 1 period / n
    return q0 + (s / dist)[:, None] * (q1 - q0)


def dwell(q: NDArray, seconds: float, period_s: float) -> NDArray[np.float64]:
    """Hold ``q`` for ``seconds`` (at least one setpoint), ``(n, 6)`` [rad]."""
    return np.repeat(np.asarray(q, float)[None, :], max(1, round(seconds / period_s)), axis=0)
