"""Sampled campaigns: N runs drawn by Latin hypercube or Sobol sampling over fault kinds, joints,
sizes and nuisance conditions (campaign key ``sample``, instead of ``sweep`` / ``zip``).

Campaign YAML (see campaigns/diagnostics.yaml)::

    sample:
      n: 2000                        # runs drawn (healthy twins come on top, see twins)
      method: lhs                    # lhs (Latin hypercube) or sobol (scrambled; n a power of 2 keeps balance)
      seed: 0                        # the design's random stream: same file, same runs
      twins: [backlash]              # kinds whose runs get a simulated healthy twin: all (default), none, or a list
      joints: [1, 2, 3, 4, 5, 6]     # joints of per-joint fault kinds
      faults:                        # kind -> weight (default 1) and size distribution
        healthy: {weight: 2}
        backlash: {weight: 3, size: {log: [0.005, 0.5]}}                     # backlash_deg
        torque_constant: {size: {log: [0.02, 0.5]}, direction: down}         # scale = 1 - size
        current_sensor_offset: {size: {log: [0.005, 0.5]}, direction: both}  # offset_A = +-size
      conditions:                    # nuisance: seed, payload_kg, temperature_C, trajectory, and
        seed: {integers: [0, 999999]}                 # <effect>.<param> of whole-robot effects
        payload_kg: [0.0, 3.0]
        delay.delay_ms: {uniform: [0.0, 2.0], step: 0.1}
        trajectory: {name: random_pick_and_place, seed: {integers: [0, 39]}}

Distributions: ``[lo, hi]`` or ``{uniform: [lo, hi]}``; ``{log: [lo, hi]}`` (log-uniform, lo > 0);
``{integers: [lo, hi]}`` (inclusive); ``{choices: [a, b, ...]}``; a plain value is fixed.  Any of them
may add ``step: s`` (values rounded to multiples of s).  Continuous values are rounded to 6
significant digits so that run identities are stable.  Trajectory options may only be drawn from
``integers`` or ``choices``, so that runs share trajectories and step in lockstep batches.

A fault kind is an effect of the registry whose size is one parameter with an "absent" value
(the one :mod:`.labels` measures ``fault_size`` by): the parameter is set to
``absent + sign * size`` with ``direction`` ``up`` (+), ``down`` (-) or ``both`` (a sampled sign);
``up``/``down`` is implied when the absent value is the parameter's lower/upper bound.  Every drawn
value is checked against the registry's range before any simulation.

The design has one dimension per drawn quantity (kind, joint, size, sign, each drawn condition,
each drawn trajectory option); a unit-interval coordinate maps to a choice by its cumulative
weights and to a value by the distribution's inverse CDF, so Latin hypercube strata give each kind,
joint and trajectory seed its share of runs exactly (up to rounding).  The Latin hypercube is
implemented here (one permutation and one uniform jitter per dimension from
``numpy.random.default_rng(seed)``: reproducible whatever the scipy version); Sobol points come from
``scipy.stats.qmc.Sobol``.
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..config import parse_trajectory
from ..errors import ParameterError, UnknownNameError, Ur5FaultError
from ..sim.axes import joint_index
from ..sim.effect_types import EffectKey, EffectParam
from ..sim.effects import REGISTRY, effects_of_keys, make_effect
from ..util.checks import is_integer, is_real
from ..util.yamlsafe import plain
from .design import METHODS, SIGNIFICANT_DIGITS, Dist, parse_dist, unit_design
from .runs import CONDITION_KEYS, MAX_RUNS, refuse_trajectory_payload

SAMPLE_KEYS = ("n", "method", "seed", "twins", "joints", "faults", "conditions")
DIRECTIONS = ("up", "down", "both")
KIND_KEYS = ("weight", "size", "direction")


@dataclasses.dataclass(frozen=True)
class FaultKind:
    name: str  # effect name or "healthy"
    weight: float
    size: Dist | None
    param: EffectParam | None
    direction: str


def _size_param(name: str, where: str) -> EffectParam:
    eff = REGISTRY[name]
    params = eff.size_parameters()
    if len(params) != 1 or params[0].absent is None:
        raise ParameterError(f"{where}: effect {name!r} has no single parameter with an 'absent' value; "
                             f"it cannot be a sampled fault kind")
    return params[0]


def _parse_kind(name: str, spec: Any, where: str) -> FaultKind:
    if name != "healthy" and name not in REGISTRY:
        raise UnknownNameError("fault kind", name, ["healthy", *REGISTRY], where)
    spec = {} if spec is None else spec
    if not isinstance(spec, Mapping):
        raise ParameterError(f"{where}: expected a mapping with keys {', '.join(KIND_KEYS)}")
    for key in spec:
        if key not in KIND_KEYS:
            raise UnknownNameError("key", key, KIND_KEYS, where)
    w = spec.get("weight", 1)
    if not is_real(w) or not 0 < w < math.inf:
        raise ParameterError(f"{where}.weight = {w!r} must be a positive number")
    if name == "healthy":
        if "size" in spec or "direction" in spec:
            raise ParameterError(f"{where}: healthy takes only a weight")
        return FaultKind(name, float(w), None, None, "up")
    if "size" not in spec:
        raise ParameterError(f"{where}: fault kind {name!r} needs a size distribution, e.g. size: {{log: [lo, hi]}}")
    size = parse_dist(spec["size"], f"{where}.size")
    p = _size_param(name, where)
    implied = "up" if p.absent == p.lo else ("down" if p.absent == p.hi else None)
    direction = spec.get("direction", implied)
    if direction not in DIRECTIONS:
        raise UnknownNameError("direction", direction, DIRECTIONS, f"{where}.direction")
    for s in size.bounds():
        if not is_real(s) or s <= 0:
            raise ParameterError(f"{where}.size: {s!r} must be a positive number ({p.name} deviation"
                                 f"{p.unit_text(' in {}')})")
        for sign in _signs(direction):
            v = p.absent + sign * s
            if not p.lo <= v <= p.hi:
                raise ParameterError(f"{where}.size: size {s:g} gives {name}.{p.name} = {v:g}, out of range "
                                     f"{p.range_text()}")
    return FaultKind(name, float(w), size, p, str(direction))


def _signs(direction: str) -> tuple[float, ...]:
    return {"up": (1.0,), "down": (-1.0,), "both": (1.0, -1.0)}[direction]


def _check_condition(key: str, dist: Dist, where: str) -> None:
    """Every value a condition can take is valid, checked at the extremes / on every choice."""
    if key == "trajectory":
        return
    for v in dist.bounds():
        if key == "seed":
            if not is_integer(v) or v < 0:
                raise ParameterError(f"{where}: seed = {v!r} must be a non-negative integer")
        elif key == "payload_kg":
            make_effect("payload", where=where, mass_kg=v)
        elif key == "temperature_C":
            make_effect("temperature", where=where, temperature_C=v)
        else:
            effects_of_keys([(key, v)], where)


def _condition_key(key: str, where: str) -> None:
    if key in CONDITION_KEYS:
        return
    ek = EffectKey.parse(key)
    if ek is None or ek.effect not in REGISTRY:
        raise UnknownNameError("condition", key, list(CONDITION_KEYS) + ["<whole-robot effect>.<param>"], where)
    eff = REGISTRY[ek.effect]
    if eff.per_joint or ek.effect in ("payload", "temperature"):
        why = "is per joint: sample it as a fault kind" if eff.per_joint else "is set by payload_kg / temperature_C"
        raise ParameterError(f"{where}: condition {key!r}: effect {ek.effect!r} {why}")
    eff.param(ek.param)  # unknown parameter -> lists the effect's parameters


def _trajectory_dists(spec: Any, where: str) -> tuple[Any, dict[str, Dist]]:
    """The trajectory's fixed spec and its drawn options."""
    if not isinstance(spec, Mapping):
        return plain(spec), {}
    refuse_trajectory_payload(spec, where)
    fixed, drawn = {}, {}
    for k, v in spec.items():
        d = parse_dist(v, f"{where}.{k}") if isinstance(v, (Mapping, list)) else Dist("fixed", (v,))
        if d.drawn and d.kind not in ("integers", "choices"):
            raise ParameterError(f"{where}.{k}: trajectory options are drawn from integers or choices only "
                                 f"(runs must share trajectories to step in lockstep batches)")
        (drawn if d.drawn else fixed)[k] = d if d.drawn else plain(v)
    return fixed, drawn


