"""The commands of a single run: ``ur5fault simulate`` (one configuration to a time series), ``effects`` (the
effect registry) and ``show`` (one run's figure).  Registered on the parser by :func:`register`, as every command
group is (``ur5fault/cli.py``)."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Mapping
from pathlib import Path

from .errors import Ur5FaultError
from .util import progress
from .util.usage import examples

#: the run configuration and overlay formats, shown by `ur5fault simulate --help` (a wheel carries no docs/)
RUN_CONFIG_HELP = """\
run configuration (--config RUN.yaml); every key is optional:
  trajectory: pick_and_place        # or {name: pick_and_place, speed_scale: 0.5}
  seed: 0                           # sensor-noise seed
  payload_kg: 2.0                   # gripped mass (the trajectory's default when absent)
  temperature_C: 28.0               # all joints
  duration_s: 13.0                  # default: the whole trajectory
  log_period_s: 0.001               # a whole multiple of the 50 us physics step
  effects:                          # any entry of `ur5fault effects`, each with its size
    - {effect: backlash, joint: shoulder_lift_joint, backlash_deg: 0.1}
    - {effect: coulomb_friction, joint: elbow, scale: 1.5}
  params:                           # overrides of the robot parameters, merged key by key
    gear: {damping_Nms_per_rad: [18, 24, 14, 1.2, 1.2, 0.36]}   # per joint; one number sets all six

