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
import functools
import inspect
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from ...util.checks import check_bool, check_number, short
from ..axes import N_JOINTS
from ..budget import MAX_DURATION_S
from ..effects import REGISTRY

CB3_SETPOINT_PERIOD_S = 0.008  # 125 Hz (ur5-facts.md)
UR_DEFAULT_SPEED_RAD_S = 1.047  # controller default joint speed (ur5-facts.md)
UR_DEFAULT_ACCEL_RAD_S2 = 1.396  # controller default joint acceleration (ur5-facts.md)
UR_MAX_SPEED_RAD_S = np.pi  # the UR5's maximum joint speed, 180 deg/s (ur5-facts.md)
#: the fastest a fixed motion may be scaled: the UR5's maximum joint speed over the controller default, 3.0
MAX_SPEED_SCALE = UR_MAX_SPEED_RAD_S / UR_DEFAULT_SPEED_RAD_S
MIN_SPEED_SCALE = 0.05
_PAYLOAD = REGISTRY["payload"].param("mass_kg")  # the payload's one range
#: the numeric options of the trajectory functions, ``(lo, hi, unit)``: each function checks its own against them at
#: its edge, and a YAML file's trajectory options are checked against them before it is built.  The payload
#: effect's range; speed up to UR's maximum joint speed (pi rad/s, ur5-facts.md) over the controller default
#: 1.047 rad/s; dwell times up to the run-length limit; setpoint periods from the 0.1 ms servo period to 10 Hz
OPTION_RANGES = {
    "payload_kg": (_PAYLOAD.lo, _PAYLOAD.hi, "kg"),
    "speed_scale": (MIN_SPEED_SCALE, MAX_SPEED_SCALE, "-"),
    "seconds": (0.01, MAX_DURATION_S, "s"),
    "setpoint_period_s": (1e-4, 0.1, "s"),
}


def check_option(fn: str, key: str, value: Any) -> float:
    """``value`` of the trajectory function ``fn``'s option ``key``, checked against :data:`OPTION_RANGES`."""
    lo, hi, unit = OPTION_RANGES[key]
    return check_number(value, f"{fn}: {key}", lo, hi, unit)


