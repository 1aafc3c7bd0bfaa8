"""``ur5fault campaign run|status|show|list`` and ``ur5fault plot``."""

from __future__ import annotations

import argparse
import shutil
import sys
import textwrap
from pathlib import Path

from ..util.io import json_text
from ..util.usage import examples
from .spec import shipped_campaigns


def register(sub) -> None:
    c = sub.add_parser("campaign", help="run a YAML fault campaign into Parquet feature tables")
    csub = c.add_subparsers(dest="campaign_command", metavar="{run,status,show,list}", parser_class=type(c))
    c.set_defaults(func=lambda args: _usage(c))
    r = csub.add_parser("run", help="run (or resume) a campaign",
                        **examples("ur5fault campaign run default    # campaigns/default.yaml, shipped -> "
                                   "results/default/",
                                   "ur5fault campaign run paper --duration-s 2 --out trial    # a quick trial",
                                   "ur5fault campaign status results/default"))
    r.add_argument("file", metavar="FILE|NAME",
                   help="campaign YAML, or the name of a campaign shipped with ur5fault: "
                        f"{', '.join(shipped_campaigns())} (e.g. `ur5fault campaign run paper`)")
    r.add_argument("--out", help="output folder (default: the file's `out`, e.g. results/paper)")
    r.add_argument("--model", help="model overlay YAML (e.g. from `ur5fault discrepancy`) applied to every run "
                                          "(default: none, the nominal model)")
    r.add_argument("--duration-s", type=float, dest="duration_s",
                   help="simulated time of every run [s], replacing the file's duration_s (a quick trial; default: "
                        "the file's, else the whole trajectory)")
    r.add_argument("--jobs", type=int, help="worker processes (default: all cores)")
    r.add_argument("--backend", choices=("loky", "dask"), default="loky",
                   help="loky: processes on this machine (default); dask: a Dask cluster (--scheduler)")
    r.add_argument("--scheduler", help="Dask scheduler address for --backend dask, e.g. tcp://127.0.0.1:8786 "
                                              "(required with --backend dask)")
    r.add_argument("--save-timeseries", action="store_true", help="also write each run's time series")
    r.add_argument("--threshold-mm", type=float,
                   help="TCP acceptability threshold of the summary [mm] (default: the file's threshold_mm, else 0.5)")
    r.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, plain lines in a log)")
    r.add_argument("--yes", action="store_true",
                   help="start a large campaign (over 1000 runs or 2e9 physics steps; a life campaign: if no unit "
                        "fails early) without asking")
    r.add_argument("--replace-changed", action="store_true", dest="replace_changed",
                   help="re-simulate stored runs of OUT made under other settings, or replace there the results "
                        "of another version of the campaign (default: stop and name the first difference)")
    r.set_defaults(func=cmd_run)
    s = csub.add_parser("status", help="what a campaign folder holds, every run file verified (exit 1 on problems)",
                        **examples("ur5fault campaign status results/default"))
    s.add_argument("dir", help="campaign output folder, e.g. results/paper")
    s.set_defaults(func=cmd_status)
    sh = csub.add_parser("show", help="print a campaign file shipped with ur5fault (redirect it to a file to edit a "
                                      "copy)",
                         **examples("ur5fault campaign show default    # > my.yaml: an editable copy (give it its "
                                    "own name and out:), then ur5fault campaign run my.yaml",
                                    "ur5fault campaign show paper"))
    sh.add_argument("name", metavar="NAME", help=f"a shipped campaign: {', '.join(shipped_campaigns())}")
    sh.set_defaults(func=cmd_show)
    ls = csub.add_parser("list", help="the campaigns shipped with ur5fault, one a line: its name and what it is",
                         **examples("ur5fault campaign list", "ur5fault campaign run paper    # one of them"))
    ls.set_defaults(func=cmd_list)
    p = sub.add_parser("plot", help="draw the paper's backlash figures and a severity figure per swept effect (PNG)",
                       **examples("ur5fault campaign run paper && ur5fault plot results/paper    # -> "
                                  "results/paper/plots/",
                                  "ur5fault plot results/paper --feature current_spike_max_A"))
    p.add_argument("dir", help="campaign output folder")
    p.add_argument("--feature", default="tcp_dev_max_mm",
                   help="feature of the severity figures and heat maps: a features.parquet column, or a per-joint "
                        "feature without _j{j} (e.g. current_spike_max_A: read on the faulty joint); "
                        "default tcp_dev_max_mm")
    p.add_argument("--out", help="folder for the PNG files (default: DIR/plots)")
    p.add_argument("--replace", action="store_true",
                   help="replace the figures of an earlier plot in that folder (default: refused, naming the first)")
    p.set_defaults(func=cmd_plot)


