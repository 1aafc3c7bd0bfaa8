"""The multibody side of a batch: MuJoCo models and states of every run.

Two interchangeable steppers with the same interface:

* :class:`LoopMultibody` - the simple path: one ``MjModel``/``MjData`` per run and a Python
  loop over ``mj_step``.
* :class:`BatchMultibody` - the fast path: MuJoCo's ``mujoco.batch.Batch``, which steps all
  runs in C on a thread pool; documented (and tested here) bit-identical to the loop.

Arrays are live views shaped ``(n_runs, 6)``: ``qpos``, ``qvel``, ``qfrc_applied`` and ``dof_damping``
(per-run joint damping, which MuJoCo's Euler integrator applies implicitly: the drive's friction slope).
"""

from __future__ import annotations

import copy

import mujoco
import numpy as np
from numpy.typing import NDArray

from .axes import N_JOINTS
from .gravity import gravity_torque

PAYLOAD_CUBE_M = 0.06  # payload inertia: a solid cube of this edge [m] (assumption)


def payload_inertia(mass_kg: NDArray) -> NDArray:
    """Diagonal inertia [kg*m^2] of a solid cube of edge PAYLOAD_CUBE_M, ``(..., 3)``."""
    return np.repeat((np.asarray(mass_kg, float) * PAYLOAD_CUBE_M**2 / 6.0)[..., None], 3, axis=-1)


class _Ids:
    def __init__(self, model: mujoco.MjModel) -> None:
        self.tcp = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "tcp")
        self.payload = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "payload")
        self.m_diag = np.asarray(model.M_rowadr) + np.asarray(model.M_rownnz) - 1
        self.links = [int(model.jnt_bodyid[j]) for j in range(N_JOINTS)]  # the body each joint moves
        # subtree[j, b]: body b moves with joint j (b is the joint's body or one of its descendants)
        self.subtree = np.zeros((N_JOINTS, model.nbody), dtype=bool)
        for j, top in enumerate(self.links):
            for b in range(model.nbody):
                a = b
                while a > 0 and a != top:
                    a = int(model.body_parentid[a])
                self.subtree[j, b] = a == top
        self.up = -np.asarray(model.opt.gravity) / max(np.linalg.norm(model.opt.gravity), 1e-300)


class LoopMultibody:
    """Simple path: a Python loop over per-run ``mj_step``."""

    def __init__(self, model: mujoco.MjModel, n: int, tcp_m: NDArray, payload_com_m: NDArray) -> None:
        self.ids = _Ids(model)
        self.models = []
        for r in range(n):
            m = copy.deepcopy(model)
            m.site_pos[self.ids.tcp] = tcp_m
            m.body_pos[self.ids.payload] = tcp_m
            m.body_ipos[self.ids.payload] = payload_com_m[r]
            self.models.append(m)
        self.datas = [mujoco.MjData(m) for m in self.models]
        self.qpos = np.zeros((n, N_JOINTS))
        self.qvel = np.zeros((n, N_JOINTS))
        self.qfrc_applied = np.zeros((n, N_JOINTS))
        self.dof_damping = np.tile(np.asarray(model.dof_damping, float), (n, 1))
        #: the joint damping the MJCF itself declares (the engine adds the friction slope to it)
        self.model_damping = np.asarray(model.dof_damping, float).copy()

    def set_payload(self, mass_kg: NDArray) -> None:
        inertia = payload_inertia(mass_kg)
        for r, m in enumerate(self.models):
            m.body_mass[self.ids.payload] = mass_kg[r]
            m.body_inertia[self.ids.payload] = inertia[r]

    def start(self, q: NDArray) -> NDArray:
        """Place every run at ``q`` at rest; return the bias forces (gravity) ``(n, 6)`` [N*m]."""
        bias = np.empty_like(self.qpos)
        for r, (m, d) in enumerate(zip(self.models, self.datas)):
            d.qpos[:] = q[r]
            d.qvel[:] = 0.0
            mujoco.mj_forward(m, d)
            bias[r] = d.qfrc_bias
        self.qpos[:] = q
        self.qvel[:] = 0.0
        return bias

    def mass_diagonal(self) -> NDArray:
        return np.stack([d.M[self.ids.m_diag] for d in self.datas])

    def step(self, active: NDArray) -> None:
        for r in np.flatnonzero(active):
            d = self.datas[r]
            d.qfrc_applied[:] = self.qfrc_applied[r]
            self.models[r].dof_damping[:] = self.dof_damping[r]
            mujoco.mj_step(self.models[r], d)
            self.qpos[r] = d.qpos
            self.qvel[r] = d.qvel

    def warnings(self) -> NDArray:
        return np.array([sum(w.number for w in d.warning) for d in self.datas])

    def run_models(self) -> list[mujoco.MjModel]:
        return self.models

    # -- used by the data-driven terms (ur5fault/sim/terms.py)
    def model_field(self, name: str) -> list[NDArray]:
        """Per run, a writable view of a model field (call :meth:`model_changed` after writing)."""
        return [getattr(m, name) for m in self.models]

    def link_bodies(self) -> list[int]:
        return self.ids.links

    def model_changed(self) -> None:
        for m, d in zip(self.models, self.datas):
            mujoco.mj_setConst(m, d)

    def gravity_torque(self) -> NDArray:
        """Static gravity torque of every run and joint ``(n, 6)`` [N*m] (see :func:`gravity_torque`)."""
        g = float(np.linalg.norm(self.models[0].opt.gravity))
        return gravity_torque(self.ids, g, np.stack([m.body_mass for m in self.models]),
                              np.stack([d.xipos for d in self.datas]), np.stack([d.xanchor for d in self.datas]),
                              np.stack([d.xaxis for d in self.datas]))


