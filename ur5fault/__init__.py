"""ur5fault: a high-fidelity UR5 fault-injection simulator.

MuJoCo holds the multibody; per-step vectorised Python runs every joint's drive chain
(cascaded loops, inverter, DC/PMSM motor, 101:1 gear with elastic backlash, Stribeck
friction with temperature, sensors).  See README.md.
"""

from .sim.axes import JOINT_NAMES, N_JOINTS
from .sim.effects import REGISTRY, make_effect
from .sim.engine import RunSpec, Simulator, Status
from .sim.params import RobotParams, load_params
from .sim.result import SimResult
from .sim.trajectories import Trajectory, get_trajectory, pick_and_place
from .util.provenance import package_version

__all__ = [
    "JOINT_NAMES", "N_JOINTS", "REGISTRY", "make_effect", "RunSpec", "Simulator", "Status", "RobotParams",
    "load_params", "SimResult", "Trajectory", "get_trajectory", "pick_and_place",
]

__version__ = package_version()