def _usage(parser: argparse.ArgumentParser) -> int:
    """``ur5fault campaign`` without run, status, show or list (:func:`..util.usage.missing_command`)."""
    from ..util.usage import missing_command

    return missing_command(parser)


def cmd_run(args: argparse.Namespace) -> int:
    from ..errors import ParameterError
    from ..health.prognostics.spec import is_life_file
    from ..util.checks import check_number
    from . import acceptable_backlash, load_campaign, run_campaign, tcp_table
    from .limits import confirmation_needed, effective_jobs, estimate
    from .spec import MAX_THRESHOLD_MM
    from .summary import MANY_SIZES, acceptable_backlash_text

    if is_life_file(args.file):  # a life campaign (issue 20): units run to failure
        from ..health.prognostics.cli import cmd_life_run

        return cmd_life_run(args)
    camp = load_campaign(args.file, args.out, args.model, args.duration_s)
    if args.threshold_mm is not None:
        check_number(args.threshold_mm, "--threshold-mm", 0.0, MAX_THRESHOLD_MM, "mm", lo_open=True)
    jobs, _ = effective_jobs(args.jobs) if args.backend == "loky" else (args.jobs or 1, None)
    why = confirmation_needed(camp, estimate(camp, jobs))
    if why and not args.yes:
        raise ParameterError(why)
    manifest = run_campaign(camp, camp.out, jobs=args.jobs, backend=args.backend, scheduler=args.scheduler,
                            progress=not args.quiet, save_timeseries=args.save_timeseries or None,
                            replace_changed=args.replace_changed)

    from ..util.io import read_parquet_stored
    from .store import REBUILD_FEATURES

    features = read_parquet_stored(Path(camp.out) / "features.parquet", REBUILD_FEATURES)
    thr = args.threshold_mm if args.threshold_mm is not None else camp.threshold_mm
    table = tcp_table(features, camp.swept_keys)
    if table.shape[1] > MANY_SIZES:  # a sampled campaign's continuous backlash sizes: no readable grid
        print(f"\n{len(features)} runs with {table.shape[1]} distinct backlash sizes: see `ur5fault benchmark`")
    elif not table.empty:
        if args.duration_s is not None:  # a quick trial: a clearance shows only where the motion so far reverses
            print(f"\nnote: every run shortened to {args.duration_s:g} s (--duration-s): the TCP deviations below are "
                  "of that part of the motion only; a backlash shows where it reverses a joint's torque")
        print("\nmax TCP deviation from the healthy twin [mm], fault joint x backlash [deg]:")
        print(table.to_string(float_format=lambda v: f"{v:.3f}"))
        print(f"\nlargest backlash keeping the TCP within {thr:g} mm [deg]:")
        print(acceptable_backlash_text(acceptable_backlash(features, thr, camp.swept_keys), table).to_string())
    bad = features[features["status"] != "ok"]
    if len(bad):
        print(f"\n{len(bad)} run(s) not ok:\n" + bad[["run_id", "status", "reason"]].to_string(index=False))
    print(f"\nwrote {camp.out}/features.parquet ({manifest['n_runs']} rows) and manifest.json "
          f"in {manifest['wall_s_this_invocation']:.1f} s")
    return 0


