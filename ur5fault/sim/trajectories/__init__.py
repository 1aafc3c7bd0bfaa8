"""Joint setpoint trajectories: the stream type and joint moves (:mod:`.base`), the fixed paper
pick-and-place and test motions (:mod:`.fixed`), the seeded random pick-and-place family
(:mod:`.random_pnp`, poses by :mod:`.ik`), and the registry campaigns name them by."""

from __future__ import annotations

import inspect
from collections.abc import Callable

from ...errors import UnknownNameError
from .base import CB3_SETPOINT_PERIOD_S, UR_DEFAULT_ACCEL_RAD_S2, UR_DEFAULT_SPEED_RAD_S, Trajectory, dwell, movej
from .fixed import PICK, PICK_APPROACH, PLACE, PLACE_APPROACH, hold, joint_sweep, pick_and_place
from .random_pnp import random_pick_and_place

TRAJECTORIES: dict[str, Callable[..., Trajectory]] = {
    "pick_and_place": pick_and_place,
    "hold": hold,
    "joint_sweep": joint_sweep,
    "random_pick_and_place": random_pick_and_place,
}


def get_trajectory(name: str, **kwargs) -> Trajectory:
    """Build a named trajectory; an unknown name lists the valid ones, an unknown option the trajectory's options."""
    if not isinstance(name, str) or name not in TRAJECTORIES:
        raise UnknownNameError("trajectory", name, TRAJECTORIES)
    options = inspect.signature(TRAJECTORIES[name]).parameters
    for key in kwargs:
        if key not in options:
            raise UnknownNameError(f"option of trajectory {name!r}", key, options)
    return TRAJECTORIES[name](**kwargs)


__all__ = [
    "CB3_SETPOINT_PERIOD_S", "PICK", "PICK_APPROACH", "PLACE", "PLACE_APPROACH", "TRAJECTORIES",
    "UR_DEFAULT_ACCEL_RAD_S2", "UR_DEFAULT_SPEED_RAD_S", "Trajectory", "dwell", "get_trajectory", "hold",
    "joint_sweep", "movej", "pick_and_place", "random_pick_and_place",
]
