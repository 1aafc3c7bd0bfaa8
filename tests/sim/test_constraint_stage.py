"""MuJoCo's constraint stage switched off for a model without constraints (sim/engine.py
``skip_constraint_stage``): every signal of a run equals the run with the stage on, bit for bit, for every effect of
the registry; a model with a constraint keeps the stage."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.sim.effects import REGISTRY
from ur5fault.sim.engine import has_no_constraints, skip_constraint_stage

DUR = 0.3
OFF = int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)


def _every_effect() -> list[RunSpec]:
    runs = [RunSpec("healthy", 1)]
    for i, (name, eff) in enumerate(sorted(REGISTRY.items())):
        values = {q.name: (q.lo + q.hi) / 2 if q.absent is None else q.absent + (q.hi - q.absent) * 0.2
                  for q in eff.params}
        runs.append(RunSpec(name, i % 4, (make_effect(name, 1 + i % 6 if eff.per_joint else None, **values),)))
    return runs


def test_the_packaged_model_steps_without_its_constraint_stage_and_nothing_changes():
    traj = dataclasses.replace(pick_and_place(), payload_events=((0.1, True), (0.2, False)))
    runs = _every_effect()
    off = Simulator()
    assert off.model.opt.disableflags & OFF
    on = Simulator()
    on.model.opt.disableflags &= ~OFF
    a, b = off.run(traj, runs, duration_s=DUR), on.run(traj, runs, duration_s=DUR)
    assert a.status == b.status
    for k in a.signals:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)
    np.testing.assert_array_equal(a.tcp_m, b.tcp_m)


def test_a_model_with_a_constraint_keeps_the_stage():
    for change in ("limit", "frictionloss", "contact"):
        m = mujoco.MjModel.from_xml_path(str(Simulator().model_path))
        if change == "limit":
            m.jnt_limited[1] = 1
        elif change == "frictionloss":
            m.dof_frictionloss[2] = 0.1
        else:
            m.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
            m.geom_contype[:] = 1
        assert not has_no_constraints(m), change
        skip_constraint_stage(m)
        assert not m.opt.disableflags & OFF, change
