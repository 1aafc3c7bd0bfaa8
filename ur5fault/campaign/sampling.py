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
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..config import parse_trajectory
from ..errors import ParameterError, UnknownNameError, Ur5FaultError
from ..sim.axes import joint_index
from ..sim.effects import REGISTRY, EffectKey, EffectParam, effects_of_keys, make_effect
from .labels import SIZE_PARAM

SAMPLE_KEYS = ("n", "method", "seed", "twins", "joints", "faults", "conditions")
METHODS = ("lhs", "sobol")
DIST_KEYS = ("uniform", "log", "integers", "choices")
DIRECTIONS = ("up", "down", "both")
KIND_KEYS = ("weight", "size", "direction")
BASE_CONDITIONS = ("seed", "payload_kg", "temperature_C", "trajectory")
MAX_RUNS = 1_000_000
SIGNIFICANT_DIGITS = 6


@dataclasses.dataclass(frozen=True)
class Dist:
    """A one-dimensional distribution mapped from a unit-interval coordinate."""

    kind: str  # uniform, log, integers, choices, fixed
    args: tuple[Any, ...]
    step: float | None = None

    @property
    def drawn(self) -> bool:
        return self.kind != "fixed"

    def value(self, u: float) -> Any:
        """The value at coordinate ``u`` in [0, 1) (inverse CDF)."""
        k, a = self.kind, self.args
        if k == "fixed":
            return a[0]
        if k == "choices":
            return a[min(int(u * len(a)), len(a) - 1)]
        if k == "integers":
            return int(min(a[0] + int(u * (a[1] - a[0] + 1)), a[1]))
        v = a[0] + u * (a[1] - a[0]) if k == "uniform" else math.exp(math.log(a[0]) + u * math.log(a[1] / a[0]))
        if self.step:
            v = min(max(round(v / self.step) * self.step, a[0]), a[1])
        return float(f"{v:.{SIGNIFICANT_DIGITS}g}")

    def bounds(self) -> tuple[Any, ...]:
        """The extreme values it can give (for validation before any simulation)."""
        if self.kind in ("fixed", "choices"):
            return self.args
        return (self.value(0.0), self.value(1.0 - 1e-12))


@dataclasses.dataclass(frozen=True)
class FaultKind:
    name: str  # effect name or "healthy"
    weight: float
    size: Dist | None
    param: EffectParam | None
    direction: str


def parse_dist(spec: Any, where: str) -> Dist:
    """A distribution from YAML (see the module docstring)."""
    if isinstance(spec, list):
        spec = {"uniform": spec}
    if not isinstance(spec, Mapping):
        return Dist("fixed", (spec,))
    keys = [k for k in spec if k in DIST_KEYS]
    extra = [k for k in spec if k not in DIST_KEYS + ("step",)]
    if extra or len(keys) != 1:
        bad = extra[0] if extra else "/".join(keys) or "(none)"
        raise UnknownNameError("distribution", bad, DIST_KEYS, where)
    kind, args = keys[0], spec[keys[0]]
    step = spec.get("step")
    if step is not None and (isinstance(step, bool) or not isinstance(step, (int, float)) or not step > 0):
        raise ParameterError(f"{where}: step = {step!r} must be a positive number")
    if kind == "choices":
        if not isinstance(args, list) or not args:
            raise ParameterError(f"{where}: choices must be a non-empty list")
        return Dist("choices", tuple(args), step)
    if (not isinstance(args, list) or len(args) != 2
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in args)):
        raise ParameterError(f"{where}: {kind} = {args!r} must be a list [lo, hi] of two numbers")
    lo, hi = args
    if kind == "integers" and not (isinstance(lo, int) and isinstance(hi, int)):
        raise ParameterError(f"{where}: integers = {args!r} must be two integers")
    if not lo <= hi:
        raise ParameterError(f"{where}: {kind} = {args!r} needs lo <= hi")
    if kind == "log" and not lo > 0:
        raise ParameterError(f"{where}: log = {args!r} needs 0 < lo <= hi")
    return Dist(kind, (lo, hi), float(step) if step is not None else None)


