"""``ur5fault discrepancy LOG [LOG ...] --format rtde|nist|sim [--hold-out LOG ...] [--model M] --out DIR``."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from ..logs.options import add_log_options
from ..twin.residuals import FIT_FRACTION
from ..util.usage import KUFIETA, KUFIETA_RUNS, examples, shipped


def register(sub) -> None:
    d = sub.add_parser("discrepancy", help="find, name and fix where the model and a measured log disagree",
                       **examples(f"ur5fault discrepancy {shipped('nist')} --format nist --out fit    # 40-70 s "
                                  "on 2 cores",
                                  f"ur5fault discrepancy {KUFIETA_RUNS} {KUFIETA} --hold-out {shipped('kufieta/TEST')} "
                                  "--out kfit",
                                  "ur5fault simulate --model fit/model.yaml --out calibrated.parquet"))
    add_log_options(d, ("rtde", "nist", "sim"), hold_out=True)
    d.add_argument("--model", help="model overlay YAML to start from (e.g. an earlier model.yaml; default: none, the "
                                   "nominal model)")
    d.add_argument("--out", required=True, help="output folder (report.md, model.yaml, summary.json; created)")
    d.add_argument("--replace", action="store_true",
                   help="replace an earlier result at --out (default: refused, nothing a user made is lost silently)")
    d.add_argument("--fit-fraction", type=float, default=FIT_FRACTION,
                   help=f"share of the log used for fitting (0.2..0.9, default {FIT_FRACTION:g})")
    d.add_argument("--max-effects", type=int, default=1,
                   help="most effects of the library named per joint; robot-wide ones count as one more joint "
                        "(default 1)")
    d.add_argument("--max-terms", type=int, default=4,
                   help="most terms discovered outside the library (default 4; 0: library only)")
    d.add_argument("--jobs", type=int, help="worker processes for the simulation batches (default: all cores)")
    d.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, plain lines in a log)")
    d.set_defaults(func=cmd_discrepancy)


def held_out_line(name: str, entry: dict) -> str:
    """One log's held-out current RMS after the fit (``summary.json``'s ``per_log`` entry): as multiples of UR's
    own model where the log has its target currents, else in amperes."""
    cur = entry["rms_after"].get("current_A", {})
    ur = entry.get("rms_controller_model_current_A")
    head = f"{entry['role']}: {name}: held-out current RMS after the fit"
    if ur:
        return head + ", as a multiple of UR's own model: " + " / ".join(
            f"{cur[j] / ur[j]:.2f}" if cur.get(j) is not None and ur.get(j) else "-" for j in cur)
    return head + f" [A], J1..J{len(cur)}: " + " / ".join("-" if v is None else f"{v:.3f}" for v in cur.values())


def cmd_discrepancy(args: argparse.Namespace) -> int:
    from ..config import Overlay
    from ..errors import ParameterError
    from ..logs.length import check_files_length, check_logs_length
    from ..logs.measured import assumption_notes
    from ..logs.options import log_entries
    from ..logs.read_entries import read_log_options
    from ..sim.params import load_params
    from ..twin.replay import refuse_log_owned
    from ..util.checks import check_count, check_number
    from ..util.results import check_new_output, present, said_written
    from .model import FIT_FRACTION_RANGE, DiscrepancyModel
    from .report import RESULT_FILES, summary, write_report

    # everything that can be checked before minutes of fitting is checked first, in the options' own names
    check_number(args.fit_fraction, "--fit-fraction", *FIT_FRACTION_RANGE)
    for option, value, least in (("--max-effects", args.max_effects, 0), ("--max-terms", args.max_terms, 0),
                                 ("--jobs", args.jobs if args.jobs is not None else 1, 1)):
        check_count(value, option, least)
    jobs = (os.cpu_count() or 1) if args.jobs is None else args.jobs
    model = DiscrepancyModel(fit_fraction=args.fit_fraction, max_effects=args.max_effects,
                             max_terms=args.max_terms, jobs=jobs, progress=not args.quiet)
    check_new_output(args.out, folder=True, results=RESULT_FILES, replace=args.replace)
    overlay = Overlay.load(args.model) if args.model else None
    params, effects = (dict(overlay.params), overlay.effects) if overlay else (None, ())
    refuse_log_owned(params, effects, [])  # a payload in the overlay: before any log is read
    check_files_length([e.path for e in log_entries(args)], "discrepancy")  # an hour-long log: refused in seconds
    logs, held = read_log_options(args, allow_unknown=True)  # an unknown payload is fitted (and said so)
    check_logs_length([*logs, *held], "discrepancy")
    refuse_log_owned(params, effects, [*logs, *held])  # another tool: before the logs' notes
    if not logs:
        raise ParameterError("every log given is held out; name at least one log to fit")
    temps = load_params(overrides=dict(overlay.params) if overlay else None).joint_temperature_C
    for line in assumption_notes([*logs, *held], temps):
        print(f"note: {line}", file=sys.stderr)
    model.fit(logs if len(logs) > 1 else logs[0], dict(overlay.params) if overlay else None,
              overlay.effects if overlay else (), hold_out=held,
              on_payload=lambda line: print(line, file=sys.stderr, flush=True))
    log = model.replay_.log
    earlier = present(Path(args.out) / name for name in RESULT_FILES)  # with --replace: said as replaced
    paths = write_report(model, Path(args.out), replace=args.replace)
    summ = summary(model)
    print(f"{log.source}: {log.t_s[-1]:.1f} s at {1 / log.period_s:.0f} Hz")
    for name, e in summ["per_log"].items():
        print(held_out_line(name, e))
    nothing = ("nothing named: what the model leaves is listed as unexplained below" if summ["unexplained"]
               else "nothing explains the residual better than noise")
    for line in summ["named"] or [nothing]:
        print(line)
    for line in summ["dropped"]:
        print(f"dropped: {line}")
    for u in summ["unexplained"]:
        print(f"unexplained: {u['signal']} on {u['joint']} (held-out RMS {u['rms_held_out']:.3g}, "
              f"largest {u['largest_where']})")
    print(said_written(paths[:3], earlier, f" in {summ['wall_s']:.0f} s"))
    return 0
