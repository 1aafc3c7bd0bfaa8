"""YAML run configuration shared by ``simulate``, campaigns and model overlays.

A run configuration (``ur5fault simulate --config run.yaml``)::

    trajectory: pick_and_place        # or {name: pick_and_place, speed_scale: 0.5}
    seed: 0
    payload_kg: 2.0                   # gripped mass (trajectory default when absent)
    temperature_C: 28.0               # all joints
    duration_s: 13.0                  # default: the whole trajectory
    log_period_s: 0.001
    effects:                          # any entry of the effect registry
      - {effect: backlash, joint: shoulder_lift_joint, backlash_deg: 0.1}
    params: {gear: {damping_Nms_per_rad: [18, 24, 14, 1.2, 1.2, 0.36]}}   # overrides of the robot parameters

A *model overlay* (written by the discrepancy workflow, accepted by ``--model``) holds the
``params`` and ``effects`` keys only; they are merged into every run.
"""

from __future__ import annotations

import dataclasses
import inspect
import json
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .errors import ConfigFileError, ParameterError, UnknownNameError
from .sim.budget import MAX_DURATION_S, check_memory, sim_bytes
from .sim.effects import EffectSpec, effect_of, make_effect
from .sim.params import RobotParams, deep_merge, load_params, read_yaml
from .sim.runspec import MAX_SEED
from .sim.trajectories import TRAJECTORIES, Trajectory, get_trajectory
from .sim.trajectories.base import OPTION_RANGES
from .sim.trajectories.fixed import check_speed_scale
from .util.checks import check_int, check_number, is_real, short
from .util.results import check_whole

#: numeric trajectory options and their valid ranges (written once, in the trajectories: each function checks its
#: own options against them too)
TRAJECTORY_OPTIONS = OPTION_RANGES
RUN_KEYS = ("trajectory", "seed", "payload_kg", "temperature_C", "duration_s", "log_period_s", "effects", "params")
OVERLAY_KEYS = ("params", "effects")


def parse_effects(items: Any, where: str) -> tuple[EffectSpec, ...]:
    """Parse a YAML list of effects ``[{effect: name, joint: j, <param>: value}, ...]``."""
    if items is None:
        return ()
    if not isinstance(items, Sequence) or isinstance(items, (str, bytes)):
        raise ParameterError(f"{where}: expected a list of effects")
    out = []
    for i, item in enumerate(items):
        loc = f"{where}[{i}]"
        if not isinstance(item, Mapping) or "effect" not in item:
            raise ParameterError(f"{loc}: each effect is a mapping with an 'effect' key (and its parameters)")
        values = {k: v for k, v in item.items() if k not in ("effect", "joint")}
        out.append(effect_of(str(item["effect"]), item.get("joint"), values, loc))
    return tuple(out)


def refuse_repeats(effects: Sequence[EffectSpec], where: str) -> None:
    """One effect per joint in a run's own list: a second ``backlash`` on the same joint would silently replace
    the first (an effect that sets a value keeps the last) or compound with it (one that scales), neither of
    which a user giving two sizes means.  Harmonics of different periods are different effects and may repeat.
    (A model overlay's list is not checked: ``discrepancy`` writes a finding on top of its starting model's effect
    of the same kind on purpose.)"""
    seen: dict[tuple, int] = {}
    for i, e in enumerate(effects):
        key = effect_key(e)
        if key in seen:
            raise ParameterError(f"{where}[{i}]: {e.describe()} repeats {where.rsplit(': ', 1)[-1]}[{seen[key]}] "
                                 f"({effects[seen[key]].describe()}); give each effect once"
                                 + (" per joint" if e.joint is not None else ""))
        seen[key] = i


#: whole-robot effects that a run condition also sets, and the condition's key
CONDITION_EFFECTS = {"payload": "payload_kg", "temperature": "temperature_C"}


