"""ur5fault: a high-fidelity UR5 fault-injection simulator.

MuJoCo holds the multibody; per-step vectorised Python runs every joint's drive chain
(cascaded loops, inverter, DC/PMSM motor, 101:1 gear with elastic backlash, Stribeck
friction with temperature, sensors).  See README.md.

The names below, and ``__version__``, are looked up on first use (``ur5fault.Simulator``, ``from ur5fault import
RunSpec``): the simulator's modules (MuJoCo, numba, pandas) take most of a second and ``importlib.metadata``
40 ms, which ``ur5fault --version`` and the commands that need none of them should not wait for; and until the
command line's ``main`` runs, Ctrl-C prints a traceback.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .sim.axes import JOINT_NAMES, N_JOINTS
    from .sim.effects import REGISTRY, make_effect
    from .sim.engine import RunSpec, Simulator, Status
    from .sim.params import RobotParams, load_params
    from .sim.result import SimResult
    from .sim.trajectories import Trajectory, get_trajectory, pick_and_place

    __version__: str

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


if not TYPE_CHECKING:  # hidden from type checkers, which then still catch a misspelled ``ur5fault.Simulatr``

    def __getattr__(name: str) -> Any:
        if name == "__version__":  # the installed distribution's (pyproject.toml is its one source)
            value: Any = import_module(".util.provenance", __name__).package_version()
        elif name in _LAZY:
            value = getattr(import_module(_LAZY[name], __name__), name)
        else:
            raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
        globals()[name] = value  # once: later lookups find it without this function
        return value


def __dir__() -> list[str]:
    return sorted({*globals(), *__all__, "__version__"})
