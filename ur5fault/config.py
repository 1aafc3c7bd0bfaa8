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
    params: {gear: {damping_Nms_per_rad: 15}}   # overrides of the robot parameters

A *model overlay* (written by the discrepancy workflow, accepted by ``--model``) holds the
``params`` and ``effects`` keys only; they are merged into every run.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .effects import EffectSpec, make_effect
from .errors import ParameterError, UnknownNameError
from .params import RobotParams, deep_merge, load_params, read_yaml
from .trajectory import TRAJECTORIES, Trajectory, get_trajectory

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
        out.append(make_effect(str(item["effect"]), item.get("joint"), where=loc, **values))
    return tuple(out)


def parse_trajectory(spec: Any, where: str) -> Trajectory:
    """``"name"`` or ``{name: ..., <keyword>: value}`` -> a :class:`Trajectory`."""
    if isinstance(spec, str):
        return get_trajectory(spec)
    if isinstance(spec, Mapping) and "name" in spec:
        kwargs = {k: v for k, v in spec.items() if k != "name"}
        if spec["name"] not in TRAJECTORIES:
            raise UnknownNameError("trajectory", spec["name"], TRAJECTORIES, where)
        try:
            return get_trajectory(str(spec["name"]), **kwargs)
        except TypeError as exc:
            raise ParameterError(f"{where}: {exc}") from None
    raise ParameterError(
        f"{where}: expected a trajectory name or a mapping with 'name'; valid: {', '.join(TRAJECTORIES)}")


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
        data = read_yaml(path)
        check_keys(data, OVERLAY_KEYS, path.name)
        params = data.get("params") or {}
        if not isinstance(params, Mapping):
            raise ParameterError(f"{path.name}: params must be a mapping")
        load_params(overrides=dict(params))  # validate now, with key paths
        return cls(dict(params), parse_effects(data.get("effects"), f"{path.name}: effects"))


@dataclasses.dataclass(frozen=True)
class RunConfig:
    """A validated single-run configuration."""

    trajectory: Trajectory
    params: RobotParams
    effects: tuple[EffectSpec, ...]
    seed: int = 0
    duration_s: float | None = None
    log_period_s: float = 1e-3


def build_run_config(data: Mapping[str, Any], where: str = "config", overlay: Overlay | None = None) -> RunConfig:
    """Validate a run-configuration mapping (see the module docstring)."""
    check_keys(data, RUN_KEYS, where)
    traj = parse_trajectory(data.get("trajectory", "pick_and_place"), f"{where}: trajectory")
    overrides = dict(data.get("params") or {})
    if overlay is not None:
        overrides = deep_merge(dict(overlay.params), overrides)
    params = load_params(overrides=overrides)
    effects = parse_effects(data.get("effects"), f"{where}: effects")
    if overlay is not None:
        effects = overlay.effects + effects
    if data.get("payload_kg") is not None:
        effects += (make_effect("payload", where=f"{where}: payload_kg", mass_kg=data["payload_kg"]),)
    if data.get("temperature_C") is not None:
        effects += (make_effect("temperature", where=f"{where}: temperature_C", temperature_C=data["temperature_C"]),)
    seed = data.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError(f"{where}: seed = {seed!r} must be a non-negative integer")
    dur = data.get("duration_s")
    if dur is not None and (not isinstance(dur, (int, float)) or dur <= 0):
        raise ParameterError(f"{where}: duration_s = {dur!r} must be a positive number of seconds")
    lp = data.get("log_period_s", 1e-3)
    if not isinstance(lp, (int, float)) or lp <= 0:
        raise ParameterError(f"{where}: log_period_s = {lp!r} must be a positive number of seconds")
    return RunConfig(traj, params, effects, seed, None if dur is None else float(dur), float(lp))