def refuse_condition_effects(effects: Sequence[EffectSpec], where: str, given: Mapping[str, Any],
                             how: str = "") -> None:
    """An effect in a run's list that a condition key given beside it (``payload_kg``, ``temperature_C``) would set
    again: the condition is applied last and would silently win, so the pair is refused.  ``how`` names where the
    condition key came from (e.g. the command-line option)."""
    for i, e in enumerate(effects):
        key = CONDITION_EFFECTS.get(e.name)
        if key is not None and given.get(key) is not None:
            raise ParameterError(f"{where}[{i}]: {e.describe()} and {key} = {given[key]!r}{how} both set the "
                                 f"{e.name}: give it once (as {key})")


def effect_key(e: EffectSpec) -> tuple:
    """What makes two effects the same one (:func:`refuse_repeats`): kind, joint and, for harmonics, the period."""
    return e.name, e.joint, dict(e.values).get("periods_per_rev")


def repeats_of(base: Sequence[EffectSpec], added: Sequence[EffectSpec]) -> list[tuple[EffectSpec, EffectSpec]]:
    """Pairs (``base`` effect, ``added`` effect) of the same kind on the same joint (as :func:`refuse_repeats`
    counts them): a run's effect given on top of its model overlay's, which is allowed but worth a note."""
    first = {effect_key(e): e for e in base}
    return [(first[effect_key(e)], e) for e in added if effect_key(e) in first]


def trajectory_key(spec: Any) -> str:
    """What makes two valid trajectory specs the same motion: the name and every option, a default filled in and a
    number as a float (``pick_and_place``, ``{name: pick_and_place}`` and ``{name: pick_and_place, speed_scale: 1}``
    are one). For telling repeats apart only: a run's identity keeps its spec as written."""
    name, given = (spec, {}) if isinstance(spec, str) else (spec["name"], {k: v for k, v in spec.items()
                                                                          if k != "name"})
    options = {k: p.default for k, p in inspect.signature(TRAJECTORIES[name]).parameters.items()
               if p.default is not inspect.Parameter.empty}
    options.update(given)

    def canon(v):
        if isinstance(v, (list, tuple)):
            return [canon(x) for x in v]
        return float(v) if is_real(v) else v

    return json.dumps([name, {k: canon(v) for k, v in sorted(options.items())}], default=str)


def parse_trajectory(spec: Any, where: str) -> Trajectory:
    """``"name"`` or ``{name: ..., <option>: value}`` -> a :class:`Trajectory`.

    Options are checked before the trajectory is built: known names only (listed on error),
    finite numbers in :data:`TRAJECTORY_OPTIONS` ranges, ``q_rad`` six joint angles.
    """
    if isinstance(spec, str):
        if spec not in TRAJECTORIES:
            raise UnknownNameError("trajectory", spec, TRAJECTORIES, where)
        return get_trajectory(spec)
    if isinstance(spec, Mapping) and "name" in spec:
        name = spec["name"]
        if not isinstance(name, str) or name not in TRAJECTORIES:
            raise UnknownNameError("trajectory", name if isinstance(name, str) else short(name), TRAJECTORIES, where)
        valid = [k for k in inspect.signature(TRAJECTORIES[name]).parameters]
        kwargs = {}
        for key, value in spec.items():
            if key == "name":
                continue
            if key not in valid:
                raise UnknownNameError(f"option of trajectory {name!r}", key, valid, where)
            kwargs[key] = _trajectory_option(key, value, f"{where}.{key}")
        try:
            return get_trajectory(name, **kwargs)
        except (TypeError, ValueError) as exc:
            if isinstance(exc, ParameterError):
                raise ParameterError(f"{where}: {exc}") from None
            raise ParameterError(f"{where}: {' '.join(str(exc).split())}") from None
    raise ParameterError(
        f"{where}: expected a trajectory name or a mapping with 'name'; valid: {', '.join(TRAJECTORIES)}")


