"""Joint friction at the output shaft, the paper's eq. (2), with temperature.

Eq. (2) as printed, ``(T_s - T_c)(1 - tanh(10 w)) + T_c + f_v w``, is not odd in ``w``:
it returns ``T_s`` at rest whatever the direction and grows towards ``2 T_s - T_c`` for
``w < 0`` (see :func:`friction_as_printed`).  We implement its physical reading,

    T_f = sgn(w) * [(T_s - T_c)(1 - tanh(10 |w|)) + T_c] + f_v(T) * w,

with a smooth sign ``sgn(w) = tanh(w / w_s)`` and viscous friction falling with joint
temperature, ``f_v(T) = f_v,ref * exp(-beta (T - T_ref))`` (lubricant viscosity trend of
the paper's ref. [16]).  ``T_f`` opposes motion: the joint receives ``T = T_id - T_f``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def viscous_coefficient(
    viscous_ref_Nms_per_rad: ArrayLike, temp_coeff_per_K: ArrayLike, temperature_C: ArrayLike, reference_temp_C: float
) -> NDArray[np.float64]:
    """f_v(T) [N*m*s/rad]: the reference value scaled by ``exp(-beta (T - T_ref))``."""
    return np.asarray(viscous_ref_Nms_per_rad) * np.exp(
        -np.asarray(temp_coeff_per_K) * (np.asarray(temperature_C) - reference_temp_C)
    )


def friction_torque(
    w_rad_s: ArrayLike,
    coulomb_Nm: ArrayLike,
    static_Nm: ArrayLike,
    viscous_Nms_per_rad: ArrayLike,
    stribeck_rate_s_per_rad: float,
    sign_smoothing_rad_s: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Friction torque T_f [N*m] (odd in speed) and its non-negative slope [N*m*s/rad].

    The slope ``dT_f/dw`` (without the small negative Stribeck part) lets the caller
    integrate the steep smooth sign semi-implicitly (see :func:`implicit_friction`).
    """
    w = np.asarray(w_rad_s, dtype=float)
    tc = np.asarray(coulomb_Nm)
    s = np.tanh(w / sign_smoothing_rad_s)
    level = (np.asarray(static_Nm) - tc) * (1.0 - np.tanh(stribeck_rate_s_per_rad * np.abs(w))) + tc
    fv = np.asarray(viscous_Nms_per_rad)
    torque = s * level + fv * w
    slope = level * (1.0 - s * s) / sign_smoothing_rad_s + fv
    return torque, slope


def implicit_friction(torque_Nm: ArrayLike, slope_Nms_per_rad: ArrayLike, inertia_kgm2: ArrayLike, dt_s: float):
    """Friction torque to apply over one explicit step, linearised backward Euler.

    For a damper ``T = b w`` on inertia ``M`` the backward-Euler step applies
    ``b w / (1 + b dt / M)``; we apply the same factor with ``b`` the local slope, which
    keeps the near-zero-speed smooth sign stable at any step while leaving the torque
    unchanged as ``dt -> 0`` (checked by the convergence test).
    """
    return np.asarray(torque_Nm) / (1.0 + np.asarray(slope_Nms_per_rad) * dt_s / np.asarray(inertia_kgm2))


def friction_as_printed(
    w_rad_s: ArrayLike, coulomb_Nm: ArrayLike, static_Nm: ArrayLike, viscous_Nms_per_rad: ArrayLike
) -> NDArray[np.float64]:
    """Eq. (2) exactly as printed in the paper (kept to document why it is not used)."""
    w = np.asarray(w_rad_s, dtype=float)
    return (np.asarray(static_Nm) - coulomb_Nm) * (1.0 - np.tanh(10.0 * w)) + coulomb_Nm + viscous_Nms_per_rad * w
