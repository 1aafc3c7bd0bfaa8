"""Campaign specification: the YAML file validated and expanded into runs (before any simulation).

Campaign YAML (see campaigns/default.yaml)::

    name: default
    out: results/default            # output folder (``--out`` overrides)
    trajectory: pick_and_place      # name or {name: ..., speed_scale: ...}; may also be swept
    base: {seed: 0, payload_kg: 2.0, temperature_C: 28.0, effects: [], params: {}}
    sweep:                          # Cartesian product of every key's list
      backlash.joint: [1, 2, 3, 4, 5, 6]
      backlash.backlash_deg: [0, 0.02, 0.05, 0.1, 0.2, 0.5]
    zip:                            # groups whose lists vary together (one axis per group)
      - {payload_kg: [1.0, 2.0], temperature_C: [25.0, 40.0]}
    split: {by: trajectory_seed, test_fraction: 0.25, seed: 0}   # train/test column (campaign/labels.py)
    threshold_mm: 0.5               # TCP acceptability threshold of the summary
    batch_size: 32                  # runs stepped in lockstep per batch
    log_period_s: 0.001
    save_timeseries: false
    twin_residuals: false           # give every run its digital twin and the twin residual features
                                    # (ur5fault/health/twin_features.py); about twice the simulation
    motor_encoders: true            # false: log like a UR robot (no motor-side encoder): every feature of
                                    # the encoder mismatch is NaN (ur5fault/health/signals.py)

Sweep keys: ``seed``, ``payload_kg``, ``temperature_C``, ``trajectory`` (conditions), and
``<effect>.<parameter>`` / ``<effect>.joint`` for any entry of the effect registry (faults).
Each run is compared with its *healthy twin*: the run with the same conditions and no swept
fault, which the campaign adds and simulates in the same batch.

Instead of ``sweep``/``zip``, a ``sample:`` section draws N runs by Latin hypercube or Sobol
sampling over fault kinds, joints, sizes and nuisance conditions (format in :mod:`.sampling`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import itertools
import json
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import yaml

from ..config import (
    Overlay,
    check_duration,
    check_keys,
    check_log_period,
    check_mapping,
    check_seed,
    parse_effects,
    parse_trajectory,
)
from ..errors import ParameterError, UnknownNameError
from ..sim.axes import joint_index
from ..sim.effects import REGISTRY, EffectKey, EffectSpec, effects_of_keys
from ..sim.params import deep_merge, load_params, read_yaml
from ..util.checks import check_bool, check_int, check_number, check_text, short
from .labels import SplitRule, parse_split
from .sampling import sample_runs

CAMPAIGN_KEYS = ("name", "out", "trajectory", "base", "sweep", "zip", "threshold_mm", "batch_size",
                 "log_period_s", "save_timeseries", "duration_s", "split", "sample", "twin_residuals",
                 "motor_encoders")
BASE_KEYS = ("seed", "payload_kg", "temperature_C", "effects", "params")
CONDITION_KEYS = ("seed", "payload_kg", "temperature_C", "trajectory")
#: largest grid expanded at all (checked from the list lengths before expanding; assumption: a
#: million runs is ~ 3e11 physics steps, far beyond one machine, and its run list alone ~ 1 GB)
MAX_RUNS = 1_000_000
#: largest TCP acceptability threshold [mm]: the UR5's reach is 850 mm
MAX_THRESHOLD_MM = 1000.0


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


@dataclasses.dataclass(frozen=True)
class Campaign:
    """A validated campaign file."""

    name: str
    path: Path | None
    text: str
    out: Path
    base_effects: tuple[EffectSpec, ...]
    base_params: Mapping[str, Any]
    runs: tuple[CampaignRun, ...]  # unique, twins included
    swept_keys: tuple[str, ...]
    threshold_mm: float
    batch_size: int
    log_period_s: float
    save_timeseries: bool
    duration_s: float | None
    data: Mapping[str, Any] = dataclasses.field(default_factory=dict)  # the validated mapping (JSON-able)
    split: SplitRule = SplitRule()  # train/test split of the feature rows (campaign/labels.py)
    twin_residuals: bool = False  # every run gets its digital twin and the twin residual features
    #: False: the runs are logged like a UR robot's, without the motor-side encoder (its features are NaN)
    motor_encoders: bool = True

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()


def _as_list(value: Any, where: str) -> list:
    if not isinstance(value, list) or not value:
        raise ParameterError(f"{where}: expected a non-empty list of values, got {short(value)}")
    return value


def _check_value(key: Any, value: Any, where: str) -> Any:
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
        parse_trajectory(value, where)
        return value if isinstance(value, str) else dict(value)
    ek = EffectKey.parse(key)
    if ek is None or ek.effect not in REGISTRY:
        valid = list(CONDITION_KEYS) + [f"{e}.<param>" for e in REGISTRY]
        raise UnknownNameError("sweep key", key if isinstance(key, str) else short(key), valid, where)
    eff = REGISTRY[ek.effect]
    if ek.param == "joint":
        if not eff.per_joint:
            raise ParameterError(f"{where}: effect {ek.effect!r} acts on the whole robot and takes no joint")
        return joint_index(value, where) + 1
    p = eff.param(ek.param, where)
    return check_number(value, f"{where}: {key}", p.lo, p.hi, p.unit)


#: the example campaigns shipped inside the package (``ur5fault campaign run paper``)
SHIPPED_DIR = Path(__file__).resolve().parent.parent / "campaigns"


def shipped_campaigns() -> list[str]:
    """Names of the campaign files shipped with the package (``default``, ``paper``, ...)."""
    return sorted(p.stem for p in SHIPPED_DIR.glob("*.yaml"))


def resolve_campaign(path: str | Path) -> Path:
    """A campaign file: an existing path, or the name of a shipped campaign (``paper`` or ``paper.yaml``).

    A path that exists always wins, so a user's own ``paper.yaml`` in the working folder is the one run.
    """
    p = Path(path)
    if p.exists() or p.parent != Path("."):
        return p
    shipped = SHIPPED_DIR / (p.name if p.suffix in (".yaml", ".yml") else f"{p.name}.yaml")
    if shipped.is_file():
        return shipped
    from ..errors import ConfigFileError

    raise ConfigFileError(f"{p}: no such file, and no shipped campaign of that name "
                          f"(shipped: {', '.join(shipped_campaigns())})")


def load_campaign(path: str | Path, out: str | Path | None = None, overlay: str | Path | None = None,
                  duration_s: float | None = None) -> Campaign:
    """Read and validate a campaign file; every error names the file and key path.

    ``overlay``: a model overlay YAML (``params`` and ``effects``, e.g. written by ``ur5fault
    discrepancy``) merged into the campaign's ``base``: its parameters under the campaign's own, its
    effects before them.  ``duration_s`` replaces the file's (a quick trial of a campaign).  The merged text is
    what the manifest records.  ``path`` may also name a shipped campaign (:func:`resolve_campaign`).
    """
    path = resolve_campaign(path)
    data = read_yaml(path)
    text = path.read_text()
    if overlay is not None:
        ov_path = Path(overlay)
        Overlay.load(ov_path)  # validated with its own file name in messages
        ov = read_yaml(ov_path)
        base = dict(check_mapping(data.get("base"), f"{path.name}: base"))
        own = dict(check_mapping(base.get("params"), f"{path.name}: base.params"))
        base["params"] = deep_merge(dict(ov.get("params") or {}), own)
        own_effects = base.get("effects") or []
        if not isinstance(own_effects, list):
            raise ParameterError(f"{path.name}: base.effects: expected a list of effects")
        base["effects"] = list(ov.get("effects") or []) + own_effects
        data = {**data, "base": base}
        text = yaml.safe_dump(dict(data), sort_keys=False)
    if duration_s is not None:
        data = {**data, "duration_s": duration_s}
        text = yaml.safe_dump(dict(data), sort_keys=False)
    return build_campaign(data, path.name, text, path, out)


def build_campaign(data: Mapping[str, Any], where: str, text: str = "", path: Path | None = None,
                   out: str | Path | None = None) -> Campaign:
    """Validate a campaign mapping and expand it into runs (twins included); nothing is simulated.

    Every value that reaches the engine is checked here: types (no bool or string as a number),
    finiteness, ranges, the log period against the physics step, and the grid size before expanding.
    """
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where}: expected a mapping of campaign keys, got {short(data)}")
    check_keys(data, CAMPAIGN_KEYS, where)
    base = check_mapping(data.get("base"), f"{where}: base")
    check_keys(base, BASE_KEYS, f"{where}: base")
    params = dict(check_mapping(base.get("params"), f"{where}: base.params"))
    robot = load_params(overrides=params, where=f"{where}: base.params")  # validate robot overrides now
    base_effects = parse_effects(base.get("effects"), f"{where}: base.effects")
    cond0 = _base_conditions(data, base, where)
    axes, swept = _sweep_axes(data, where)
    sampled = data.get("sample") is not None  # a sampled campaign (campaign/sampling.py) instead of a grid
    if sampled and (axes or swept):
        raise ParameterError(f"{where}: sample cannot be combined with sweep or zip; use one of them")
    if sampled:
        runs, swept = _sampled_runs(data["sample"], cond0, where)
    else:
        runs = _grid_runs(axes, cond0)
    thr = check_number(data.get("threshold_mm", 0.5), f"{where}: threshold_mm", 0.0, MAX_THRESHOLD_MM, "mm",
                       lo_open=True)
    bs = check_int(data.get("batch_size", 32), f"{where}: batch_size", 1, 1024)
    dur = data.get("duration_s")
    dur = None if dur is None else check_duration(dur, f"{where}: duration_s")
    shortest = dur if dur is not None else min(
        parse_trajectory(t, f"{where}: trajectory").duration_s for t in trajectory_specs(runs.values()))
    lp = check_log_period(data.get("log_period_s", 1e-3), f"{where}: log_period_s", robot.physics_dt_s, shortest)
    save_ts = check_bool(data.get("save_timeseries", False), f"{where}: save_timeseries")
    twin_res = check_bool(data.get("twin_residuals", False), f"{where}: twin_residuals")
    motor_enc = check_bool(data.get("motor_encoders", True), f"{where}: motor_encoders")
    name = check_text(data["name"], f"{where}: name") if data.get("name") is not None else (
        path.stem if path else "campaign")
    file_out = check_text(data["out"], f"{where}: out", max_len=4096) if data.get("out") is not None else None
    out = out if out is not None else file_out
    out_dir = Path(out) if out is not None else Path("results") / name
    resolved = {**dict(data), "base": {**dict(base), "params": params}}
    return Campaign(name, path, text or yaml.safe_dump(dict(data)), out_dir, base_effects, params,
                    tuple(runs.values()), tuple(swept), thr, bs, lp, save_ts, dur, resolved,
                    parse_split(data.get("split"), where), twin_res, motor_enc)


def _base_conditions(data: Mapping[str, Any], base: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The conditions every run starts from (seed, payload, temperature, trajectory), validated."""
    return {
        "seed": _check_value("seed", base.get("seed", 0), f"{where}: base.seed"),
        "payload_kg": _check_value("payload_kg", base.get("payload_kg", 2.0), f"{where}: base.payload_kg"),
        "temperature_C": _check_value("temperature_C", base.get("temperature_C", 28.0),
                                      f"{where}: base.temperature_C"),
        "trajectory": _check_value("trajectory", data.get("trajectory", "pick_and_place"), f"{where}: trajectory"),
    }


