"""Identification in code: every measured (``[nist]``) parameter of ``ur5_drive.yaml`` from a log.

``ur5fault identify LOG --format nist|rtde --out params.yaml`` (see docs/parameters.md).
One concern per module: :mod:`.signals` (speeds and the inverse-dynamics torque of the log),
:mod:`.friction` with :mod:`.motor` (friction and torque constant on moving samples),
:mod:`.stickslip` (breakaway and presliding stiffness at starts), :mod:`.sensors` (noise at
rest, resolver resolution), :mod:`.loop` (tracking lag, feed-forward, bandwidth sweep),
:mod:`.stats` (estimates and intervals), :mod:`.report` (overlay and its text forms).
"""

from .core import identify
from .report import Identification
from .stats import Estimate

__all__ = ["Estimate", "Identification", "identify"]
