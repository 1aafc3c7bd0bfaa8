"""Static gravity torque of every joint from the multibody's own state: the weight of every body that
moves with a joint, taken about that joint's axis.  The multibody offers it (``gravity_torque()`` of
:mod:`ur5fault.sim.multibody`); the data-driven gravity term scales it (:mod:`ur5fault.sim.terms`) and
the discrepancy workflow builds its gravity columns from the same quantity.  The acceleration is the
MJCF's own ``opt.gravity`` (9.82 m/s^2 in the packaged model), never restated here.
"""

from __future__ import annotations

import sys

import numpy as np
from numba import njit
from numpy.typing import NDArray

from .axes import N_JOINTS
from .jitcache import protect


def gravity_torque(ids, g_m_s2: float, mass: NDArray, xipos: NDArray, xanchor: NDArray,
                   xaxis: NDArray) -> NDArray:
    """Static gravity torque each joint's motor supplies ``(n, 6)`` [N*m]: the weight of every body that
    moves with the joint, ``m_b g`` upwards at its centre of mass, taken about the joint's axis.

    ``ids`` holds ``subtree`` ``(6, n_bodies)`` (body b moves with joint j) and ``up`` (unit vector
    against gravity), as the multibody's body ids do."""
    out = np.empty((mass.shape[0], N_JOINTS))
    gravity_moments(np.ascontiguousarray(mass), np.ascontiguousarray(xipos), np.ascontiguousarray(xanchor),
                    np.ascontiguousarray(xaxis), ids.subtree, g_m_s2 * ids.up, out)
    return out


@njit(cache=True)
def gravity_moments(mass, xipos, xanchor, xaxis, subtree, up, out):
    """Static gravity torque per run and joint (:func:`gravity_moment_j`) into ``out`` ``(n, 6)``."""
    n = mass.shape[0]
    nj = subtree.shape[0]
    for r in range(n):
        for j in range(nj):
            out[r, j] = gravity_moment_j(j, mass[r], xipos[r], xanchor[r], xaxis[r], subtree, up)


@njit(cache=True, inline="always")
def gravity_moment_j(j, mass, xipos, xanchor, xaxis, subtree, up):
    """Static gravity torque of joint ``j`` of one run: for every body moving with the joint, the moment of its
    weight (``mass * up``, ``up`` the holding force per kg) about the joint's axis.  ``mass`` ``(nbody,)``,
    ``xipos`` ``(nbody, 3)``, ``xanchor`` and ``xaxis`` ``(njnt, 3)``."""
    tx, ty, tz = 0.0, 0.0, 0.0
    for b in range(subtree.shape[1]):
        if subtree[j, b] and mass[b] != 0.0:
            ax = xipos[b, 0] - xanchor[j, 0]
            ay = xipos[b, 1] - xanchor[j, 1]
            az = xipos[b, 2] - xanchor[j, 2]
            m = mass[b]
            tx += m * (ay * up[2] - az * up[1])
            ty += m * (az * up[0] - ax * up[2])
            tz += m * (ax * up[1] - ay * up[0])
    return tx * xaxis[j, 0] + ty * xaxis[j, 1] + tz * xaxis[j, 2]

protect(sys.modules[__name__])  # the numba cache of the functions above verified on read (jitcache.py)