class BatchMultibody:
    """Fast path: ``mujoco.batch.Batch`` steps all runs in C on ``nthread`` threads."""

    def __init__(self, model: mujoco.MjModel, n: int, tcp_m: NDArray, payload_com_m: NDArray,
                 nthread: int = 1) -> None:
        from mujoco.batch import Batch

        self.ids = _Ids(model)
        self.template = model
        self.batch = Batch(model, n, nthread=nthread)
        b = self.batch
        b.expand("site_pos")[:, self.ids.tcp] = tcp_m
        b.expand("body_pos")[:, self.ids.payload] = tcp_m
        b.expand("body_ipos")[:, self.ids.payload] = payload_com_m
        self._mass = b.expand("body_mass")
        self._inertia = b.expand("body_inertia")
        self.qpos = b.bind("qpos")
        self.qvel = b.bind("qvel")
        self.qfrc_applied = b.bind("qfrc_applied")
        self.dof_damping = b.expand("dof_damping")
        #: the joint damping the MJCF itself declares (the engine adds the friction slope to it)
        self.model_damping = np.asarray(model.dof_damping, float).copy()
        self._M = b.bind("M")
        self._bias = b.bind("qfrc_bias")  # bound before any call: a derived field bound later reads zero until then
        self._all = np.arange(n)

    def set_payload(self, mass_kg: NDArray) -> None:
        self._mass[:, self.ids.payload] = mass_kg
        self._inertia[:, self.ids.payload] = payload_inertia(mass_kg)

    def start(self, q: NDArray) -> NDArray:
        self.qpos[:] = q
        self.qvel[:] = 0.0
        self.batch.forward()
        return self._bias.copy()

    def mass_diagonal(self) -> NDArray:
        return self._M[:, self.ids.m_diag]

    def step(self, active: NDArray) -> None:
        if active.all():
            self.batch.step()
        else:
            self.batch.step(ids=self._all[active])

    def warnings(self) -> NDArray:
        return np.asarray(self.batch.warning)[:, :, 1].sum(axis=1)  # (nsim, mjNWARNING, [lastinfo, number])

    def run_models(self) -> list[mujoco.MjModel]:
        return [self.batch.get_model(r) for r in range(len(self._all))]

    # -- used by the data-driven terms (ur5fault/sim/terms.py)
    def model_field(self, name: str) -> NDArray:
        """A writable ``(n, ...)`` array of per-run model values (call :meth:`model_changed` after writing)."""
        return self.batch.expand(name)

    def link_bodies(self) -> list[int]:
        return self.ids.links

    def model_changed(self) -> None:
        self.batch.set_const()

    def gravity_torque(self) -> NDArray:
        """Static gravity torque of every run and joint ``(n, 6)`` [N*m] (see :func:`gravity_torque`).
        The kinematic fields are bound at the first call; call it before :meth:`start`."""
        if not hasattr(self, "_xipos"):
            self._xipos, self._xanchor, self._xaxis = (self.batch.bind(f) for f in ("xipos", "xanchor", "xaxis"))
        g = float(np.linalg.norm(self.template.opt.gravity))
        return gravity_torque(self.ids, g, self._mass, self._xipos, self._xanchor, self._xaxis)
