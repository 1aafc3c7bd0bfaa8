"""Torque constant: the slope of measured current against the model torque.

Joints of one motor size share one torque constant ([facts]: J1-J3 size 3, J4-J6 size 1).
Only joints whose model torque varies enough over the moving samples carry it (gravity on
the shoulder and elbow, 20-55 N*m); on the base the torque is inertia only (~0.3 N*m RMS)
and the slope is indistinguishable from friction.  The constant is fitted jointly with each
contributing joint's friction (a pooled least squares with a shared slope), on moving samples
only (at rest the current is whatever static friction holds).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

#: [facts] UR5 joint sizes: base, shoulder, elbow "size 3"; wrists "size 1"
MOTOR_SIZE = (3, 3, 3, 1, 1, 1)
#: a joint carries its torque constant if its model torque over the moving samples varies by at
#: least this much (RMS about the mean) [N*m]: 10x a size-3 joint's current noise times K
MIN_TORQUE_SPREAD_NM = 2.0


def torque_lever(torque_Nm: NDArray, moving: NDArray) -> NDArray:
    """RMS spread of the model torque over each joint's moving samples ``(6,)`` [N*m]."""
    out = np.zeros(torque_Nm.shape[1])
    for j in range(torque_Nm.shape[1]):
        x = torque_Nm[moving[:, j], j]
        out[j] = x.std() if x.size else 0.0
    return out


def pooled_inverse_gain(current_A: NDArray, torque_Nm: NDArray, friction_cols: Sequence[NDArray],
                        rows: Sequence[NDArray], joints: Sequence[int],
                        shared_Nm: NDArray | None = None) -> tuple[float, NDArray]:
    """Shared slope 1/K [A/(N*m)] of current on torque over ``joints``.

    Args:
        current_A, torque_Nm: ``(n, 6)`` measured current and model torque.
        friction_cols: per joint, the ``(n, m)`` friction design columns (see :mod:`.friction`).
        rows: per joint, the sample indices to use (moving samples).
        joints: the joints that share the constant.
        shared_Nm: ``(p, n, 6)`` further torques with unknown sizes ``x`` (an unknown payload's columns,
            :mod:`.payload`): the current is ``(torque + shared . x) / K``, fitted as the linear ``phi = x / K``.

    Returns:
        ``1/K`` and ``phi`` ``(p,)`` (``x = phi * K``; empty without ``shared_Nm``).
    """
    blocks, ys = [], []
    p = 0 if shared_Nm is None else shared_Nm.shape[0]
    n_fric = sum(friction_cols[j].shape[1] for j in joints)
    col = 1 + p
    for j in joints:
        r = rows[j]
        a = np.zeros((r.size, 1 + p + n_fric))
        a[:, 0] = torque_Nm[r, j]
        if p:
            a[:, 1 : 1 + p] = shared_Nm[:, r, j].T  # type: ignore[index]
        m = friction_cols[j].shape[1]
        a[:, col : col + m] = friction_cols[j][r]
        col += m
        blocks.append(a)
        ys.append(current_A[r, j])
    coef = np.linalg.lstsq(np.vstack(blocks), np.concatenate(ys), rcond=None)[0]
    return float(coef[0]), coef[1 : 1 + p]