@dataclasses.dataclass(frozen=True)
class SamplePlan:
    """A validated ``sample`` section: what is drawn, from which distributions, with which design."""

    n: int
    method: str
    seed: int
    kinds: tuple[FaultKind, ...]
    joints: tuple[int, ...]  # 1-based
    twin_kinds: frozenset[str]
    cond_dists: Mapping[str, Dist]
    traj_fixed: Any
    traj_drawn: Mapping[str, Dist]

    @property
    def drawn_conditions(self) -> list[str]:
        return [k for k, d in self.cond_dists.items() if d.drawn]

    @property
    def dims(self) -> list[str]:
        """Columns of the unit design, in order."""
        return ["kind", "joint", "size", "sign"] + self.drawn_conditions + [f"trajectory.{k}" for k in self.traj_drawn]

    @property
    def keys(self) -> list[str]:
        """The drawn keys (for the manifest)."""
        return ([k.name for k in self.kinds if k.size is not None] + self.drawn_conditions
                + [f"trajectory.{k}" for k in self.traj_drawn])


def sample_runs(spec: Any, cond0: Mapping[str, Any], where: str) -> tuple[list[tuple[dict, dict, bool]], list[str]]:
    """Draw the runs of a ``sample`` section.

    Args:
        spec: the ``sample`` mapping.
        cond0: the base conditions (seed, payload_kg, temperature_C, trajectory) the draws override.
        where: file name for messages.

    Returns:
        ``(runs, keys)``: per run ``(conditions, faults, wants_twin)`` with faults as
        ``{"<effect>.joint": j, "<effect>.<param>": v}``, and the drawn keys (for the manifest).
    """
    loc = f"{where}: sample"
    plan = parse_sample(spec, cond0, loc)
    runs, trajectories = draw_runs(plan, cond0)
    _check_trajectories(trajectories, loc)
    return runs, plan.keys


