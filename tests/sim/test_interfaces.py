"""The declared seams of the simulation core (ur5fault/sim/interfaces.py): every implementation the
engine takes provides each method of its protocol with the same parameters."""

from __future__ import annotations

import inspect

import mujoco
import numpy as np
import pytest

from ur5fault.sim import interfaces
from ur5fault.sim.drive.state import NumbaDrive, NumpyDrive
from ur5fault.sim.effects import REGISTRY
from ur5fault.sim.engine import DEFAULT_MODEL_PATH
from ur5fault.sim.multibody import BatchMultibody, LoopMultibody
from ur5fault.sim.terms import TermHook


def _methods(proto: type) -> dict[str, inspect.Signature]:
    return {name: inspect.signature(fn) for name, fn in vars(proto).items()
            if callable(fn) and not name.startswith("_") or name == "__call__"}


def _params(sig: inspect.Signature) -> list[str]:
    return [p.name for p in sig.parameters.values() if p.name != "self"]


@pytest.mark.parametrize("proto, impl", [(interfaces.Multibody, LoopMultibody),
                                         (interfaces.Multibody, BatchMultibody),
                                         (interfaces.Drive, NumpyDrive), (interfaces.Drive, NumbaDrive),
                                         (interfaces.DataDrivenTerms, TermHook)])
def test_implementation_has_every_method_with_the_same_parameters(proto, impl):
    wanted = _methods(proto)
    assert wanted, proto
    for name, sig in wanted.items():
        assert hasattr(impl, name), f"{impl.__name__} lacks {name}"
        assert _params(inspect.signature(getattr(impl, name))) == _params(sig), f"{impl.__name__}.{name}"


def test_multibody_instances_conform_with_their_arrays():
    model = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    for cls in (LoopMultibody, BatchMultibody):
        mb = cls(model, 2, np.array([0.0, 0.0, 0.15]), np.zeros((2, 3)))
        assert isinstance(mb, interfaces.Multibody)
        assert mb.qpos.shape == mb.qfrc_applied.shape == mb.dof_damping.shape == (2, 6)


def test_every_effect_applier_takes_arrays_row_joint_values():
    want = _params(inspect.signature(interfaces.EffectApplier.__call__))
    for name, eff in REGISTRY.items():
        assert isinstance(eff.apply, interfaces.EffectApplier), name
        assert len(inspect.signature(eff.apply).parameters) == len(want), name
