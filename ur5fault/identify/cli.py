"""``ur5fault identify LOG [LOG ...] --format nist|rtde [--payload-kg M] [--tcp-offset-m X Y Z] --out params.yaml``."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
from pathlib import Path

from ..logs.options import add_log_options
from ..util.usage import KUFIETA, KUFIETA_RUNS, examples, shipped
from .loop import SWEEP_WINDOW_S
from .stats import MAX_BOOT, N_BOOT


def register(sub) -> None:
    d = sub.add_parser("identify", help="re-derive the measured drive parameters from a log (parameter overlay)",
                       **examples(f"ur5fault identify {shipped('nist')} --format nist --out nist.yaml",
                                  f"ur5fault identify {KUFIETA_RUNS} {KUFIETA} --out kufieta.yaml    # two runs of "
                                  "one robot, jointly",
                                  "ur5fault simulate --model nist.yaml --out identified.parquet"))
    add_log_options(d, ("nist", "rtde"))
    d.add_argument("--out", required=True, metavar="PARAMS.yaml",
                   help="parameter overlay YAML to write (accepted by --model; missing folders are created)")
    d.add_argument("--replace", action="store_true",
                   help="replace an earlier result at --out or --json (default: refused, nothing a user made is "
                        "lost silently)")
    d.add_argument("--json", metavar="FILE.json", help="also write every estimate with its interval as JSON "
                                                          "(default: not written)")
    d.add_argument("--no-sweep", action="store_true",
                   help="skip the position-loop bandwidth sweep (it replays the log once per candidate)")
    d.add_argument("--sweep-window-s", type=float,
                   help=f"the part of the log the sweep replays, from its start; of several logs, the first whose "
                        f"part moves a joint (default {SWEEP_WINDOW_S:g})")
    d.add_argument("--bootstrap", type=int, default=N_BOOT,
                   help=f"resamples per interval, 20..{MAX_BOOT} (default {N_BOOT})")
    d.add_argument("--quiet", action="store_true", help="no progress messages")
    d.set_defaults(func=cmd_identify)


def cmd_identify(args: argparse.Namespace) -> int:
    from ..errors import ParameterError
    from ..logs.length import check_files_length, check_logs_length
    from ..logs.measured import assumption_notes
    from ..logs.options import log_entries
    from ..logs.read_entries import read_log_options
    from ..sim.params import load_params
    from ..util.io import write_json_atomic, write_text_atomic
    from ..util.results import check_new_output, file_lock, present, said_written
    from . import identify

    if not 20 <= args.bootstrap <= MAX_BOOT:
        raise ParameterError(f"--bootstrap = {args.bootstrap} must be 20..{MAX_BOOT} resamples")
    if args.sweep_window_s is not None and args.no_sweep:
        raise ParameterError("--sweep-window-s applies to the bandwidth sweep, which --no-sweep skips: give one")
    window_s = SWEEP_WINDOW_S if args.sweep_window_s is None else args.sweep_window_s
    if not math.isfinite(window_s) or window_s <= 0:
        raise ParameterError(f"--sweep-window-s = {window_s} must be a positive number of seconds")
    # before the fit, not after it: a folder or an earlier result in the way, or a name that is no YAML, refused now
    check_new_output(args.out, replace=args.replace, suffixes=(".yaml", ".yml"))
    if args.json:
        check_new_output(args.json, replace=args.replace, suffixes=(".json",), option="--json")  # never --out
    check_files_length([e.path for e in log_entries(args)], "identify")  # an hour-long log: refused in seconds
    logs, held = read_log_options(args, allow_unknown=True)
    if not logs:
        raise ParameterError("every log given is held out; name at least one log to fit")
    if held:  # a manifest shared with discrepancy or monitor: its held-out runs stay unseen by the fit
        print(f"note: left out (hold_out in the manifest; identify scores no held-out run, `ur5fault discrepancy` "
              f"does): {', '.join(g.source for g in held)}", file=sys.stderr)
    check_logs_length(logs, "identify")
    log = logs[0]
    say = None if args.quiet else (lambda msg: print(f"identify: {msg}...", file=sys.stderr, flush=True))
    params = load_params()
    notes = [line for lg in logs for line in lg.assumptions(params.joint_temperature_C)]  # per log, in --json
    for line in assumption_notes(logs, params.joint_temperature_C):
        print(f"note: {line}", file=sys.stderr)
    result = identify(logs if len(logs) > 1 else log, params, sweep=not args.no_sweep,
                      sweep_window_s=window_s,
                      n_boot=args.bootstrap, progress=say)
    for rec in result.payloads:
        if not rec.known:
            print(rec.line(), file=sys.stderr)
    print(result.table())
    for line in result.notes:
        print(f"note: {line}", file=sys.stderr)
    out = Path(args.out)
    text = result.to_yaml(params)  # checked as --model reads it before any lock is taken
    written = [out, *([Path(args.json)] if args.json else [])]
    with contextlib.ExitStack() as held:
        for path, option in zip(written, ("--out", "--json")):  # again, under the file's lock: another run may
            held.enter_context(file_lock(path))  # have written it while this one fitted
            check_new_output(path, replace=args.replace, option=option)
        earlier = present(written)  # with --replace (else refused above): said as replaced
        write_text_atomic(out, text)
        if args.json:
            write_json_atomic(Path(args.json), {**result.to_json(), "log_assumptions": notes})
    print(said_written(written, earlier))
    return 0
