"""LuGre friction (Canudas de Wit et al., 1995): a bristle state ``z`` [rad] that sticks.

    dz/dt = w - sigma0 |w| z / g(w)
    T_f   = sigma0 z + sigma1 dz/dt + sigma2 w

``g(w) > 0`` is the steady-state friction level, here eq. (2)'s Stribeck curve
(:func:`ur5fault.sim.drive.friction.stribeck_level`), and ``sigma2 = f_v(T)``: at constant speed
``z -> sgn(w) g(w) / sigma0`` and ``T_f -> sgn(w) g(w) + f_v w``, the friction law of eq. (2)
with an exact sign.  At rest the bristles act as a spring ``sigma0`` (presliding), so a joint
holds a load up to ``T_f,s`` without creeping: the stick that eq. (2)'s smooth sign lacks.

Discretisation over one physics step of length ``dt`` at a fixed speed ``w`` (the speed at the
*end* of the step, as the symplectic step advances positions with it):

* the bristle ODE is linear in ``z`` at fixed ``w`` and is integrated exactly,
  ``z+ = e z + phi w`` with ``e = exp(-x)``, ``x = sigma0 |w| dt / g``, ``phi = dt (1 - e) / x``
  (stable for any stiffness; the same zero-order-hold update as MuJoCo's ``dcmotor``);
* the torque over the step is ``T_f(w) = sigma0 z+ + sigma1 (z+ - z) / dt + sigma2 w``, i.e. the
  bristle spring is taken at the end of the step (backward Euler);
* the caller applies it linearised about the speed at the start of the step,
  ``T_f(w+) ~ T_f(w) + S (w+ - w)`` with ``S = dT_f/dw >= 0`` solved together with every other
  torque on the body (MuJoCo's implicit joint damping on the link, a local solve on the rotor).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: smallest friction level used in ``1 / g`` [N*m] (a joint without friction has no bristle force)
LEVEL_FLOOR_NM = 1e-12
#: below this ``x`` the expansions of ``(1 - e^-x) / x`` and its derivative are used
SMALL_X = 1e-4


def _decay(sigma0, w, level, dt):
    """``x = sigma0 |w| dt / g``, ``e = exp(-x)`` and ``r = (1 - e) / x`` (``r -> 1`` at ``x = 0``)."""
    x = np.asarray(sigma0) * np.abs(w) * dt / np.maximum(level, LEVEL_FLOOR_NM)
    e = np.exp(-x)
    small = x < SMALL_X
    r = np.where(small, 1.0 - x / 2.0 + x * x / 6.0, -np.expm1(-x) / np.where(small, 1.0, x))
    return x, e, r


def bristle_step(z: ArrayLike, w_rad_s: ArrayLike, level_Nm: ArrayLike, sigma0_Nm_per_rad: ArrayLike,
                 dt_s: float) -> NDArray[np.float64]:
    """Bristle deflection [rad] after one step at fixed speed ``w``, exact for that speed."""
    w = np.asarray(w_rad_s, dtype=float)
    _, e, r = _decay(sigma0_Nm_per_rad, w, level_Nm, dt_s)
    return e * np.asarray(z) + dt_s * r * w


def lugre_torque(
    z: ArrayLike,
    w_rad_s: ArrayLike,
    level_Nm: ArrayLike,
    dlevel_Nms_per_rad: ArrayLike,
    sigma0_Nm_per_rad: ArrayLike,
    sigma1_Nms_per_rad: ArrayLike,
    sigma2_Nms_per_rad: ArrayLike,
    dt_s: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Bristle state after the step, friction torque over the step and its slope, at speed ``w``.

    Args:
        z: bristle deflection at the start of the step [rad].
        w_rad_s: speed over the step [rad/s].
        level_Nm: steady-state level ``g(w) > 0`` [N*m].
        dlevel_Nms_per_rad: ``dg/d|w|`` [N*m*s/rad] (negative on the Stribeck dip).
        sigma0_Nm_per_rad: bristle (presliding) stiffness.
        sigma1_Nms_per_rad: bristle damping.
        sigma2_Nms_per_rad: viscous coefficient ``f_v(T)``.
        dt_s: step [s].

    Returns:
        ``(z+, T_f, S)``: deflection [rad], torque [N*m] and ``S = max(dT_f/dw, 0)`` [N*m*s/rad].
    """
    w = np.asarray(w_rad_s, dtype=float)
    z0 = np.asarray(z, dtype=float)
    s0, s1, s2 = np.asarray(sigma0_Nm_per_rad), np.asarray(sigma1_Nms_per_rad), np.asarray(sigma2_Nms_per_rad)
    g = np.maximum(level_Nm, LEVEL_FLOOR_NM)
    x, e, r = _decay(s0, w, g, dt_s)
    phi = dt_s * r
    z1 = e * z0 + phi * w
    k = s0 + s1 / dt_s
    torque = k * z1 - (s1 / dt_s) * z0 + s2 * w
    # slope: z+ depends on w directly and through x(w) = sigma0 |w| dt / g(|w|)
    dx = s0 * dt_s * np.sign(w) * (g - np.abs(w) * np.asarray(dlevel_Nms_per_rad)) / (g * g)
    psi = np.where(x < SMALL_X, -0.5 + x / 3.0 - x * x / 8.0,
                   (e * (1.0 + x) - 1.0) / np.where(x < SMALL_X, 1.0, x * x))  # d r / d x
    dz1 = -z0 * e * dx + phi + w * dt_s * psi * dx
    slope = np.maximum(k * dz1 + s2, 0.0)
    return z1, torque, slope
