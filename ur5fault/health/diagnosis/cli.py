"""``ur5fault diagnose LOG --format rtde|nist|sim [--model OVERLAY] [--baseline-logs LOG ...] --detector DIR
--out DIR``."""

from __future__ import annotations

import argparse
import copy

from ...logs.options import add_log_options
from ...util import progress
from ...util.usage import KUFIETA, KUFIETA_RUNS, examples, shipped


def register(sub) -> None:
    d = sub.add_parser("diagnose", help="score a measured log with the classifiers `ur5fault benchmark` saved: "
                                        "p(fault) per window and joint, likeliest kinds and sizes",
                       **examples("ur5fault campaign run diagnostics_urlog --yes && ur5fault benchmark "
                                  "results/diagnostics_urlog    # a detector for UR logs (8 ms, no motor encoders)",
                                  f"ur5fault diagnose {shipped('kufieta/TEST')} {KUFIETA} --detector "
                                  f"results/diagnostics_urlog/benchmark --baseline-logs {KUFIETA_RUNS} --out diag"))
    add_log_options(d, ("rtde", "nist", "sim"), several=False)
    d.add_argument("--model", help="model overlay YAML of the robot (e.g. model.yaml of `ur5fault discrepancy`; "
                                   "default: none, the nominal model)")
    d.add_argument("--baseline-logs", nargs="+", metavar="LOG",
                   help="healthy logs of the same robot (never the diagnosed one; same --format / payload options "
                        "as the log, or one manifest), replayed under the same model and windowed the same way: "
                        "every input is referred to this robot's healthy spread instead of the simulated one "
                        "(default: none, the inputs are scored as they are)")
    d.add_argument("--detector", required=True,
                   help="folder of the saved classifiers (a benchmark folder with models/, or models/ itself)")
    d.add_argument("--out", required=True, help="output folder (diagnosis.json, report.md, diagnosis.png; created)")
    d.add_argument("--replace", action="store_true",
                   help="replace an earlier result at --out (default: refused, nothing a user made is lost silently)")
    d.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, plain lines in a log)")
    d.set_defaults(func=cmd_diagnose)


def baseline_notes(log, healthy, temperature_C) -> list[str]:
    """The notes on the baseline logs ``healthy`` of the diagnosed ``log`` (:class:`~ur5fault.logs.MeasuredLog`):
    what they assume, logs of two controllers (the robot's threshold would be read off another robot's logs) and a
    payload outside theirs (as ``ur5fault monitor`` says it: :func:`~ur5fault.health.monitoring.coverage.
    payload_kg_notes`); printed and written into ``diagnosis.json``'s notes and ``report.md``."""
    from ...logs.measured import controllers_note
    from ..monitoring.coverage import payload_kg_notes

    return ([f"baseline {n}" for n in dict.fromkeys(n for g in healthy for n in g.assumptions(temperature_C))]
            + controllers_note([(g.source, g.rest_target) for g in (log, *healthy)])
            + [f"{log.source} {n}" for n in payload_kg_notes([g.payload_kg for g in healthy], log.payload_kg)])


