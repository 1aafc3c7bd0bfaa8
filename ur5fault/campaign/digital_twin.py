"""The digital twin of a campaign run: what the robot's own model predicts from what the robot knows.

A run's twin carries the campaign's base model (its ``base.params`` and ``base.effects``, which a
``--model`` overlay extends: the robot's fitted model) and the run's commanded trajectory, configured
payload mass and joint temperature; not its fault, not the nuisance the robot does not know (payload
centre of mass, setpoint latency: the run's ``<effect>.<param>`` conditions), and not its noise stream
(an independent seed, so the residual carries the noise of both).  A run and its simulated healthy
twin share their conditions, hence one digital twin.  Twins are simulated in the batch of their runs
(:func:`ur5fault.campaign.execute.run_batch`), and with them the batch's noise-free twins on a grid of payload
masses (:func:`regressor_runs`), whose motor currents and gear torques are the twin fits' regressors, and (option
``twin_com_twins``) at each grid mass above zero three more with the payload's centre of mass shifted, the current
fit's CoM columns
(:mod:`ur5fault.health.twin_regressors`). :func:`regressor_grid` and :func:`add_twin_features` turn a simulated
batch's twins into each run's twin residual features.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..sim.effects import EffectSpec, make_effect
from .runs import CampaignRun
from .spec import Campaign

#: prefix of a digital twin's run id (it is never stored: its signals only feed its runs' features)
TWIN_PREFIX = "twin-"
#: a twin's noise seed: this many bits of a hash of the run's seed (independent of the run's stream)
TWIN_SEED_BITS = 62


def twin_seed(seed: int) -> int:
    """The twin's noise seed for a run with noise seed ``seed`` (deterministic, not ``seed`` itself)."""
    digest = hashlib.sha256(f"ur5fault digital twin of seed {int(seed)}".encode()).digest()
    return int.from_bytes(digest[:8], "big") >> (64 - TWIN_SEED_BITS)


def twin_effects(camp: Campaign, rc: CampaignRun) -> tuple[EffectSpec, ...]:
    """The effects a run's twin carries: the base model, the configured payload mass, the temperature."""
    c = rc.cond
    return camp.base_effects + (make_effect("payload", mass_kg=c["payload_kg"]),
                                make_effect("temperature", temperature_C=c["temperature_C"]))


def regressor_runs(camp: Campaign, batch: Sequence[CampaignRun], temperature_C: float
                   ) -> tuple[tuple[float, ...], dict[str, tuple[int, tuple[EffectSpec, ...]]]]:
    """The batch's noise-free twins (:mod:`ur5fault.health.twin_regressors`): ``(grid masses [kg], run id ->
    (noise seed, effects))``, one per mass of :func:`~ur5fault.health.twin_regressors.payload_grid` of the batch's
    payloads, at ``temperature_C`` (the regressors move each run's viscous friction to its own); the base model
    as a twin's, its sensors' white noise off; with the campaign's ``twin_com_twins``, at each mass above zero also
    the three CoM twins
    (:func:`~ur5fault.health.twin_regressors.com_effects`, ids :func:`regressor_id`).  A run's regressors come from
    the grid masses just below and above its own payload and do not depend on the other runs of its batch."""
    from ..health.twin_regressors import COM_AXES, REGRESSOR_EFFECTS, com_effects, payload_grid

    grid = payload_grid(rc.cond["payload_kg"] for rc in batch)
    runs: dict[str, tuple[int, tuple[EffectSpec, ...]]] = {}
    for kg in grid:
        base = camp.base_effects + (make_effect("payload", mass_kg=kg),
                                    make_effect("temperature", temperature_C=temperature_C)) + REGRESSOR_EFFECTS
        runs[regressor_id(kg)] = (0, base)
        if camp.twin_com_twins and kg > 0:  # a shift of no mass moves nothing: the CoM columns at 0 kg are zero
            for ax, shift in zip(COM_AXES, com_effects()):
                runs[regressor_id(kg, ax)] = (0, base + shift)
    return grid, runs


