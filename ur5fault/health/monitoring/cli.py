"""``ur5fault monitor LOG [LOG ...] --baseline MODEL.yaml (--baseline-logs LOG ... | --baseline-stats FILE)
--out DIR``."""

from __future__ import annotations

import argparse
import copy
import math
import os
import sys
from pathlib import Path

from ...logs.options import add_log_options
from ...util import progress
from ...util.usage import KUFIETA, KUFIETA_RUNS, examples, shipped

#: what `monitor` writes into --out (report.py); one of them there is an earlier result
RESULT_FILES = ("monitor.json", "baseline.json", "report.md")


def register(sub) -> None:
    p = sub.add_parser("monitor", help="compare new logs of a robot with its fitted baseline: consistent, changed "
                                       "or anomaly",
                       **examples(f"ur5fault identify {KUFIETA_RUNS} {KUFIETA} --out kufieta.yaml",
                                  f"ur5fault monitor {shipped('kufieta/Movement_No5_Acc_slow_w_disturbance')} "
                                  f"{KUFIETA} --baseline kufieta.yaml --baseline-logs "
                                  f"{shipped('kufieta/Movement_No5_Acc_slow_no_disturbance')} {KUFIETA_RUNS} --out "
                                  "mon    # pushed by hand: anomaly, 9 events",
                                  f"ur5fault monitor {shipped('kufieta/Movement_No1')} {KUFIETA} --baseline "
                                  "kufieta.yaml --baseline-stats mon/baseline.json --out mon2    # its statistics "
                                  "reused; notes where the log moves faster than the baseline runs"))
    add_log_options(p, ("rtde", "nist", "sim"))
    p.add_argument("--baseline", required=True, metavar="MODEL.yaml",
                   help="the robot's fitted model overlay (model.yaml of ur5fault discrepancy, or identify's)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--baseline-logs", nargs="+", metavar="LOG",
                     help="healthy runs of the robot, at least 2, replayed under the overlay for the residual "
                          "statistics the thresholds come from (same --format / payload options as the logs; or one "
                          "manifest); this or --baseline-stats is required")
    src.add_argument("--baseline-stats", metavar="FILE",
                     help="baseline.json written by an earlier ur5fault monitor with the same overlay; this or "
                          "--baseline-logs is required")
    p.add_argument("--out", required=True, help="output folder (monitor.json, baseline.json, report.md, figures; "
                                                "created)")
    p.add_argument("--replace", action="store_true",
                   help="replace an earlier result at --out (default: refused, nothing a user made is lost silently)")
    p.add_argument("--event-channels", nargs="+", choices=("current", "position"), default=["current"],
                   metavar="CHANNEL",
                   help="the residuals events are judged on: current (default) and/or position (the measured "
                        "tracking error less the twin's; each at half the false-alarm probability when both)")
    p.add_argument("--jobs", type=int, help="worker processes for the simulation batches (default: all cores)")
    p.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, plain lines in a log)")
    p.set_defaults(func=cmd_monitor)


