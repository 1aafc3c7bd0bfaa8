"""Gearbox: 101:1 strain-wave gear with elastic backlash, the paper's eq. (1).

``theta_rel`` is the relative angle of the gear teeth seen at the joint side,
``theta_M / N - q`` [rad], and ``dtheta_rel`` its rate [rad/s].  The clearance lies
between ``theta_rel = 0`` and ``theta_rel = alpha``; in contact the teeth act as a
spring-damper that can only push (a would-be pulling torque is zero).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray


def gear_torque(
    theta_rel_rad: ArrayLike,
    dtheta_rel_rad_s: ArrayLike,
    stiffness_Nm_per_rad: ArrayLike,
    damping_Nms_per_rad: ArrayLike,
    backlash_rad: ArrayLike,
) -> NDArray[np.float64]:
    """Ideal output torque T_id [N*m] of eq. (1), every branch as printed (``alpha`` is ``backlash_rad``).

    1. ``alpha == 0``: ``k*theta + c*dtheta`` (no backlash, no clamp).
    2. ``theta > alpha`` and ``k*(theta-alpha) + c*dtheta > 0``: that value.
    3. ``theta > alpha`` and it is ``< 0``: 0 (the teeth separate, contact cannot pull).
    4. ``theta < 0`` and ``k*theta + c*dtheta < 0``: that value.
    5. ``theta < 0`` and it is ``> 0``: 0.
    6. otherwise (inside the clearance): 0.
    """
    th = np.asarray(theta_rel_rad, dtype=float)
    dth = np.asarray(dtheta_rel_rad_s, dtype=float)
    k = np.asarray(stiffness_Nm_per_rad, dtype=float)
    c = np.asarray(damping_Nms_per_rad, dtype=float)
    backlash_rad = np.asarray(backlash_rad, dtype=float)
    t_low = k * th + c * dth  # contact on the theta = 0 flank (and the alpha = 0 law)
    t_high = t_low - k * backlash_rad  # contact on the theta = alpha flank
    in_gap = np.where(th > backlash_rad, np.maximum(t_high, 0.0), np.where(th < 0.0, np.minimum(t_low, 0.0), 0.0))
    return np.where(backlash_rad == 0.0, t_low, in_gap)