def regressor_id(kg: float, com_axis: str | None = None) -> str:
    """Run id of the noise-free twin at grid mass ``kg``, or of its CoM twin shifted along ``com_axis``."""
    from ..health.twin_regressors import REGRESSOR_PREFIX

    return f"{REGRESSOR_PREFIX}{kg:g}kg" + ("" if com_axis is None else f"-com-{com_axis}")


def twin_id(rc: CampaignRun) -> str:
    """Identifier of a run's digital twin (shared by runs with the same known conditions and seed)."""
    c = rc.cond
    key = json.dumps([c["seed"], c["payload_kg"], c["temperature_C"], c["trajectory"]], sort_keys=True, default=str)
    return TWIN_PREFIX + hashlib.sha1(key.encode()).hexdigest()[:12]


def twin_runs(camp: Campaign, batch: Sequence[CampaignRun]) -> dict[str, tuple[int, tuple[EffectSpec, ...]]]:
    """The distinct digital twins of ``batch``: twin id -> (noise seed, effects)."""
    out: dict[str, tuple[int, tuple[EffectSpec, ...]]] = {}
    for rc in batch:
        out.setdefault(twin_id(rc), (twin_seed(int(rc.cond["seed"])), twin_effects(camp, rc)))
    return out


def regressor_grid(res, grid, grid_at: dict[str, int], temperature_C: float, qd, params, com_twins: bool):
    """The batch's :class:`~ur5fault.health.twin_regressors.RegressorGrid` from its noise-free twins (``grid_at``:
    run id -> index in ``res``), with the centre-of-mass columns of its CoM twins (zero at 0 kg) where the
    campaign simulates them (``com_twins``: its ``twin_com_twins``)."""
    from ..health.twin_regressors import COM_AXES, RegressorGrid, com_difference

    base = [grid_at[regressor_id(kg)] for kg in grid]
    i_a = res["i_q_A"][base]
    com = None
    if com_twins:
        com = np.zeros((*i_a.shape, len(COM_AXES)))
        for g, kg in enumerate(grid):
            if kg > 0:
                com[g] = com_difference(res["i_q_A"][[grid_at[regressor_id(kg, ax)] for ax in COM_AXES]], i_a[g])
    return RegressorGrid(np.asarray(grid), temperature_C, i_a, res["T_gear_Nm"][base], qd, params, com)


def add_twin_features(row: dict[str, Any], res, i: int, k: int, params, cond: dict[str, Any], held, motion,
                       regressors) -> None:
    """The twin residual features of run ``i`` against its digital twin ``k`` of the same batch (NaN, and the
    run not ``ok``, when the twin or a noise-free regressor twin failed); ``cond``: the run's conditions (its
    configured payload mass and temperature, known to the robot); ``held``: when the gripper holds the payload
    (the centre-of-mass columns of the current fit); ``motion``: the batch's ``commanded_motion``;
    ``regressors``: the batch's :class:`~ur5fault.health.twin_regressors.RegressorGrid`, or the ``(status,
    reason)`` of its twin that failed."""
    from ..health.twin_features import FEATURE_UNITS as TWIN_UNITS
    from ..health.twin_features import twin_features

    if res.status[k] != "ok" or isinstance(regressors, tuple):
        row.update(dict.fromkeys(TWIN_UNITS, float("nan")))
        if row["status"] == "ok":
            row["status"], row["reason"] = ((res.status[k], f"digital twin: {res.reason[k]}") if res.status[k] != "ok"
                                            else regressors)
        return
    payload_kg = float(cond["payload_kg"])
    i_a, torque = regressors.signals(payload_kg, float(cond["temperature_C"]))
    names = ("q_FB_rad", "q_M_FB_rad", "i_FB_A")
    row.update(twin_features(res.t_s, res.q_set_rad, {n: res[n][i] for n in names},
                             {**{n: res[n][k] for n in names}, "i_q_A": i_a, "T_gear_Nm": torque,
                              **({} if regressors.com_A_per_m is None
                                 else {"com_A_per_m": regressors.com_columns(payload_kg)})},
                             params, payload_kg, held, motion))
