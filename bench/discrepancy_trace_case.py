"""Trace one case of ``bench/discrepancy_real_hidden.py`` fitted from the clean log's fitted model (``--baseline``):
the screening's estimate, z and delta BIC of each injected current offset on its joint (judged alone and beside
the screening's other choices), the best library candidates on that joint judged alone, then every judgement of
the search trace (library, dictionary, joint checks, held-out check, re-screen) and every finding with its
held-out ratio and the reason it was dropped.  Usage::

    PYTHONPATH=$PWD .venv/bin/python bench/discrepancy_trace_case.py CASE [--jobs N] [--clean-cache DIR]

``--clean-cache DIR``: the clean fit's kept findings are stored there (``clean_LOG.pkl``) and reused, so that the
cases of one log share one clean fit.  Delete the files when the workflow's code changes.

``--per-log``: the case as the bench's per-log table fits it (each log on its own, from nothing): the clean
log is fitted too (with ``--clean-cache DIR`` its kept values are stored, ``perlog_LOG.pkl``), and each injected
effect's estimate less the clean fit's is printed; for every injected offset the final model's mean current
residual on its joint is printed at rest and in motion, on the fitting and on the held-out part (an offset is the
one effect that shows at rest).

``--engineer``: the case as ``discrepancy_real_hidden.py --engineer`` fits it: the suspect run fitted from the
baseline fitted on the robot's healthy runs (with ``--clean-cache DIR``, the bench's ``--cache DIR``: its stored
baseline ``baseline_nist.pkl`` or ``baseline_kufieta.pkl`` is used).
"""

from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "bench"))

import discrepancy_real_hidden as hidden  # noqa: E402

from ur5fault.discrepancy import DiscrepancyModel, steps  # noqa: E402
from ur5fault.discrepancy.model import LIKELIHOODS  # noqa: E402
from ur5fault.discrepancy.search import judge  # noqa: E402
from ur5fault.discrepancy.statistics import BlockGram  # noqa: E402
from ur5fault.discrepancy.weighting import per_channel  # noqa: E402
from ur5fault.sim.axes import JOINT_NAMES  # noqa: E402


