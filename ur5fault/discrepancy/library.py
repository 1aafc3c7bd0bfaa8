"""Screening the effect library: linearised sensitivities of every candidate from one lockstep batch.

Every (effect, parameter) of the registry is simulated once at a probe value (a typical fault size).
A per-joint effect is probed on every joint at once in a single run: a joint's drive hardly moves the
other joints' readings (their coupling through the arm changes a position by micro-radians), so the
run's change on joint ``j``'s channels is the sensitivity of candidate ``(effect, j)``, and the batch
holds one run per effect parameter instead of one per joint.  The secant from the baseline to the probe
is the candidate's column of the linearised problem.

The secants are taken between replays of one noise stream, so that the sensor noise cancels in them - except
for an effect that scales the noise itself.  A current-sensor gain multiplies the reading's noise: its secant held
the replay's own noise, which the residual (measured minus that replay) holds with the opposite sign, an
errors-in-variables bias that named a wrist_3 current gain of 0.60-0.68 at z 11-16 on logs the model itself
simulated (wrist_3's current is about its noise level; docs/discrepancy.md, "Findings on a log of the model
itself").  Such an effect (:data:`SCALES_NOISE`) is probed between two replays with the sensors' white noise off
(:data:`NOISE_FREE`): its column is then the effect's change of the expected reading only.  The other effects keep
the noisy pair: friction at stick answers the noise's dither, and a noise-free secant of a breakaway friction
misses part of it (tried on the test suite's hidden breakaway on shoulder_lift: sized ×1.853 for ×1.803 with a
Stribeck-like term beside it, against ×1.806 alone from the noisy pair).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..sim.effects import NOISE_FREE, REGISTRY, EffectSpec
from ..sim.params import RobotParams, load_params
from ..twin.replay import LogReplay, Replayed
from .candidates import LibraryCandidate

#: probe value per (effect, parameter): a typical fault size, for the secant of the screening batch
PROBES: dict[tuple[str, str], float | None] = {
    ("backlash", "backlash_deg"): 0.1,
    ("coulomb_friction", "scale"): 1.5,
    ("viscous_friction", "scale"): 1.5,
    ("viscous_temperature", "coeff_per_K"): 0.04,
    # stick-slip and where friction acts (issue 10): breakaway 50 % above its identified level, a bristle
    # three times more compliant, all of the joint's friction moved to the motor side of the clearance
    ("breakaway_friction", "scale"): 1.5,
    ("presliding_stiffness", "scale"): 0.3,
    ("friction_share", "motor_side_share"): None,  # probed at the end of its range farther from the model's
    # load-dependent gear friction (issue 17): 5 % of the transmitted torque, the size the real logs' at-speed
    # residual gives on shoulder_lift (bench/load_friction_evidence.py)
    ("load_friction", "coeff"): 0.05,
    ("gear_stiffness", "scale"): 0.5,
    ("torque_constant", "scale"): 0.9,
    ("resolver_offset", "offset_deg"): 0.01,
    ("current_sensor_gain", "gain"): 1.1,
    ("current_sensor_offset", "offset_A"): 0.1,
    ("cogging", "amplitude_Nm"): 0.02,
    ("delay", "delay_ms"): 4.0,
    ("payload", "mass_kg"): None,  # the log's payload + PAYLOAD_PROBE_KG (- within 0.5 kg of the range's top)
    ("payload_com", "dx_m"): 0.05, ("payload_com", "dy_m"): 0.05, ("payload_com", "dz_m"): 0.05,
}
PAYLOAD_PROBE_KG = 0.5
#: effects that are operating conditions read from the log, not discrepancies
CONDITIONS = {"temperature"}
#: effects that scale a sensor's white noise (the reading's noise times the gain): probed between noise-free
#: replays (module docstring)
SCALES_NOISE = frozenset({"current_sensor_gain"})


def kinds() -> list[str]:
    """The effect kinds the library screens, in order."""
    return list(dict.fromkeys(name for name, _ in PROBES if name not in CONDITIONS))


def candidates(payload_kg: float, joints: Sequence[int] = range(N_JOINTS),
               kinds: Sequence[str] | None = None, params: RobotParams | None = None) -> list[LibraryCandidate]:
    """Every candidate of the library (optionally only some effect kinds), per-joint ones on ``joints``.

    ``params``: the model being fitted (default: the packaged one); parameters without an "absent" value
    are linearised about its values."""
    params = params if params is not None else load_params()
    out = []
    for (name, par), probe in PROBES.items():
        if name in CONDITIONS or (kinds is not None and name not in kinds):
            continue
        eff = REGISTRY[name]
        for j in (joints if eff.per_joint else [None]):
            x0, at = eff.param(par).absent, probe
            if name == "payload":  # probed heavier, or lighter where heavier leaves the effect's range (5 kg)
                x0 = payload_kg
                at = x0 + PAYLOAD_PROBE_KG if x0 + PAYLOAD_PROBE_KG <= eff.param(par).hi else x0 - PAYLOAD_PROBE_KG
            elif name == "viscous_temperature":  # linearised about the model's coefficient
                x0 = params.friction.viscous_temp_coeff_per_K[0 if j is None else j]
            elif name == "friction_share":  # no "absent" value: about the model's share, probed at the far end
                x0 = params.friction.motor_side_share[j]
                at = 1.0 if x0 < 0.5 else 0.0
            out.append(LibraryCandidate(name, j, par, float(x0), float(at)))
    return out


def _probe_runs(cands: list[LibraryCandidate]) -> list[tuple[list[LibraryCandidate], tuple[EffectSpec, ...]]]:
    """Group the candidates into probe runs: per-joint ones of one (effect, parameter) share a run."""
    groups: dict[tuple[str, str], list[LibraryCandidate]] = {}
    for c in cands:
        groups.setdefault((c.effect, c.param), []).append(c)
    runs = []
    for group in groups.values():
        if group[0].joint is None:
            runs += [([c], (c.spec(np.array([c.coef(c.probe)])),)) for c in group]
        else:
            runs.append((group, tuple(c.spec(np.array([c.coef(c.probe)])) for c in group)))
    return runs


def screen(rp: LogReplay, n: int, cands: list[LibraryCandidate], current: Sequence[EffectSpec] = (),
           progress=None) -> tuple[Replayed, NDArray, list[LibraryCandidate]]:
    """Simulate the baseline and every probe run over samples ``1..n`` in one batch.

    Returns:
        The baseline replay, the weighted columns ``(p, n, n_channels)`` (the change of the *simulated*
        readings per unit coefficient, divided by the noise sigma; noise-free for :data:`SCALES_NOISE`) and the
        candidates they belong to (those whose probe run failed, even when probed alone, are left out).
    """
    runs = _probe_runs(cands)
    pre = [tuple(current) + (NOISE_FREE,) * (group[0].effect in SCALES_NOISE) for group, _ in runs]
    bases = list(dict.fromkeys([tuple(current), *pre]))  # the baseline, and the noise-free one where a probe needs it
    sims = rp.run(bases + [p + specs for p, (_, specs) in zip(pre, runs)], n, progress)
    ref = dict(zip(bases, sims))
    base, probes = sims[0], sims[len(bases):]
    retry = [(c, p) for (group, _), sim, p in zip(runs, probes, pre) if not sim.ok and len(group) > 1 for c in group]
    if retry:  # a probe that failed on one joint spoils its shared run: probe those joints one by one
        probes += rp.run([p + (c.spec(np.array([c.coef(c.probe)])),) for c, p in retry], n)
        runs += [([c], ()) for c, _ in retry]
        pre += [p for _, p in retry]
    sigma = rp.sigma
    cols, kept = [], []
    for (group, _), sim, p in zip(runs, probes, pre):
        if not sim.ok or not ref[p].ok:
            continue
        delta = (sim.y - ref[p].y) / sigma
        for c in group:
            if c in kept:
                continue
            col = delta / c.coef(c.probe)
            if c.joint is not None:  # a per-joint probe's column: its own joint's channels only
                col = np.where(np.arange(N_JOINTS) == c.joint, col, 0.0)
            if not np.any(col):
                continue
            cols.append(col.reshape(n, -1))
            kept.append(c)
    return base, np.array(cols), kept
