"""Power electronics: the inverter turns V_ref into the supply voltage the bus allows.

The DC-equivalent H-bridge gives ``|v| <= V_bus``; the three-phase inverter with
space-vector modulation gives ``|v_dq| <= V_bus / sqrt(3)`` (linear range).  Switching
is averaged: the voltage is held between servo samples (zero-order hold).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray


def voltage_limit(bus_voltage_V: float, is_pmsm: NDArray) -> NDArray[np.float64]:
    """Largest voltage magnitude [V] the inverter can apply, per joint."""
    return np.where(is_pmsm, bus_voltage_V / np.sqrt(3.0), bus_voltage_V)


def limit_voltage(v_d_V: NDArray, v_q_V: NDArray, limit_V: NDArray) -> tuple[NDArray, NDArray]:
    """Scale the (v_d, v_q) vector down to the inverter limit, keeping its direction."""
    mag = np.sqrt(v_d_V * v_d_V + v_q_V * v_q_V)
    scale = np.minimum(1.0, limit_V / np.maximum(mag, 1e-300))
    return v_d_V * scale, v_q_V * scale
