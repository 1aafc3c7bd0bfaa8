"""A campaign's runs: one run's specification (conditions and faults, its identity and healthy twin) and the
grid of ``sweep``/``zip`` axes expanded into runs, every value checked before anything is simulated.

The campaign file's other keys, its loading and the sampled (``sample:``) runs are :mod:`.spec`'s.
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from ..config import CONDITION_EFFECTS, check_mapping, check_seed, parse_trajectory, trajectory_key
from ..errors import ParameterError, UnknownNameError
from ..sim.axes import joint_index
from ..sim.effect_types import EffectKey
from ..sim.effects import REGISTRY, EffectSpec, effects_of_keys
from ..util.checks import check_number, short
from ..util.yamlsafe import plain

CONDITION_KEYS = ("seed", "payload_kg", "temperature_C", "trajectory")
#: largest grid expanded at all (checked from the list lengths before expanding; assumption: a
#: million runs is ~ 3e11 physics steps, far beyond one machine, and its run list alone ~ 1 GB)
MAX_RUNS = 1_000_000

@dataclasses.dataclass(frozen=True)
class CampaignRun:
    """One run of a campaign, fully specified (hashable, JSON-able)."""

    conditions: tuple[tuple[str, Any], ...]  # seed, payload_kg, temperature_C, trajectory
    faults: tuple[tuple[str, Any], ...]  # swept fault keys -> values, sorted
    #: the faults as validated effects, built once when the run is (not compared: they follow from ``faults``)
    _effects: tuple[EffectSpec, ...] = dataclasses.field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        effects = tuple(e for e in effects_of_keys(self.faults) if not e.is_absent)
        object.__setattr__(self, "_effects", effects)

    @property
    def cond(self) -> dict[str, Any]:
        return dict(self.conditions)

    def is_healthy(self) -> bool:
        return not self._effects

    def fault_effects(self) -> tuple[EffectSpec, ...]:
        """Effects of the swept faults (validated when the run was built); those at their 'absent' value
        are dropped."""
        return self._effects

    def twin(self) -> CampaignRun:
        return CampaignRun(self.conditions, ())

    @property
    def run_id(self) -> str:
        """Stable identifier: a hash of the run's conditions and (effective) faults."""
        eff = [(e.name, e.joint, e.values) for e in self.fault_effects()]
        key = json.dumps([sorted(self.conditions), eff], sort_keys=True, default=str)
        return "r" + hashlib.sha1(key.encode()).hexdigest()[:12]


def as_list(value: Any, where: str) -> list:
    """``value`` as a non-empty list, or one line saying it is not."""
    if not isinstance(value, list) or not value:
        raise ParameterError(f"{where}: expected a non-empty list of values, got {short(value)}")
    return value


def refuse_trajectory_payload(spec: Any, where: str) -> None:
    """A campaign run's payload is its ``payload_kg`` condition (``base.payload_kg``, swept or drawn), applied last:
    a trajectory's own ``payload_kg`` option (which ``simulate`` honours) would be silently replaced by it."""
    if isinstance(spec, Mapping) and "payload_kg" in spec:
        raise ParameterError(f"{where}: payload_kg: a campaign run's payload is its payload_kg condition, which "
                             "replaces the trajectory's: give it as base.payload_kg (or sweep payload_kg)")


def check_value(key: Any, value: Any, where: str) -> Any:
    """Validate one swept (or base) value now, before any simulation starts."""
    if key == "seed":
        return check_seed(value, where)
    if key == "payload_kg":
        p = REGISTRY["payload"].param("mass_kg")
        return check_number(value, where, p.lo, p.hi, p.unit)
    if key == "temperature_C":
        p = REGISTRY["temperature"].param("temperature_C")
        return check_number(value, where, p.lo, p.hi, p.unit)
    if key == "trajectory":
        refuse_trajectory_payload(value, where)
        parse_trajectory(value, where)
        return value if isinstance(value, str) else plain(dict(value))  # numpy options: the numbers they hold
    ek = EffectKey.parse(key)
    if ek is None or ek.effect not in REGISTRY:
        valid = list(CONDITION_KEYS) + [f"{e}.<param>" for e in REGISTRY]
        raise UnknownNameError("sweep key", key if isinstance(key, str) else short(key), valid, where)
    eff = REGISTRY[ek.effect]
    if ek.effect in CONDITION_EFFECTS:  # every run's own payload_kg / temperature_C would be applied after it
        raise ParameterError(f"{where}: {key!r} is set by every run's {CONDITION_EFFECTS[ek.effect]}: sweep "
                             f"{CONDITION_EFFECTS[ek.effect]} instead")
    if ek.param == "joint":
        if not eff.per_joint:
            raise ParameterError(f"{where}: effect {ek.effect!r} acts on the whole robot and takes no joint")
        return joint_index(value, where) + 1
    p = eff.param(ek.param, where)
    return check_number(value, f"{where}: {key}", p.lo, p.hi, p.unit)


