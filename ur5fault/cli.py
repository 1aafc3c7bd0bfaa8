"""Command line: ``ur5fault simulate | effects | campaign | plot | discrepancy``.

Bad input prints one line ``ur5fault: error: ...`` naming the problem and the valid
choices, and exits with status 2; never a traceback.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

from . import progress
from .errors import Ur5FaultError

EXIT_USAGE = 2


def cmd_simulate(args: argparse.Namespace) -> int:
    from .config import Overlay, build_run_config
    from .engine import RunSpec, Simulator
    from .params import read_yaml

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
    sim = Simulator(cfg.params)
    with progress.bar(1.0, "simulate", "run", enabled=not args.quiet,
                      bar_format="{desc}: {percentage:3.0f}%|{bar}| {elapsed}<{remaining}") as pbar:
        res = sim.run(cfg.trajectory, [RunSpec("run", cfg.seed, cfg.effects)], log_period_s=cfg.log_period_s,
                      duration_s=cfg.duration_s, progress=progress.fraction_callback(pbar))
    out = Path(args.out)
    res.to_parquet(out)
    summ = res.summary(0)
    print(f"wrote {out} ({res.t_s.size} samples x {len(res.to_pandas(0).columns)} columns)")
    print("effects: " + ("; ".join(res.effects[0]) or "none (healthy)"))
    print(json.dumps(summ, indent=None))
    return 0 if res.status[0] == "ok" else 1


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
        try:
            item[key] = float(val)
        except ValueError:
            raise Ur5FaultError(f"--effect {spec!r}: {key} = {val!r} is not a number") from None
    return item


def cmd_effects(args: argparse.Namespace) -> int:
    from .effects import REGISTRY

    for e in REGISTRY.values():
        ps = ", ".join(f"{p.name} [{p.lo:g}..{p.hi:g}]" + (f" absent={p.absent:g}" if p.absent is not None else "")
                       for p in e.params)
        print(f"{e.name:22s} {'per joint' if e.per_joint else 'robot    '}  {ps}  - {e.doc}")
    return 0


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # one line, exit 2
        self.exit(EXIT_USAGE, f"ur5fault: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    p = _Parser(prog="ur5fault", description="UR5 fault-injection simulator")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)
    s = sub.add_parser("simulate", help="run one configuration and write its time series to Parquet")
    s.add_argument("--config", help="run configuration YAML (see docs/usage.md)")
    s.add_argument("--model", help="model overlay YAML (params and effects), e.g. from `discrepancy`")
    s.add_argument("--backlash", action="append", metavar="JOINT:DEG",
                   help="backlash fault, e.g. shoulder_lift_joint:0.1 (repeatable)")
    s.add_argument("--effect", action="append", metavar="NAME[@JOINT]:K=V,...",
                   help="any registered effect, e.g. coulomb_friction@elbow:scale=1.5 (see `ur5fault effects`)")
    s.add_argument("--trajectory", help="trajectory name (default pick_and_place)")
    s.add_argument("--seed", type=int)
    s.add_argument("--payload-kg", type=float, dest="payload_kg")
    s.add_argument("--temperature-C", type=float, dest="temperature_C")
    s.add_argument("--duration-s", type=float, dest="duration_s")
    s.add_argument("--log-period-s", type=float, dest="log_period_s")
    s.add_argument("--out", default="run.parquet", help="output Parquet file (default run.parquet)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.set_defaults(func=cmd_simulate)
    e = sub.add_parser("effects", help="list the effect registry")
    e.set_defaults(func=cmd_effects)
    _add_optional_commands(sub)
    return p


def _add_optional_commands(sub) -> None:
    """The campaign and discrepancy command groups (imported directly: a broken module is an error,
    not a silently missing command)."""
    from . import discrepancy_cli
    from .benchmark import cli as benchmark_cli
    from .campaign import cli as campaign_cli

    campaign_cli.register(sub)
    discrepancy_cli.register(sub)
    benchmark_cli.register(sub)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except Ur5FaultError as exc:
        sys.stderr.write(f"ur5fault: error: {exc}\n")
        return EXIT_USAGE
    except KeyboardInterrupt:
        sys.stderr.write("ur5fault: interrupted\n")
        return 130


if __name__ == "__main__":
    sys.exit(main())
