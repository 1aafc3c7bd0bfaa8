"""Joint setpoint trajectories, sent at the CB3 controller rate (125 Hz) as the real
controller sends them.

A :class:`Trajectory` is the stream of joint setpoints ``q_set`` sampled every
``setpoint_period_s`` plus the payload events (grip, release).  The joint servo
interpolates linearly between consecutive setpoints (assumption: the drive holds the
next setpoint one period ahead, which is what makes the real log's target and actual
positions line up in time; docs/parameters.md) and feeds the interpolation slope
forward as the velocity setpoint.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from .axes import N_JOINTS
from .errors import ParameterError, UnknownNameError

CB3_SETPOINT_PERIOD_S = 0.008  # 125 Hz (ur5-facts.md)
UR_DEFAULT_SPEED_RAD_S = 1.047  # controller default joint speed (ur5-facts.md)
UR_DEFAULT_ACCEL_RAD_S2 = 1.396  # controller default joint acceleration (ur5-facts.md)


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

    def setpoint_times_s(self) -> NDArray[np.float64]:
        """Times of the setpoints [s], shape ``(n_setpoints,)``."""
        return np.arange(self.q_set_rad.shape[0]) * self.setpoint_period_s

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


def _dwell(q: NDArray, seconds: float, period_s: float) -> NDArray[np.float64]:
    return np.repeat(np.asarray(q, float)[None, :], max(1, round(seconds / period_s)), axis=0)


# Pick-and-place waypoints [rad], tool pointing down (z axis of the TCP = -z of the base within 1e-3).
# Found by numerical IK on ur5fault/models/ur5.xml with TCP offset 0.15 m: the TCP drops 0.12 m from each
# approach pose; the transfer takes the arm over the top, so the shoulder and elbow gravity torques
# change sign (checked by tests/test_trajectory.py).
PICK_APPROACH = (-0.4, -1.0, 1.6, -2.17, -1.5708, 0.0)
PICK = (-0.4, -0.8132, 1.6555, -2.4131, -1.5708, 0.0)
PLACE_APPROACH = (0.5, -2.2043, -1.4889, -1.0192, 1.5708, 0.9)
PLACE = (0.5, -2.3794, -1.5444, -0.7885, 1.5708, 0.9)


def pick_and_place(
    payload_kg: float = 2.0,
    speed_scale: float = 1.0,
    setpoint_period_s: float = CB3_SETPOINT_PERIOD_S,
) -> Trajectory:
    """Pick a mass in front, carry it over the top and place it behind, then return.

    Moves at the UR controller's default joint speed and acceleration times ``speed_scale``.
    Contains velocity reversals on every moving joint and gravity-torque sign changes on
    the shoulder and elbow (the base joint's axis is vertical, so it carries no gravity
    torque; its torque reverses through inertia).  About 14 s at ``speed_scale = 1``.
    """
    if not 0.05 <= speed_scale <= 1.0:
        raise ParameterError(f"speed_scale = {speed_scale} is out of range [0.05, 1]")
    v, a, ts = UR_DEFAULT_SPEED_RAD_S * speed_scale, UR_DEFAULT_ACCEL_RAD_S2 * speed_scale, setpoint_period_s
    parts: list[NDArray] = [_dwell(PICK_APPROACH, 0.5, ts)]
    events: list[tuple[float, bool]] = []

    def go(q_to):
        parts.append(movej(parts[-1][-1], q_to, v, a, ts))

    def dwell_with_event(seconds, gripped):
        start = sum(len(p) for p in parts) - 1
        parts.append(_dwell(parts[-1][-1], seconds, ts))
        events.append(((start + 0.5 * seconds / ts) * ts, gripped))

    go(PICK)
    dwell_with_event(0.6, True)
    go(PICK_APPROACH)
    go(PLACE_APPROACH)
    go(PLACE)
    dwell_with_event(0.6, False)
    go(PLACE_APPROACH)
    go(PICK_APPROACH)
    parts.append(_dwell(PICK_APPROACH, 0.5, ts))
    q = np.concatenate(parts, axis=0)
    return Trajectory("pick_and_place", ts, q, tuple(events), False, float(payload_kg))


def hold(q_rad=PICK_APPROACH, seconds: float = 1.0, payload_kg: float = 0.0) -> Trajectory:
    """Stand still at ``q_rad`` (useful for noise and drift checks)."""
    q = _dwell(q_rad, seconds, CB3_SETPOINT_PERIOD_S)
    return Trajectory("hold", CB3_SETPOINT_PERIOD_S, np.vstack([q, q[-1:]]), (), payload_kg > 0, payload_kg)


def joint_sweep(speed_scale: float = 1.0, payload_kg: float = 1.0) -> Trajectory:
    """Every joint out and back twice, holding a payload throughout; about 10 s.

    The outward pose leans the arm over the top, so the shoulder and elbow gravity torques
    change sign (-41 -> +20 N*m and -19 -> +2 N*m with 1 kg); every joint reverses its velocity.
    Used to test the discrepancy workflow on a motion it was not developed on.
    """
    v, a, ts = UR_DEFAULT_SPEED_RAD_S * speed_scale, UR_DEFAULT_ACCEL_RAD_S2 * speed_scale, CB3_SETPOINT_PERIOD_S
    home = np.asarray(PICK_APPROACH)
    out_ = np.array([0.5, -2.0, 0.2, -1.5, -1.2, 0.9])
    back = home + np.array([-0.35, -0.25, 0.3, -0.4, -0.5, -0.6])
    parts = [_dwell(home, 0.4, ts)]
    for target in (out_, back, out_, home):
        parts.append(movej(parts[-1][-1], target, v, a, ts))
    parts.append(_dwell(home, 0.4, ts))
    return Trajectory("joint_sweep", ts, np.concatenate(parts), (), payload_kg > 0, float(payload_kg))


TRAJECTORIES: dict[str, Callable[..., Trajectory]] = {"pick_and_place": pick_and_place, "hold": hold,
                                                      "joint_sweep": joint_sweep}


def get_trajectory(name: str, **kwargs) -> Trajectory:
    """Build a named trajectory; an unknown name lists the valid ones."""
    if name not in TRAJECTORIES:
        raise UnknownNameError("trajectory", name, TRAJECTORIES)
    return TRAJECTORIES[name](**kwargs)