def sweep_axes(data: Mapping[str, Any], where: str) -> tuple[list[list[dict[str, Any]]], list[str]]:
    """The grid's axes (``sweep`` keys one axis each, a ``zip`` group one axis) with checked values, and the
    swept keys; the grid's size is checked before anything is expanded."""
    axes: list[list[dict[str, Any]]] = []
    swept: list[str] = []
    sweep = check_mapping(data.get("sweep"), f"{where}: sweep")
    for key, values in sweep.items():
        loc = f"{where}: sweep.{key}"
        vals = [check_value(key, v, loc) for v in as_list(values, loc)]
        first: dict[str, int] = {}
        for i, v in enumerate(vals):  # the same value twice is the same run, kept once: the grid would shrink silently
            same = trajectory_key(v) if key == "trajectory" else json.dumps(v, sort_keys=True, default=str)
            i0 = first.setdefault(same, i)
            if i0 != i:
                raise ParameterError(f"{loc}[{i}]: {short(values[i])} repeats [{i0}] ({short(values[i0])}); give each "
                                     "value once")
        axes.append([{key: v} for v in vals])
        swept.append(key)
    zips = data.get("zip") or []
    if not isinstance(zips, list):
        raise ParameterError(f"{where}: zip must be a list of groups (mappings of key -> list)")
    for g, group in enumerate(zips):
        loc = f"{where}: zip[{g}]"
        if not isinstance(group, Mapping) or not group:
            raise ParameterError(f"{loc}: expected a mapping of key -> list of values")
        lists = {k: as_list(v, f"{loc}.{k}") for k, v in group.items()}
        lengths = {len(v) for v in lists.values()}
        if len(lengths) != 1:
            raise ParameterError(f"{loc}: zipped lists must have equal lengths, got {sorted(lengths)}")
        axes.append([{k: check_value(k, lists[k][i], f"{loc}.{k}[{i}]") for k in lists}
                     for i in range(lengths.pop())])
        swept.extend(lists)
    if len(set(swept)) != len(swept):
        dup = sorted({k for k in swept if swept.count(k) > 1})
        raise ParameterError(f"{where}: key swept twice: {', '.join(dup)}")
    _check_fault_keys(swept, where)
    check_grid_size([len(a) for a in axes], where)
    return axes, swept


def grid_runs(axes: Sequence[Sequence[Mapping[str, Any]]], cond0: Mapping[str, Any]) -> dict[str, CampaignRun]:
    """Every point of the grid and its healthy twin, by run_id (a repeated point is kept once)."""
    runs: dict[str, CampaignRun] = {}
    for combo in itertools.product(*axes) if axes else [()]:
        values: dict[str, Any] = {}
        for part in combo:
            values.update(part)
        cond = {**cond0, **{k: v for k, v in values.items() if k in CONDITION_KEYS}}
        faults = tuple(sorted((k, v) for k, v in values.items() if k not in CONDITION_KEYS))
        rc = CampaignRun(tuple(sorted(cond.items(), key=lambda kv: kv[0])), faults)
        if rc.is_healthy():  # (built, so validated) a fault at its "absent" value: the healthy run
            rc = rc.twin()   # itself, stored without faults whichever sweep point made it
        for r in (rc, rc.twin()):
            runs.setdefault(r.run_id, r)
    return runs


def trajectory_specs(runs: Iterable[CampaignRun]) -> list[Any]:
    """The distinct trajectory specifications of ``runs``, in first-seen order."""
    seen: dict[str, Any] = {}
    for r in runs:
        seen.setdefault(json.dumps(r.cond["trajectory"], sort_keys=True), r.cond["trajectory"])
    return list(seen.values())


def check_grid_size(axis_lengths: Sequence[int], where: str) -> int:
    """Number of grid points of the axes; refuse above :data:`MAX_RUNS` before expanding."""
    n = 1
    for length in axis_lengths:
        n *= length
    if n > MAX_RUNS:
        raise ParameterError(f"{where}: the sweep expands to {n:.3g} runs, above the limit of {MAX_RUNS:g}; "
                             "sweep fewer values")
    return n


def _check_fault_keys(swept: Sequence[str], where: str) -> None:
    """A per-joint effect that is swept needs its joint swept (or a single joint) too, and a swept joint needs a
    size: sweeping only ``backlash.joint`` would give runs of size 0, which are healthy runs."""
    effects = {ek.effect for ek in map(EffectKey.parse, swept) if ek is not None}
    for name in sorted(effects):
        if REGISTRY[name].per_joint and f"{name}.joint" not in swept:
            raise ParameterError(f"{where}: sweep of effect {name!r} needs '{name}.joint' (list of joints 1..6)")
        if swept.count(f"{name}.joint") and not [k for k in swept if k.startswith(f"{name}.") and k != f"{name}.joint"]:
            sizes = ", ".join(f"'{name}.{p.name}'{p.unit_text(' [{}]')}" for p in REGISTRY[name].params)
            raise ParameterError(f"{where}: sweep of effect {name!r} gives joints but no size; sweep {sizes} too")
