"""Campaign specification: the YAML file validated and expanded into runs (before any simulation).

Campaign YAML (see campaigns/default.yaml)::

    name: default                   # a name, not a path: the default folder is results/NAME
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
    twin_com_twins: false           # with twin_residuals: the current fit's payload CoM columns from noise-free
                                    # twins with the CoM shifted (twin residuals format 6; about +10 % of the
                                    # diagnostics campaign's run-steps); false: the CoM's gravity torque (format 5)
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
import os
import re
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..config import (
    CONDITION_EFFECTS,
    Overlay,
    check_duration,
    check_keys,
    check_log_period,
    check_mapping,
    effect_key,
    parse_effects,
    parse_trajectory,
    refuse_condition_effects,
    refuse_repeats,
    repeats_of,
)
from ..errors import ParameterError
from ..seed_paper import PAPER_TCP_MM
from ..sim.axes import JOINT_NAMES
from ..sim.effects import EffectSpec
from ..sim.params import NOMINAL_JOINT_TEMPERATURE_C, deep_merge, load_params, read_yaml
from ..util.checks import check_bool, check_int, check_name, check_number, check_text, short
from ..util.yamlsafe import dump, plain
from .labels import SplitRule, parse_split
from .runs import CampaignRun, check_value, grid_runs, sweep_axes, trajectory_specs
from .sampling import sample_runs

CAMPAIGN_KEYS = ("name", "out", "trajectory", "base", "sweep", "zip", "threshold_mm", "batch_size",
                 "log_period_s", "save_timeseries", "duration_s", "split", "sample", "twin_residuals",
                 "twin_com_twins", "motor_encoders")
BASE_KEYS = ("seed", "payload_kg", "temperature_C", "effects", "params")
#: largest TCP acceptability threshold [mm]: the UR5's reach is 850 mm
MAX_THRESHOLD_MM = 1000.0


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
    #: with ``twin_residuals``: the current fit's payload CoM columns from CoM-shifted noise-free twins
    #: (health/twin_regressors.py; twin residuals format 6), else the CoM's gravity torque in closed form
    twin_com_twins: bool = False
    #: what the user should know before it runs, said by ``campaign run`` (e.g. equal draws collapsed into one run)
    notes: tuple[str, ...] = ()
    #: the command-line options that shaped it beyond its file (``model``: the overlay's path, ``duration_s``), so
    #: that advice can repeat the command that makes it again
    command_options: Mapping[str, Any] = dataclasses.field(default_factory=dict)

    @property
    def sha256(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()


#: the example campaigns shipped inside the package (``ur5fault campaign run paper``)
SHIPPED_DIR = Path(__file__).resolve().parent.parent / "campaigns"


def shipped_campaigns() -> list[str]:
    """Names of the campaign files shipped with the package (``default``, ``paper``, ...)."""
    return sorted(p.stem for p in SHIPPED_DIR.glob("*.yaml"))


def shipped_campaign_about(name: str) -> str:
    """What the shipped campaign ``name`` is, in one line: the first sentence of the comment its file opens with
    (``""`` for a file that opens with none); ``ur5fault campaign list`` prints it beside the name."""
    comment = []
    for line in (SHIPPED_DIR / f"{name}.yaml").read_text(encoding="utf-8").splitlines():
        if not line.startswith("#"):
            break
        comment.append(line[1:])
    text = " ".join(" ".join(comment).split())
    # a sentence ends at . ! or ? before a capital or a `command` ("Fig. 3" and "s.d. with" do not end one)
    return re.split(r"(?<=[.!?])\s+(?=[A-Z`])", text, maxsplit=1)[0]


def resolve_campaign(path: str | Path) -> Path:
    """A campaign file: an existing path, or the name of a shipped campaign (``paper`` or ``paper.yaml``).

    A path that exists always wins, so a user's own ``paper.yaml`` in the working folder is the one run, by
    either name (``paper`` too: it ran the shipped one while the user's edited copy sat there). A folder is not a
    campaign file: ``campaign run paper --out paper`` resumes into its own folder.
    """
    if not isinstance(path, (str, os.PathLike)) or not str(path).strip():
        raise ParameterError(f"campaign = {short(path)} must be a campaign file's path or a shipped campaign's name "
                             f"({', '.join(shipped_campaigns())})")
    p = Path(path)
    if (p.exists() and not p.is_dir()) or p.parent != Path("."):
        return p
    if p.suffix not in (".yaml", ".yml"):
        for own in (p.with_name(f"{p.name}.yaml"), p.with_name(f"{p.name}.yml")):
            if own.is_file():
                return own
    name = p.stem if p.suffix in (".yaml", ".yml") else p.name  # the shipped name asked for (paper.yml too)
    shipped = SHIPPED_DIR / f"{name}.yaml"
    if shipped.is_file():
        return shipped
    from ..errors import ConfigFileError, close_names

    names = shipped_campaigns()
    close = close_names(name, names)  # a mistyped shipped name
    hint = (f"; did you mean {' or '.join(map(repr, close))}? (`ur5fault campaign list` lists them)" if close else
            f" (shipped: {', '.join(names)}; `ur5fault campaign list` describes them)")
    raise ConfigFileError(f"{p}: {'a folder, not a campaign file' if p.is_dir() else 'no such file'}, and no shipped "
                          f"campaign of that name{hint}")


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
    n_model = 0
    if overlay is not None:
        ov_path = Path(overlay)
        for i, e in enumerate(Overlay.load(ov_path).effects):  # validated with its own file name in messages
            key = CONDITION_EFFECTS.get(e.name)
            if key is not None:  # else refused below as the campaign file's base.effects, which it does not hold
                raise ParameterError(f"{ov_path.name}: effects[{i}]: {e.describe()}: every campaign run sets its "
                                     f"{key} (base.{key} of {path.name}, or its default): give it there, not in "
                                     "the model overlay")
        ov = read_yaml(ov_path)
        base = dict(check_mapping(data.get("base"), f"{path.name}: base"))
        own = dict(check_mapping(base.get("params"), f"{path.name}: base.params"))
        base["params"] = deep_merge(dict(ov.get("params") or {}), own)
        own_effects = base.get("effects") or []
        if not isinstance(own_effects, list):
            raise ParameterError(f"{path.name}: base.effects: expected a list of effects")
        base["effects"] = list(ov.get("effects") or []) + own_effects
        n_model = len(ov.get("effects") or [])
        data = {**data, "base": base}
        text = dump(data, path.name, sort_keys=False)
    if duration_s is not None:
        check_duration(duration_s, "command line: --duration-s")  # refused naming its source, not the file
        if isinstance(data, Mapping) and data.get("duration_s") is not None:  # the file's, replaced: still valid
            check_duration(data["duration_s"], f"{path.name}: duration_s")
        data = {**data, "duration_s": duration_s}
        text = dump(data, path.name, sort_keys=False)
    options = {k: v for k, v in (("model", str(Path(overlay).resolve()) if overlay is not None else None),
                                 ("duration_s", duration_s)) if v is not None}
    return dataclasses.replace(build_campaign(data, path.name, text, path, out, n_model), command_options=options)


def build_campaign(data: Mapping[str, Any], where: str, text: str = "", path: Path | None = None,
                   out: str | Path | None = None, model_effects: int | None = 0) -> Campaign:
    """Validate a campaign mapping and expand it into runs (twins included); nothing is simulated.

    Every value that reaches the engine is checked here: types (no bool or string as a number),
    finiteness, ranges, the log period against the physics step, and the grid size before expanding.
    ``model_effects``: how many of ``base.effects`` came first from a model overlay (:func:`load_campaign`; a
    swept fault may come on top of those, not of the file's own); None: a campaign rebuilt from its manifest,
    checked when it ran (the count is not recorded there).
    """
    if not isinstance(data, Mapping):
        raise ParameterError(f"{where}: expected a mapping of campaign keys, got {short(data)}")
    if "life" in data:  # the command line runs it as one; through the API its life section was silently dropped
        raise ParameterError(f"{where}: a life campaign (it has a `life:` section): load it with "
                             "ur5fault.health.prognostics.spec.load_life and run it with "
                             "ur5fault.health.prognostics.fleet.run_life, or `ur5fault campaign run` it")
    # `life` is named among the valid keys (a file with it is a life campaign, refused above): a typo of it gets
    # "did you mean" instead of a list without it
    check_keys(data, (*CAMPAIGN_KEYS, "life"), where)
    base = check_mapping(data.get("base"), f"{where}: base")
    check_keys(base, BASE_KEYS, f"{where}: base")
    params = dict(check_mapping(base.get("params"), f"{where}: base.params"))
    robot = load_params(overrides=params, where=f"{where}: base.params")  # validate robot overrides now
    base_effects = parse_effects(base.get("effects"), f"{where}: base.effects")
    cond0 = _base_conditions(data, base, where)
    # every run has a payload_kg and a temperature_C (2 kg and 28 degC unless given), applied after the base effects
    refuse_condition_effects(base_effects, f"{where}: base.effects", cond0,
                             " (every run has one: base.payload_kg 2 kg and base.temperature_C 28 degC unless given)")
    axes, swept = sweep_axes(data, where)
    sampled = data.get("sample") is not None  # a sampled campaign (campaign/sampling.py) instead of a grid
    if sampled and (axes or swept):
        raise ParameterError(f"{where}: sample cannot be combined with sweep or zip; use one of them")
    notes: tuple[str, ...] = ()
    if sampled:
        runs, swept, notes = _sampled_runs(data["sample"], cond0, where)
    else:
        runs = grid_runs(axes, cond0)
    notes += _base_and_swept(base_effects, len(base_effects) if model_effects is None else model_effects,
                             runs.values(), where)
    thr = check_number(data.get("threshold_mm", PAPER_TCP_MM), f"{where}: threshold_mm", 0.0, MAX_THRESHOLD_MM, "mm",
                       lo_open=True)
    bs = check_int(data.get("batch_size", 32), f"{where}: batch_size", 1, 1024)
    dur = data.get("duration_s")
    dur = None if dur is None else check_duration(dur, f"{where}: duration_s")
    own = min(parse_trajectory(t, f"{where}: trajectory").duration_s for t in trajectory_specs(runs.values()))
    shortest = dur if dur is not None else own
    if dur is not None and dur > own + 1e-9:  # as simulate says it
        notes += (f"{where}: duration_s {dur:g} s outlasts a trajectory, which ends at {own:g} s: the robot holds its "
                  "last setpoint for the rest",)
    lp = check_log_period(data.get("log_period_s", 1e-3), f"{where}: log_period_s", robot.physics_dt_s, shortest)
    save_ts = check_bool(data.get("save_timeseries", False), f"{where}: save_timeseries")
    twin_res = check_bool(data.get("twin_residuals", False), f"{where}: twin_residuals")
    motor_enc = check_bool(data.get("motor_encoders", True), f"{where}: motor_encoders")
    com_twins = check_bool(data.get("twin_com_twins", False), f"{where}: twin_com_twins")
    if com_twins and not twin_res:
        raise ParameterError(f"{where}: twin_com_twins needs twin_residuals: true (they are the twin fits' columns)")
    name = check_text(data["name"], f"{where}: name") if data.get("name") is not None else (
        path.stem if path else "campaign")
    out_dir = out_folder(data, where, out, name)
    resolved = plain({**dict(data), "base": {**dict(base), "params": params}})  # the manifest's JSON: no numpy
    return Campaign(name, path, text or dump(data, where), out_dir, base_effects, params,
                    tuple(runs.values()), tuple(swept), thr, bs, lp, save_ts, dur, resolved,
                    parse_split(data.get("split"), where), twin_res, motor_enc, com_twins, notes)


def _base_and_swept(base_effects: tuple[EffectSpec, ...], model_effects: int, runs, where: str) -> tuple[str, ...]:
    """A swept (or drawn) fault of the same kind on the same joint as a base effect: refused where the campaign
    file gives both (a set value such as backlash is replaced in the faulty runs while the healthy ones keep it, so
    the labels say the opposite of the robot; a scale compounds with it unsaid), and said in a note where the base
    effect is the model overlay's (its first ``model_effects``): the robot's model, which the faults are meant to
    come on top of, as ``simulate --model`` says of a run's effect."""
    refuse_repeats(base_effects[model_effects:], f"{where}: base.effects")
    first = {effect_key(e): i for i, e in enumerate(base_effects)}
    notes: dict[int, str] = {}
    for rc in runs:
        for e in rc.fault_effects():
            i = first.get(effect_key(e))
            if i is None or i in notes:
                continue
            b = base_effects[i]
            if i >= model_effects:
                raise ParameterError(f"{where}: base.effects[{i - model_effects}] ({b.describe()}) is also swept "
                                     f"(a run with {e.describe()}): the run's value would replace it (a set value "
                                     "such as backlash) or compound with it (a scale) while the healthy runs keep "
                                     "it, so the labels would not say the robot's fault; give it in base.effects or "
                                     "in the sweep, not both")
            notes[i] = (f"{where}: faults of {e.name}{' on ' + JOINT_NAMES[e.joint] if e.joint is not None else ''} "
                        f"come on top of the model overlay's {b.describe()}: an effect that sets a value (e.g. "
                        "backlash) keeps the run's, one that scales compounds with it; the labels give the run's "
                        "effect alone")
    over = [f"{where}: base.effects' {added.describe()} is given on top of the model overlay's {b.describe()}: an "
            "effect that sets a value (e.g. backlash) keeps the campaign's, one that scales compounds with it"
            for b, added in repeats_of(base_effects[:model_effects], base_effects[model_effects:])]
    return tuple(over) + tuple(notes[i] for i in sorted(notes))


def out_folder(data: Mapping[str, Any], where: str, out: str | Path | None, name: str) -> Path:
    """The folder a campaign (or life campaign) file runs into: ``out`` given on the command line, else the file's
    ``out:`` (a non-empty one-line text: a number, a list or ``""``, the working folder itself, refused), else
    ``results/NAME`` (the name then checked to stay inside results/: :func:`~ur5fault.util.checks.check_name`)."""
    file_out = check_text(data["out"], f"{where}: out", max_len=4096) if data.get("out") is not None else None
    out = out if out is not None else file_out
    # the name makes the folder only here: checked here (a stored folder's manifest is rebuilt with its out)
    return Path(out) if out is not None else Path("results") / check_name(name, f"{where}: name")


def _base_conditions(data: Mapping[str, Any], base: Mapping[str, Any], where: str) -> dict[str, Any]:
    """The conditions every run starts from (seed, payload, temperature, trajectory), validated."""
    return {
        "seed": check_value("seed", base.get("seed", 0), f"{where}: base.seed"),
        "payload_kg": check_value("payload_kg", base.get("payload_kg", 2.0), f"{where}: base.payload_kg"),
        "temperature_C": check_value("temperature_C", base.get("temperature_C", NOMINAL_JOINT_TEMPERATURE_C),
                                      f"{where}: base.temperature_C"),
        "trajectory": check_value("trajectory", data.get("trajectory", "pick_and_place"), f"{where}: trajectory"),
    }


def _sampled_runs(spec: Any, cond0: Mapping[str, Any], where: str
                  ) -> tuple[dict[str, CampaignRun], list[str], tuple[str, ...]]:
    """The drawn runs (with their twins where wanted) by run_id, the drawn keys, and a note when equal draws
    collapsed into one run."""
    runs: dict[str, CampaignRun] = {}
    drawn, swept = sample_runs(spec, cond0, where)
    distinct = set()
    for cond, faults, wants_twin in drawn:
        rc = CampaignRun(tuple(sorted(cond.items())), tuple(sorted(faults.items())))  # validates them
        distinct.add(rc.run_id)
        for r in (rc, rc.twin()) if wants_twin else (rc,):
            runs.setdefault(r.run_id, r)
    notes = () if len(distinct) == len(drawn) else (
        f"{where}: sample: {len(drawn)} draws gave {len(distinct)} distinct runs (equal draws are one run; draw the "
        "sensor-noise seed among the conditions, e.g. seed: {integers: [0, 999999]}, for repeats)",)
    return runs, swept, notes