model overlay (--model OVERLAY.yaml): only the keys params and effects, as above.
joints: shoulder_pan_joint .. wrist_3_joint, 1..6, or UR's short names base, shoulder (= shoulder_lift),
elbow, wrist1, wrist2, wrist3.
"""


def cmd_simulate(args: argparse.Namespace) -> int:
    from .config import Overlay, build_run_config, repeats_of
    from .sim.engine import RunSpec, Simulator
    from .sim.params import read_yaml
    from .util.results import written

    file_data = dict(read_yaml(Path(args.config))) if args.config else {}
    where = Path(args.config).name if args.config else "command line"
    _check_flags(args, file_data)
    given = {key: val for key, val in (("trajectory", args.trajectory), ("seed", args.seed),
                                       ("payload_kg", args.payload_kg), ("temperature_C", args.temperature_C),
                                       ("duration_s", args.duration_s), ("log_period_s", args.log_period_s))
             if val is not None}
    # the command line's, validated apart from the file's so that errors name their source; in the order typed
    # (--backlash and --effect append to one list), so that effects[i] is the i-th typed
    effects = [_parse_backlash_arg(spec) if flag == "--backlash" else _parse_effect_arg(spec)
               for flag, spec in args.cli_effects or []]
    data = _over_file(file_data, given, effects, where)
    overlay = Overlay.load(args.model) if args.model else None
    flags = {key: "--" + key.replace("_", "-") for key in given if key != "trajectory"}  # --temperature-C kept
    cfg = build_run_config(data, where, overlay, labels=flags)
    if overlay is not None:
        for base, added in repeats_of(overlay.effects, cfg.effects[len(overlay.effects):]):
            print(f"note: {added.describe()} is given on top of the model overlay's {base.describe()}: an effect "
                  "that sets a value (e.g. backlash) keeps the run's, one that scales compounds with it",
                  file=sys.stderr)
    duration = cfg.duration_s if cfg.duration_s is not None else cfg.trajectory.duration_s
    if duration > cfg.trajectory.duration_s + 1e-9:
        print(f"note: the trajectory ends at {cfg.trajectory.duration_s:g} s; the robot holds its last setpoint for "
              f"the remaining {duration - cfg.trajectory.duration_s:g} s", file=sys.stderr)
    n_log = math.floor(duration / cfg.log_period_s + 1e-9)
    if duration - n_log * cfg.log_period_s > 1e-9:  # the run is logged, and reported, to its last whole sample
        print(f"note: the run ends at {n_log * cfg.log_period_s:g} s, its last logged sample ({duration:g} s is not a "
              f"whole number of log periods of {cfg.log_period_s:g} s)", file=sys.stderr)
    out = _check_out_file(Path(args.out), args.replace)  # before simulating, not after
    replaced = out.exists()
    sim = Simulator(cfg.params)
    with progress.bar(1.0, "simulate", "run", enabled=not args.quiet,
                      bar_format=progress.PERCENT_FORMAT) as pbar:
        res = sim.run(cfg.trajectory, [RunSpec("run", cfg.seed, cfg.effects)], log_period_s=cfg.log_period_s,
                      duration_s=cfg.duration_s, progress=progress.fraction_callback(pbar))
    if out.suffix.lower() == ".csv":
        res.to_csv(out)
    else:
        res.to_parquet(out)
    # prose on stderr, the one data line (the run's summary as JSON) on stdout: `simulate ... | jq` works
    sys.stderr.write(f"{written(replaced)} {out} ({res.t_s.size} samples x {len(res.to_pandas(0).columns)} "
                     "columns)\n")
    sys.stderr.write("effects: " + ("; ".join(res.effects[0]) or "none (healthy)") + "\n")
    print(json.dumps(res.summary(0), indent=None, allow_nan=False))  # strict JSON: jq reads it
    return 0 if res.status[0] == "ok" else 1


def _check_flags(args: argparse.Namespace, file_data: dict) -> None:
    """The command line's values in range, refused under the flags' names (the run configuration's checks name its
    keys, which a command-line user never typed)."""
    from .config import MIN_LOGGED_SAMPLES, check_duration, check_seed
    from .sim.effects import REGISTRY
    from .util.checks import check_number, is_real

    if args.seed is not None:
        check_seed(args.seed, "--seed")
    for value, flag, effect, param in ((args.payload_kg, "--payload-kg", "payload", "mass_kg"),
                                       (args.temperature_C, "--temperature-C", "temperature", "temperature_C")):
        if value is not None:
            p = REGISTRY[effect].param(param)
            check_number(value, flag, p.lo, p.hi, p.unit)
    if args.duration_s is not None:
        check_duration(args.duration_s, "--duration-s")
        log_period = args.log_period_s if args.log_period_s is not None else file_data.get("log_period_s", 1e-3)
        if is_real(log_period) and args.duration_s < MIN_LOGGED_SAMPLES * log_period:  # else refused by its key
            raise Ur5FaultError(f"--duration-s {args.duration_s:g} holds fewer than {MIN_LOGGED_SAMPLES} log periods "
                                f"of {log_period:g} s: a run's features take speeds and accelerations of its "
                                "logged samples; give a longer run or --log-period-s")
    if args.log_period_s is not None:
        check_number(args.log_period_s, "--log-period-s", 0.0, math.inf, "s", lo_open=True)


#: output formats of `simulate --out`, by file suffix
OUT_SUFFIXES = (".parquet", ".csv")


def _check_out_file(out: Path, replace: bool) -> Path:
    """``simulate --out``: a ``.parquet`` or ``.csv`` file that can be written (missing folders are created) and
    holds no earlier run unless ``replace``."""
    from .util.results import check_new_output

    return check_new_output(out, replace=replace, suffixes=OUT_SUFFIXES)


def _over_file(file_data: dict, given: dict, cli_items: list, where: str) -> dict:
    """The run configuration: the file's keys and effects with the command line's options (``given``) and effects
    on top. Each side is checked on its own first, so that an error names its source and index. A command-line
    effect replaces the file's effect of the same kind on the same joint, a command-line ``--payload-kg`` the
    file's payload effect and a command-line payload effect the file's ``payload_kg`` (temperature alike), each
    said on stderr: command-line options override the file."""
    from .config import CONDITION_EFFECTS, effect_key, parse_effects, refuse_condition_effects, refuse_repeats

    file_items = file_data.get("effects")
    file_specs = parse_effects(file_items, f"{where}: effects")
    refuse_repeats(file_specs, f"{where}: effects")
    refuse_condition_effects(file_specs, f"{where}: effects", file_data)
    cli_specs = parse_effects(cli_items, "command line: effects")
    refuse_repeats(cli_specs, "command line: effects")
    for key, flag in (("payload_kg", "--payload-kg"), ("temperature_C", "--temperature-C")):  # the one typed
        refuse_condition_effects(cli_specs, "command line: effects", {key: given.get(key)}, f" ({flag})")
    data = {**file_data, **given, **_trajectory_over_file(file_data.get("trajectory"), given.get("trajectory"), where)}
    by_key = {effect_key(e): e for e in cli_specs}
    kept = []
    for item, spec in zip(file_items or [], file_specs):
        key = CONDITION_EFFECTS.get(spec.name)
        if effect_key(spec) in by_key:
            print(f"note: the command line's {by_key[effect_key(spec)].describe()} replaces {where}'s "
                  f"{spec.describe()}", file=sys.stderr)
        elif key in given:
            print(f"note: the command line's {key} = {given[key]!r} replaces {where}'s {spec.describe()}",
                  file=sys.stderr)
        else:
            kept.append(item)
    for spec in cli_specs:
        key = CONDITION_EFFECTS.get(spec.name)
        if key is not None and file_data.get(key) is not None:
            print(f"note: the command line's {spec.describe()} replaces {where}'s {key} = {file_data[key]!r}",
                  file=sys.stderr)
            data.pop(key)
    data["effects"] = kept + cli_items
    return data


def _trajectory_over_file(file_spec, name: str | None, where: str) -> dict:
    """``--trajectory NAME`` over the file's ``trajectory``: the file's options kept when it names the same motion
    (``--trajectory pick_and_place`` over ``{name: pick_and_place, speed_scale: 0.5}`` runs at half speed); when it
    names another, the command line wins, as it does for every key, and a note says which options went."""
    if name is None or not isinstance(file_spec, Mapping) or "name" not in file_spec:
        return {}
    if file_spec["name"] == name:
        return {"trajectory": file_spec}
    options = ", ".join(f"{k}: {v!r}" for k, v in file_spec.items() if k != "name")
    if options:
        print(f"note: the command line's --trajectory {name} replaces {where}'s trajectory {file_spec['name']!r} "
              f"and its options ({options}); {name} runs with its defaults", file=sys.stderr)
    return {}


def _refuse_robot_log(target: Path) -> None:
    """``show`` draws a run of ``simulate`` (Parquet, or CSV with its columns); a robot log (CSV text, plain or
    gzip), which it would call unreadable Parquet, is named as one with the commands that read it. From the first
    bytes: whatever is neither is left to the reader's own error."""
    from .errors import ConfigFileError, LogFormatError
    from .logs.source import sniff

    try:
        with open(target, "rb") as f:
            if f.read(4) == b"PAR1":
                return
    except OSError:  # unreadable: the reader's own one line says why
        return
    try:
        columns = sniff(target, str(target)).columns
    except LogFormatError:
        return
    if "t_s" not in columns or "q_set_rad_j1" not in columns:
        raise ConfigFileError(f"{target}: not a ur5fault time series (a CSV without simulate's t_s and q_set_rad_j1 "
                              "columns); `ur5fault show` reads simulate's Parquet (or CSV) output; a robot log is read "
                              "by identify, discrepancy, monitor or diagnose with --format nist|rtde")


