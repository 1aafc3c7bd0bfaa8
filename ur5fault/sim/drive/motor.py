"""Motor: brushless DC-equivalent or three-phase PMSM in the d-q frame.

Both share one vectorised model (amplitude-invariant Park transform, L_d = L_q = L):

    L di_d/dt = v_d - R i_d + m p w L i_q
    L di_q/dt = v_q - R i_q - m p w L i_d - K_e w
    T_M = K_t i_q

with ``m = 1`` for PMSM joints and ``m = 0`` for DC-equivalent joints (whose single
current is ``i_q``; ``i_d`` stays 0).  ``K_e = K_t`` for the DC-equivalent motor and
``K_e = K_t / 1.5 = p psi`` for the PMSM.  The resistive decay is integrated exactly
over the step, the back-EMF and cross-coupling terms held.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def back_emf_constant(torque_constant_Nm_per_A: NDArray, is_pmsm: NDArray) -> NDArray[np.float64]:
    """K_e [V*s/rad] (per-phase peak for the PMSM) from K_t and the motor kind."""
    return np.where(is_pmsm, torque_constant_Nm_per_A / 1.5, torque_constant_Nm_per_A)


def electrical_step(
    i_d_A: NDArray,
    i_q_A: NDArray,
    v_d_V: NDArray,
    v_q_V: NDArray,
    w_motor_rad_s: NDArray,
    decay: NDArray,
    gain_A_per_V: NDArray,
    cross_rad_H: NDArray,
    back_emf_V_s_per_rad: NDArray,
) -> tuple[NDArray, NDArray]:
    """Advance the winding currents by one step.

    Args:
        decay: ``exp(-R dt / L)`` per joint.
        gain_A_per_V: ``(1 - decay) / R`` per joint.
        cross_rad_H: ``m * p * L`` per joint (0 for DC-equivalent joints).
    """
    coupling = cross_rad_H * w_motor_rad_s
    i_d = decay * i_d_A + gain_A_per_V * (v_d_V + coupling * i_q_A)
    i_q = decay * i_q_A + gain_A_per_V * (v_q_V - coupling * i_d_A - back_emf_V_s_per_rad * w_motor_rad_s)
    return i_d, i_q


def phase_currents(i_d_A: NDArray, i_q_A: NDArray, electrical_angle_rad: NDArray) -> NDArray[np.float64]:
    """Inverse Park/Clarke: phase currents (a, b, c) [A], stacked on a new last axis."""
    th = np.asarray(electrical_angle_rad)
    shifts = np.array([0.0, -2.0 * np.pi / 3.0, 2.0 * np.pi / 3.0])
    ang = th[..., None] + shifts
    return np.asarray(i_d_A)[..., None] * np.cos(ang) - np.asarray(i_q_A)[..., None] * np.sin(ang)


def ripple_torque(motor_angle_rad: NDArray, cogging_Nm: NDArray, cogging_per_rev: NDArray, harmonic_sin_Nm: NDArray,
                  harmonic_cos_Nm: NDArray, harmonic_per_rev: NDArray) -> NDArray[np.float64]:
    """Rotor torque periodic in the motor angle [N*m]: the ``cogging`` effect ``A sin(k th)`` plus the
    ``motor_harmonic`` effect ``a sin(m th) + b cos(m th)`` (its phase fitted to a log)."""
    th = np.asarray(motor_angle_rad)
    x = np.asarray(harmonic_per_rev) * th
    return (np.asarray(cogging_Nm) * np.sin(np.asarray(cogging_per_rev) * th)
            + (np.asarray(harmonic_sin_Nm) * np.sin(x) + np.asarray(harmonic_cos_Nm) * np.cos(x)))