def rest_means(m, joints, what: str) -> None:
    """The final model's mean (and spread) of the current residual [A] on each of ``joints``, at rest and in motion
    (the target's speed, ``ur5fault.twin.residuals.conditions``), on the fitting and the held-out part, with the
    sample counts."""
    from ur5fault.twin.residuals import conditions

    rp = m.replay_
    r = m.residual_after_[:, list(rp.signals).index("current_A")]
    rest = conditions(rp.log, r.shape[0], m.sim_after_.torque_gear_Nm)["at rest"]
    for j in joints:
        parts = []
        for part, sl in (("fit", slice(0, m.n_fit_)), ("held out", slice(m.n_fit_, None))):
            for cond, mask in (("at rest", rest[sl, j]), ("moving", ~rest[sl, j])):
                x = r[sl, j][mask]
                mean, sd = (np.nanmean(x), np.nanstd(x)) if x.size else (float("nan"), float("nan"))
                parts.append(f"{part} {cond} {mean:+.4f} sd {sd:.4f} (n {x.size})")
        print(f"{what} fit's current residual mean on {JOINT_NAMES[j]} [A]: " + "; ".join(parts))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("case", type=int, help="index into discrepancy_real_hidden.CASES")
    ap.add_argument("--jobs", type=int, default=2, help="worker processes per fit (default 2)")
    ap.add_argument("--clean-cache", type=Path, default=None, help="directory for the clean fits' findings")
    ap.add_argument("--engineer", action="store_true",
                    help="fit the suspect run from the baseline fitted on the robot's healthy runs")
    ap.add_argument("--likelihood", choices=LIKELIHOODS, default="pooled",
                    help="the selections' likelihood of every fit (DiscrepancyModel(likelihood=...))")
    ap.add_argument("--rest-hold", action="store_true",
                    help="every fit with the current held at rest as a nuisance (DiscrepancyModel(rest_hold=True))")
    ap.add_argument("--per-log", action="store_true",
                    help="fit the injected log on its own (from nothing), as the bench's per-log table does")
    args = ap.parse_args()
    if not 0 <= args.case < len(hidden.CASES):
        ap.error(f"case must be in 0..{len(hidden.CASES) - 1}")
    name, effects = hidden.CASES[args.case]

    def model() -> DiscrepancyModel:
        return DiscrepancyModel(jobs=args.jobs, likelihood=args.likelihood, rest_hold=args.rest_hold)

    seen = {}
    screen = steps.screen_library

    def recorded(*a, **k):  # the library record of the injected fit, for the offset's screening statistics
        seen["lib"] = screen(*a, **k)
        return seen["lib"]

    base = hidden.read(name)
    cache = None if args.clean_cache is None else args.clean_cache / f"clean_{name}.pkl"
    full, params = base, None
    if args.per_log:
        pcache = None if args.clean_cache is None else args.clean_cache / f"perlog_{name}.pkl"
        if pcache is not None and pcache.exists():
            clean_vals, kept, clean_keys = pickle.loads(pcache.read_bytes())
            print(f"clean fit (stored): kept {kept}")
        else:
            t = time.perf_counter()
            clean = model().fit(base)
            clean_vals, kept = hidden.kept_values(clean), [f.candidate.label for f in clean.findings_ if f.kept]
            clean_keys = hidden.kept_keys(clean)
            print(f"clean fit, {time.perf_counter() - t:.0f} s: kept {kept}")
            rest_means(clean, [j for kind, j, _ in effects if kind == "current_sensor_offset"], "clean")
            if pcache is not None:
                pcache.parent.mkdir(parents=True, exist_ok=True)
                pcache.write_bytes(pickle.dumps((clean_vals, kept, clean_keys)))
        start = ()
    elif args.engineer:
        healthy, base = hidden.engineer_plan(name)
        def fit(logs, st, pr=None):
            return model().fit(logs, pr, base_effects=st)

        b = hidden._cached(args.clean_cache, hidden.baseline_key(name), lambda: hidden.baseline_record(healthy, fit))
        start, params = b["effects"], b.get("params")
        print(f"baseline's findings (healthy runs {[lg.source for lg in healthy]}): {[e.name for e in start]}")
    elif cache is not None and cache.exists():
        start = pickle.loads(cache.read_bytes())
        print(f"clean fit's findings (stored): {[e.name for e in start]}")
    else:
        t = time.perf_counter()
        clean = model().fit(base)
        start = hidden.baseline_of(clean)
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            cache.write_bytes(pickle.dumps(start))
        kept = [f.candidate.label for f in clean.findings_ if f.kept]
        print(f"clean fit, {time.perf_counter() - t:.0f} s: kept {kept}")
        print(f"  dropped: {[(f.candidate.label, f.reason) for f in clean.findings_ if not f.kept]}")
    log = hidden.injected(base, effects, centre_from=full)
    steps.screen_library = recorded
    try:
        t = time.perf_counter()
        m = model().fit(log, params, base_effects=start)
    finally:
        steps.screen_library = screen
    if args.per_log:
        for kind, j, v in effects:
            if kind in hidden.NAMED_AS:
                effect, par, to_size = hidden.NAMED_AS[kind]
                est, alt = hidden.library_value(m, effect, j)
                there = clean_vals.get((effect, j), 0.0)
                print(f"per log: {kind} {JOINT_NAMES[j]} truth {to_size(v[par]):+.4g}: injected fit "
                      f"{'-' if est is None else f'{est:+.4g}'}{' (alternative)' if alt else ''}, clean fit "
                      f"{there:+.4g}, change {'-' if est is None else f'{est - there:+.4g}'}")
        injected = {(hidden.NAMED_AS[k][0], j) for k, j, _ in effects if k in hidden.NAMED_AS}
        extra = hidden.kept_keys(m) - clean_keys - injected - {("torque_constant", j) for _, j in injected}
        print(f"per log: extra findings {sorted(extra, key=str) or 0}; unexplained {len(m.unexplained_)}")
        rest_means(m, [j for kind, j, _ in effects if kind == "current_sensor_offset"], "injected")
    print(f"case {args.case} {name} {effects}: wall {time.perf_counter() - t:.0f} s")
    lib = seen["lib"]
    X_w, e_w, _ = per_channel(lib.X, lib.e0, lib.own_variance)  # the screening's own problem (its likelihood)
    bg = BlockGram.build(X_w, e_w)
    chosen = [lib.candidates.index(c) for c in lib.chosen]
    for kind, j, _ in effects:
        if kind != "current_sensor_offset":
            continue
        k = next(i for i, c in enumerate(lib.candidates) if c.effect == kind and c.joint == j)
        for how, others in (("alone", []), ("beside the screening's choices", [o for o in chosen if o != k])):
            v = judge(bg, e_w, X_w, lib.candidates, lib.cols, others, k)
            print(f"screening, offset on {JOINT_NAMES[j]} {how}: {v.theta[0]:+.4f} A, z {v.z:.1f}, "
                  f"delta BIC {v.delta_bic:.1f} [{v.reason or 'passes'}]")
        alone = [judge(bg, e_w, X_w, lib.candidates, lib.cols, [], i) for i, c in enumerate(lib.candidates)
                 if c.joint in (j, None)]
        for v in sorted(alone, key=lambda v: v.delta_bic)[:6]:
            print(f"  alone: {v.label} {np.round(v.theta, 4)} z {v.z:.1f} delta BIC {v.delta_bic:.1f} "
                  f"[{v.reason or 'passes'}]")
    print(f"library chose: {[c.label for c in lib.chosen]}")
    for s in m.search_:
        print(f"{s.stage:30s} {s.candidate:52s} {np.round(s.estimate, 4)} z {s.z:.1f} dBIC {s.delta_bic:.1f} "
              f"{'accepted' if s.accepted else s.reason}")
    for f in m.findings_:
        ho = "-" if f.held_out is None else f"{100 * f.held_out.ratio:.0f} %"
        print(f"finding {'kept' if f.kept else 'dropped'}: {f.candidate.label} {np.round(f.theta, 4)} held out {ho} "
              f"{f.reason} {[(a.label, np.round(th, 4)) for a, th in f.alternatives]}")
        for r in f.rivals:
            print(f"  rival: {r.candidate.label} {np.round(r.theta, 4)} held out {100 * r.held_out_ratio:.0f} %, "
                  f"delta BIC {r.held_out_delta_bic:+.1f}; {r.tell_apart}")
    for part, table in (("before", m.rms_before_), ("after", m.rms_after_)):
        print(f"held-out current RMS {part} [A]: {({k: round(v, 4) for k, v in table['current_A'].items()})}")


if __name__ == "__main__":
    main()
