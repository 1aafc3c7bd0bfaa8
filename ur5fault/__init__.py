"""ur5fault: a high-fidelity UR5 fault-injection simulator.

MuJoCo holds the multibody; per-step vectorised Python runs every joint's drive chain
(cascaded loops, inverter, DC/PMSM motor, 101:1 gear with elastic backlash, Stribeck
friction with temperature, sensors).  See README.md.

The names below are imported on first use (``ur5fault.Simulator``, ``from ur5fault import RunSpec``): the
simulator's modules (MuJoCo, numba, pandas) take most of a second, which ``ur5fault --version`` and every
command that needs none of them should not wait for.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

from .util.provenance import package_version

if TYPE_CHECKING:
    from .sim.axes import JOINT_NAMES, N_JOINTS
    from .sim.effects import REGISTRY, make_effect
    from .sim.engine import RunSpec, Simulator, Status
    from .sim.params import RobotParams, load_params
    from .sim.result import SimResult
    from .sim.trajectories import Trajectory, get_trajectory, pick_and_place

#: each name of ``__all__`` -> the module that defines it
_LAZY = {
    "JOINT_NAMES": ".sim.axes", "N_JOINTS": ".sim.axes", "REGISTRY": ".sim.effects", "make_effect": ".sim.effects",
    "RunSpec": ".sim.engine", "Simulator": ".sim.engine", "Status": ".sim.engine", "RobotParams": ".sim.params",
    "load_params": ".sim.params", "SimResult": ".sim.result", "Trajectory": ".sim.trajectories",
    "get_trajectory": ".sim.trajectories", "pick_and_place": ".sim.trajectories",
}

__all__ = [
    "JOINT_NAMES", "N_JOINTS", "REGISTRY", "make_effect", "RunSpec", "Simulator", "Status", "RobotParams",
    "load_params", "SimResult", "Trajectory", "get_trajectory", "pick_and_place",
]

__version__ = package_version()


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(_LAZY[name], __name__), name)
    globals()[name] = value  # once: later lookups find it without this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__})
