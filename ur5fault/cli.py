"""Command line: ``ur5fault simulate | effects | campaign | plot | show | discrepancy | identify | benchmark |
diagnose | prognose``.

Bad input prints one line ``ur5fault: error: ...`` naming the problem and the valid
choices, and exits with status 2; never a traceback.  ``-v`` (before or after the
subcommand) shows the library's ``logging`` messages at INFO, ``-vv`` at DEBUG;
``--quiet`` switches the progress bar off.
"""

from __future__ import annotations

import argparse
import functools
import json
import logging
import signal
import sys
from collections.abc import Sequence
from pathlib import Path

from .errors import Ur5FaultError
from .util import progress

EXIT_USAGE = 2

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
    from .config import Overlay, build_run_config
    from .sim.engine import RunSpec, Simulator
    from .sim.params import read_yaml

    data = read_yaml(Path(args.config)) if args.config else {}
    where = Path(args.config).name if args.config else "command line"
    for key, val in (("trajectory", args.trajectory), ("seed", args.seed), ("payload_kg", args.payload_kg),
                     ("temperature_C", args.temperature_C), ("duration_s", args.duration_s),
                     ("log_period_s", args.log_period_s)):
        if val is not None:
            data[key] = val
    effects = list(data.get("effects") or [])
    for spec in args.backlash or []:
        joint, _, deg = spec.partition(":")
        try:
            value = float(deg)
        except ValueError:
            raise Ur5FaultError(f"--backlash {spec!r}: expected JOINT:DEGREES, e.g. shoulder_lift_joint:0.1") from None
        effects.append({"effect": "backlash", "joint": joint, "backlash_deg": value})
    for spec in args.effect or []:
        effects.append(_parse_effect_arg(spec))
    data["effects"] = effects
    overlay = Overlay.load(args.model) if args.model else None
    cfg = build_run_config(data, where, overlay)
    out = _check_out_file(Path(args.out), args.replace)  # before simulating, not after
    replaced = out.exists()
    sim = Simulator(cfg.params)
    with progress.bar(1.0, "simulate", "run", enabled=not args.quiet,
                      bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}") as pbar:
        res = sim.run(cfg.trajectory, [RunSpec("run", cfg.seed, cfg.effects)], log_period_s=cfg.log_period_s,
                      duration_s=cfg.duration_s, progress=progress.fraction_callback(pbar))
    if out.suffix.lower() == ".csv":
        res.to_csv(out)
    else:
        res.to_parquet(out)
    # prose on stderr, the one data line (the run's summary as JSON) on stdout: `simulate ... | jq` works
    verb = "replaced" if replaced else "wrote"
    sys.stderr.write(f"{verb} {out} ({res.t_s.size} samples x {len(res.to_pandas(0).columns)} columns)\n")
    sys.stderr.write("effects: " + ("; ".join(res.effects[0]) or "none (healthy)") + "\n")
    print(json.dumps(res.summary(0), indent=None, allow_nan=False))  # strict JSON: jq reads it
    return 0 if res.status[0] == "ok" else 1


#: output formats of `simulate --out`, by file suffix
OUT_SUFFIXES = (".parquet", ".csv")


def _check_out_file(out: Path, replace: bool) -> Path:
    """``simulate --out``: a ``.parquet`` or ``.csv`` file that can be written (missing folders are created) and
    holds no earlier run unless ``replace``."""
    from .util.io import check_new_output

    return check_new_output(out, replace=replace, suffixes=OUT_SUFFIXES)


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

    for e in REGISTRY.values():
        ps = ", ".join(f"{p.name} [{p.lo:g}..{p.hi:g}]" + (f" absent={p.absent:g}" if p.absent is not None else "")
                       for p in e.params)
        print(f"{e.name:22s} {'per joint' if e.per_joint else 'robot    '}  {ps}  - {e.doc}")
    return 0


