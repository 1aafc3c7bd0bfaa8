"""The machine's speed when a report is written, so that wall times taken on machines of different speed
or load can be compared: wall time over (simulated run-steps x one bare ``mujoco.mj_step``).  Measured by
the report, never inside the fit."""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from .model import DiscrepancyModel

#: bare MuJoCo steps timed to measure the machine's speed (about 0.1 s)
SPEED_PROBE_STEPS = 20000


def bare_mj_step_us(dt_s: float) -> float:
    """Wall time of one bare ``mujoco.mj_step`` of the packaged UR5 now [us] (no drive, no Python loop
    around it beyond this one)."""
    import mujoco

    from ..sim.engine import DEFAULT_MODEL_PATH

    m = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    m.opt.timestep = dt_s
    d = mujoco.MjData(m)
    t = time.perf_counter()
    for _ in range(SPEED_PROBE_STEPS):
        mujoco.mj_step(m, d)
    return (time.perf_counter() - t) / SPEED_PROBE_STEPS * 1e6


def wall_over_mj_steps(model: DiscrepancyModel, step_us: float) -> float:
    """The fit's wall time as a multiple of (simulated run-steps x ``step_us``); NaN when nothing was
    simulated."""
    steps = model.simulated_s_ / model.replay_.params.physics_dt_s
    return model.wall_s_ / (steps * step_us * 1e-6) if steps else float("nan")