def _parse_backlash_arg(spec: str) -> dict:
    """``joint:degrees`` -> backlash effect mapping."""
    joint, _, deg = spec.partition(":")
    try:
        value = float(deg)
    except ValueError:
        raise Ur5FaultError(f"--backlash {spec!r}: expected JOINT:DEGREES, e.g. shoulder_lift_joint:0.1") from None
    return {"effect": "backlash", "joint": joint, "backlash_deg": value}


def _parse_effect_arg(spec: str) -> dict:
    """``name[@joint]:key=value,key=value`` -> effect mapping."""
    head, _, rest = spec.partition(":")
    name, _, joint = head.partition("@")
    item: dict = {"effect": name}
    if joint:
        item["joint"] = joint
    for pair in filter(None, rest.split(",")):
        key, eq, val = pair.partition("=")
        if not eq:
            raise Ur5FaultError(f"--effect {spec!r}: expected NAME[@JOINT]:KEY=VALUE[,KEY=VALUE]")
        if key in item:
            raise Ur5FaultError(f"--effect {spec!r}: {key} given twice")
        try:
            item[key] = float(val)
        except ValueError:
            raise Ur5FaultError(f"--effect {spec!r}: {key} = {val!r} is not a number") from None
    return item


def cmd_effects(args: argparse.Namespace) -> int:
    from .sim.effects import REGISTRY

    width = max(len(name) for name in REGISTRY)  # the longest name sets the column (one was wider than 22)
    for e in REGISTRY.values():
        ps = ", ".join(f"{p.name} [{p.lo:g}..{p.hi:g}]" + (f" absent={p.absent:g}" if p.absent is not None else "")
                       for p in e.params)
        print(f"{e.name:{width}s}  {'per joint' if e.per_joint else 'robot    '}  {ps}  - {e.doc}")
    return 0


