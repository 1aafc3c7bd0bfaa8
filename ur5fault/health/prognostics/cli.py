"""``ur5fault campaign run LIFE.yaml`` (a file with a ``life:`` section) and ``ur5fault prognose DIR``."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ...util.usage import examples
from .twin_choices import CALIBRATIONS, TWIN_FRICTION

#: `campaign run` options a life campaign does not take (named in the error instead of ignored)
_NOT_FOR_LIFE = {"model": "--model", "save_timeseries": "--save-timeseries", "threshold_mm": "--threshold-mm",
                 "duration_s": "--duration-s (set duration_s in the file)"}


def register(sub) -> None:
    p = sub.add_parser("prognose", help="benchmark remaining-useful-life estimators on a life campaign's held-out "
                                        "units (report.md, metrics.json, figures)",
                       **examples("ur5fault campaign run prognostics --yes    # a fleet worn to failure -> "
                                  "results/prognostics/fleet",
                                  "ur5fault prognose results/prognostics/fleet --out results/prognostics/benchmark",
                                  "ur5fault prognose results/prognostics/fleet --twin --replace    # with the "
                                  "twin's clearance estimates"))
    p.add_argument("dir", help="life campaign folder (with inspections.parquet), e.g. results/prognostics/fleet")
    p.add_argument("--out", help="report folder (default: DIR/benchmark)")
    p.add_argument("--replace", action="store_true",
                   help="replace an earlier report in the report folder (default: refused, nothing a user made is "
                        "lost silently; the twin's radius cache there is read and extended either way)")
    p.add_argument("--seed", type=int, default=0,
                   help="random state of the RUL distributions' Monte Carlo draws (default: 0)")
    p.add_argument("--twin", action="store_true",
                   help="also the estimator whose failure boundary the digital twin simulates along each unit's "
                        "direction of clearance growth (simulations: minutes on the default fleet)")
    p.add_argument("--model", metavar="OVERLAY",
                   help="with --twin: the model overlay YAML the twin runs (default: the packaged model, the one the "
                        "fleet was simulated with); e.g. a robot's fitted model, or parameters off by a model error")
    p.add_argument("--twin-calibration", choices=CALIBRATIONS,
                   help="with --twin: calibrate the twin's boundary on the failed training units of the unit's own "
                        "duty cycle, shrunk towards all tasks' (task), that corrected by the units of nearby "
                        "directions of growth (direction; the one to use when the twin's model may be off, "
                        "ur5fault's docs/prognostics.md), or at once on up to 16 failed training units of all tasks, "
                        "every m-th (pooled, the default; 14 of the 100-unit fleet's)")
    p.add_argument("--twin-friction", choices=TWIN_FRICTION,
                   help="with --twin: the friction rise per degree of clearance and per 10^6 cycles the twin gives a "
                        "worn joint: learned per unit from its inspections (learned, the default: maps fitted on the "
                        "training units' measured friction) or the wear law's constants in the fleet's manifest (law)")
    p.add_argument("--twin-cache", metavar="FILE",
                   help="with --twin: file of the twin's simulated failure radii, keyed by model, setup and ray, "
                        "read and extended (default: OUT/twin_radii.json)")
    p.add_argument("--quiet", action="store_true",
                   help="with --twin: no progress of the twin's simulations (a bar on a terminal, sparse lines in a "
                        "log)")
    p.set_defaults(func=cmd_prognose)


def cmd_life_run(args: argparse.Namespace) -> int:
    """``campaign run`` of a life campaign file."""
    import shlex

    from ...errors import ParameterError
    from .fleet import run_life
    from .spec import life_confirmation_needed, load_life

    for attr, flag in _NOT_FOR_LIFE.items():
        if getattr(args, attr, None):
            raise ParameterError(f"{flag} does not apply to a life campaign ({args.file} has a `life:` section)")
    camp = load_life(args.file, args.out)
    why = life_confirmation_needed(camp)
    large = why is not None
    if large and not args.yes:  # as a fault campaign: a typo (or a forgotten section) more likely than intent
        raise ParameterError(why)
    m = run_life(camp, camp.out, jobs=args.jobs, backend=args.backend, scheduler=args.scheduler,
                 progress=not args.quiet, replace_changed=args.replace_changed)
    if m["state"] != "complete":
        again = (f"ur5fault campaign run {shlex.quote(str(args.file))} --out {shlex.quote(str(camp.out))}"
                 + (" --yes" if large else ""))
        print(f"life campaign stopped early; run it again to resume: {again}")
        return 1
    ipu = m["inspections_per_unit"]
    beyond = m.get("n_censored_beyond_model", 0)
    censored = (f"{m['n_censored']} censored at {m['max_cycles']} cycles" if not beyond else
                f"{m['n_censored']} censored ({m['n_censored'] - beyond} at {m['max_cycles']} cycles, {beyond} where "
                "their next wear state lay beyond the simulator's effect ranges)")
    print(f"{m['n_units']} units: {m['n_failed']} failed, {censored}; "
          f"{m['n_inspections']} inspections ({ipu['min']}-{ipu['max']} per unit, mean {ipu['mean']:.1f}); "
          + (f"median life {m['eol_cycles']['median']:.4g} cycles" if m["n_failed"] else
             f"no unit failed within {m['max_cycles']} cycles"))
    print(f"wrote {camp.out}/inspections.parquet and manifest.json in {m['wall_s_this_invocation']:.1f} s")
    if m["n_failed_unworn"]:
        print(f"note: {m['n_failed_unworn']} of {m['n_units']} units met the failure criterion "
              f"{camp.failure.feature} >= {camp.failure.threshold:g} at their first inspection, unworn: the healthy "
              "robot meets it on their task (raise life.failure.threshold)", file=sys.stderr)
    return 0


def cmd_prognose(args: argparse.Namespace) -> int:
    import time

    from ...config import Overlay, check_seed
    from ...errors import ParameterError
    from ...util.results import written
    from .benchmark import run_prognose

    t0 = time.perf_counter()
    check_seed(args.seed, "--seed")
    for flag, value in (("--model", args.model), ("--twin-calibration", args.twin_calibration),
                        ("--twin-cache", args.twin_cache), ("--twin-friction", args.twin_friction)):
        if value and not args.twin:
            raise ParameterError(f"{flag} sets up the twin estimator: it needs --twin")
    model = Overlay.load(args.model) if args.model else None
    m = run_prognose(Path(args.dir), Path(args.out) if args.out else None, seed=args.seed, twin=args.twin,
                     twin_model=model, twin_calibration=args.twin_calibration or "pooled",
                     twin_cache=Path(args.twin_cache) if args.twin_cache else None,
                     twin_friction=args.twin_friction or "learned", replace=args.replace,
                     progress=not args.quiet)
    print(f"{m['dataset']['n_train_units']} train / {m['dataset']['n_test_units']} test units")
    for name in m["estimators"]:
        r = m["estimators"][name]
        rm = ", ".join(f"{k}: {v:.4g}" for k, v in r["rmse_cycles"].items())
        print(f"  {name}: RUL RMSE [cycles] at life fraction {rm}; alpha-lambda accuracy (alpha 0.2, lambda 0.5) "
              f"{r['alpha_lambda_accuracy']:.2f}; median prognostic horizon "
              f"{r['prognostic_horizon_cycles_median']:.4g} cycles")
    print(f"{written(m['replaced'])} {m['out']}/report.md, metrics.json and figures in "
          f"{time.perf_counter() - t0:.1f} s")  # on stdout, as every command's result line (simulate's aside)
    return 0