def cmd_status(args: argparse.Namespace) -> int:
    from . import status

    info = status(Path(args.dir))
    print(json_text(info))
    runs = info.get("runs") or info.get("inspections") or {}   # a life campaign's files are inspections
    table = info.get("inspections_table" if info.get("kind") == "life" else "features") or {}
    stale = info.get("state") == "complete" and table.get("state") != "ok"
    damaged = (info.get("manifest") or {}).get("state") in ("bad", "missing")
    return 1 if runs.get("bad") or runs.get("changed") or stale or damaged else 0


def cmd_show(args: argparse.Namespace) -> int:
    """The text of a shipped campaign file on stdout (``ur5fault campaign show default > my.yaml``: a copy to edit,
    which a wheel user cannot otherwise reach inside the installed package)."""
    from ..errors import UnknownNameError
    from .spec import SHIPPED_DIR

    names = shipped_campaigns()
    name = args.name[: -len(".yaml")] if args.name.endswith(".yaml") else args.name
    if name not in names:
        raise UnknownNameError("shipped campaign", args.name, names)
    sys.stdout.write((SHIPPED_DIR / f"{name}.yaml").read_text(encoding="utf-8"))
    return 0


def cmd_list(args: argparse.Namespace) -> int:
    """The shipped campaigns on stdout, one a line: the name and the first sentence of its file's opening comment."""
    from .spec import shipped_campaign_about

    names = shipped_campaigns()
    width = max(map(len, names), default=0)
    # each description wrapped to the terminal (100 columns off one), indented under its start
    columns = max(shutil.get_terminal_size((100, 24)).columns, width + 40)
    for name in names:
        about = textwrap.wrap(shipped_campaign_about(name), columns - width - 2) or [""]
        print(f"{name:{width}s}  {about[0]}".rstrip())
        for line in about[1:]:
            print(" " * (width + 2) + line)
    print("\nrun one: ur5fault campaign run NAME\n"
          "its whole file, a copy to edit: ur5fault campaign show NAME > my.yaml")
    return 0


def cmd_plot(args: argparse.Namespace) -> int:
    from ..plotting import FIG3_STEM, FIG4_STEM, FIGURE_STEMS, drawn_and_failed, figure_stems, save
    from ..util.io import check_writable
    from ..util.results import check_new_output, present, said_written
    from .result import CampaignResult

    if args.out is not None:
        check_writable(args.out, folder=True)  # a file in the way is refused before the figures are drawn
    result = CampaignResult.load(Path(args.dir))
    plot_dir = Path(args.out) if args.out else result.out / "plots"
    check_writable(plot_dir, folder=True)  # the default place too
    # the paper's figures do not depend on --feature: an earlier plot's are kept (said below) where another feature's
    # figures are asked for; any other figure there (or a user's file of its name) is not lost silently
    kept = {s for s in (FIG3_STEM, FIG4_STEM) if not args.replace and (plot_dir / f"{s}.png").exists()}
    for stem in figure_stems(result, args.feature):
        if stem not in kept:
            check_new_output(plot_dir / f"{stem}.png", replace=args.replace, default_place=args.out is None)
    figures, messages, failures = drawn_and_failed(result, args.feature, skip=kept)
    earlier = present(plot_dir / f"{stem}.png" for stem in figures)  # with --replace: said as replaced
    drawn = save(figures, plot_dir)
    for path in drawn:
        print(said_written([path], earlier))
    for message in dict.fromkeys(messages):  # what the campaign cannot have
        print(message)
    for failure in dict.fromkeys(failures):  # Fig. 3 and Fig. 4 read the same runs: one reason, said once
        print(f"ur5fault: error: {failure}", file=sys.stderr)
    ours = {p for stem in FIGURE_STEMS for p in plot_dir.glob(f"{stem}*.png")}  # not `show`'s, nor a user's
    for path in sorted(ours - set(drawn)):  # not redrawn: not to be taken for this plot's
        print(f"{path}: from an earlier plot, not redrawn now")
    return 1 if failures else 0  # a figure the campaign has was not drawn: not a success to a script