def _size_param(name: str, where: str) -> EffectParam:
    eff = REGISTRY[name]
    params = [eff.param(SIZE_PARAM[name])] if name in SIZE_PARAM else list(eff.params)
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
    if isinstance(w, bool) or not isinstance(w, (int, float)) or not 0 < w < math.inf:
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
        if isinstance(s, bool) or not isinstance(s, (int, float)) or s <= 0:
            raise ParameterError(f"{where}.size: {s!r} must be a positive number ({p.name} deviation in {p.unit})")
        for sign in _signs(direction):
            v = p.absent + sign * s
            if not p.lo <= v <= p.hi:
                raise ParameterError(f"{where}.size: size {s:g} gives {name}.{p.name} = {v:g}, out of range "
                                     f"[{p.lo:g}, {p.hi:g}] {p.unit}")
    return FaultKind(name, float(w), size, p, str(direction))


def _signs(direction: str) -> tuple[float, ...]:
    return {"up": (1.0,), "down": (-1.0,), "both": (1.0, -1.0)}[direction]


def _check_condition(key: str, dist: Dist, where: str) -> None:
    """Every value a condition can take is valid, checked at the extremes / on every choice."""
    if key == "trajectory":
        return
    for v in dist.bounds():
        if key == "seed":
            if isinstance(v, bool) or not isinstance(v, int) or v < 0:
                raise ParameterError(f"{where}: seed = {v!r} must be a non-negative integer")
        elif key == "payload_kg":
            make_effect("payload", where=where, mass_kg=v)
        elif key == "temperature_C":
            make_effect("temperature", where=where, temperature_C=v)
        else:
            effects_of_keys([(key, v)], where)


def _condition_key(key: str, where: str) -> None:
    if key in BASE_CONDITIONS:
        return
    ek = EffectKey.parse(key)
    if ek is None or ek.effect not in REGISTRY:
        raise UnknownNameError("condition", key, list(BASE_CONDITIONS) + ["<whole-robot effect>.<param>"], where)
    eff = REGISTRY[ek.effect]
    if eff.per_joint or ek.effect in ("payload", "temperature"):
        why = "is per joint: sample it as a fault kind" if eff.per_joint else "is set by payload_kg / temperature_C"
        raise ParameterError(f"{where}: condition {key!r}: effect {ek.effect!r} {why}")
    eff.param(ek.param)  # unknown parameter -> lists the effect's parameters


def _trajectory_dists(spec: Any, where: str) -> tuple[Any, dict[str, Dist]]:
    """The trajectory's fixed spec and its drawn options."""
    if not isinstance(spec, Mapping):
        return spec, {}
    fixed, drawn = {}, {}
    for k, v in spec.items():
        d = parse_dist(v, f"{where}.{k}") if isinstance(v, (Mapping, list)) else Dist("fixed", (v,))
        if d.drawn and d.kind not in ("integers", "choices"):
            raise ParameterError(f"{where}.{k}: trajectory options are drawn from integers or choices only "
                                 f"(runs must share trajectories to step in lockstep batches)")
        (drawn if d.drawn else fixed)[k] = d if d.drawn else v
    return fixed, drawn