def cmd_data(args: argparse.Namespace) -> int:
    """The shipped real logs: a table of them, or the path(s) of one (or of a group), one per line for the shell."""
    from .logs.shipped import shipped_log, shipped_logs

    if args.name is not None:
        print("\n".join(str(lg.path) for lg in shipped_log(args.name)))
        return 0
    logs = shipped_logs().values()
    opts = {lg.name: " ".join(("--format", lg.format, *lg.options)) for lg in logs}
    width, opts_width = max(map(len, opts)), max(map(len, opts.values()))
    for lg in logs:
        print(f"{lg.name:{width}s}  {opts[lg.name]:{opts_width}s}  {lg.about}")
    print(f"\nin {next(iter(logs)).path.parent.parent} (a README per folder); the path of one: ur5fault data NAME, "
          "e.g. ur5fault identify \"$(ur5fault data nist)\" --format nist --out params.yaml")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    from .errors import ConfigFileError
    from .logs.readers import RESIMULATE
    from .plotting import run_figure
    from .util.io import check_stored, check_writable, write_figure_atomic
    from .util.results import check_new_output, present, said_written

    target = Path(args.target)
    if args.out is not None:  # before reading or re-simulating anything
        check_writable(args.out)
        if Path(args.out).suffix.lower() != ".png":
            raise ConfigFileError(f"--out {args.out}: the figure is written as PNG; give a .png file name")
        check_new_output(args.out, replace=args.replace)  # an earlier figure, or a user's own file
    if target.suffix.lower() in OUT_SUFFIXES or target.is_file():
        import pandas as pd

        if args.campaign is not None:
            raise ConfigFileError(f"--campaign {args.campaign}: names the campaign of a run id; {target} is a file "
                                  "and is shown as it is (drop --campaign, or give a run id)")
        if not target.is_file():
            raise ConfigFileError(f"{target}: no such file")
        png = Path(args.out) if args.out else target.with_suffix(".png")
        check_new_output(png, replace=args.replace, default_place=args.out is None)  # one line, before reading
        csv = target.suffix.lower() == ".csv"
        check_stored(target, RESIMULATE)  # a campaign's time series carries its checksum: never drawn damaged
        _refuse_robot_log(target)
        try:
            series = pd.read_csv(target) if csv else pd.read_parquet(target)
        except (OSError, ValueError) as exc:
            raise ConfigFileError(f"{target}: cannot read as {'CSV' if csv else 'Parquet'} ({exc})") from None
        twin = None
    else:
        from .campaign.result import CampaignResult

        if target.is_dir():
            raise ConfigFileError(f"{target}: a folder; show draws one run: give a run file, or a run id with its "
                                  f"campaign folder (ur5fault show RUN_ID --campaign {target}; the run ids are in "
                                  f"its features.parquet), or draw the whole campaign with ur5fault plot {target}")
        if args.campaign is None and not Path("features.parquet").is_file():
            raise ConfigFileError(f"{target}: no such file; to show a run of a campaign, give its folder: "
                                  f"ur5fault show {target} --campaign DIR")
        result = CampaignResult.load(Path(args.campaign or "."))
        row = result.run(args.target)
        png = Path(args.out) if args.out else result.out / "plots" / f"show_{row['run_id']}.png"
        check_new_output(png, replace=args.replace, default_place=args.out is None)  # before reading or re-simulating
        twin_id = row.get("twin_run_id", row["run_id"])
        tables = result.time_series([row["run_id"], twin_id])
        series, twin = tables[row["run_id"]], tables[twin_id] if twin_id != row["run_id"] else None
    fig = run_figure(series, twin=twin)
    _note_empty_columns(series, twin)
    png.parent.mkdir(parents=True, exist_ok=True)
    earlier = present([png])  # with --replace (else refused above): said as replaced
    write_figure_atomic(fig, png)
    print(said_written([png], earlier))
    return 0


def _note_empty_columns(series, twin) -> None:
    """``show``: one note on stderr naming the drawn columns with no finite value (their curves are missing from the
    figure); a column finite in part (a run stopped early) is drawn as far as it goes and not named."""
    from .plotting.run import columns_without_values

    empty = columns_without_values(series, twin)
    if empty:
        named = ", ".join(empty[:6]) + (f" and {len(empty) - 6} more" if len(empty) > 6 else "")
        status = series.attrs.get("ur5fault", {}).get("status")
        run = f"; the run's status: {status}" if status not in (None, "ok") else ""
        print(f"note: no finite value in {named} (NaN or inf in every row{run}): "
              f"{'its curves are' if len(empty) == 1 else 'their curves are'} missing from the figure", file=sys.stderr)


