"""``ur5fault benchmark OUT``: the diagnostics baseline on a campaign folder."""

from __future__ import annotations

import argparse
import math
import sys

from ...util.usage import examples


def register(sub) -> None:
    b = sub.add_parser("benchmark", help="train baseline classifiers on a campaign's train split, report on its test "
                                         "split (needs scikit-learn and skops: pip install 'scikit-learn>=1.3' "
                                         "'skops>=0.10', or the wheel's [ml] extra)",
                       **examples("ur5fault campaign run diagnostics_reduced    # 320 labelled runs, 407 with twins",
                                  "ur5fault benchmark results/diagnostics_reduced    # -> "
                                  "results/diagnostics_reduced/benchmark/",
                                  "ur5fault benchmark results/diagnostics --test results/diagnostics_other_motions    "
                                  "# the classifiers the benchmark of results/diagnostics saved, on motions never "
                                  "trained on (both campaigns run first)"))
    b.add_argument("dir", help="campaign output folder (with features.parquet), e.g. results/diagnostics")
    b.add_argument("--out", help="report folder (default: DIR/benchmark)")
    b.add_argument("--replace", action="store_true",
                   help="replace an earlier report and classifiers in the report folder (default: refused, nothing a "
                        "user made is lost silently)")
    b.add_argument("--seed", type=int, default=0, help="random state of the classifiers and the bootstrap (default 0)")
    b.add_argument("--shuffle-labels", action="store_true",
                   help="control run: permute the training labels (every score must fall to chance)")
    b.add_argument("--features", choices=("paper", "twin", "both"),
                   help="classifier inputs: the paper's health features, the twin residual features or both "
                        "(default: both when the campaign has twin residuals, else paper)")
    b.add_argument("--test", metavar="OTHER_DIR",
                   help="score the classifiers saved in DIR/benchmark/models (or --models) on every run of this other "
                        "campaign folder, without retraining (report in OTHER_DIR/benchmark_transfer unless --out; "
                        "default: train and score on DIR's own split)")
    b.add_argument("--models", metavar="REPORT_DIR",
                   help="with --test: the report folder the classifiers were saved in, when the benchmark that "
                        "trained them was given --out (default: DIR/benchmark)")
    b.add_argument("--jobs", type=int, help="worker processes for the feature sets' comparison, run beside the "
                                            "main training (default: all cores available; 1: one after the other)")
    b.add_argument("--quiet", action="store_true", help="no progress (a bar on a terminal, plain lines in a log)")
    b.set_defaults(func=cmd_benchmark)


def cmd_benchmark(args: argparse.Namespace) -> int:
    import time

    from ...campaign.limits import effective_jobs
    from ...errors import ParameterError
    from ...util.checks import check_int
    from ...util.results import written
    from . import run_benchmark

    t0 = time.perf_counter()
    check_int(args.seed, "--seed", 0, 2**32 - 1, "an integer")  # scikit-learn's random_state range
    if args.test is not None and args.features is not None:
        raise ParameterError("--features chooses the inputs of new classifiers; --test scores saved ones with "
                             "their own inputs: use one of them")
    jobs, _ = effective_jobs(args.jobs)  # the campaigns' rule: at least 1, at most the cores available
    m = run_benchmark(args.dir, args.out, seed=args.seed, shuffle_labels=args.shuffle_labels,
                      feature_set=args.features, test_dir=args.test, models_dir=args.models,
                      jobs=jobs, replace=args.replace,
                      progress=not args.quiet)  # the report folder checked before any training
    for note in m.get("notes", []):
        print(f"ur5fault: note: {note}", file=sys.stderr)
    det, loc, kind = m["detection"], m["localisation"], m["kind"]
    print(f"{m['dataset']['n_train']} train / {m['dataset']['n_test']} test runs, features {m['feature_set']}"
          + (" (training labels shuffled)" if m["shuffled_labels"] else ""))
    bj = (m.get("detection_by_joint") or {}).get("auc_all")
    print(f"detection ROC AUC {det['auc_all']:.3f}"
          + (f" (by joint, the detector `ur5fault diagnose` uses: {bj:.3f})" if isinstance(bj, (int, float)) else "")
          + f"; joint accuracy {loc['accuracy']:.3f}; fault-kind accuracy {kind['accuracy']:.3f}")
    for j, v in m["backlash"]["per_joint"].items():
        a90 = v["alpha_90_deg"]
        why = v.get("note", f"{v['n_test']} test runs")
        print(f"  backlash J{j}: " + (f"alpha_90 = {a90:.3g} deg" if math.isfinite(a90) else f"no alpha_90 ({why})"))
    print(f"{written(m['replaced'])} {m['out']}/report.md, metrics.json and figures in "
          f"{time.perf_counter() - t0:.1f} s")  # on stdout, as every command's result line (simulate's aside)
    return 0
