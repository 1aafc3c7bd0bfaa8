"""Hidden-effect logs made from REAL robot logs: an effect of a size a maintenance engineer cares about is
injected into the measured signals, so the workflow must find it beside the model's own error on that robot.

How each effect enters a measured log (written here, independently of the workflow's code):

* ``current_sensor_offset``: ``offset_A`` added to the joint's logged current.
* ``current_sensor_gain``: the joint's logged current multiplied by ``gain`` (the sensor reads ``gain`` x the
  true current; the true current is the logged one).
* ``coulomb_friction``: the joint torque the packaged friction law (eq. (2), Coulomb and breakaway level, the
  registry's ``coulomb_friction`` scales both) adds at ``scale`` at the *measured* joint speed, converted to
  motor current by ``K_t N`` and added to the logged current.  Quasi-static: the speed loop supplies a
  slowly varying extra load torque in full; the measured motion is taken as unchanged (the position loop
  holds the path; on the NIST log the tracking error is ~1e-4 rad).
* ``local_friction``: a friction rise ``amplitude_A`` over an angle window of the joint (raised-cosine in
  angle, ``width_deg`` wide at its base, centred at ``centre_deg``), odd in the measured speed (a worn region
  of the gear), added to the logged current.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ur5fault.logs import MeasuredLog
from ur5fault.sim.drive.friction import steady_friction
from ur5fault.sim.params import load_params

#: width of the smooth sign applied to the measured speed [rad/s] (the packaged law's own smoothing order)
SIGN_WIDTH_RAD_S = 0.01
#: samples of the centred moving average on the measured speed (encoder quantisation)
SPEED_SMOOTHING = 5


def measured_speed(log: MeasuredLog) -> np.ndarray:
    qd = np.gradient(log.q_actual_rad, log.t_s, axis=0)
    k = SPEED_SMOOTHING
    pad = np.pad(qd, ((k // 2, k // 2), (0, 0)), mode="edge")
    return np.stack([np.convolve(pad[:, j], np.ones(k) / k, mode="valid") for j in range(qd.shape[1])], axis=1)


def _motor_A_per_Nm(j: int) -> float:
    p = load_params()
    return 1.0 / (p.motor.torque_constant_Nm_per_A[j] * p.gear.ratio[j])


def inject(log: MeasuredLog, kind: str, joint: int, **v: float) -> MeasuredLog:
    """``log`` with one effect injected into its measured current of ``joint`` (0-based)."""
    cur = log.current_A.copy()
    if kind == "current_sensor_offset":
        cur[:, joint] += v["offset_A"]
    elif kind == "current_sensor_gain":
        cur[:, joint] *= v["gain"]
    elif kind == "coulomb_friction":
        p = load_params().friction
        w = measured_speed(log)[:, joint]
        level = steady_friction(w, p.coulomb_Nm[joint], p.static_Nm[joint], 0.0, p.stribeck_rate_s_per_rad)
        # steady_friction has an exact sign; the smooth sign keeps the injected torque continuous at rest
        dT = (v["scale"] - 1.0) * np.abs(level) * np.tanh(w / SIGN_WIDTH_RAD_S)
        cur[:, joint] += dT * _motor_A_per_Nm(joint)
    elif kind == "local_friction":
        w = measured_speed(log)[:, joint]
        x = (np.rad2deg(log.q_actual_rad[:, joint]) - v["centre_deg"]) / v["width_deg"]
        window = np.where(np.abs(x) < 0.5, 0.5 * (1.0 + np.cos(2.0 * np.pi * x)), 0.0)
        cur[:, joint] += v["amplitude_A"] * window * np.tanh(w / SIGN_WIDTH_RAD_S)
    else:
        raise ValueError(kind)
    return dataclasses.replace(log, current_A=cur, source=f"{log.source} + {kind} on joint {joint + 1}")


#: speed above which a joint counts as moving for placing a local effect [rad/s] (assumption: well above the
#: friction law's smoothing, so the injected friction is at its full level there)
MOVING_RAD_S = 0.05


def busy_angle_deg(log: MeasuredLog, joint: int, from_share: float = 0.6) -> float:
    """The median angle [deg] of ``joint`` while it moves in the log's last ``1 - from_share`` (the held-out
    part): where a worn region of the gear shows both in the fitted and the held-out part."""
    k = int(from_share * log.t_s.size)
    w = measured_speed(log)[k:, joint]
    deg = np.rad2deg(log.q_actual_rad[k:, joint])
    return float(np.median(deg[np.abs(w) > MOVING_RAD_S]))
