"""Inverse dynamics of a log's motion with the simulator's own MuJoCo model.

The joint torque the drives must deliver for the logged motion (gravity, Coriolis and
inertia of the links and of the log's payload) is what a friction or torque-constant
regression must remove first: on the shoulder and elbow gravity is ten times the friction.
The model is the one the simulator steps (``ur5fault/models/ur5.xml``), with the payload
body set up exactly as :mod:`ur5fault.sim.multibody` does (mass at the TCP, a solid cube's
inertia), so an identified parameter means the same thing in a simulation.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from .multibody import payload_inertia


def payload_model(model_path: str | Path, payload_kg: float, tcp_offset_m) -> mujoco.MjModel:
    """The MJCF with the tool offset and a payload of ``payload_kg`` at the TCP."""
    m = mujoco.MjModel.from_xml_path(str(model_path))
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
    m.site_pos[site] = tcp_offset_m
    place_payload(m, payload_kg, tcp_offset_m)
    return m


def place_payload(m: mujoco.MjModel, mass_kg: float, pos_m) -> None:
    """Set ``m``'s payload body as the simulator does: ``mass_kg`` at ``pos_m`` in the flange frame, a solid
    cube's inertia (:func:`ur5fault.sim.multibody.payload_inertia`)."""
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "payload")
    m.body_sameframe[body] = 0
    m.body_pos[body] = pos_m
    m.body_ipos[body] = 0.0
    m.body_mass[body] = mass_kg
    m.body_inertia[body] = payload_inertia(np.asarray(mass_kg))


def inverse_dynamics_Nm(model: mujoco.MjModel, q_rad: NDArray, qd_rad_s: NDArray, qdd_rad_s2: NDArray) -> NDArray:
    """Joint torques ``(n, 6)`` [N*m] that produce the motion, by ``mujoco.mj_inverse`` per sample."""
    d = mujoco.MjData(model)
    out = np.empty_like(q_rad)
    for k in range(q_rad.shape[0]):
        d.qpos[:] = q_rad[k]
        d.qvel[:] = qd_rad_s[k]
        d.qacc[:] = qdd_rad_s2[k]
        mujoco.mj_inverse(model, d)
        out[k] = d.qfrc_inverse
    return out