def parse_sample(spec: Any, cond0: Mapping[str, Any], loc: str) -> SamplePlan:
    """Validate a ``sample`` mapping (every message starts with ``loc``)."""
    if not isinstance(spec, Mapping):
        raise ParameterError(f"{loc} must be a mapping with keys {', '.join(SAMPLE_KEYS)}")
    for key in spec:
        if key not in SAMPLE_KEYS:
            raise UnknownNameError("key", key, SAMPLE_KEYS, loc)
    n = spec.get("n")
    if not is_integer(n) or not 1 <= n <= MAX_RUNS:
        raise ParameterError(f"{loc}.n = {n!r} must be an integer in [1, {MAX_RUNS}]")
    method = spec.get("method", "lhs")
    if method not in METHODS:
        raise UnknownNameError("sampling method", method, METHODS, f"{loc}.method")
    seed = spec.get("seed", 0)
    if not is_integer(seed) or seed < 0:
        raise ParameterError(f"{loc}.seed = {seed!r} must be a non-negative integer")
    faults = spec.get("faults") or {"healthy": {}}
    if not isinstance(faults, Mapping):
        raise ParameterError(f"{loc}.faults must be a mapping of fault kind -> {{weight, size, direction}}")
    kinds = [_parse_kind(str(k), v, f"{loc}.faults.{k}") for k, v in faults.items()]
    joints = spec.get("joints", [1, 2, 3, 4, 5, 6])
    if not isinstance(joints, list) or not joints:
        raise ParameterError(f"{loc}.joints must be a non-empty list of joints 1..6")
    joints = [joint_index(j, f"{loc}.joints") + 1 for j in joints]
    twice = sorted({j for j in joints if joints.count(j) > 1})
    if twice:  # [2, shoulder_lift]: joint 2 would be drawn twice as often, unsaid (a sweep refuses the same)
        raise ParameterError(f"{loc}.joints: joint {twice[0]} is given twice (by number and name or alias); give "
                             "each joint once")
    twin_kinds = _twin_kinds(spec.get("twins", "all"), kinds, loc)
    cond_dists, traj_fixed, traj_drawn = _condition_dists(spec.get("conditions") or {}, cond0, kinds, loc)
    return SamplePlan(int(n), method, int(seed), tuple(kinds), tuple(joints), frozenset(twin_kinds), cond_dists,
                      traj_fixed, traj_drawn)


