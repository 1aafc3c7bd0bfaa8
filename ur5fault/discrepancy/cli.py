"""``ur5fault discrepancy LOG --format rtde|nist|sim [--model OVERLAY] --out DIR``."""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ..logs.options import add_log_options
from ..twin.residuals import FIT_FRACTION


def register(sub) -> None:
    d = sub.add_parser("discrepancy", help="find, name and fix where the model and a measured log disagree")
    add_log_options(d, ("rtde", "nist", "sim"))
    d.add_argument("--model", help="model overlay YAML to start from (e.g. an earlier model.yaml)")
    d.add_argument("--out", required=True, help="output folder (report.md, model.yaml, summary.json)")
    d.add_argument("--fit-fraction", type=float, default=FIT_FRACTION,
                   help=f"share of the log used for fitting (0.2..0.9, default {FIT_FRACTION:g})")
    d.add_argument("--max-effects", type=int, default=3, help="most effects of the library named (default 3)")
    d.add_argument("--max-terms", type=int, default=4,
                   help="most terms discovered outside the library (default 4; 0: library only)")
    d.add_argument("--jobs", type=int, help="worker processes for the simulation batches (default: all cores)")
    d.add_argument("--quiet", action="store_true", help="no progress bar")
    d.set_defaults(func=cmd_discrepancy)


def cmd_discrepancy(args: argparse.Namespace) -> int:
    from ..config import Overlay
    from ..logs.options import read_log_option
    from ..util.io import check_writable
    from .model import DiscrepancyModel
    from .report import summary, write_report

    jobs = (os.cpu_count() or 1) if args.jobs is None else args.jobs
    # everything that can be checked before minutes of fitting is checked first
    model = DiscrepancyModel(fit_fraction=args.fit_fraction, max_effects=args.max_effects,
                             max_terms=args.max_terms, jobs=jobs, progress=not args.quiet)
    check_writable(args.out, folder=True)
    log = read_log_option(args)
    overlay = Overlay.load(args.model) if args.model else None
    model.fit(log, dict(overlay.params) if overlay else None, overlay.effects if overlay else ())
    paths = write_report(model, Path(args.out))
    summ = summary(model)
    print(f"{log.source}: {log.t_s[-1]:.1f} s at {1 / log.period_s:.0f} Hz")
    for line in summ["named"] or ["nothing explains the residual better than noise"]:
        print(line)
    for line in summ["dropped"]:
        print(f"dropped: {line}")
    for u in summ["unexplained"]:
        print(f"unexplained: {u['signal']} on {u['joint']} (held-out RMS {u['rms_held_out']:.3g}, "
              f"largest {u['largest_where']})")
    print(f"wrote {', '.join(str(p) for p in paths[:3])} in {summ['wall_s']:.0f} s")
    return 0
