"""Compatibility module: the trajectories now live in the :mod:`ur5fault.trajectories` package."""

from .trajectories import *  # noqa: F403
from .trajectories import __all__  # noqa: F401
