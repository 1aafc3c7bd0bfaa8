"""Inverse kinematics of the packaged MJCF's TCP site, tool pointing straight down.

Damped least squares (Levenberg-Marquardt on the 6-D pose error) with MuJoCo's own site
Jacobian, so a solution is exact for the model the simulator steps (``ur5fault/models/ur5.xml``,
which is UR's DH kinematics).  Starting from a seed configuration, it converges to the
solution on the seed's branch (shoulder, elbow and wrist configuration), which is how a
pick-and-place cell keeps its arm in one posture family.

Its products and solves go through :mod:`ur5fault.util.portable`, not BLAS or LAPACK: the IK iterates to a
tolerance, so a kernel's own rounding moved the last bits of a motion's joint targets with the machine.
"""

from __future__ import annotations

import dataclasses
import math
from importlib import resources

import mujoco
import numpy as np
from numpy.typing import NDArray

from ...util.portable import matmul, solve_spd, sq_norm

IK_TOL = 1e-14  # squared pose error at convergence [m^2 + rad^2]: 0.1 um, 0.1 urad
IK_MAX_ITER = 200
IK_DAMPING = 1e-4  # Levenberg-Marquardt damping [m^2], keeps steps finite near singular poses
IK_MAX_STEP_RAD = 0.2  # largest joint change per iteration [rad]


def model_path() -> str:
    """The packaged MJCF (the same file the simulator loads)."""
    return str(resources.files("ur5fault") / "models" / "ur5.xml")


def down_rotation(yaw_rad: float) -> NDArray[np.float64]:
    """Tool frame (columns x, y, z in the base frame) pointing down, x axis at ``yaw_rad`` about vertical."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, -1.0]])


@dataclasses.dataclass
class TcpKinematics:
    """Forward and inverse kinematics of the model's ``tcp`` site (0.15 m beyond the flange)."""

    model: mujoco.MjModel
    data: mujoco.MjData
    site: int

    @classmethod
    def load(cls) -> TcpKinematics:
        m = mujoco.MjModel.from_xml_path(model_path())
        return cls(m, mujoco.MjData(m), mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp"))

    def fk(self, q: NDArray) -> tuple[NDArray, NDArray]:
        """TCP position [m] and rotation matrix (columns = tool axes) at joint angles ``q`` [rad]."""
        self.data.qpos[:] = q
        mujoco.mj_kinematics(self.model, self.data)
        return self.data.site_xpos[self.site].copy(), self.data.site_xmat[self.site].reshape(3, 3).copy()

    def pose_error(self, q: NDArray, pos: NDArray, rot: NDArray) -> NDArray:
        """6-vector: position error [m] and rotation error (axis-angle for small errors) [rad]."""
        p, r = self.fk(q)
        rot_err = 0.5 * sum(np.cross(r[:, k], rot[:, k]) for k in range(3))
        return np.concatenate([pos - p, rot_err])

    def ik(self, pos: NDArray, rot: NDArray, q_seed: NDArray) -> NDArray | None:
        """Joint angles placing the TCP at ``pos`` with orientation ``rot``; ``None`` if not reached."""
        q = np.array(q_seed, dtype=float)
        jp, jr = np.zeros((3, self.model.nv)), np.zeros((3, self.model.nv))
        for _ in range(IK_MAX_ITER):
            e = self.pose_error(q, pos, rot)
            if sq_norm(e) < IK_TOL:
                return q
            mujoco.mj_comPos(self.model, self.data)  # the Jacobian reads cdof, which mj_kinematics leaves stale
            mujoco.mj_jacSite(self.model, self.data, jp, jr, self.site)
            jac = np.vstack([jp, jr])
            jjt = matmul(jac, jac.T) + IK_DAMPING * np.eye(6)
            dq = matmul(jac.T, solve_spd(jjt, e)[:, None])[:, 0]
            big = np.max(np.abs(dq))
            q += dq * min(1.0, IK_MAX_STEP_RAD / big) if big > 0 else 0.0
        e = self.pose_error(q, pos, rot)
        return q if sq_norm(e) < IK_TOL else None
