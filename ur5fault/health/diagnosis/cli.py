"""``ur5fault diagnose LOG --format rtde|nist|sim [--model OVERLAY] --detector DIR --out DIR``."""

from __future__ import annotations

import argparse

from ...logs.options import add_log_options


def register(sub) -> None:
    d = sub.add_parser("diagnose", help="score a measured log with the classifiers `ur5fault benchmark` saved: "
                                        "p(fault) per window and joint, likeliest kinds and sizes")
    add_log_options(d, ("rtde", "nist", "sim"), several=False)
    d.add_argument("--model", help="model overlay YAML of the robot (e.g. model.yaml of `ur5fault discrepancy`; "
                                   "default: none, the nominal model)")
    d.add_argument("--detector", required=True,
                   help="folder of the saved classifiers (a benchmark folder with models/, or models/ itself)")
    d.add_argument("--out", required=True, help="output folder (diagnosis.json, report.md, diagnosis.png)")
    d.set_defaults(func=cmd_diagnose)


def cmd_diagnose(args: argparse.Namespace) -> int:
    import sys

    from ...config import Overlay
    from ...logs.length import check_files_length, check_logs_length
    from ...logs.options import log_entries, read_entry
    from ...util.io import check_writable
    from ..diagnostics.classifier import require_sklearn
    from ..diagnostics.saved import load_models
    from . import diagnose
    from .report import write_diagnosis
    from .score import check_schema
    from .windows import window_length

    entries = log_entries(args)
    if len(entries) != 1:
        from ...errors import ParameterError

        raise ParameterError(f"diagnose reads one log; the manifest names {len(entries)}")
    require_sklearn()
    check_writable(args.out, folder=True)
    window_s = check_schema(load_models(args.detector)[1], args.detector)  # refused before the replay
    check_files_length([e.path for e in entries], "diagnose")
    log = read_entry(entries[0], window_length(window_s))
    check_logs_length([log], "diagnose")
    overlay = Overlay.load(args.model) if args.model else None
    d = diagnose(log, args.detector, dict(overlay.params) if overlay else None, overlay.effects if overlay else ())
    for n in d["notes"]:
        print(f"note: {n}", file=sys.stderr)
    paths = write_diagnosis(d, args.out)
    print(f"{d['log']}: {d['n_flagged']} of {d['n_windows']} windows of {d['detector']['window_s']:g} s flagged "
          f"(p(fault) > {d['detector']['p_fault_at_threshold']:.3f}); largest p(fault) "
          f"{max(w['p_fault'] for w in d['windows']):.3f}")
    print(f"wrote {', '.join(str(p) for p in paths)}")
    return 0