def cmd_monitor(args: argparse.Namespace) -> int:
    from ...config import Overlay
    from ...errors import ParameterError
    from ...logs.length import check_files_length, check_logs_length
    from ...logs.measured import assumption_notes, same_period
    from ...logs.options import log_entries, refuse_hold_out
    from ...logs.plausible import JUDGE_LENGTH
    from ...logs.read_entries import read_log_options, refuse_unknown_payload
    from ...logs.same_samples import refuse_same_samples
    from ...sim.params import load_params
    from ...twin.replay import refuse_log_owned
    from ...util.io import checksum_path
    from ...util.results import check_new_output, present, result_folder, said_written
    from .baseline import MIN_RUNS, MIN_RUNS_WHY, Baseline, fit_baseline, overlay_sha256
    from .observe import BASELINE_SCREEN_S, observe
    from .report import write
    from .verdict import assess, refuse_baseline_runs

    jobs = (os.cpu_count() or 1) if args.jobs is None else args.jobs
    if jobs < 1:
        raise ParameterError(f"--jobs {jobs} must be at least 1")
    check_new_output(args.out, folder=True, results=RESULT_FILES, replace=args.replace)
    overlay = Overlay.load(args.baseline)
    refuse_log_owned(dict(overlay.params), overlay.effects, [])  # a payload in the overlay: before any log is read
    sha = overlay_sha256(dict(overlay.params), overlay.effects)
    stats, verified = None, True
    if args.baseline_stats:
        stats = Baseline.load(args.baseline_stats)
        sidecar = checksum_path(Path(args.baseline_stats))
        verified = sidecar.exists()
        if not verified:  # edited by hand, or copied without it
            print(f"note: {args.baseline_stats}: no {sidecar.name} beside it; read unverified (and written to "
                  f"{args.out} without one)", file=sys.stderr)
        if stats.overlay_sha256 != sha:
            raise ParameterError(f"{args.baseline_stats}: was built under another model overlay than "
                                 f"{args.baseline}; rebuild it with --baseline-logs")
    base_args = None
    if args.baseline_logs:
        base_args = copy.copy(args)
        base_args.log = args.baseline_logs
        base_args.log_group = "--baseline-logs"  # named in its refusals
    groups = [args] if base_args is None else [args, base_args]  # the command line's options are shared by both
    entries = [log_entries(a, *(g for g in groups if g is not a)) for a in groups]
    for group, where in zip(entries, ("the logs monitor judges", "a monitor baseline")):
        refuse_hold_out(group, where)
        refuse_unknown_payload(group)  # before any log is read
    check_files_length([e.path for group in entries for e in group], "monitor")
    logs, _ = read_log_options(args, others=groups[1:], role="monitored", length=JUDGE_LENGTH)  # nothing fitted
    healthy = read_log_options(base_args, others=[args], role="a baseline log")[0] if base_args is not None else []
    check_logs_length([*logs, *healthy], "monitor")
    refuse_same_samples([("monitored", logs), ("a baseline log", healthy)])  # a run cannot judge itself
    if stats is not None:  # nor one of the runs baseline.json was built from: before any replay
        refuse_baseline_runs(stats, logs)
    if base_args is not None and len(healthy) < MIN_RUNS:  # before any replay
        raise ParameterError(f"--baseline-logs: {len(healthy)} healthy run given; a baseline needs at least "
                             f"{MIN_RUNS}: {MIN_RUNS_WHY}")
    rate = healthy[0].period_s if healthy else stats.period_s if stats is not None else None
    for g in [*healthy, *logs] if rate is not None else []:  # before any replay (it was told after seconds of it)
        if not same_period(g.period_s, rate):
            raise ParameterError(f"{g.source}: logged every {1e3 * g.period_s:g} ms, the baseline's runs every "
                                 f"{1e3 * rate:g} ms: a baseline judges logs of its own rate (its spread and tails "
                                 "depend on it); build one from healthy logs at this rate with --baseline-logs")
    refuse_log_owned(dict(overlay.params), overlay.effects, [*healthy, *logs])  # another tool: before the notes
    temps = load_params(overrides=dict(overlay.params)).joint_temperature_C
    recorded = () if stats is None or stats.rest_targets is None else tuple(zip(stats.segments, stats.rest_targets))
    if stats is not None and stats.rest_targets is None:  # written before baseline.json recorded it
        print(f"note: {args.baseline_stats} does not record its runs' target at rest (written by an earlier "
              f"version): whether the logs are of its runs' controller is not checked; rebuild it with "
              f"--baseline-logs to have it checked", file=sys.stderr)
    unrecorded = [] if stats is None else [what for what, v in (("motion range", stats.motion_max),
                                                                 ("payloads", stats.payloads_kg)) if v is None]
    if stats is not None and stats.motion_max is not None and not all(map(math.isfinite, stats.motion_max.flat)):
        unrecorded.append("other joints' speed while a joint stands")  # recorded since 2026-12-02
    if unrecorded:  # the same, for what the baseline runs covered (coverage.py)
        print(f"note: {args.baseline_stats} does not record its runs' {' and '.join(unrecorded)} (written by an "
              f"earlier version): whether a log leaves them is not said; rebuild it with --baseline-logs to have it "
              f"said", file=sys.stderr)
    notes = assumption_notes([*healthy, *logs], temps, others=recorded)
    for line in notes:
        print(f"note: {line}", file=sys.stderr)
    params, effects = dict(overlay.params), overlay.effects
    replays = (healthy if stats is None else []) + logs  # each replayed once: the work of this command
    with progress.bar(len(replays), "monitor: logs replayed", "log", enabled=not args.quiet) as pbar:
        def replayed(group, **kw):
            for g in group:
                yield observe(g, params, effects, jobs=jobs, **kw)
                pbar.update(1)

        if stats is None:  # fitted (or refused) before the monitored logs are replayed
            stats = fit_baseline(list(replayed(healthy, screen_s=BASELINE_SCREEN_S)), sha)
        observed = list(replayed(logs))
    channels = tuple(dict.fromkeys(args.event_channels))
    entries = [assess(stats, o, channels) for o in observed]
    earlier = present(Path(args.out) / name for name in RESULT_FILES)  # with --replace: said as replaced
    with result_folder(args.out, RESULT_FILES, args.replace) as out:  # one set: a stop between files is marked
        paths = write(out, stats, observed, entries, args.baseline, channels, verified, notes)
    for e in entries:
        blind = f"; events not seen on {', '.join(e['events_not_seen'])}: note below" if e["events_not_seen"] else ""
        print(f"{e['log']}: {e['verdict']} ({len(e['changes'])} changes, {len(e['events'])} events{blind})")
        for line in e["notes"]:
            print(f"note: {e['log']}: {line}", file=sys.stderr)
    print(said_written([*paths[:2], paths[-1]], earlier))
    return 0
