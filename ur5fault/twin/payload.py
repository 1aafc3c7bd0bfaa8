"""The motor currents a payload adds to a log's motion, as columns linear in its unknowns.

A payload held at the flange is a point mass ``m`` at ``c`` in the flange frame (plus the solid cube's
inertia the simulator gives every payload, :func:`ur5fault.sim.multibody.payload_inertia`). The joint torque
it adds, gravity and inertia of the logged motion, is linear in ``(m, m*cx, m*cy, m*cz)`` up to the term
``m c c^T`` (the point mass's inertia about the flange: at ``|c| = 0.1 m`` and 1 kg, 0.01 kg*m^2, a tenth of
the wrists' own link inertia; taken at the linearisation point, not fitted). The columns are MuJoCo's inverse
dynamics of the simulator's own model (``ur5fault/models/ur5.xml``) with the payload body set as the simulator
sets it, at the log's *target* motion (speeds and accelerations by central differences, as
:mod:`ur5fault.identify.signals` takes them), divided by each joint's torque constant and gear ratio to give
motor current: the current loop delivers the torque the motion needs.

``com_m`` given: only the mass is unknown, at that centre of mass (one column); ``None``: mass and centre of
mass unknown (four columns, linearised at the flange).
"""

from __future__ import annotations

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..sim.inverse_dynamics import inverse_dynamics_Nm, place_payload
from ..sim.params import RobotParams

#: names of the payload's linear unknowns, in column order (mass, then its first moments)
UNKNOWNS = ("mass_kg", "mass_x_kg_m", "mass_y_kg_m", "mass_z_kg_m")
#: half-step of the central difference that takes a first moment's column [m] (the columns are linear in the
#: first moment, so the step only sets rounding: 5 cm, about a gripper's reach)
MOMENT_STEP_M = 0.05


def _inverse(m: mujoco.MjModel, mass_kg: float, pos_m: NDArray, q: NDArray, qd: NDArray, qdd: NDArray) -> NDArray:
    """Joint torques ``(n, 6)`` of the motion with a payload of ``mass_kg`` at ``pos_m`` (flange frame)."""
    place_payload(m, mass_kg, pos_m)
    return inverse_dynamics_Nm(m, q, qd, qdd)


def payload_current_columns(params: RobotParams, q_target_rad: NDArray, period_s: float,
                            com_m: tuple[float, float, float] | None = None) -> NDArray:
    """Motor current per unit of each payload unknown, ``(k, n, 6)`` [A per kg, A per kg*m].

    Args:
        params: the model (torque constants, gear ratios).
        q_target_rad: the log's target positions ``(n, 6)`` (one log: differentiated as one motion).
        period_s: its sample period.
        com_m: the payload's centre of mass when known (``k = 1``: the mass only), else ``None`` (``k = 4``:
            mass and first moments, :data:`UNKNOWNS`).
    """
    from ..sim.engine import Simulator

    q = np.asarray(q_target_rad, dtype=float)
    qd = np.gradient(q, period_s, axis=0)
    qdd = np.gradient(qd, period_s, axis=0)
    m = Simulator(params).model
    c0 = np.zeros(3) if com_m is None else np.asarray(com_m, dtype=float)
    empty = _inverse(m, 0.0, c0, q, qd, qdd)
    cols = [_inverse(m, 1.0, c0, q, qd, qdd) - empty]
    if com_m is None:
        for axis in range(3):
            step = np.zeros(3)
            step[axis] = MOMENT_STEP_M
            up = _inverse(m, 1.0, c0 + step, q, qd, qdd)
            down = _inverse(m, 1.0, c0 - step, q, qd, qdd)
            cols.append((up - down) / (2.0 * MOMENT_STEP_M))
    per_amp = np.asarray(params.motor.torque_constant_Nm_per_A, float) * np.asarray(params.gear.ratio, float)
    return np.array(cols) / per_amp