def _sweep_axes(data: Mapping[str, Any], where: str) -> tuple[list[list[dict[str, Any]]], list[str]]:
    """The grid's axes (``sweep`` keys one axis each, a ``zip`` group one axis) with checked values, and the
    swept keys; the grid's size is checked before anything is expanded."""
    axes: list[list[dict[str, Any]]] = []
    swept: list[str] = []
    sweep = check_mapping(data.get("sweep"), f"{where}: sweep")
    for key, values in sweep.items():
        loc = f"{where}: sweep.{key}"
        vals = [_check_value(key, v, loc) for v in _as_list(values, loc)]
        axes.append([{key: v} for v in vals])
        swept.append(key)
    zips = data.get("zip") or []
    if not isinstance(zips, list):
        raise ParameterError(f"{where}: zip must be a list of groups (mappings of key -> list)")
    for g, group in enumerate(zips):
        loc = f"{where}: zip[{g}]"
        if not isinstance(group, Mapping) or not group:
            raise ParameterError(f"{loc}: expected a mapping of key -> list of values")
        lists = {k: _as_list(v, f"{loc}.{k}") for k, v in group.items()}
        lengths = {len(v) for v in lists.values()}
        if len(lengths) != 1:
            raise ParameterError(f"{loc}: zipped lists must have equal lengths, got {sorted(lengths)}")
        axes.append([{k: _check_value(k, lists[k][i], f"{loc}.{k}[{i}]") for k in lists}
                     for i in range(lengths.pop())])
        swept.extend(lists)
    if len(set(swept)) != len(swept):
        dup = sorted({k for k in swept if swept.count(k) > 1})
        raise ParameterError(f"{where}: key swept twice: {', '.join(dup)}")
    _check_fault_keys(swept, where)
    check_grid_size([len(a) for a in axes], where)
    return axes, swept


def _grid_runs(axes: Sequence[Sequence[Mapping[str, Any]]], cond0: Mapping[str, Any]) -> dict[str, CampaignRun]:
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


def _sampled_runs(spec: Any, cond0: Mapping[str, Any], where: str) -> tuple[dict[str, CampaignRun], list[str]]:
    """The drawn runs (with their twins where wanted) by run_id, and the drawn keys."""
    runs: dict[str, CampaignRun] = {}
    drawn, swept = sample_runs(spec, cond0, where)
    for cond, faults, wants_twin in drawn:
        rc = CampaignRun(tuple(sorted(cond.items())), tuple(sorted(faults.items())))  # validates them
        for r in (rc, rc.twin()) if wants_twin else (rc,):
            runs.setdefault(r.run_id, r)
    return runs, swept


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
            sizes = ", ".join(f"'{name}.{p.name}' [{p.unit}]" for p in REGISTRY[name].params)
            raise ParameterError(f"{where}: sweep of effect {name!r} gives joints but no size; sweep {sizes} too")