def _twin_kinds(twins: Any, kinds: Sequence[FaultKind], loc: str) -> set[str]:
    if twins == "all":
        return {k.name for k in kinds}
    if twins == "none":
        return set()
    if isinstance(twins, list):
        for t in twins:
            if t not in {k.name for k in kinds}:
                raise UnknownNameError("twin kind", t, [k.name for k in kinds], f"{loc}.twins")
        return set(twins)
    raise ParameterError(f"{loc}.twins = {twins!r} must be all, none or a list of fault kinds")


def _condition_dists(conds: Any, cond0: Mapping[str, Any], kinds: Sequence[FaultKind], loc: str
                     ) -> tuple[dict[str, Dist], Any, dict[str, Dist]]:
    """The conditions' distributions, the trajectory's fixed spec and its drawn options."""
    if not isinstance(conds, Mapping):
        raise ParameterError(f"{loc}.conditions must be a mapping of condition -> distribution")
    cond_dists: dict[str, Dist] = {}
    traj_fixed, traj_drawn = cond0["trajectory"], {}
    for key, v in conds.items():
        cloc = f"{loc}.conditions.{key}"
        _condition_key(str(key), cloc)
        if key == "trajectory":
            traj_fixed, traj_drawn = _trajectory_dists(v, cloc)
            continue
        ek = EffectKey.parse(key)
        if ek is not None and ek.effect in {k.name for k in kinds}:
            raise ParameterError(f"{cloc}: {ek.effect!r} is also a fault kind; choose one")
        cond_dists[key] = parse_dist(v, cloc)
        _check_condition(key, cond_dists[key], cloc)
    return cond_dists, traj_fixed, traj_drawn


def draw_runs(plan: SamplePlan, cond0: Mapping[str, Any]) -> tuple[list[tuple[dict, dict, bool]], dict[str, Any]]:
    """The plan's runs ``(conditions, faults, wants_twin)`` and its distinct trajectories (by repr)."""
    weights = np.array([k.weight for k in plan.kinds])
    cum = np.cumsum(weights) / weights.sum()
    dims = plan.dims
    u = unit_design(plan.method, plan.n, len(dims), plan.seed)
    col = {name: u[:, i] for i, name in enumerate(dims)}
    kinds, joints = plan.kinds, plan.joints
    runs = []
    trajectories: dict[str, Any] = {}
    for r in range(plan.n):
        kind = kinds[min(int(np.searchsorted(cum, col["kind"][r], side="right")), len(kinds) - 1)]
        cond = dict(cond0)
        for key, d in plan.cond_dists.items():
            cond[key] = d.value(col[key][r]) if d.drawn else d.args[0]
        if plan.traj_drawn:
            traj = {**plan.traj_fixed,
                    **{k: d.value(col[f"trajectory.{k}"][r]) for k, d in plan.traj_drawn.items()}}
        else:
            traj = plan.traj_fixed
        cond["trajectory"] = traj
        trajectories.setdefault(repr(traj), traj)
        fault: dict[str, Any] = {}
        if kind.size is not None and kind.param is not None:
            size = kind.size.value(col["size"][r])
            sign = -1.0 if kind.direction == "down" or (kind.direction == "both" and col["sign"][r] < 0.5) else 1.0
            value = float(f"{kind.param.absent + sign * size:.{SIGNIFICANT_DIGITS + 2}g}")
            fault[str(EffectKey(kind.name, kind.param.name))] = value
            if REGISTRY[kind.name].per_joint:
                fault[str(EffectKey(kind.name, "joint"))] = joints[min(int(col["joint"][r] * len(joints)),
                                                                       len(joints) - 1)]
        runs.append((cond, fault, kind.name in plan.twin_kinds and bool(fault)))
    return runs, trajectories


def _check_trajectories(trajectories: Mapping[str, Any], loc: str) -> None:
    """Every drawn trajectory builds, before any simulation."""
    for traj in trajectories.values():
        tloc = f"{loc}.conditions.trajectory {json.dumps(traj, sort_keys=True)}"
        try:
            parse_trajectory(traj, tloc)
        except Ur5FaultError as exc:
            if str(exc).startswith(tloc):
                raise
            raise ParameterError(f"{tloc}: {exc}") from None