def _trajectory_option(key: str, value: Any, where: str) -> Any:
    if key == "q_rad":
        if not isinstance(value, Sequence) or isinstance(value, str) or len(value) != 6:
            raise ParameterError(f"{where} = {short(value)} must be a list of 6 joint angles [rad]")
        return tuple(check_number(v, f"{where}[{j + 1}]", -2 * math.pi, 2 * math.pi, "rad")
                     for j, v in enumerate(value))
    if key == "seed":  # a trajectory family's seed (random_pick_and_place)
        return check_seed(value, where)
    if key == "speed_scale":  # the API's message, its bound rounded alike and the reason for it given
        return check_speed_scale(value, where)
    lo, hi, unit = TRAJECTORY_OPTIONS.get(key, (-math.inf, math.inf, ""))
    return check_number(value, where, lo, hi, unit)


def check_seed(value: Any, where: str) -> int:
    """A noise seed: an integer in [0, 2**63 - 1] (``1e9`` is the integer it means)."""
    return check_int(value, where, 0, MAX_SEED, "a non-negative integer")


def check_duration(value: Any, where: str) -> float:
    """Simulated time of one run [s]: a finite number in (0, MAX_DURATION_S]."""
    return check_number(value, where, 0.0, MAX_DURATION_S, "s", lo_open=True)


#: a run logs at least this many samples: its features take speeds and accelerations (first and second
#: differences) of the logged signals, which a run of one or two samples does not have
MIN_LOGGED_SAMPLES = 3


def check_log_period(value: Any, where: str, physics_dt_s: float, duration_s: float) -> float:
    """Log period [s]: a whole multiple of the physics step, :data:`MIN_LOGGED_SAMPLES` of them within the run."""
    lp = check_number(value, where, physics_dt_s, math.inf, "s")
    if MIN_LOGGED_SAMPLES * lp > max(duration_s, physics_dt_s) * (1 + 1e-9):  # said as what it is
        raise ParameterError(f"{where} = {short(value)} leaves fewer than {MIN_LOGGED_SAMPLES} logged samples in the "
                             f"run ({duration_s:g} s): its features take speeds and accelerations of them; lengthen "
                             "the run (duration_s, or --duration-s) or log more often")
    k = round(lp / physics_dt_s)
    if abs(k * physics_dt_s - lp) > 1e-12:
        raise ParameterError(f"{where} = {short(value)} must be a whole multiple of physics_dt_s = {physics_dt_s:g} s")
    return lp


def check_mapping(value: Any, where: str) -> Mapping[str, Any]:
    """An optional mapping (``None`` is empty)."""
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise ParameterError(f"{where} = {short(value)} must be a mapping of keys to values")
    return value


def check_keys(data: Mapping[str, Any], valid: Sequence[str], where: str) -> None:
    for key in data:
        if key not in valid:
            raise UnknownNameError("key", key, valid, where)


@dataclasses.dataclass(frozen=True)
class Overlay:
    """Model overlay: robot-parameter overrides and effects applied to every run."""

    params: Mapping[str, Any] = dataclasses.field(default_factory=dict)
    effects: tuple[EffectSpec, ...] = ()

    @classmethod
    def load(cls, path: str | Path) -> Overlay:
        path = Path(path)
        check_whole(path, "run the command that wrote it")  # a discrepancy's model.yaml: one file of a set
        refuse_json_overlay(path)
        return cls.from_data(read_yaml(path), path.name)

    @classmethod
    def from_data(cls, data: Any, where: str) -> Overlay:
        """An overlay's parsed YAML, validated as :meth:`load` validates a file (``where``: its name in errors)."""
        check_keys(data, OVERLAY_KEYS, where)
        params = check_mapping(data.get("params"), f"{where}: params")
        load_params(overrides=dict(params), where=f"{where}: params")  # validate now, with key paths
        return cls(dict(params), parse_effects(data.get("effects"), f"{where}: effects"))


#: where a model overlay comes from, said when another file is given for one
OVERLAY_FROM = "--baseline and --model take the model overlay YAML (model.yaml of discrepancy, or identify's)"


