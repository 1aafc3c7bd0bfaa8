"""'Measured' logs with hidden effects for the discrepancy tests.

The simulator makes a log of the ``joint_sweep`` trajectory (not the motion the model was developed on)
with sensor noise from the test's own seed; only the written file reaches the workflow.  Effects outside
the library are made *independently of ur5fault's term code*: torques by a MuJoCo passive-force callback
written here, inertia and link masses by editing the MJCF, a sensor drift by editing the written current.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import mujoco
import numpy as np
import pandas as pd
import pyarrow.parquet as pq

from ur5fault import RunSpec, Simulator
from ur5fault.discrepancy import WORKFLOW_SEED
from ur5fault.sim.effects import EffectSpec
from ur5fault.sim.engine import DEFAULT_MODEL_PATH
from ur5fault.sim.trajectories import joint_sweep

#: the payload the 'user' declares (and the log holds)
PAYLOAD_KG = 1.0
#: the tool offset the hidden logs are simulated with (the packaged model's, ur5_drive.yaml)
SIM_TCP_M = (0.0, 0.0, 0.15)
#: joint temperatures of an RTDE log: a ramp over the log, centred on the model's 28 degC reference
TEMPERATURE_RAMP_C = (23.0, 33.0)


def edited_model(tmp_path: Path, old: str, new: str) -> Path:
    """The packaged MJCF with one string replaced (checked to occur once, and to compile)."""
    xml = DEFAULT_MODEL_PATH.read_text()
    assert xml.count(old) == 1, old
    path = tmp_path / "edited.xml"
    path.write_text(xml.replace(old, new))
    mujoco.MjModel.from_xml_path(str(path))
    return path


def simulate(effects: Sequence[EffectSpec] = (), seed: int = 0, model_path: Path | None = None,
             torque: Callable[[float, float], float] | None = None, joint: int | None = None):
    """One run of the joint sweep; ``torque(q, qd)`` is an extra load torque on ``joint`` (0-based)
    applied through MuJoCo's passive-force callback (plain-loop stepper)."""
    assert seed != WORKFLOW_SEED
    sim = Simulator(model_path=model_path, stepper="loop" if torque is not None else None)
    if torque is not None:
        def passive(m, d):
            d.qfrc_passive[joint] -= torque(d.qpos[joint], d.qvel[joint])

        mujoco.set_mjcb_passive(passive)
    try:
        return sim.run(joint_sweep(payload_kg=PAYLOAD_KG), [RunSpec("measured", seed, tuple(effects))],
                       log_period_s=0.008)
    finally:
        mujoco.set_mjcb_passive(None)


def write_sim(res, path: Path) -> Path:
    """ur5fault's own Parquet time series (with motor encoders); the log declares the nominal payload."""
    res.to_parquet(path, 0)
    table = pq.read_table(path)
    meta = json.loads(table.schema.metadata[b"ur5fault"])
    meta["payload_kg"] = PAYLOAD_KG
    pq.write_table(table.replace_schema_metadata({**table.schema.metadata, b"ur5fault": json.dumps(meta)}), path)
    return path


def write_rtde(res, path: Path, drift: tuple[int, float] | None = None) -> Path:
    """An RTDE-style CSV (no motor encoders) with joint temperatures ramping over the log; ``drift``:
    (joint, A/K) adds a current-reading drift with temperature about 28 degC."""
    t = res.t_s
    temp = np.linspace(*TEMPERATURE_RAMP_C, t.size)
    current = res["i_FB_A"][0].copy()
    if drift is not None:
        current[:, drift[0]] += drift[1] * (temp - 28.0)
    cols = {"timestamp": t}
    for j in range(6):
        cols[f"target_q_{j}"] = res.q_set_rad[:, j]
        cols[f"actual_q_{j}"] = res["q_FB_rad"][0][:, j]
        cols[f"actual_current_{j}"] = current[:, j]
        cols[f"joint_temperatures_{j}"] = temp
    pd.DataFrame(cols).to_csv(path, index=False)
    return path


def named(model, kind: str, joint: int | None):
    """(candidate, estimate) of ``kind`` on ``joint`` among the kept library findings or their alternatives."""
    for f in model.effects_:
        for c, th in [(f.candidate, f.theta), *f.alternatives]:
            if c.source == "library" and c.effect == kind and c.joint == joint:
                return c, c.value(th)
    return None