def cmd_show(args: argparse.Namespace) -> int:
    from .errors import ConfigFileError
    from .plotting import run_figure
    from .util.io import check_writable, write_figure_atomic

    target = Path(args.target)
    if args.out is not None:  # before reading or re-simulating anything
        check_writable(args.out)
        if Path(args.out).suffix.lower() != ".png":
            raise ConfigFileError(f"--out {args.out}: the figure is written as PNG; give a .png file name")
    if target.suffix.lower() in OUT_SUFFIXES or target.is_file():
        import pandas as pd

        if not target.is_file():
            raise ConfigFileError(f"{target}: no such file")
        png = Path(args.out) if args.out else target.with_suffix(".png")
        check_writable(png)  # the default place too: a folder in the way is one line, before reading
        csv = target.suffix.lower() == ".csv"
        try:
            series = pd.read_csv(target) if csv else pd.read_parquet(target)
        except (OSError, ValueError) as exc:
            raise ConfigFileError(f"{target}: cannot read as {'CSV' if csv else 'Parquet'} ({exc})") from None
        fig = run_figure(series)
    else:
        from .campaign.result import CampaignResult

        if args.campaign is None and not Path("features.parquet").is_file():
            raise ConfigFileError(f"{target}: no such file; to show a run of a campaign, give its folder: "
                                  f"ur5fault show {target} --campaign DIR")
        result = CampaignResult.load(Path(args.campaign or "."))
        row = result.run(args.target)
        twin = row.get("twin_run_id", row["run_id"])
        series = result.time_series([row["run_id"], twin])
        fig = run_figure(series[row["run_id"]], twin=series[twin] if twin != row["run_id"] else None)
        png = Path(args.out) if args.out else result.out / "plots" / f"show_{row['run_id']}.png"
        check_writable(png)
    png.parent.mkdir(parents=True, exist_ok=True)
    write_figure_atomic(fig, png)
    print(f"wrote {png}")
    return 0


class _Parser(argparse.ArgumentParser):
    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        # on every (sub)parser, so `ur5fault -v simulate` and `ur5fault simulate -v` both work; SUPPRESS keeps a
        # subcommand's parser from resetting a count given before the subcommand
        self.add_argument("-v", "--verbose", action="count", default=argparse.SUPPRESS,
                          help="log what the library does (-v: INFO, -vv: DEBUG)")

    def add_argument(self, *args, **kwargs):
        action = super().add_argument(*args, **kwargs)
        if action.option_strings and not isinstance(action, _REPEATABLE):
            action.__class__ = _once(type(action))  # a second --out, --seed, ... would silently win
        return action

    def parse_known_args(self, args=None, namespace=None):
        self._given: dict[str, str] = {}  # dest -> the option string that set it, in this parse
        return super().parse_known_args(args, namespace)

    def error(self, message: str):  # one line, exit 2
        self.exit(EXIT_USAGE, f"ur5fault: error: {message}\n")


#: actions meant to be given several times (--backlash, --effect, -v), flags that take no value (--quiet twice
#: loses nothing) and those that end the parse (--help, --version)
_REPEATABLE = (argparse._AppendAction, argparse._CountAction, argparse._StoreConstAction, argparse._HelpAction,
               argparse._VersionAction)


@functools.cache
def _once(cls: type) -> type:
    """``cls`` refusing a second use of its option in one command line (argparse keeps the last value silently);
    one such class per action class, not one per option."""

    class Once(cls):  # type: ignore[valid-type, misc]
        def __call__(self, parser, namespace, values, option_string=None):
            given = getattr(parser, "_given", None)
            if given is not None:
                if self.dest in given:  # an abbreviation (--dur) arrives as the full option string
                    parser.error(f"{option_string} given twice; give it once")
                given[self.dest] = option_string
            super().__call__(parser, namespace, values, option_string)

    Once.__name__ = Once.__qualname__ = f"Once{cls.__name__}"
    return Once


def _version() -> str:
    from importlib.metadata import version

    from . import __version__

    deps = ", ".join(f"{name} {version(name)}" for name in ("mujoco", "numpy"))
    return f"ur5fault {__version__} ({deps}, python {sys.version.split()[0]})"