def refuse_json_overlay(path: Path) -> None:
    """Refuse in one line a JSON file (suffix ``.json`` or text starting with ``{``) given where a model overlay
    YAML is expected, saying what it is and where it goes: a monitor's ``baseline.json`` (1.7 MB, refused as too
    large for a YAML file before) goes to ``--baseline-stats``. A JSON mapping of overlay keys only is valid YAML
    and an overlay: read as before; unreadable files and text that is no JSON are left to the YAML reader."""
    from .util.yamlsafe import MAX_BYTES

    try:
        size = path.stat().st_size
        with path.open("rb") as fh:
            head = fh.read(4096).lstrip(b"\xef\xbb\xbf \t\r\n")
    except OSError:
        return
    if path.suffix.lower() != ".json" and not head.startswith(b"{"):
        return
    if head.startswith(b"{") and re.search(rb'"format"\s*:\s*"ur5fault-monitor-baseline', head[:400]):
        raise ConfigFileError(f"{path}: a monitor baseline (baseline.json): give it to --baseline-stats; "
                              f"{OVERLAY_FROM}")
    if size > MAX_BYTES:
        raise ConfigFileError(f"{path}: a JSON file of {size} bytes, not a model overlay; {OVERLAY_FROM}")
    try:
        data = json.loads(path.read_bytes().decode("utf-8-sig"))
    except (OSError, ValueError):
        return  # no JSON (a YAML flow mapping): the YAML reader's message
    if isinstance(data, dict) and set(data) & set(OVERLAY_KEYS):
        return  # an overlay written as JSON, perhaps with a misspelt key: the YAML reader names it ("did you mean")
    if not isinstance(data, dict) or data:
        what = (f"keys {', '.join(map(str, list(data)[:5]))}" if isinstance(data, dict) else
                "null" if data is None else f"a {type(data).__name__}")
        raise ConfigFileError(f"{path}: a JSON file ({what}), not a model overlay; {OVERLAY_FROM}")


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """A validated single-run configuration."""

    trajectory: Trajectory
    params: RobotParams
    effects: tuple[EffectSpec, ...]
    seed: int = 0
    duration_s: float | None = None
    log_period_s: float = 1e-3


def build_run_config(data: Mapping[str, Any], where: str = "config", overlay: Overlay | None = None,
                     labels: Mapping[str, str] | None = None) -> RunConfig:
    """Validate a run-configuration mapping (see the module docstring). ``labels``: the name an error gives a key
    whose value came from elsewhere (``simulate``'s flags: ``{"log_period_s": "--log-period-s"}``), instead of
    ``where: key``."""
    check_keys(data, RUN_KEYS, where)

    def label(key: str) -> str:
        return (labels or {}).get(key) or f"{where}: {key}"

    traj = parse_trajectory(data.get("trajectory", "pick_and_place"), f"{where}: trajectory")
    overrides = dict(check_mapping(data.get("params"), f"{where}: params"))
    if overlay is not None:
        overrides = deep_merge(dict(overlay.params), overrides)
    params = load_params(overrides=overrides, where=f"{where}: params")
    effects = parse_effects(data.get("effects"), f"{where}: effects")
    refuse_repeats(effects, f"{where}: effects")
    refuse_condition_effects(effects, f"{where}: effects", data)
    if overlay is not None:
        effects = overlay.effects + effects
    if data.get("payload_kg") is not None:
        effects += (make_effect("payload", where=label("payload_kg"), mass_kg=data["payload_kg"]),)
    if data.get("temperature_C") is not None:
        effects += (make_effect("temperature", where=label("temperature_C"), temperature_C=data["temperature_C"]),)
    seed = check_seed(data.get("seed", 0), label("seed"))
    dur = data.get("duration_s")
    duration = traj.duration_s if dur is None else check_duration(dur, label("duration_s"))
    lp = check_log_period(data.get("log_period_s", 1e-3), label("log_period_s"), params.physics_dt_s, duration)
    check_memory(sim_bytes(1, int(duration / lp)), f"{where}: a run of {duration:g} s logged every {lp:g} s",
                 "raise log_period_s or shorten duration_s")
    return RunConfig(traj, params, effects, seed, None if dur is None else duration, lp)
