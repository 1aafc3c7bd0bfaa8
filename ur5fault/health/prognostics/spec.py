"""Life campaigns: a fleet of units run to failure, validated from YAML before anything runs.

Life campaign YAML (see campaigns/prognostics.yaml)::

    name: prognostics
    out: results/prognostics/fleet
    life:
      units: 100                    # fleet size
      seed: 0                       # decides every unit's duty, wear rates, increments and noise
      interval_cycles: 80000        # duty cycles between two inspections
      max_cycles: 6000000           # a unit still sound here is right-censored
      failure: {feature: tcp_dev_max_mm, threshold: 0.5}   # default: the paper's 0.5 mm TCP deviation
      wear: {backlash_rate_deg_per_MJ: 1.3e-3, unit_sigma: 0.25, ...}   # WearLaw (wear.py)
      duty:                         # each unit draws its task once
        trajectories: [{name: random_pick_and_place, seed: 0}]
        payload_kg: [0.5, 2.0]      # uniform range (or one number)
        temperature_C: [20.0, 35.0]
    split: {test_fraction: 0.3, seed: 0}   # by unit: a unit is wholly train or wholly test
    batch_size: 32
    log_period_s: 0.001
    duration_s: 3.0                 # optional: simulate only the first 3 s of the duty cycle (quick looks)

A unit is inspected at cycles 0, interval, 2 x interval, ...: one duty cycle is simulated in its
current wear state (a fresh sensor-noise seed per inspection) and its health features written; the
wear is then carried forward over the interval from that cycle's gear work (wear.py).  Inspection 0
(no wear) is the unit's healthy reference: ``tcp_dev_*`` of later inspections is the TCP's distance
from it.  The unit stops at the first inspection that meets the failure criterion.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...campaign.spec import out_folder
from ...config import check_duration, check_keys, check_log_period, check_mapping, check_seed, parse_trajectory
from ...errors import ParameterError, UnknownNameError
from ...seed_paper import PAPER_TCP_MM
from ...sim.effects import REGISTRY
from ...sim.params import JOINT_TEMPERATURE_RANGE_C, NOMINAL_JOINT_TEMPERATURE_C, load_params, read_yaml
from ...util.checks import check_int, check_number, check_text, short
from ...util.yamlsafe import dump, plain
from ..features import FEATURE_UNITS
from .wear import WearLaw, stream

LIFE_FILE_KEYS = ("name", "out", "life", "split", "batch_size", "log_period_s", "duration_s")
LIFE_KEYS = ("units", "seed", "interval_cycles", "max_cycles", "failure", "wear", "duty")
#: the keys of ``life:`` that size the fleet (its units and their inspections); one left out takes its default
SIZE_KEYS = ("units", "interval_cycles", "max_cycles")
DUTY_KEYS = ("trajectories", "payload_kg", "temperature_C")
#: the paper's acceptability limit of a pick-and-place: 0.5 mm TCP deviation from the healthy robot
#: random stream purpose of a unit's duty draw (wear.py uses 0..2)
STREAM_DUTY = 3
#: largest fleet and inspection count accepted (assumption: 1e4 units x 1e3 inspections ~ 1e7 runs is
#: far beyond one machine; the check stops a typo before any work)
MAX_UNITS, MAX_INSPECTIONS = 10_000, 1_000
#: largest share of units held out (at least one unit must be left to fit on)
MAX_TEST_FRACTION = 0.95


@dataclasses.dataclass(frozen=True)
class Failure:
    """Failure criterion: the inspection whose ``feature`` reaches ``threshold`` fails."""

    feature: str = "tcp_dev_max_mm"
    threshold: float = PAPER_TCP_MM


@dataclasses.dataclass(frozen=True)
class Unit:
    """One robot of the fleet: its index, task (trajectory, payload, temperature) and split."""

    index: int
    trajectory: Any
    payload_kg: float
    temperature_C: float
    split: str

    @property
    def unit_id(self) -> str:
        return f"u{self.index:05d}"

    def __hash__(self) -> int:  # the trajectory may be a mapping: units are keyed by their index
        return hash(self.index)


@dataclasses.dataclass(frozen=True)
class LifeCampaign:
    name: str
    out: Path
    units: tuple[Unit, ...]
    seed: int
    interval_cycles: int
    max_cycles: int
    failure: Failure
    wear: WearLaw
    batch_size: int
    log_period_s: float
    test_fraction: float
    split_seed: int
    duration_s: float | None
    text: str
    data: Mapping[str, Any]
    path: Path | None = None

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()

    @property
    def max_inspections(self) -> int:
        return self.max_cycles // self.interval_cycles + 1

    def inspection_s(self) -> dict[str, float]:
        """Simulated seconds of one inspection per task (keyed by its trajectory's JSON): ``duration_s`` where set
        (past the trajectory's end the robot holds its last setpoint), else the trajectory's length."""
        out: dict[str, float] = {}
        for u in self.units:
            key = json.dumps(u.trajectory, sort_keys=True)
            if key not in out:
                out[key] = (parse_trajectory(u.trajectory, "trajectory").duration_s if self.duration_s is None
                            else self.duration_s)
        return out


def upper_bound(camp: LifeCampaign) -> tuple[int, float]:
    """The most a life campaign can cost: ``(runs, physics steps)`` when no unit fails before ``max_cycles`` (every
    unit inspected :attr:`LifeCampaign.max_inspections` times, plus its healthy reference run)."""
    dt = load_params().physics_dt_s
    seconds = camp.inspection_s()
    steps = sum(round(seconds[json.dumps(u.trajectory, sort_keys=True)] / dt) for u in camp.units)
    return len(camp.units) * (camp.max_inspections + 1), float(steps * (camp.max_inspections + 1))


def check_life_limits(camp: LifeCampaign) -> tuple[str, float]:
    """The campaign's :func:`upper_bound` as a sentence and its steps; above a fault campaign's hard limit
    (``campaign.limits.MAX_RUN_STEPS``) refused."""
    from ...campaign.limits import MAX_RUN_STEPS
    from ...sim.budget import core_hours

    runs, steps = upper_bound(camp)
    bound = (f"life campaign {camp.name}: up to {runs} runs ({len(camp.units)} units x up to "
             f"{camp.max_inspections} inspections and a reference each, if none fails early), {steps:.3g} physics "
             f"steps (about {core_hours(steps):.3g} core-hours)")
    if steps > MAX_RUN_STEPS:
        raise ParameterError(f"{bound}; above the limit of {MAX_RUN_STEPS:g} physics steps: fewer units, a longer "
                             "interval_cycles or a lower max_cycles")
    return bound, steps


def life_confirmation_needed(camp: LifeCampaign) -> str | None:
    """Why ``campaign run`` needs --yes to start the life campaign ``camp``, or None: a fault campaign's rule and
    words (``campaign.limits.beyond_confirmation``, ``needs_yes_because``; a fault campaign's own reason:
    ``campaign.limits.confirmation_needed``) on its :func:`upper_bound`, which :func:`check_life_limits` states.
    Where the file left the fleet's size to the defaults (an empty ``life:``), the reason says what that default
    fleet is and how to state another."""
    from ...campaign.limits import beyond_confirmation, needs_yes_because

    bound, steps = check_life_limits(camp)
    runs, _ = upper_bound(camp)
    if not beyond_confirmation(runs, steps):
        return None
    why = needs_yes_because(bound)
    given = camp.data.get("life") if isinstance(camp.data.get("life"), Mapping) else {}
    unstated = [f"life.{k}" for k in SIZE_KEYS if k not in given]
    if unstated:
        why += (f"; {', '.join(unstated)} not given: the defaults size this fleet ({len(camp.units)} units inspected "
                f"every {camp.interval_cycles} cycles up to {camp.max_cycles} cycles): state "
                f"{'them' if len(unstated) > 1 else 'it'} in the file's life section, or give --yes to run it")
    return why


def is_life_file(path: str | Path) -> bool:
    """True when a campaign YAML (a path or a shipped campaign's name) has a top-level ``life:``
    section.  Read through the one strict, bounded loader (an alias bomb or a deeply nested file must not
    reach PyYAML's recursion here); a file it refuses is not a life file, and the campaign loader then
    reports it in one line."""
    from ...campaign.spec import resolve_campaign
    from ...errors import ConfigFileError

    try:
        data = read_yaml(resolve_campaign(path))
    except ConfigFileError:
        return False
    return isinstance(data, Mapping) and "life" in data


def load_life(path: str | Path, out: str | Path | None = None) -> LifeCampaign:
    """A life campaign from a file, or a shipped campaign's name (``prognostics``)."""
    from ...campaign.spec import resolve_campaign

    path = resolve_campaign(path)
    data = read_yaml(path)
    return build_life(data, path.name, path.read_text(), path, out)


def _range(value: Any, where: str, lo: float, hi: float, unit: str) -> tuple[float, float]:
    if isinstance(value, (list, tuple)):
        if len(value) != 2:
            raise ParameterError(f"{where} = {short(value)} must be a number or a range [low, high] {unit}")
        a, b = (check_number(v, f"{where}[{k}]", lo, hi, unit) for k, v in enumerate(value))
        if a > b:
            raise ParameterError(f"{where} = {short(value)}: low must not exceed high")
        return a, b
    v = check_number(value, where, lo, hi, unit)
    return v, v


def build_life(data: Mapping[str, Any], where: str, text: str = "", path: Path | None = None,
               out: str | Path | None = None) -> LifeCampaign:
    """Validate a life campaign's mapping and draw its fleet (every error names its key)."""
    check_keys(data, LIFE_FILE_KEYS, where)
    life = check_mapping(data.get("life"), f"{where}: life")
    check_keys(life, LIFE_KEYS, f"{where}: life")
    name = check_text(data.get("name", "life"), f"{where}: name")
    out_dir = out_folder(data, where, out, name)
    n_units = check_int(life.get("units", 100), f"{where}: life.units", 2, MAX_UNITS)
    seed = check_seed(life.get("seed", 0), f"{where}: life.seed")
    interval = check_int(life.get("interval_cycles", 80_000), f"{where}: life.interval_cycles", 1, 10**9)
    max_cycles = check_int(life.get("max_cycles", 50 * interval), f"{where}: life.max_cycles", interval, 10**12)
    if max_cycles // interval + 1 > MAX_INSPECTIONS:
        raise ParameterError(f"{where}: life.max_cycles / interval_cycles = {max_cycles // interval} inspections; "
                             f"at most {MAX_INSPECTIONS - 1}")
    fail = check_mapping(life.get("failure"), f"{where}: life.failure")
    check_keys(fail, ("feature", "threshold"), f"{where}: life.failure")
    feature = fail.get("feature", Failure.feature)
    if feature not in FEATURE_UNITS:
        raise UnknownNameError("feature", feature if isinstance(feature, str) else short(feature), FEATURE_UNITS,
                               f"{where}: life.failure.feature")  # the error quotes a name itself
    thr = check_number(fail.get("threshold", PAPER_TCP_MM), f"{where}: life.failure.threshold", 0.0, 1e6,
                       FEATURE_UNITS[feature], lo_open=True)
    try:
        wear = WearLaw.from_mapping(check_mapping(life.get("wear"), f"{where}: life.wear"), f"{where}: life.wear")
    except TypeError as exc:
        raise ParameterError(f"{where}: life.wear: {exc}") from None
    duty = check_mapping(life.get("duty"), f"{where}: life.duty")
    check_keys(duty, DUTY_KEYS, f"{where}: life.duty")
    trajs = duty.get("trajectories", ["pick_and_place"])
    if not isinstance(trajs, list) or not trajs:
        raise ParameterError(f"{where}: life.duty.trajectories must be a non-empty list of trajectories")
    durations = [parse_trajectory(t, f"{where}: life.duty.trajectories[{k}]").duration_s for k, t in enumerate(trajs)]
    trajs = plain(trajs)  # numpy options (a mapping built in Python) as the numbers they hold
    mass = REGISTRY["payload"].param("mass_kg")
    payload = _range(duty.get("payload_kg", 1.0), f"{where}: life.duty.payload_kg", mass.lo, mass.hi, "kg")
    temperature = _range(duty.get("temperature_C", NOMINAL_JOINT_TEMPERATURE_C), f"{where}: life.duty.temperature_C",
                         *JOINT_TEMPERATURE_RANGE_C, "degC")
    split = check_mapping(data.get("split"), f"{where}: split")
    check_keys(split, ("test_fraction", "seed"), f"{where}: split")
    frac = check_number(split.get("test_fraction", 0.3), f"{where}: split.test_fraction", 0.0, MAX_TEST_FRACTION)
    split_seed = check_seed(split.get("seed", 0), f"{where}: split.seed")
    batch = check_int(data.get("batch_size", 32), f"{where}: batch_size", 1, 1024)
    dt = load_params().physics_dt_s
    duration = None
    if data.get("duration_s") is not None:
        duration = check_duration(data["duration_s"], f"{where}: duration_s")
        durations = [min(d, duration) for d in durations]
    log_period = check_log_period(data.get("log_period_s", 0.001), f"{where}: log_period_s", dt, min(durations))
    splits = split_units(n_units, frac, split_seed)
    units = []
    for u in range(n_units):
        rng = stream(seed, u, 0, STREAM_DUTY)
        k = int(rng.integers(len(trajs)))
        units.append(Unit(u, trajs[k], float(rng.uniform(*payload)), float(rng.uniform(*temperature)), splits[u]))
    return LifeCampaign(name, out_dir, tuple(units), seed, interval, max_cycles, Failure(str(feature), thr), wear,
                        batch, log_period, frac, split_seed, duration,
                        text or dump(data, where, sort_keys=False),
                        json.loads(json.dumps(plain(data), default=str)), path)


def split_units(n_units: int, test_fraction: float, seed: int) -> list[str]:
    """``"train"`` / ``"test"`` per unit: a seeded permutation puts round(fraction x n) units in test
    (at least one on each side when there are two or more units and the fraction is positive)."""
    n_test = round(test_fraction * n_units)
    if test_fraction > 0:
        n_test = min(max(n_test, 1), n_units - 1)
    test = set(np.random.default_rng(seed).permutation(n_units)[:n_test].tolist())
    return ["test" if u in test else "train" for u in range(n_units)]
