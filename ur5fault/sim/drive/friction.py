"""Joint friction, the paper's eq. (2) with temperature, as a smooth-sign law or as the
steady state of the LuGre law (``lugre.py``), split between the two sides of the gear.

Eq. (2) as printed, ``(T_s - T_c)(1 - tanh(10 w)) + T_c + f_v w``, is not odd in ``w``:
it returns ``T_s`` at rest whatever the direction and grows towards ``2 T_s - T_c`` for
``w < 0`` (see :func:`friction_as_printed`).  We implement its physical reading,

    T_f = sgn(w) * g(w) + f_v(T) * w,   g(w) = (T_s - T_c)(1 - tanh(10 |w|)) + T_c,

with viscous friction falling with joint temperature, ``f_v(T) = f_v,ref * exp(-beta (T - T_ref))``
(lubricant viscosity trend of the paper's ref. [16]).  Two laws realise the sign:

* ``smooth``: ``sgn(w) = tanh(w / w_s)`` (no state; at rest it is a steep damper, so a joint
  under a load below ``T_s`` creeps instead of sticking);
* ``lugre``: the LuGre bristle model whose steady state is exactly the law above (it sticks).

``T_f`` opposes motion.  A share ``s`` of it acts on the motor side of the gear clearance (on the
rotor, at the rotor speed divided by the ratio) and ``1 - s`` on the link.  Every law returns its
torque and a non-negative slope ``S`` with which the caller applies it implicitly,
``T_f + S (w+ - w)`` solved together with the other torques (:func:`implicit_speed`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .lugre import bristle_step, lugre_torque


def viscous_coefficient(
    viscous_ref_Nms_per_rad: ArrayLike, temp_coeff_per_K: ArrayLike, temperature_C: ArrayLike, reference_temp_C: float
) -> NDArray[np.float64]:
    """f_v(T) [N*m*s/rad]: the reference value scaled by ``exp(-beta (T - T_ref))``."""
    return np.asarray(viscous_ref_Nms_per_rad) * np.exp(
        -np.asarray(temp_coeff_per_K) * (np.asarray(temperature_C) - reference_temp_C)
    )


def load_levels(coulomb_Nm: ArrayLike, static_Nm: ArrayLike, load_coeff: ArrayLike, gear_torque_Nm: ArrayLike
                ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Coulomb and static friction levels of a strain-wave gear carrying ``gear_torque_Nm`` [N*m]: both raised by
    ``load_coeff * |T_gear|`` (load-dependent friction: the tooth and wave-generator bearing forces, and so their
    friction, grow with the transmitted torque; effect ``load_friction``, docs/model.md)."""
    extra = np.asarray(load_coeff, dtype=float) * np.abs(np.asarray(gear_torque_Nm, dtype=float))
    return np.asarray(coulomb_Nm, dtype=float) + extra, np.asarray(static_Nm, dtype=float) + extra