def unit_design(method: str, n: int, d: int, seed: int) -> np.ndarray:
    """``(n, d)`` points in the unit cube: Latin hypercube (here) or scrambled Sobol (scipy)."""
    if d == 0:
        return np.zeros((n, 0))
    if method == "lhs":
        rng = np.random.default_rng(seed)
        return np.stack([(rng.permutation(n) + rng.random(n)) / n for _ in range(d)], axis=1)
    from scipy.stats import qmc

    try:
        sobol = qmc.Sobol(d, scramble=True, rng=seed)
    except TypeError:  # scipy < 1.15 names it seed
        sobol = qmc.Sobol(d, scramble=True, seed=seed)
    return sobol.random_base2(max(0, math.ceil(math.log2(n))))[:n]


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
    if not isinstance(spec, Mapping):
        raise ParameterError(f"{loc} must be a mapping with keys {', '.join(SAMPLE_KEYS)}")
    for key in spec:
        if key not in SAMPLE_KEYS:
            raise UnknownNameError("key", key, SAMPLE_KEYS, loc)
    n = spec.get("n")
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_RUNS:
        raise ParameterError(f"{loc}.n = {n!r} must be an integer in [1, {MAX_RUNS}]")
    method = spec.get("method", "lhs")
    if method not in METHODS:
        raise UnknownNameError("sampling method", method, METHODS, f"{loc}.method")
    seed = spec.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError(f"{loc}.seed = {seed!r} must be a non-negative integer")
    faults = spec.get("faults") or {"healthy": {}}
    if not isinstance(faults, Mapping):
        raise ParameterError(f"{loc}.faults must be a mapping of fault kind -> {{weight, size, direction}}")
    kinds = [_parse_kind(str(k), v, f"{loc}.faults.{k}") for k, v in faults.items()]
    joints = spec.get("joints", [1, 2, 3, 4, 5, 6])
    if not isinstance(joints, list) or not joints:
        raise ParameterError(f"{loc}.joints must be a non-empty list of joints 1..6")
    joints = [joint_index(j, f"{loc}.joints") + 1 for j in joints]
    twins = spec.get("twins", "all")
    if twins == "all":
        twin_kinds = {k.name for k in kinds}
    elif twins == "none":
        twin_kinds = set()
    elif isinstance(twins, list):
        for t in twins:
            if t not in {k.name for k in kinds}:
                raise UnknownNameError("twin kind", t, [k.name for k in kinds], f"{loc}.twins")
        twin_kinds = set(twins)
    else:
        raise ParameterError(f"{loc}.twins = {twins!r} must be all, none or a list of fault kinds")
    conds = spec.get("conditions") or {}
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

    weights = np.array([k.weight for k in kinds])
    cum = np.cumsum(weights) / weights.sum()
    drawn_conds = [k for k, d in cond_dists.items() if d.drawn]
    dims = ["kind", "joint", "size", "sign"] + drawn_conds + [f"trajectory.{k}" for k in traj_drawn]
    u = unit_design(method, n, len(dims), seed)
    col = {name: u[:, i] for i, name in enumerate(dims)}
    runs = []
    trajectories: dict[str, Any] = {}
    for r in range(n):
        kind = kinds[min(int(np.searchsorted(cum, col["kind"][r], side="right")), len(kinds) - 1)]
        cond = dict(cond0)
        for key, d in cond_dists.items():
            cond[key] = d.value(col[key][r]) if d.drawn else d.args[0]
        if traj_drawn:
            traj = {**traj_fixed, **{k: d.value(col[f"trajectory.{k}"][r]) for k, d in traj_drawn.items()}}
        else:
            traj = traj_fixed
        cond["trajectory"] = traj
        trajectories.setdefault(repr(traj), traj)
        fault: dict[str, Any] = {}
        if kind.size is not None and kind.param is not None:
            size = kind.size.value(col["size"][r])
            sign = -1.0 if kind.direction == "down" or (kind.direction == "both" and col["sign"][r] < 0.5) else 1.0
            value = float(f"{kind.param.absent + sign * size:.{SIGNIFICANT_DIGITS + 2}g}")
            fault[f"{kind.name}.{kind.param.name}"] = value
            if REGISTRY[kind.name].per_joint:
                fault[f"{kind.name}.joint"] = joints[min(int(col["joint"][r] * len(joints)), len(joints) - 1)]
        runs.append((cond, fault, kind.name in twin_kinds and bool(fault)))
    for traj in trajectories.values():  # every trajectory builds, before any simulation
        tloc = f"{loc}.conditions.trajectory {json.dumps(traj, sort_keys=True)}"
        try:
            parse_trajectory(traj, tloc)
        except Ur5FaultError as exc:
            if str(exc).startswith(tloc):
                raise
            raise ParameterError(f"{tloc}: {exc}") from None
    keys = [k.name for k in kinds if k.size is not None] + drawn_conds + [f"trajectory.{k}" for k in traj_drawn]
    return runs, keys