def check_pose(q: Any, where: str) -> NDArray[np.float64]:
    """Six finite joint angles [rad] (a list, tuple or array of shape ``(6,)``)."""
    try:
        arr = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (N_JOINTS,):
        raise ParameterError(f"{where} = {short(q)} must be {N_JOINTS} joint angles [rad], shape ({N_JOINTS},)")
    if not np.all(np.isfinite(arr)):
        raise ParameterError(f"{where} = {short(q)} must be finite (no NaN or inf)")
    return arr


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
        options: the options the motion was built with, defaults filled in (``(name, value)`` pairs of plain
            Python values; :func:`records_options`, random_pick_and_place its own), written to outputs with the
            name; empty when built directly.

    The schedule (events, held at start) says *when* the gripper holds the payload and never depends on its
    mass: a run's payload effect replaces the mass only, so a schedule that held nothing at 0 kg would drop
    the mass a run asks for.
    """

    name: str
    setpoint_period_s: float
    q_set_rad: NDArray[np.float64]
    payload_events: tuple[tuple[float, bool], ...] = ()
    payload_gripped_at_start: bool = False
    default_payload_kg: float = 0.0
    options: tuple[tuple[str, Any], ...] = ()

    def __post_init__(self) -> None:
        name = self.name
        if not isinstance(name, str) or not name.strip():
            raise ParameterError(f"Trajectory: name = {short(name)} must be a non-empty string (written to outputs)")
        where = f"trajectory {name!r}"
        try:
            q = np.asarray(self.q_set_rad, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError(f"{where}: q_set_rad = {short(self.q_set_rad)} must be an array of joint angles "
                                 "[rad], shape (n >= 2, 6)") from None
        if q.ndim != 2 or q.shape[1] != N_JOINTS or q.shape[0] < 2:
            raise ParameterError(f"{where}: q_set_rad must have shape (n >= 2, 6), got {q.shape}")
        if not np.all(np.isfinite(q)):
            raise ParameterError(f"{where}: q_set_rad contains NaN or inf")
        period = check_number(self.setpoint_period_s, f"{where}: setpoint_period_s", 0.0, math.inf, "s",
                              lo_open=True)
        q.setflags(write=False)
        object.__setattr__(self, "q_set_rad", q)
        object.__setattr__(self, "setpoint_period_s", period)
        object.__setattr__(self, "payload_events", _checked_events(self.payload_events, where))
        object.__setattr__(self, "payload_gripped_at_start",
                           check_bool(self.payload_gripped_at_start, f"{where}: payload_gripped_at_start"))
        object.__setattr__(self, "default_payload_kg",
                           check_number(self.default_payload_kg, f"{where}: default_payload_kg", 0.0, math.inf, "kg"))

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


def records_options(fn: Callable[..., Trajectory]) -> Callable[..., Trajectory]:
    """Decorate a trajectory function so that the motion it returns records the options it was built with, the
    defaults filled in (a run's metadata names the motion that ran, not only its name)."""
    signature = inspect.signature(fn)

    @functools.wraps(fn)
    def build(*args: Any, **kwargs: Any) -> Trajectory:
        traj = fn(*args, **kwargs)
        bound = signature.bind(*args, **kwargs)
        bound.apply_defaults()
        options = tuple((k, v if isinstance(v, str) else np.asarray(v).tolist()) for k, v in bound.arguments.items())
        return dataclasses.replace(traj, options=options)

    return build


def _checked_events(events: Any, where: str) -> tuple[tuple[float, bool], ...]:
    """Payload events as ``((time_s, gripped), ...)``: finite times >= 0 in increasing order, each with a bool."""
    if isinstance(events, (str, bytes)) or not hasattr(events, "__iter__"):
        raise ParameterError(f"{where}: payload_events = {short(events)} must be a sequence of (time_s, gripped) "
                             "pairs")
    out: list[tuple[float, bool]] = []
    for k, ev in enumerate(events):
        at = f"{where}: payload_events[{k}]"
        if isinstance(ev, (str, bytes)) or not hasattr(ev, "__len__") or len(ev) != 2:
            raise ParameterError(f"{at} = {short(ev)} must be a (time_s, gripped) pair")
        t = check_number(ev[0], f"{at} time", 0.0, math.inf, "s")
        if out and t <= out[-1][0]:
            raise ParameterError(f"{at} time = {t:g} s must come after the event before it ({out[-1][0]:g} s): "
                                 "events in increasing time")
        out.append((t, check_bool(ev[1], f"{at} gripped")))
    return tuple(out)


def movej(q0: NDArray, q1: NDArray, v_max: float, a_max: float, period_s: float) -> NDArray[np.float64]:
    """UR-style joint move: a trapezoidal speed profile shared by all joints (they start and
    stop together), limited by the joint with the largest displacement.

    Args:
        q0, q1: start and end joint angles, six finite values each [rad].
        v_max: joint speed, finite and > 0 [rad/s].
        a_max: joint acceleration, finite and > 0 [rad/s^2].
        period_s: setpoint period, finite and > 0 [s].

    Returns setpoints from ``q0`` (excluded) to ``q1`` (included), ``(n, 6)`` [rad].
    """
    q0, q1 = check_pose(q0, "movej: q0"), check_pose(q1, "movej: q1")
    v_max = check_number(v_max, "movej: v_max", 0.0, math.inf, "rad/s", lo_open=True)
    a_max = check_number(a_max, "movej: a_max", 0.0, math.inf, "rad/s^2", lo_open=True)
    period_s = check_number(period_s, "movej: period_s", 0.0, math.inf, "s", lo_open=True)
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
    """Hold ``q`` (six finite joint angles) for ``seconds`` (finite, >= 0; at least one setpoint), ``(n, 6)``
    [rad]."""
    q = check_pose(q, "dwell: q")
    seconds = check_number(seconds, "dwell: seconds", 0.0, MAX_DURATION_S, "s")
    period_s = check_number(period_s, "dwell: period_s", 0.0, math.inf, "s", lo_open=True)
    return np.repeat(q[None, :], max(1, round(seconds / period_s)), axis=0)
