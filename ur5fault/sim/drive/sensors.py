"""Sensors (paper sec. 2.2): resolver and motor encoder as second-order transfer
functions, current sensor first order; then white noise, sample-and-hold at the servo
rate, and quantisation.

The analog filters run at the physics step with exact (zero-order-hold) discretisation,
so they are stable for any step; the digital reading is taken only at servo instants.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ...util.portable import matmul


def _expm(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Matrix exponential of a small matrix (scaling and squaring with a Taylor series; the products through
    :func:`ur5fault.util.portable.matmul`, so the coefficients are the same on every machine)."""
    norm = float(np.max(np.sum(np.abs(a), axis=1)))
    s = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0.5 else 0
    x = a / (2.0**s)
    out = np.eye(a.shape[0])
    term = np.eye(a.shape[0])
    for k in range(1, 20):
        term = matmul(term, x) / k
        out = out + term
    for _ in range(s):
        out = matmul(out, out)
    return out


def second_order_coefficients(bandwidth_Hz: ArrayLike, damping: ArrayLike, dt_s: float) -> NDArray[np.float64]:
    """Exact first-order-hold (ramp-invariant) discretisation of
    ``y'' = wn^2 (u - y) - 2 zeta wn y'`` per joint.

    The input is taken as piecewise linear between steps (exact for a ramp, so the filter's
    derivative state is an unbiased speed estimate; a zero-order hold reads a ramp's slope
    about 20 % low at a 5 kHz filter and 20 kHz step).

    Returns ``(8, n_joints)`` coefficients ``(p00, p01, a0, b0, p10, p11, a1, b1)`` so that
    ``y+ = p00 y + p01 y' + a0 u + b0 u+`` and ``y'+ = p10 y + p11 y' + a1 u + b1 u+``,
    with ``u`` the input at the start of the step and ``u+`` at its end.
    """
    wn = 2.0 * np.pi * np.asarray(bandwidth_Hz, dtype=float)
    z = np.asarray(damping, dtype=float) * np.ones_like(wn)
    out = np.empty((8, wn.size))
    for j, (w, zj) in enumerate(zip(wn, z)):
        m = np.zeros((4, 4))
        m[0, 1] = 1.0
        m[1, 0], m[1, 1], m[1, 2] = -w * w, -2.0 * zj * w, w * w
        m[2, 3] = 1.0  # u' = constant slope over the step
        e = _expm(m * dt_s)
        for row in (0, 1):
            out[4 * row : 4 * row + 4, j] = e[row, 0], e[row, 1], e[row, 2] - e[row, 3] / dt_s, e[row, 3] / dt_s
    return out


def second_order_step(y: NDArray, dy: NDArray, u: NDArray, u_new: NDArray, c: NDArray) -> tuple[NDArray, NDArray]:
    """Advance a second-order sensor filter one physics step (``c`` from
    :func:`second_order_coefficients`; ``u``, ``u_new`` the input at the step's start and end)."""
    return (c[0] * y + c[1] * dy + c[2] * u + c[3] * u_new,
            c[4] * y + c[5] * dy + c[6] * u + c[7] * u_new)


def first_order_coefficients(bandwidth_Hz: ArrayLike, dt_s: float) -> NDArray[np.float64]:
    """Exact first-order-hold discretisation of the lag ``y' = 2 pi f (u - y)``.

    Returns ``(3, n)`` coefficients ``(a, c0, c1)``: ``y+ = a y + c0 u + c1 u+`` with ``u`` and
    ``u+`` the input at the start and end of the step (exact for an input linear in the step).
    """
    lam_dt = 2.0 * np.pi * np.asarray(bandwidth_Hz, dtype=float) * dt_s
    a = np.exp(-lam_dt)
    c1 = 1.0 - (1.0 - a) / lam_dt
    return np.stack([a, (1.0 - a) - c1, c1])


def first_order_step(y: NDArray, u: NDArray, u_new: NDArray, c: NDArray) -> NDArray:
    """Advance a first-order sensor lag one physics step (``c`` from :func:`first_order_coefficients`)."""
    return c[0] * y + c[1] * u + c[2] * u_new


def quantise(x: NDArray, lsb: NDArray) -> NDArray:
    """Round to the nearest multiple of ``lsb`` (``lsb == 0`` leaves ``x`` unquantised)."""
    safe = np.where(lsb > 0.0, lsb, 1.0)
    return np.where(lsb > 0.0, np.round(x / safe) * safe, x)


def read(analog: NDArray, noise_std: NDArray, unit_noise: NDArray, lsb: NDArray) -> NDArray:
    """Digital reading at a sample instant: analog value plus white noise, quantised.

    ``unit_noise`` is a standard-normal draw of the same shape (from the run's own
    random stream); the value is held until the next sample by the caller.
    """
    return quantise(analog + noise_std * unit_noise, lsb)