def configure_logging(verbosity: int) -> None:
    """Send the ``ur5fault`` loggers' records to stderr: WARNING by default, INFO at ``-v``, DEBUG at ``-vv``."""
    logger = logging.getLogger("ur5fault")
    logger.setLevel(logging.WARNING if verbosity <= 0 else logging.INFO if verbosity == 1 else logging.DEBUG)
    if not any(getattr(h, "_ur5fault_cli", False) for h in logger.handlers):
        handler = logging.StreamHandler(sys.stderr)
        handler.setFormatter(logging.Formatter("ur5fault: %(levelname)s: %(name)s: %(message)s"))
        handler._ur5fault_cli = True  # type: ignore[attr-defined]
        logger.addHandler(handler)


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="ur5fault", description="UR5 fault-injection simulator")
    p.add_argument("--version", action="version", version=_version())
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    p.set_defaults(func=_usage(p))
    from .sim.trajectories import TRAJECTORIES

    s = sub.add_parser("simulate", help="run one configuration and write its time series to Parquet or CSV",
                       description="Simulate one run and write its time series (one row per log sample). "
                                   "Command-line options override the --config file.",
                       epilog=RUN_CONFIG_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    s.add_argument("--config", metavar="RUN.yaml",
                   help="run configuration YAML (format below; default: none, every key at its default)")
    s.add_argument("--model", metavar="OVERLAY.yaml",
                   help="model overlay YAML (only params and effects, format below), e.g. from `ur5fault discrepancy` "
                        "or `ur5fault identify` (default: none, the nominal model)")
    s.add_argument("--backlash", action="append", metavar="JOINT:DEG",
                   help="backlash fault, e.g. shoulder_lift_joint:0.1 (repeatable; default: none)")
    s.add_argument("--effect", action="append", metavar="NAME[@JOINT]:K=V,...",
                   help="any registered effect, e.g. coulomb_friction@elbow:scale=1.5 (see `ur5fault effects`; "
                        "repeatable; default: none, a healthy run)")
    s.add_argument("--trajectory", choices=list(TRAJECTORIES),
                   help="trajectory (default pick_and_place; options of a trajectory: --config)")
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
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_simulate)
    e = sub.add_parser("effects", help="list the effect registry")
    e.set_defaults(func=cmd_effects)
    sh = sub.add_parser("show", help="draw one run: setpoint vs resolver, encoder mismatch, currents, TCP deviation")
    sh.add_argument("target", help="a time-series Parquet file (from `simulate`, or a campaign's timeseries/), or the "
                                   "run_id of a run in the campaign folder --campaign (re-simulated if not saved)")
    sh.add_argument("--campaign", help="campaign output folder of a RUN_ID (default: this folder)")
    sh.add_argument("--out", help="PNG file (default: FILE.png beside the file, or CAMPAIGN/plots/show_RUN_ID.png)")
    sh.set_defaults(func=cmd_show)
    _add_optional_commands(sub)
    return p


def _add_optional_commands(sub) -> None:
    """The campaign and discrepancy command groups (imported directly: a broken module is an error,
    not a silently missing command)."""
    from .campaign import cli as campaign_cli
    from .discrepancy import cli as discrepancy_cli
    from .health.diagnosis import cli as diagnose_cli
    from .health.diagnostics import cli as benchmark_cli
    from .health.monitoring import cli as monitor_cli
    from .health.prognostics import cli as prognose_cli
    from .identify import cli as identify_cli

    campaign_cli.register(sub)
    discrepancy_cli.register(sub)
    identify_cli.register(sub)
    benchmark_cli.register(sub)
    diagnose_cli.register(sub)
    prognose_cli.register(sub)
    monitor_cli.register(sub)


def _one_line(message: str) -> int:
    sys.stderr.write(f"ur5fault: error: {' '.join(message.split())}\n")
    return EXIT_USAGE


def _silence_stdout() -> None:
    """Point stdout at /dev/null so that Python's own flush at exit raises no second BrokenPipeError."""
    import os

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
    except (OSError, ValueError):
        pass


class Terminated(KeyboardInterrupt):
    """SIGTERM arrived: unwind like Ctrl-C (locks released, workers stopped, temporary files removed)."""


def _on_sigterm(signum, frame) -> None:
    raise Terminated()


def _usage(parser: argparse.ArgumentParser):
    """The action of a command group given without its subcommand: its help on stderr, exit 2."""

    def show(args: argparse.Namespace) -> int:
        parser.print_help(sys.stderr)
        return EXIT_USAGE

    return show


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    configure_logging(getattr(args, "verbose", 0))
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main thread: leave signals alone
        previous = None
    try:
        return int(args.func(args) or 0)
    except Ur5FaultError as exc:
        return _one_line(str(exc))
    except BrokenPipeError:  # `ur5fault campaign status DIR | head`: the reader left, nothing is wrong
        _silence_stdout()
        return 128 + signal.SIGPIPE
    except Exception as exc:
        if type(exc).__name__ != "TerminatedWorkerError":  # joblib's: a worker process was killed
            raise
        return _one_line("a worker process died (killed, or out of memory); every result written before it is "
                         "kept: run the same command again to continue")
    except Terminated:
        sys.stderr.write("ur5fault: terminated\n")
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        sys.stderr.write("ur5fault: interrupted\n")
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())