def cmd_diagnose(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    from ...config import Overlay
    from ...errors import ParameterError
    from ...logs.length import check_files_length, check_logs_length
    from ...logs.options import log_entries, refuse_hold_out
    from ...logs.read_entries import read_entry, refuse_unknown_payload
    from ...logs.same_samples import refuse_same_samples
    from ...twin.replay import refuse_log_owned
    from ...util.results import check_new_output, present, result_folder, said_written
    from ..diagnostics.classifier import require_sklearn
    from ..diagnostics.saved import load_models, models_folder
    from . import diagnose, robot_baseline
    from .rate import at_training_rate
    from .report import FIGURE_FILE, JSON_FILE, REPORT_FILE, write_diagnosis
    from .score import check_schema
    from .windows import window_length

    base_args = None
    if args.baseline_logs:
        base_args = copy.copy(args)
        base_args.log = args.baseline_logs
        base_args.log_group = "--baseline-logs"  # named in its refusals
    entries = log_entries(args, *([base_args] if base_args else []))  # the command line's options serve both
    if len(entries) != 1:
        raise ParameterError(f"diagnose reads one log; the manifest names {len(entries)}")
    refuse_hold_out(entries, "the log diagnose scores")
    base = []
    if base_args is not None:
        base = log_entries(base_args, args)
        refuse_hold_out(base, "a diagnose baseline")
        names = [e.path.resolve() for e in base]
        dup = sorted({str(n) for n in names if names.count(n) > 1})
        if dup:
            raise ParameterError(f"baseline log {dup[0]!r} given twice")
        if entries[0].path.resolve() in names:
            raise ParameterError(f"{entries[0].path} is both diagnosed and a baseline log; a run cannot judge "
                                 "itself: give other healthy logs of the robot")
    refuse_unknown_payload([*entries, *base])  # before the models are loaded and the logs read
    require_sklearn()
    results = (JSON_FILE, REPORT_FILE, FIGURE_FILE)
    if Path(args.detector).exists():  # a folder of the wrong kind: its own reason before a word on --out
        models_folder(args.detector)
    check_new_output(args.out, folder=True, results=results, replace=args.replace)
    schema = load_models(args.detector)[1]
    window_s = check_schema(schema, args.detector)  # refused before the replay
    overlay = Overlay.load(args.model) if args.model else None
    params, effects = (dict(overlay.params), overlay.effects) if overlay else (None, ())
    refuse_log_owned(params, effects, [])  # a payload in the overlay: before any log is read
    check_files_length([e.path for e in (*entries, *base)], "diagnose")
    # a log sampled a whole number of times faster than the training runs: at their rate (rate.py)
    log = at_training_rate(read_entry(entries[0], window_length(window_s)), schema.get("log_period_s"))
    healthy = [at_training_rate(read_entry(e, window_length(window_s)), schema.get("log_period_s")) for e in base]
    check_logs_length([log, *healthy], "diagnose")
    refuse_same_samples([("diagnosed", [log]), ("a baseline log", healthy)])  # a copy under another name too
    refuse_log_owned(params, effects, [log, *healthy])  # another tool: before the logs' notes
    base_notes = []
    if healthy:  # what the baseline logs assume (the diagnosed log's own notes come with its diagnosis)
        from ...sim.params import load_params

        base_notes = baseline_notes(log, healthy, load_params(overrides=params).joint_temperature_C)
        for line in base_notes:
            print(f"note: {line}", file=sys.stderr)
    with progress.bar(len(healthy) + 1, "diagnose: logs replayed", "log", enabled=not args.quiet) as pbar:
        baseline = robot_baseline(healthy, args.detector, params, effects) if healthy else None
        pbar.update(len(healthy))
        d = diagnose(log, args.detector, params, effects, baseline=baseline)
        pbar.update(1)
    for n in d["notes"]:
        print(f"note: {n}", file=sys.stderr)
    d["notes"] = [*base_notes, *d["notes"]]  # every note printed is in diagnosis.json and report.md too
    earlier = present(Path(args.out) / name for name in results)  # with --replace: said as replaced
    with result_folder(args.out, results, args.replace) as out:  # one set: a stop between files is marked
        paths = write_diagnosis(d, out)
    ft = d["flag_threshold"]  # p(fault) and the raw score it was calibrated from: two numbers, each named
    scale = (f"the calibrated probability at the detector's raw-score threshold {ft['score']:.3f}"
             if d["detector"]["calibrated"] else "the detector's raw-score threshold itself (no calibration saved)")
    print(f"{d['log']}: {d['n_flagged']} of {d['n_windows']} windows of {d['detector']['window_s']:.3g} s flagged "
          f"(p(fault) > {ft['p_fault']:.3f}, {scale}: {ft['from']}); largest p(fault) "
          f"{max(w['p_fault'] for w in d['windows']):.3f}")
    if baseline is not None:
        print(f"baseline: {baseline.n_windows} windows of {len(baseline.logs)} healthy log(s)")
    print(said_written(paths, earlier))
    return 0