def stribeck_level(w_rad_s: ArrayLike, coulomb_Nm: ArrayLike, static_Nm: ArrayLike,
                   stribeck_rate_s_per_rad: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Eq. (2)'s friction level ``g(|w|)`` [N*m] and its derivative ``dg/d|w|`` [N*m*s/rad]."""
    th = np.tanh(stribeck_rate_s_per_rad * np.abs(np.asarray(w_rad_s, dtype=float)))
    excess = np.asarray(static_Nm) - np.asarray(coulomb_Nm)
    return excess * (1.0 - th) + coulomb_Nm, -excess * stribeck_rate_s_per_rad * (1.0 - th * th)


def steady_friction(w_rad_s: ArrayLike, coulomb_Nm: ArrayLike, static_Nm: ArrayLike, viscous_Nms_per_rad: ArrayLike,
                    stribeck_rate_s_per_rad: float) -> NDArray[np.float64]:
    """Eq. (2) read as odd, with an exact sign: the LuGre law's steady state [N*m]."""
    w = np.asarray(w_rad_s, dtype=float)
    return np.sign(w) * stribeck_level(w, coulomb_Nm, static_Nm, stribeck_rate_s_per_rad)[0] + viscous_Nms_per_rad * w


def friction_torque(
    w_rad_s: ArrayLike,
    coulomb_Nm: ArrayLike,
    static_Nm: ArrayLike,
    viscous_Nms_per_rad: ArrayLike,
    stribeck_rate_s_per_rad: float,
    sign_smoothing_rad_s: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Smooth-sign law: torque T_f [N*m] (odd in speed) and its secant slope ``T_f / w`` [N*m*s/rad].

    The secant (``T_s / w_s + f_v`` at rest) rather than the local slope is the implicit weight:
    linearised about ``w`` with it, the applied torque ``T_f(w) w+ / w`` can never reverse the
    motion by itself, whereas the local slope, tiny a few widths ``w_s`` from rest, overshoots.
    """
    w = np.asarray(w_rad_s, dtype=float)
    eps = np.asarray(sign_smoothing_rad_s)
    level = stribeck_level(w, coulomb_Nm, static_Nm, stribeck_rate_s_per_rad)[0]
    y = w / eps
    small = np.abs(y) < 1e-8
    tanh_over_y = np.where(small, 1.0, np.tanh(y) / np.where(small, 1.0, y))
    fv = np.asarray(viscous_Nms_per_rad)
    return level * tanh_over_y * y + fv * w, level * tanh_over_y / eps + fv


def friction_step(is_lugre: NDArray, z: NDArray, w_rad_s: NDArray, coulomb_Nm, static_Nm, viscous_Nms_per_rad,
                  stribeck_rate_s_per_rad: float, sign_smoothing_rad_s, sigma0_Nm_per_rad, sigma1_Nms_per_rad,
                  dt_s: float) -> tuple[NDArray, NDArray, NDArray]:
    """Either law per joint, at speed ``w`` over one step: ``(z+, T_f, S)``.

    ``z`` is the LuGre bristle state (kept at 0 where the law is ``smooth``).
    """
    level, dlevel = stribeck_level(w_rad_s, coulomb_Nm, static_Nm, stribeck_rate_s_per_rad)
    z1, t_lg, s_lg = lugre_torque(z, w_rad_s, level, dlevel, sigma0_Nm_per_rad, sigma1_Nms_per_rad,
                                  viscous_Nms_per_rad, dt_s)
    t_sm, s_sm = friction_torque(w_rad_s, coulomb_Nm, static_Nm, viscous_Nms_per_rad, stribeck_rate_s_per_rad,
                                 sign_smoothing_rad_s)
    return np.where(is_lugre, z1, 0.0), np.where(is_lugre, t_lg, t_sm), np.where(is_lugre, s_lg, s_sm)


def bristle_update(is_lugre: NDArray, z: NDArray, w_rad_s: NDArray, coulomb_Nm, static_Nm,
                   stribeck_rate_s_per_rad: float, sigma0_Nm_per_rad, dt_s: float) -> NDArray:
    """Bristle state after a step taken at the speed ``w`` the body actually reached."""
    level = stribeck_level(w_rad_s, coulomb_Nm, static_Nm, stribeck_rate_s_per_rad)[0]
    return np.where(is_lugre, bristle_step(z, w_rad_s, level, sigma0_Nm_per_rad, dt_s), 0.0)


def implicit_speed(w: ArrayLike, other_torque: ArrayLike, friction: ArrayLike, slope: ArrayLike,
                   inertia: ArrayLike, dt_s: float) -> NDArray[np.float64]:
    """Speed after one step of ``J w' = T_other - T_f(w')`` with ``T_f`` linearised about ``w``
    (linearised backward Euler in the friction, every other torque included)."""
    return np.asarray(w) + dt_s * (np.asarray(other_torque) - friction) / (np.asarray(inertia)
                                                                         + dt_s * np.asarray(slope))


def friction_as_printed(
    w_rad_s: ArrayLike, coulomb_Nm: ArrayLike, static_Nm: ArrayLike, viscous_Nms_per_rad: ArrayLike
) -> NDArray[np.float64]:
    """Eq. (2) exactly as printed in the paper (kept to document why it is not used)."""
    w = np.asarray(w_rad_s, dtype=float)
    return (np.asarray(static_Nm) - coulomb_Nm) * (1.0 - np.tanh(10.0 * w)) + coulomb_Nm + viscous_Nms_per_rad * w
