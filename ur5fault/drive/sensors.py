"""Sensors (paper sec. 2.2): resolver and motor encoder as second-order transfer
functions, current sensor first order; then white noise, sample-and-hold at the servo
rate, and quantisation.

The analog filters run at the physics step with exact (zero-order-hold) discretisation,
so they are stable for any step; the digital reading is taken only at servo instants.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def _expm(a: NDArray[np.float64]) -> NDArray[np.float64]:
    """Matrix exponential of a small matrix (scaling and squaring with a Taylor series)."""
    norm = float(np.max(np.sum(np.abs(a), axis=1)))
    s = max(0, int(np.ceil(np.log2(norm))) + 1) if norm > 0.5 else 0
    x = a / (2.0**s)
    out = np.eye(a.shape[0])
    term = np.eye(a.shape[0])
    for k in range(1, 20):
        term = term @ x / k
        out = out + term
    for _ in range(s):
        out = out @ out
    return out


def second_order_coefficients(bandwidth_Hz: ArrayLike, damping: ArrayLike, dt_s: float) -> NDArray[np.float64]:
    """Exact ZOH discretisation of ``y'' = wn^2 (u - y) - 2 zeta wn y'`` per joint.

    Returns an array ``(6, 6)`` of coefficients ``(p00, p01, g0, p10, p11, g1)`` per joint, so
    that ``y+ = p00 y + p01 y' + g0 u`` and ``y'+ = p10 y + p11 y' + g1 u``.
    """
    wn = 2.0 * np.pi * np.asarray(bandwidth_Hz, dtype=float)
    z = np.asarray(damping, dtype=float) * np.ones_like(wn)
    out = np.empty((wn.size, 6))
    for j, (w, zj) in enumerate(zip(wn, z)):
        m = np.zeros((3, 3))
        m[0, 1] = 1.0
        m[1, 0], m[1, 1], m[1, 2] = -w * w, -2.0 * zj * w, w * w
        e = _expm(m * dt_s)
        out[j] = e[0, 0], e[0, 1], e[0, 2], e[1, 0], e[1, 1], e[1, 2]
    return out


def second_order_step(y: NDArray, dy: NDArray, u: NDArray, c: NDArray) -> tuple[NDArray, NDArray]:
    """Advance a second-order sensor filter one physics step (``c`` from
    :func:`second_order_coefficients`, transposed to ``(6 coefficients, 6 joints)``)."""
    return c[0] * y + c[1] * dy + c[2] * u, c[3] * y + c[4] * dy + c[5] * u


def first_order_coefficient(bandwidth_Hz: ArrayLike, dt_s: float) -> NDArray[np.float64]:
    """``a = exp(-2 pi f dt)`` of the exactly discretised first-order lag ``y+ = a y + (1-a) u``."""
    return np.exp(-2.0 * np.pi * np.asarray(bandwidth_Hz, dtype=float) * dt_s)


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
