"""Independent numpy reference for the UR5 (CB3): DH forward kinematics and Newton-Euler dynamics.

Written from Universal Robots' published standard (distal) DH table, link masses and centres of
mass, and the thin-cylinder inertia tensors used by public models (see ../shared/ur5-facts.md).
The values are typed in here on purpose: this module must NOT read ur5fault/models/ur5.xml and must NOT
import mujoco, so that agreement with the MuJoCo model is evidence rather than a tautology.

Conventions:
    * Standard DH: T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i); base frame 0 = world frame.
    * Joint i rotates link i about z of DH frame i-1; the joint angle q_i [rad] equals theta_i.
    * Link i's CoM and inertia are given in DH frame i.
    * Gravity acts along -z of the world (base) frame.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

N_JOINTS = 6

#: DH link lengths a_i [m], joints 1..6.
DH_A_M = np.array([0.0, -0.425, -0.39225, 0.0, 0.0, 0.0])
#: DH link offsets d_i [m], joints 1..6.
DH_D_M = np.array([0.089159, 0.0, 0.0, 0.10915, 0.09465, 0.0823])
#: DH link twists alpha_i [rad], joints 1..6.
DH_ALPHA_RAD = np.array([np.pi / 2, 0.0, 0.0, np.pi / 2, -np.pi / 2, 0.0])

#: Link masses [kg], links 1..6.
LINK_MASS_KG = np.array([3.7, 8.393, 2.33, 1.219, 1.219, 0.1879])
#: Link centres of mass [m], each in its own DH frame i, shape (6, 3).
LINK_COM_M = np.array(
    [
        [0.0, -0.02561, 0.00193],
        [0.2125, 0.0, 0.11336],
        [0.15, 0.0, 0.0265],
        [0.0, -0.0018, 0.01634],
        [0.0, 0.0018, 0.01634],
        [0.0, 0.0, -0.001159],
    ]
)
#: Principal moments of inertia about each link's CoM [kg m^2], (Ixx, Iyy, Izz) in the axes of
#: DH frame i, shape (6, 3).
LINK_INERTIA_DIAG_KGM2 = np.array(
    [
        [0.014972, 0.010406, 0.014972],
        [0.015107, 0.133886, 0.133886],
        [0.004095, 0.031217, 0.031217],
        [0.0020139, 0.0020139, 0.0021942],
        [0.0018310, 0.0018310, 0.0021942],
        [8.06e-5, 8.06e-5, 1.321e-4],
    ]
)

#: Standard gravity used by the UR controller [m/s^2].
UR_GRAVITY_MPS2 = 9.82


def _check_q(q: Sequence[float] | np.ndarray, name: str = "q") -> np.ndarray:
    arr = np.asarray(q, dtype=float)
    if arr.shape != (N_JOINTS,):
        raise ValueError(f"{name} must have shape (6,), got {arr.shape}")
    return arr


def dh_transform(theta_rad: float, d_m: float, a_m: float, alpha_rad: float) -> np.ndarray:
    """One standard-DH link transform T = Rz(theta) Tz(d) Tx(a) Rx(alpha).

    Args:
        theta_rad: joint angle theta [rad].
        d_m: offset along the previous z axis [m].
        a_m: length along the new x axis [m].
        alpha_rad: twist about the new x axis [rad].

    Returns:
        4x4 homogeneous transform of frame i in frame i-1 (translation in [m]).
    """
    ct, st = np.cos(theta_rad), np.sin(theta_rad)
    ca, sa = np.cos(alpha_rad), np.sin(alpha_rad)
    return np.array(
        [
            [ct, -st * ca, st * sa, a_m * ct],
            [st, ct * ca, -ct * sa, a_m * st],
            [0.0, sa, ca, d_m],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


def dh_frames(q: Sequence[float] | np.ndarray) -> list[np.ndarray]:
    """World poses of DH frames 0..6.

    Args:
        q: joint angles [rad], shape (6,); q_i = DH theta_i.

    Returns:
        List of seven 4x4 transforms [T_0 = I, T_0^1, ..., T_0^6] (translations in [m]).
    """
    q = _check_q(q)
    frames = [np.eye(4)]
    for i in range(N_JOINTS):
        frames.append(frames[-1] @ dh_transform(q[i], DH_D_M[i], DH_A_M[i], DH_ALPHA_RAD[i]))
    return frames


def dh_fk(q: Sequence[float] | np.ndarray) -> np.ndarray:
    """Flange pose T_1 T_2 ... T_6 (DH frame 6 in the base frame).

    Args:
        q: joint angles [rad], shape (6,).

    Returns:
        4x4 homogeneous transform; rotation block dimensionless, translation [m].
    """
    return dh_frames(q)[-1]


def tool_fk(q: Sequence[float] | np.ndarray, tool_offset_m: Sequence[float] | np.ndarray) -> np.ndarray:
    """TCP position in the base frame for a tool offset given in the flange frame.

    Args:
        q: joint angles [rad], shape (6,).
        tool_offset_m: TCP position in the flange (DH frame 6) axes [m], shape (3,).

    Returns:
        TCP position in the base frame [m], shape (3,).
    """
    T = dh_fk(q)
    return T[:3, 3] + T[:3, :3] @ np.asarray(tool_offset_m, dtype=float)


def rnea(
    q: Sequence[float] | np.ndarray,
    qd: Sequence[float] | np.ndarray,
    qdd: Sequence[float] | np.ndarray,
    gravity: float = UR_GRAVITY_MPS2,
    payload_mass_kg: float = 0.0,
    payload_pos_flange_m: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    payload_inertia_flange_kgm2: np.ndarray | None = None,
) -> np.ndarray:
    """Joint torques from recursive Newton-Euler inverse dynamics (no friction, no rotor inertia).

    Written in world (base) coordinates: link i turns about z_{i-1} through o_{i-1}, the origin of
    DH frame i-1. Gravity is introduced as an upward acceleration of the base.

    Args:
        q: joint angles [rad], shape (6,).
        qd: joint velocities [rad/s], shape (6,).
        qdd: joint accelerations [rad/s^2], shape (6,).
        gravity: magnitude of gravity along -z of the base frame [m/s^2].
        payload_mass_kg: extra rigid body fixed to link 6 (the flange) [kg].
        payload_pos_flange_m: payload CoM in the flange frame (DH frame 6) [m], shape (3,).
        payload_inertia_flange_kgm2: payload inertia about its CoM in flange axes [kg m^2],
            shape (3, 3); zero (a point mass) when None.

    Returns:
        Joint torques tau [N m], shape (6,), such that tau = M(q) qdd + C(q, qd) qd + g(q).
    """
    q = _check_q(q, "q")
    qd = _check_q(qd, "qd")
    qdd = _check_q(qdd, "qdd")
    frames = dh_frames(q)
    R = [T[:3, :3] for T in frames]
    o = [T[:3, 3] for T in frames]
    z = [Ri[:, 2] for Ri in R]
    # Indexing below: Python index k is joint/link k+1, which turns about z[k] through o[k]
    # (origin of DH frame k); link k+1 carries DH frame k+1, with origin o[k+1] and axes R[k+1].

    # Rigid bodies attached to each link: (mass [kg], CoM in DH frame i [m], inertia about CoM in frame i).
    bodies: list[list[tuple[float, np.ndarray, np.ndarray]]] = [
        [(LINK_MASS_KG[i], LINK_COM_M[i], np.diag(LINK_INERTIA_DIAG_KGM2[i]))] for i in range(N_JOINTS)
    ]
    if payload_mass_kg != 0.0 or payload_inertia_flange_kgm2 is not None:
        if payload_inertia_flange_kgm2 is None:
            Ip = np.zeros((3, 3))
        else:
            Ip = np.asarray(payload_inertia_flange_kgm2, dtype=float)
        bodies[5].append((float(payload_mass_kg), np.asarray(payload_pos_flange_m, float), Ip))

    # Forward recursion: angular velocity/acceleration of each link and linear acceleration of the
    # origin of its own DH frame (o[k+1] for link k+1), all in world axes.
    w = np.zeros(3)
    dw = np.zeros(3)
    acc_o = np.array([0.0, 0.0, gravity])  # base accelerates up by g  <=>  gravity acts down
    link_w, link_dw, link_acc_o = [], [], []
    for i in range(N_JOINTS):
        dw = dw + qdd[i] * z[i] + qd[i] * np.cross(w, z[i])
        w = w + qd[i] * z[i]
        r = o[i + 1] - o[i]
        acc_o = acc_o + np.cross(dw, r) + np.cross(w, np.cross(w, r))
        link_w.append(w)
        link_dw.append(dw)
        link_acc_o.append(acc_o)

    # Backward recursion: f, n = force and moment (about its joint point o[k]) that link k exerts on
    # link k+1; f_next, n_next are those acting on the next link outward (n_next about o[k+1]).
    f_next = np.zeros(3)
    n_next = np.zeros(3)
    tau = np.zeros(N_JOINTS)
    for i in reversed(range(N_JOINTS)):
        w, dw, acc_o = link_w[i], link_dw[i], link_acc_o[i]
        f = f_next.copy()
        n = n_next + np.cross(o[i + 1] - o[i], f_next)
        for mass, com_local, inertia_local in bodies[i]:
            rc = R[i + 1] @ com_local  # from o[i+1] to the CoM, world axes
            acc_c = acc_o + np.cross(dw, rc) + np.cross(w, np.cross(w, rc))
            F = mass * acc_c
            Iw = R[i + 1] @ inertia_local @ R[i + 1].T
            N = Iw @ dw + np.cross(w, Iw @ w)
            f = f + F
            n = n + np.cross(o[i + 1] + rc - o[i], F) + N
        tau[i] = n @ z[i]
        f_next, n_next = f, n
    return tau


def gravity_potential(
    q: Sequence[float] | np.ndarray,
    gravity: float = UR_GRAVITY_MPS2,
) -> float:
    """Gravitational potential energy of links 1..6 [J] (zero at base height), for self-checks.

    Args:
        q: joint angles [rad], shape (6,).
        gravity: magnitude of gravity along -z [m/s^2].
    """
    frames = dh_frames(q)
    energy = 0.0
    for i in range(N_JOINTS):
        com_world = frames[i + 1][:3, :3] @ LINK_COM_M[i] + frames[i + 1][:3, 3]
        energy += LINK_MASS_KG[i] * gravity * com_world[2]
    return float(energy)