def register(sub) -> None:
    """Add ``simulate``, ``effects`` and ``show`` to the subcommand parsers ``sub``."""
    from .sim.trajectories import TRAJECTORIES

    s = sub.add_parser("simulate", help="run one configuration and write its time series to Parquet or CSV",
                       description="Simulate one run and write its time series (one row per log sample). "
                                   "Command-line options override the --config file.",
                       **examples("ur5fault simulate --backlash shoulder_lift_joint:0.1 --out shoulder.parquet",
                                  "ur5fault simulate --effect coulomb_friction@elbow:scale=1.5 --duration-s 5 --out "
                                  "elbow.csv",
                                  "ur5fault simulate --model nist.yaml --out identified.parquet    # an overlay of "
                                  "identify or discrepancy", before=RUN_CONFIG_HELP))
    s.add_argument("--config", metavar="RUN.yaml",
                   help="run configuration YAML (format below; default: none, every key at its default)")
    s.add_argument("--model", metavar="OVERLAY.yaml",
                   help="model overlay YAML (only params and effects, format below), e.g. from `ur5fault discrepancy` "
                        "or `ur5fault identify` (default: none, the nominal model)")
    s.add_argument("--backlash", action="append", dest="cli_effects", metavar="JOINT:DEG",
                   type=lambda spec: ("--backlash", spec),
                   help="backlash fault, e.g. shoulder_lift_joint:0.1 (repeatable; default: none)")
    s.add_argument("--effect", action="append", dest="cli_effects", metavar="NAME[@JOINT]:K=V,...",
                   type=lambda spec: ("--effect", spec),
                   help="any registered effect, e.g. coulomb_friction@elbow:scale=1.5 (see `ur5fault effects`; "
                        "repeatable; default: none, a healthy run)")
    s.add_argument("--trajectory", choices=list(TRAJECTORIES),
                   help="trajectory (default pick_and_place; options of a trajectory: --config, whose options are "
                        "kept when it names the same one)")
    s.add_argument("--seed", type=int, help="sensor-noise seed (default 0)")
    s.add_argument("--payload-kg", type=float, dest="payload_kg",
                   help="gripped mass [kg] (default: the trajectory's, 2.0 for pick_and_place)")
    s.add_argument("--temperature-C", type=float, dest="temperature_C",
                   help="temperature of all joints [degC] (default 28, the paper's reference)")
    s.add_argument("--duration-s", type=float, dest="duration_s",
                   help="simulated time [s] (default: the whole trajectory, 13 s for pick_and_place)")
    s.add_argument("--log-period-s", type=float, dest="log_period_s",
                   help="time between logged samples [s], a whole multiple of the 50 us physics step (default 0.001)")
    s.add_argument("--out", default="run.parquet", metavar="FILE.parquet|FILE.csv",
                   help="output file, Parquet (with the run's metadata) or CSV by its suffix; missing folders are "
                        "created (default run.parquet)")
    s.add_argument("--replace", action="store_true", help="replace an earlier file at --out (default: refused)")
    s.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, plain lines in a log)")
    s.set_defaults(func=cmd_simulate)
    e = sub.add_parser("effects", help="list the effect registry",
                       **examples("ur5fault effects",
                                  "ur5fault simulate --effect current_sensor_offset@wrist_1:offset_A=0.1"))
    e.set_defaults(func=cmd_effects)
    d = sub.add_parser("data", help="the real UR5 logs shipped with ur5fault (NIST CB3, Kufieta CB2): names, formats, "
                                    "paths",
                       **examples("ur5fault data", "ur5fault data kufieta/TEST",
                                  'ur5fault identify "$(ur5fault data nist)" --format nist --out nist.yaml'))
    d.add_argument("name", nargs="?", help="print the path of this log (or of every run of a group, one per line), "
                                           "e.g. nist, kufieta/TEST, kufieta")
    d.set_defaults(func=cmd_data)
    sh = sub.add_parser("show", help="draw one run: setpoint vs resolver, encoder mismatch, currents, TCP deviation",
                        **examples("ur5fault show shoulder.parquet                   # -> shoulder.png",
                                   "ur5fault show shoulder.parquet --out figures/shoulder.png"))
    sh.add_argument("target", help="a time-series Parquet or CSV file (from `simulate`, or a campaign's timeseries/), "
                                   "or the run_id of a run in the campaign folder --campaign (re-simulated if not "
                                   "saved)")
    sh.add_argument("--campaign", help="campaign output folder of a RUN_ID (default: this folder)")
    sh.add_argument("--out", help="PNG file (default: FILE.png beside the file, or CAMPAIGN/plots/show_RUN_ID.png)")
    sh.add_argument("--replace", action="store_true", help="replace an earlier file at --out (default: refused)")
    sh.set_defaults(func=cmd_show)
