"""A seeded family of random pick-and-place motions: varied work for diagnostics datasets.

``random_pick_and_place(seed)`` draws, from ``numpy.random.default_rng(seed)`` only:

* a pick and a place position of the TCP inside the UR5's reachable workspace
  (:data:`REACH_RADIUS_M` from the base axis, :data:`HEIGHT_M` in height, the place
  :data:`TRANSFER_ANGLE_RAD` round the base from the pick, either way), each with a tool yaw
  (:data:`YAW_RAD` about the radial direction) and the gripper pointing straight down - or, with
  ``tool_tilt_deg`` > 0, tilted from straight down about the tool's own x and y axes by up to that
  angle each, at the pick, the via point and the place (parts on inclined fixtures; drawn from a second stream,
  ``default_rng([seed, 1])``, so the rest of the motion is the untilted seed's unless a tilted pose is
  rejected).  Straight down keeps wrist 2 at -90 deg through the whole motion: a fault that shows only
  when a joint turns or carries torque cannot show there;
* an approach pose above each (:data:`APPROACH_HEIGHT_M`) and a via point above the middle
  of the transfer (:data:`VIA_LIFT_M` above the higher approach);
* a joint speed and acceleration (:data:`SPEED_RAD_S`, :data:`ACCEL_RAD_S2`, within the UR5's
  limits) and the grip and release dwell times (:data:`GRIP_DWELL_S`).

Every pose is solved by inverse kinematics on the packaged MJCF (:mod:`.ik`) on one arm branch
(shoulder left, elbow up, wrist down, seeded from the paper trajectory's pick posture); a draw
that is unreachable or near a singular posture is rejected and redrawn from the same stream,
so a seed always gives the same motion.  The motion: from rest at the pick approach, down, grip
(payload attached mid-dwell), up, via point, place approach, down, release, up, rest.  UR-style
``movej`` segments (trapezoidal speed profile, all joints start and stop together) join the poses.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from numpy.typing import NDArray

from ...errors import ParameterError
from ...util.checks import is_integer, is_real
from ...util.portable import matmul
from ..effects import REGISTRY
from .base import CB3_SETPOINT_PERIOD_S, Trajectory, dwell, movej
from .ik import TcpKinematics, down_rotation

#: horizontal distance of the TCP from the base axis [m]; UR5 reach is 0.85 m to the wrist centre
#: (ur5-facts.md DH: |a2| + |a3| = 0.817 m plus the wrist), the inner bound keeps the wrist clear of
#: the shoulder singularity over the base axis (assumption)
REACH_RADIUS_M = (0.35, 0.75)
#: TCP height of the pick and place positions in the base frame [m] (the paper trajectory picks at -0.13 m)
HEIGHT_M = (-0.25, 0.15)
#: azimuth from the pick to the place position, either way round [rad]
TRANSFER_ANGLE_RAD = (math.pi / 6, math.pi / 2)
#: tool yaw about the vertical, relative to the radial direction [rad]
YAW_RAD = (-math.pi / 3, math.pi / 3)
#: approach pose height above pick and place [m]
APPROACH_HEIGHT_M = (0.04, 0.12)
#: via point height above the higher approach pose [m]
VIA_LIFT_M = (0.0, 0.15)
#: joint speed of the moves [rad/s]: UR5 limit pi rad/s (ur5-facts.md); controller default 1.047
SPEED_RAD_S = (0.6, 1.4)
#: joint acceleration of the moves [rad/s^2]: controller default 1.396 (ur5-facts.md); the upper bound is an
#: assumption that keeps the drives well inside their current limits (seeds 0-7 with 3 kg and an 8.5 cm CoM
#: offset peak at 60 % of the limit on the shoulder, 35 % on the wrists)
ACCEL_RAD_S2 = (0.8, 2.5)
#: gripper close / open dwell [s]; the payload is attached (released) mid-dwell
GRIP_DWELL_S = (0.25, 0.5)
REST_S = 0.15  # at rest before the first and after the last move [s]
MIN_ELBOW_SIN = 0.25  # |sin q3| below this is too close to the stretched-arm singularity
MAX_DRAWS = 200
#: seed posture of the IK (the paper trajectory's pick approach; shoulder left, elbow up, wrist down)
SEED_POSTURE = np.array([-0.4, -1.0, 1.6, -2.17, -math.pi / 2, 0.0])
SEED_AZIMUTH_RAD = 2.908  # azimuth of the TCP at SEED_POSTURE
#: largest ``tool_tilt_deg`` accepted [deg] (an assumption: a tilted part, not a side approach; at 30 deg every seed
#: 0-39 builds on the wrist-down branch, wrist 2 spanning 8-59 deg)
MAX_TOOL_TILT_DEG = 30.0
WRIST2_BRANCH_RAD = 0.3  # |q5 + pi/2| allowed with the tool straight down (IK round-off and yaw)


def random_pick_and_place(seed: int = 0, payload_kg: float = 1.0, tool_tilt_deg: float = 0.0) -> Trajectory:
    """The motion of seed ``seed`` (see the module docstring); about 5-8 s long.

    Args:
        seed: non-negative integer selecting the motion.
        payload_kg: mass gripped when a run does not set one [kg].
        tool_tilt_deg: largest tilt of the tool from straight down about each of its x and y axes [deg]
            (0: straight down, the family as it always was; at most :data:`MAX_TOOL_TILT_DEG`).
    """
    if not is_integer(seed) or seed < 0:
        raise ParameterError(f"random_pick_and_place: seed = {seed!r} must be a non-negative integer")
    mass = REGISTRY["payload"].param("mass_kg")  # the payload's one range
    if not is_real(payload_kg) or not mass.lo <= payload_kg <= mass.hi:
        raise ParameterError(f"random_pick_and_place: payload_kg = {payload_kg!r} is out of range [{mass.lo:g}, "
                             f"{mass.hi:g}] kg")
    if not is_real(tool_tilt_deg) or not 0 <= tool_tilt_deg <= MAX_TOOL_TILT_DEG:
        raise ParameterError(f"random_pick_and_place: tool_tilt_deg = {tool_tilt_deg!r} is out of range "
                             f"[0, {MAX_TOOL_TILT_DEG:g}] deg")
    return _build(int(seed), float(payload_kg), float(tool_tilt_deg))


@functools.lru_cache(maxsize=256)
def _build(seed: int, payload_kg: float, tool_tilt_deg: float) -> Trajectory:
    rng = np.random.default_rng(seed)
    tilt_rng = np.random.default_rng([seed, 1]) if tool_tilt_deg > 0 else None
    kin = TcpKinematics.load()
    for _ in range(MAX_DRAWS):
        poses = _draw_poses(rng, kin, tilt_rng, math.radians(tool_tilt_deg))
        if poses is not None:
            break
    else:  # pragma: no cover - the acceptance rate is far above 1 / MAX_DRAWS
        raise ParameterError(f"random_pick_and_place: seed = {seed} found no reachable poses")
    v, a = rng.uniform(*SPEED_RAD_S), rng.uniform(*ACCEL_RAD_S2)
    grip_s, release_s = rng.uniform(*GRIP_DWELL_S), rng.uniform(*GRIP_DWELL_S)
    pick_app, pick, via, place_app, place = poses
    ts = CB3_SETPOINT_PERIOD_S
    parts: list[NDArray] = [dwell(pick_app, REST_S, ts)]
    events: list[tuple[float, bool]] = []

    def go(q_to: NDArray) -> None:
        parts.append(movej(parts[-1][-1], q_to, v, a, ts))

    def hold(seconds: float, gripped: bool) -> None:
        start = sum(len(p) for p in parts) - 1
        parts.append(dwell(parts[-1][-1], seconds, ts))
        events.append(((start + 0.5 * seconds / ts) * ts, gripped))

    go(pick)
    hold(grip_s, True)
    go(pick_app)
    go(via)
    go(place_app)
    go(place)
    hold(release_s, False)
    go(place_app)
    parts.append(dwell(place_app, REST_S, ts))
    options = (("seed", seed), ("payload_kg", payload_kg), ("tool_tilt_deg", tool_tilt_deg))  # one cached build
    return Trajectory("random_pick_and_place", ts, np.concatenate(parts), tuple(events), False, payload_kg, options)


def _draw_poses(rng: np.random.Generator, kin: TcpKinematics, tilt_rng: np.random.Generator | None,
                tilt_rad: float) -> tuple[NDArray, ...] | None:
    """Pick approach, pick, via, place approach, place joint angles; ``None`` if a pose is rejected."""
    phi_pick = rng.uniform(-math.pi, math.pi)
    phi_place = phi_pick + rng.choice([-1.0, 1.0]) * rng.uniform(*TRANSFER_ANGLE_RAD)
    r_pick, r_place = rng.uniform(*REACH_RADIUS_M, size=2)
    z_pick, z_place = rng.uniform(*HEIGHT_M, size=2)
    yaw_pick, yaw_place = rng.uniform(*YAW_RAD, size=2)
    h_pick, h_place = rng.uniform(*APPROACH_HEIGHT_M, size=2)
    lift = rng.uniform(*VIA_LIFT_M)

    def at(phi: float, r: float, z: float) -> NDArray:
        return np.array([r * math.cos(phi), r * math.sin(phi), z])

    z_via = max(z_pick + h_pick, z_place + h_place) + lift
    phi_via, r_via = 0.5 * (phi_pick + phi_place), 0.5 * (r_pick + r_place)
    tilt_pick, tilt_via, tilt_place = (tilt_rng.uniform(-tilt_rad, tilt_rad, size=(3, 2)) if tilt_rng is not None
                                       else np.zeros((3, 2)))
    targets = [
        (at(phi_pick, r_pick, z_pick + h_pick), phi_pick + yaw_pick, tilt_pick),
        (at(phi_pick, r_pick, z_pick), phi_pick + yaw_pick, tilt_pick),
        (at(phi_via, r_via, z_via), phi_via + 0.5 * (yaw_pick + yaw_place), tilt_via),
        (at(phi_place, r_place, z_place + h_place), phi_place + yaw_place, tilt_place),
        (at(phi_place, r_place, z_place), phi_place + yaw_place, tilt_place),
    ]
    seed_q = SEED_POSTURE.copy()
    out = []
    for pos, yaw, tilt in targets:
        seed_q = seed_q.copy()
        seed_q[0] += _wrap(math.atan2(pos[1], pos[0]) - (seed_q[0] - SEED_POSTURE[0] + SEED_AZIMUTH_RAD))
        q = kin.ik(pos, tilted(down_rotation(yaw), tilt), seed_q)
        if q is None or not _on_branch(q, tilt_rad):
            return None
        out.append(q)
        seed_q = q
    return tuple(out)


def _wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


def tilted(rot: NDArray, tilt_xy_rad: NDArray) -> NDArray:
    """Tool frame ``rot`` (columns x, y, z in the base frame) turned about its own x axis by ``tilt_xy_rad[0]``,
    then about its own y axis by ``tilt_xy_rad[1]`` [rad]."""
    a, b = float(tilt_xy_rad[0]), float(tilt_xy_rad[1])
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, ca, -sa], [0.0, sa, ca]])
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    return matmul(matmul(rot, rx), ry)  # not rot @ rx @ ry: util/portable.py


def _on_branch(q: NDArray, tilt_rad: float) -> bool:
    """Elbow up and bent (away from the stretched singularity), wrist down (within the tilt drawn), within UR
    joint ranges."""
    return (MIN_ELBOW_SIN < math.sin(q[2]) and q[2] > 0
            and abs(q[4] + math.pi / 2) < WRIST2_BRANCH_RAD + math.sqrt(2.0) * tilt_rad
            and np.all(np.abs(q) < 2 * math.pi) and abs(q[2]) < math.pi)
