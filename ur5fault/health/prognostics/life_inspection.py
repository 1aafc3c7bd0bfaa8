"""One inspection of a life campaign's unit: a lockstep batch of them simulated (:func:`inspect_batch`, run in a
worker process by fleet.py), and a unit's next inspection from its stored row (:func:`next_job`), or none when it
failed, reached max_cycles or its wear left the simulator's effect ranges (:func:`beyond_model`).

A unit's next state is always computed from its stored row (clearances and gear work as float64, the increments
from the stream of (fleet seed, unit, inspection)), so that a resumed campaign writes the bytes an uninterrupted
one would (fleet.py, life_resume.py).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ...campaign.identity import DRIVE, STEPPER
from ...campaign.workers import exit_with_parent
from ...config import parse_trajectory
from ...errors import ParameterError
from ...sim.axes import N_JOINTS
from ...sim.effects import make_effect
from .life_store import run_id
from .spec import LifeCampaign, Unit
from .wear import (
    STREAM_NOISE,
    advance_backlash_deg,
    friction_scale,
    gear_work_J,
    stiffness_scale,
    stream,
    unit_rates_deg_per_MJ,
    wear_effects,
)


@dataclasses.dataclass(frozen=True)
class Job:
    """One inspection to simulate: the unit, its number, its cycles and its clearances [deg]."""

    unit: Unit
    inspection: int
    cycles: int
    backlash_deg: tuple[float, ...]


def noise_seed(camp: LifeCampaign, unit: Unit, k: int) -> int:
    """Sensor-noise seed of inspection ``k`` of ``unit`` (a fresh one per inspection)."""
    return int(stream(camp.seed, unit.index, k, STREAM_NOISE).integers(0, 2**31 - 1))


def inspect_batch(camp: LifeCampaign, jobs: Sequence[Job], refs: Mapping[str, np.ndarray | None],
                  parent_pid: int | None = None) -> list[tuple[dict[str, Any], np.ndarray | None, np.ndarray | None]]:
    """Simulate one lockstep batch of inspections (one trajectory); return (row, t_s, tcp) per job,
    t_s and tcp only for inspection 0 (the unit's reference)."""
    from ...sim.engine import RunSpec, Simulator
    from ...sim.params import load_params
    from ..features import FEATURE_UNITS, run_features

    exit_with_parent(parent_pid)
    traj = parse_trajectory(jobs[0].unit.trajectory, "trajectory")
    sim = Simulator(load_params(), stepper=STEPPER, drive=DRIVE)
    specs = []
    for job in jobs:
        a = np.asarray(job.backlash_deg)
        eff = wear_effects(camp.wear, a, job.cycles) + (
            make_effect("payload", mass_kg=job.unit.payload_kg),
            make_effect("temperature", temperature_C=job.unit.temperature_C))
        specs.append(RunSpec(run_id(job.unit, job.inspection), noise_seed(camp, job.unit, job.inspection), eff))
    res = sim.run(traj, specs, log_period_s=camp.log_period_s, duration_s=camp.duration_s)
    work = gear_work_J(res.t_s, res["q_rad"], res["T_gear_Nm"])
    ratio = np.asarray(sim.params.gear.ratio)
    out = []
    for i, job in enumerate(jobs):
        ref = res.tcp_m[i] if job.inspection == 0 else refs.get(job.unit.unit_id)
        ok = res.status[i] == "ok"
        feats = run_features(res.t_s, res.q_set_rad, res["q_FB_rad"][i], res["q_M_FB_rad"][i], res["i_FB_A"][i],
                             ratio, res.tcp_m[i], res.tcp_des_m[i], ref)
        a = np.asarray(job.backlash_deg)
        row: dict[str, Any] = {
            "run_id": run_id(job.unit, job.inspection), "twin_run_id": run_id(job.unit, 0),
            "unit_id": job.unit.unit_id, "inspection": job.inspection, "cycles": job.cycles, "split": job.unit.split,
            "trajectory": json.dumps(job.unit.trajectory, sort_keys=True), "payload_kg": job.unit.payload_kg,
            "temperature_C": job.unit.temperature_C, "seed": specs[i].seed,
            "status": res.status[i], "reason": res.reason[i],
            **{f"backlash_deg_j{j + 1}": float(a[j]) for j in range(N_JOINTS)},
            **{f"friction_scale_j{j + 1}": float(v) for j, v in
               enumerate(friction_scale(camp.wear, a, job.cycles))},
            **{f"stiffness_scale_j{j + 1}": float(v) for j, v in enumerate(stiffness_scale(camp.wear, a))},
            **{f"gear_work_J_j{j + 1}": float(work[i, j]) for j in range(N_JOINTS)},
        }
        for key in FEATURE_UNITS:
            row[key] = float(feats.get(key, float("nan")))
        # a run the robot stops (protective stop) or that diverges has failed its task too
        row["failed"] = bool(not ok or row[camp.failure.feature] >= camp.failure.threshold)
        keep = job.inspection == 0
        out.append((row, res.t_s if keep else None, res.tcp_m[i] if keep else None))
    return out


def next_job(camp: LifeCampaign, unit: Unit, row: Mapping[str, Any]) -> Job | None:
    """The unit's next inspection from its stored row, or None when it failed, reached max_cycles, or its next wear
    state lies beyond what the simulator's effects may take (:func:`beyond_model`: censored there)."""
    k, cycles = int(row["inspection"]), int(row["cycles"])
    if row["failed"] or cycles + camp.interval_cycles > camp.max_cycles:
        return None
    a = np.array([row[f"backlash_deg_j{j + 1}"] for j in range(N_JOINTS)], float)
    w = np.array([row[f"gear_work_J_j{j + 1}"] for j in range(N_JOINTS)], float)
    rates = unit_rates_deg_per_MJ(camp.wear, camp.seed, unit.index)
    a = advance_backlash_deg(camp.wear, rates, a, w, camp.interval_cycles, camp.seed, unit.index, k)
    if beyond_model(camp, a, cycles + camp.interval_cycles):
        return None
    return Job(unit, k + 1, cycles + camp.interval_cycles, tuple(float(v) for v in a))


def beyond_model(camp: LifeCampaign, backlash_deg: NDArray, cycles: float) -> str | None:
    """Why the wear state (clearance ``(6,)`` [deg] after ``cycles``) lies beyond the declared range of an effect
    it puts on the unit (e.g. a Coulomb friction factor above 10, where the wear law's constants take a unit that
    never meets the failure criterion), or None. Such a unit is not simulated further: it ends censored at its
    last inspection, as one reaching max_cycles does, and the fleet's summary counts it apart."""
    try:
        wear_effects(camp.wear, np.asarray(backlash_deg, float), cycles)
    except ParameterError as exc:
        return str(exc)
    return None
