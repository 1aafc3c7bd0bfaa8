"""The fixed trajectories: the paper's 2 kg pick-and-place (the default), a standstill and a joint
sweep used to test the discrepancy workflow."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from ...util.checks import is_real, short
from .base import (
    CB3_SETPOINT_PERIOD_S,
    MAX_SPEED_SCALE,
    MIN_SPEED_SCALE,
    UR_DEFAULT_ACCEL_RAD_S2,
    UR_DEFAULT_SPEED_RAD_S,
    UR_MAX_SPEED_RAD_S,
    Trajectory,
    check_option,
    check_pose,
    dwell,
    movej,
    records_options,
)

# Pick-and-place waypoints [rad], tool pointing down (z axis of the TCP = -z of the base within 1e-3).
# Found by numerical IK on ur5fault/models/ur5.xml with TCP offset 0.15 m: the TCP drops 0.12 m from each
# approach pose; the transfer takes the arm over the top, so the shoulder and elbow gravity torques
# change sign (checked by tests/sim/test_trajectory.py).
PICK_APPROACH = (-0.4, -1.0, 1.6, -2.17, -1.5708, 0.0)
PICK = (-0.4, -0.8132, 1.6555, -2.4131, -1.5708, 0.0)
PLACE_APPROACH = (0.5, -2.2043, -1.4889, -1.0192, 1.5708, 0.9)
PLACE = (0.5, -2.3794, -1.5444, -0.7885, 1.5708, 0.9)


#: the largest speed scale as messages show it: rounded down to 4 digits (3.000566 shown as 3.001 was itself refused)
_MAX_SHOWN = f"{math.floor(MAX_SPEED_SCALE * 1e3) / 1e3:g}"


def check_speed_scale(speed_scale: float, where: str = "speed_scale") -> float:
    """A fixed motion's speed and acceleration factor: up to the UR5's maximum joint speed (3.0006 x the default).
    One message for the API and a YAML file's trajectory (``where``: ``trajectory.speed_scale``)."""
    if not is_real(speed_scale):
        raise ParameterError(f"{where} = {short(speed_scale)} must be a number in [{MIN_SPEED_SCALE:g}, "
                             f"{_MAX_SHOWN}]")
    if not MIN_SPEED_SCALE <= speed_scale <= MAX_SPEED_SCALE:
        raise ParameterError(f"{where} = {speed_scale} is out of range [{MIN_SPEED_SCALE:g}, "
                             f"{_MAX_SHOWN}] (the UR5's maximum joint speed, {UR_MAX_SPEED_RAD_S:.4g} rad/s, "
                             f"over the controller default {UR_DEFAULT_SPEED_RAD_S:g} rad/s)")
    return float(speed_scale)


@records_options
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
    speed_scale = check_speed_scale(speed_scale)
    payload_kg = check_option("pick_and_place", "payload_kg", payload_kg)
    setpoint_period_s = check_option("pick_and_place", "setpoint_period_s", setpoint_period_s)
    v, a, ts = UR_DEFAULT_SPEED_RAD_S * speed_scale, UR_DEFAULT_ACCEL_RAD_S2 * speed_scale, setpoint_period_s
    parts: list[NDArray] = [dwell(PICK_APPROACH, 0.5, ts)]
    events: list[tuple[float, bool]] = []

    def go(q_to):
        parts.append(movej(parts[-1][-1], q_to, v, a, ts))

    def dwell_with_event(seconds, gripped):
        start = sum(len(p) for p in parts) - 1
        parts.append(dwell(parts[-1][-1], seconds, ts))
        events.append(((start + 0.5 * seconds / ts) * ts, gripped))

    go(PICK)
    dwell_with_event(0.6, True)
    go(PICK_APPROACH)
    go(PLACE_APPROACH)
    go(PLACE)
    dwell_with_event(0.6, False)
    go(PLACE_APPROACH)
    go(PICK_APPROACH)
    parts.append(dwell(PICK_APPROACH, 0.5, ts))
    q = np.concatenate(parts, axis=0)
    return Trajectory("pick_and_place", ts, q, tuple(events), False, float(payload_kg))


@records_options
def hold(q_rad=PICK_APPROACH, seconds: float = 1.0, payload_kg: float = 0.0) -> Trajectory:
    """Stand still at ``q_rad`` (six joint angles [rad]) for ``seconds`` (useful for noise and drift checks),
    the gripper closed throughout: it carries whatever payload the run sets (none at the default 0 kg)."""
    q_rad = check_pose(q_rad, "hold: q_rad")
    seconds = check_option("hold", "seconds", seconds)
    payload_kg = check_option("hold", "payload_kg", payload_kg)
    q = dwell(q_rad, seconds, CB3_SETPOINT_PERIOD_S)
    return Trajectory("hold", CB3_SETPOINT_PERIOD_S, np.vstack([q, q[-1:]]), (), True, payload_kg)


@records_options
def joint_sweep(speed_scale: float = 1.0, payload_kg: float = 1.0) -> Trajectory:
    """Every joint out and back twice, the gripper closed throughout (it carries whatever payload the run sets,
    1 kg unless given); about 10 s.

    The outward pose leans the arm over the top, so the shoulder and elbow gravity torques
    change sign (-41 -> +20 N*m and -19 -> +2 N*m with 1 kg); every joint reverses its velocity.
    Used to test the discrepancy workflow on a motion it was not developed on.
    """
    speed_scale = check_speed_scale(speed_scale)
    payload_kg = check_option("joint_sweep", "payload_kg", payload_kg)
    v, a, ts = UR_DEFAULT_SPEED_RAD_S * speed_scale, UR_DEFAULT_ACCEL_RAD_S2 * speed_scale, CB3_SETPOINT_PERIOD_S
    home = np.asarray(PICK_APPROACH)
    out_ = np.array([0.5, -2.0, 0.2, -1.5, -1.2, 0.9])
    back = home + np.array([-0.35, -0.25, 0.3, -0.4, -0.5, -0.6])
    parts = [dwell(home, 0.4, ts)]
    for target in (out_, back, out_, home):
        parts.append(movej(parts[-1][-1], target, v, a, ts))
    parts.append(dwell(home, 0.4, ts))
    return Trajectory("joint_sweep", ts, np.concatenate(parts), (), True, float(payload_kg))
