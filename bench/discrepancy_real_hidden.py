"""Hidden effects in REAL logs (docs/discrepancy.md): effects a maintenance engineer cares about injected into
the measured current of the NIST log and of Kufieta runs (``tests/real_hidden.py`` says how), one and two at a
time on different joints; each log and its clean original fitted once.  Prints a Markdown table per case and
the detection rate, size error and extra-finding rate per effect kind.  Usage::

    .venv/bin/python bench/discrepancy_real_hidden.py [--jobs N] [--cases 0,2,5] [--baseline 2,4|all] > table.md

(``--cases``: indices into :data:`CASES`, to measure a few cases before the whole table.)

A case is *named* when a kept library finding (or one of its indistinguishable alternatives) is of the
injected kind on the injected joint, and its estimate, less the clean log's own estimate of that kind there
(0 when the clean log has none), is within 25 % of the injected size.  An *extra finding* is a kept finding
on another effect or joint that the clean log's fit does not have.

``--baseline CASES``: those cases are also fitted the engineer's way of asking what changed since the robot
was healthy, and scored in a second table.  Each injected log is fitted *from the clean log's fitted model* (its
kept findings as the starting model, what ``ur5fault discrepancy --model`` does with the clean fit's
model.yaml), so a finding is itself the change against the healthy robot: its estimate is compared with the
injected size as it is, and every kept finding that is not the injected effect is an extra one.

``--engineer``: the chosen cases fitted the way a maintenance engineer can (the *engineer's baseline row*): the
robot's model is first fitted on its *healthy* runs, never on the run the fault is injected into
(:func:`engineer_plan`), and the suspect run is then fitted from that model (``ur5fault discrepancy --model
BASELINE.yaml``).  Kufieta: the baseline is ``ur5fault discrepancy`` on :data:`HEALTHY_RUNS` jointly (the same
workflow and library as the suspect fit, so a baseline finding and a suspect finding are the same parameter);
the suspect run is Movement_No1 or Movement_No3_Acc, neither of which the baseline saw.  NIST (one log): the
baseline is the workflow's fit of the clean log's first ``FIT_FRACTION`` only (its own time split inside that
part), and the suspect run is the rest of the log, with the fault injected there: the case is fitted and scored
on samples the baseline never saw, 40 % of the log (25 s), of which the suspect fit again fits the first 60 %.
A finding's size is read as it is (the change against the baseline); "clean" is the uninjected suspect run
fitted from the same baseline (the baseline's own error on that run), whose kept findings are not counted as
extra.  ``--identify``: the baseline is first ``ur5fault identify`` on the healthy runs (this robot's drive
parameters: torque constants, friction, ...), then the workflow from those parameters.  ``--cache DIR`` keeps the
baselines and the clean suspect fits (they are shared by the cases of a log).
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

from real_hidden import busy_angle_deg, inject  # noqa: E402

from ur5fault.discrepancy import DiscrepancyModel  # noqa: E402
from ur5fault.discrepancy.model import LIKELIHOODS  # noqa: E402
from ur5fault.logs.readers import read_log, read_rtde  # noqa: E402
from ur5fault.sim.axes import JOINT_NAMES  # noqa: E402
from ur5fault.twin.residuals import FIT_FRACTION, fit_samples  # noqa: E402

JOBS = 2
NIST = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
KUFIETA = REPO / "data" / "kufieta-ur5"
#: the library effect an injected kind is named as, and the parameter's value as the injected size
NAMED_AS = {"current_sensor_offset": ("current_sensor_offset", "offset_A", lambda v: v),
            "current_sensor_gain": ("current_sensor_gain", "gain", lambda v: v - 1.0),
            "coulomb_friction": ("coulomb_friction", "scale", lambda v: v - 1.0)}
#: equivalent readings: a torque constant k is a current gain 1/k
EQUIVALENT = {"current_sensor_gain": ("torque_constant", lambda k: 1.0 / k - 1.0)}

#: (log, [(kind, joint 0-based, parameters)]): offsets >= 0.05 A, gains >= 5 %, friction >= 30 %, the issue's
#: four failure cases among them, one and two effects at a time on different joints
CASES = [
    ("nist", [("current_sensor_gain", 1, {"gain": 1.12})]),                       # issue case 1
    ("nist", [("coulomb_friction", 0, {"scale": 1.79})]),                          # issue case 2
    ("nist", [("current_sensor_gain", 3, {"gain": 0.92}),
              ("current_sensor_offset", 2, {"offset_A": -0.15})]),                 # issue case 3
    ("nist", [("local_friction", 2, {"amplitude_A": 0.25, "width_deg": 10.0})]),    # issue case 4
    ("nist", [("current_sensor_offset", 4, {"offset_A": 0.05})]),
    ("nist", [("coulomb_friction", 2, {"scale": 1.3}), ("current_sensor_offset", 5, {"offset_A": 0.08})]),
    ("Movement_No1", [("current_sensor_offset", 1, {"offset_A": 0.1})]),
    ("Movement_No1", [("current_sensor_gain", 2, {"gain": 1.1})]),
    ("Movement_No1", [("coulomb_friction", 0, {"scale": 1.5}), ("current_sensor_gain", 3, {"gain": 0.93})]),
    ("Movement_No3_Acc", [("current_sensor_offset", 0, {"offset_A": -0.08}),
                          ("coulomb_friction", 2, {"scale": 1.6})]),
    ("Movement_No3_Acc", [("current_sensor_gain", 1, {"gain": 1.08})]),
]


#: the Kufieta robot's healthy runs its baseline is fitted on: no hand on the arm (not ``_w_disturbance``,
#: not the standstill run), neither of the runs faults are injected into; Movement_No2 is Movement_No1's
#: program at the same speeds, Movement_No4_Acc the accelerated program of Movement_No3_Acc
HEALTHY_RUNS = ("Movement_No2", "Movement_No4_Acc")


def read(name: str):
    if name == "nist":
        return read_log(NIST, "nist")
    # the recordings name no payload; the README's forward-kinematics check puts the TCP at the flange
    return read_rtde(KUFIETA / f"{name}.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))


def library_value(m, effect: str, joint: int) -> tuple[float | None, bool]:
    """The kept estimate of ``effect`` (or an equivalent reading) on ``joint`` as an injected size, and whether
    it came from an alternative."""
    for f in m.effects_:
        for alt, (c, th) in enumerate([(f.candidate, f.theta), *f.alternatives]):
            if c.source != "library" or c.joint != joint:
                continue
            if c.effect == effect:
                return NAMED_AS[effect][2](c.value(th)), bool(alt)
            if EQUIVALENT.get(effect, ("",))[0] == c.effect:
                return EQUIVALENT[effect][1](c.value(th)), bool(alt)
    return None, False


def named_change(m, clean, effect: str, joint: int) -> tuple[float | None, bool]:
    """The injected size ``m`` names for ``effect`` on ``joint`` (None: not named), and whether as an alternative.

    ``clean``: the clean log's own fit, whose estimate of the same effect there is subtracted (0 when it names
    none); None when ``m`` was fitted from the clean fit's model (``--baseline``), whose findings are already
    the change against it.  A finding the clean fit has and ``m`` has not is *not* read as a change: the
    report of the faulty log names nothing there."""
    est, alt = library_value(m, effect, joint)
    if est is None or clean is None:
        return est, alt
    return est - (library_value(clean, effect, joint)[0] or 0.0), alt


def kept_keys(m) -> set[tuple[str, int | None]]:
    return {(f.candidate.effect, f.candidate.joint) for f in m.findings_ if f.kept}


def baseline_of(m) -> tuple:
    """The fitted model of a clean log as a starting model: its own starting effects and every kept finding."""
    return tuple(m.base_effects_) + tuple(f.spec() for f in m.findings_ if f.kept)


def nist_split_s(log) -> float:
    """The time [s from the log start] where the workflow's time split of ``log`` falls: the first sample of its
    held-out part (``fit_samples`` of the replayed samples, rows 1..n)."""
    return float(log.t_s[fit_samples(log.t_s.size - 1, FIT_FRACTION) + 1] - log.t_s[0])


def engineer_plan(name: str) -> tuple[list, object]:
    """The healthy logs the baseline of ``name``'s cases is fitted on, and the clean suspect run the faults are
    injected into (module docstring): they share no sample."""
    if name == "nist":
        log = read(name)
        t = nist_split_s(log)
        return [log.window(0.0, t)], log.window(t, np.inf)
    return [read(n) for n in HEALTHY_RUNS if n != name], read(name)


def injected(base, effects, centre_from=None):
    """``base`` with ``effects`` injected (a worn region centred where ``centre_from`` moves most, default
    ``base``)."""
    log = base
    for kind, j, v in effects:
        if kind == "local_friction" and "centre_deg" not in v:
            v["centre_deg"] = busy_angle_deg(base if centre_from is None else centre_from, j)
        log = inject(log, kind, j, **v)
    return log


def _cached(cache: Path | None, key: str, make):
    path = None if cache is None else cache / f"{key}.pkl"
    if path is not None and path.exists():
        return pickle.loads(path.read_bytes())
    out = make()
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(pickle.dumps(out))
    return out


def kept_values(m) -> dict:
    """``{(effect, joint): kept estimate as an injected size}`` of every library kind the bench scores."""
    return {(e, j): v for e in NAMED_AS for j in range(len(JOINT_NAMES))
            if (v := library_value(m, e, j)[0]) is not None}


def baseline_key(name: str, identified: bool = False) -> str:
    """The cache name of ``name``'s baseline: one per robot (the Kufieta runs share theirs)."""
    return ("baseline_nist" if name == "nist" else "baseline_kufieta") + ("_identified" if identified else "")


def baseline_record(healthy: list, fit, identified: bool = False) -> dict:
    """The baseline fitted on the ``healthy`` logs (jointly when several): its model (``params``: the drive
    parameters ``identify`` gives on them first when ``identified``, else None), what it names, its wall."""
    t = time.perf_counter()
    params, start = None, ()
    if identified:
        from ur5fault.identify import identify
        from ur5fault.sim.params import load_params

        p = load_params()
        ov = identify(healthy if len(healthy) > 1 else healthy[0], p, sweep=False).overlay(p)
        params, start = ov["params"], effects_of(ov.get("effects"))
    m = fit(healthy if len(healthy) > 1 else healthy[0], start, params)
    return {"effects": baseline_of(m), "params": params, "labels": [f.candidate.label for f in m.findings_ if f.kept],
            "wall_s": time.perf_counter() - t, "logs": [lg.source for lg in healthy],
            "s": sum(float(lg.t_s[-1] - lg.t_s[0]) for lg in healthy)}


def effects_of(overlay_effects) -> tuple:
    """The ``effects`` entries of a model overlay as effect specs."""
    from ur5fault.sim.effects import make_effect

    skip = ("effect", "joint")
    return tuple(make_effect(e["effect"], e.get("joint"), **{k: v for k, v in e.items() if k not in skip})
                 for e in overlay_effects or ())


def engineer_fits(name: str, cases, fit, cache: Path | None = None, identified: bool = False):
    """The engineer's baseline row of ``cases`` (``[(index, effects)]``, all on log ``name``): the baseline fitted
    on the healthy logs (``identified``: ``identify``'s drive parameters first), the clean suspect run and each
    injected one fitted from it.  ``fit(logs, base_effects, params_overrides)`` returns a fitted model (a
    :class:`DiscrepancyModel`'s ``fit``; a test's recorder).  Yields ``("baseline",
    info)``, ``("clean", info)`` and ``(index, model, wall_s)``."""
    healthy, suspect = engineer_plan(name)

    base = _cached(cache, baseline_key(name, identified), lambda: baseline_record(healthy, fit, identified))
    yield "baseline", base

    def clean():
        t = time.perf_counter()
        m = fit(suspect, base["effects"], base.get("params"))
        return {"kept": kept_keys(m), "values": kept_values(m), "labels": [f.candidate.label for f in m.findings_
                                                                             if f.kept],
                "unexplained": len(m.unexplained_), "wall_s": time.perf_counter() - t}

    yield "clean", _cached(cache, f"clean_{name}" + ("_identified" if identified else ""), clean)
    full = read(name) if name == "nist" else suspect
    for ci, effects in cases:
        t = time.perf_counter()
        m = fit(injected(suspect, effects, centre_from=full), base["effects"], base.get("params"))
        yield ci, m, time.perf_counter() - t


def engineer_table(chosen: list[int], jobs: int, cache: Path | None, identified: bool = False) -> None:
    """Fit and print the engineer's baseline row of the ``chosen`` cases (module docstring)."""
    def fit(logs, start, params=None):
        return DiscrepancyModel(jobs=jobs).fit(logs, params, base_effects=start)

    rows, per_kind = [], {}
    print("| log | injected | named as | estimate (change against the baseline) | clean run from the baseline "
          "there | truth | error | extra findings | unexplained | wall |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name in dict.fromkeys(CASES[ci][0] for ci in chosen):
        cases = [(ci, CASES[ci][1]) for ci in chosen if CASES[ci][0] == name]
        clean = None
        for item in engineer_fits(name, cases, fit, cache, identified):
            if item[0] == "baseline":
                b = item[1]
                how = "identify, then the workflow" if b.get("params") else "the workflow"
                print(f"| {name} | baseline: {how} on {' + '.join(b['logs'])} ({b['s']:.0f} s) | "
                      f"{', '.join(b['labels']) or 'nothing'} | | | | | | | {b['wall_s']:.0f} s |", flush=True)
                continue
            if item[0] == "clean":
                clean = item[1]
                print(f"| {name} | clean (suspect run from the baseline) | {', '.join(clean['labels']) or 'nothing'} "
                      f"| | | | | | {clean['unexplained']} | {clean['wall_s']:.0f} s |", flush=True)
                continue
            ci, m, wall = item
            score_engineer(name, CASES[ci][1], m, clean, wall, rows, per_kind, b.get("params"))
    summarise(rows, per_kind, "the engineer's baseline row (fitted from the robot's healthy runs)")


def worn_region_found(m, joint_name: str, centre_deg: float) -> tuple[bool, str]:
    """Whether the fit reports the injected worn region: an unexplained current on its joint localised to an
    angle region holding its centre; and how that region reads in the table."""
    hits = [u for u in m.unexplained_ if u["joint"] == joint_name and u["signal"] == "current_A"
            and u.get("angle_region")]
    reg = hits[0]["angle_region"] if hits else None
    ok = reg is not None and reg["from_deg"] <= centre_deg <= reg["to_deg"]
    return ok, (f"unexplained {reg['from_deg']:g}..{reg['to_deg']:g} deg" if reg else "-")


def score_engineer(name: str, effects, m, clean: dict, wall: float, rows: list, per_kind: dict,
                   params: dict | None = None) -> None:
    """One injected suspect run fitted from the baseline: its findings read as they are; extra ones counted
    against the clean suspect run's findings from the same baseline.  ``params``: the baseline's identified
    drive parameters, against whose Coulomb level a Coulomb scale is then read (the injected rise is the
    packaged level times (scale - 1))."""
    injected_keys = {(NAMED_AS[k][0], j) for k, j, _ in effects if k in NAMED_AS}
    extra = kept_keys(m) - clean["kept"] - injected_keys - {("torque_constant", j) for _, j in injected_keys}
    extras = ", ".join(f"{e} {'robot' if k is None else JOINT_NAMES[k]}" for e, k in sorted(extra, key=str))
    for kind, j, v in effects:
        jn = JOINT_NAMES[j]
        if kind == "local_friction":
            ok, where = worn_region_found(m, jn, v["centre_deg"])
            print(f"| {name} | {kind} {jn} {v['amplitude_A']} A at {v['centre_deg']:.0f} deg | {where} | | | | "
                  f"{'found' if ok else 'missed'} | {extras or 0} | {len(m.unexplained_)} | {wall:.0f} s |",
                  flush=True)
            per_kind.setdefault(kind, []).append((ok, float("nan"), bool(extra)))
            continue
        effect, par, to_size = NAMED_AS[kind]
        truth = to_size(v[par])
        if kind == "coulomb_friction" and params:
            from ur5fault.sim.params import load_params

            truth *= load_params().friction.coulomb_Nm[j] / load_params(overrides=params).friction.coulomb_Nm[j]
        est, alt = library_value(m, effect, j)
        there = clean["values"].get((effect, j))
        err = float("nan") if est is None else (est - truth) / truth
        ok = est is not None and abs(err) <= 0.25
        how = ("alternative" if alt else "named") if est is not None else "not named"
        print(f"| {name} | {kind} {jn} {v[par]:g} | {how} | {'-' if est is None else f'{est:.4g}'} | "
              f"{'-' if there is None else f'{there:.4g}'} | {truth:.4g} | {100 * err:+.0f} % | {extras or 0} | "
              f"{len(m.unexplained_)} | {wall:.0f} s |", flush=True)
        per_kind.setdefault(kind, []).append((ok, err, bool(extra)))
    rows.append((name, effects, m, extra))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=JOBS, help=f"worker processes per fit (default {JOBS})")
    ap.add_argument("--cases", default=None, help="comma-separated indices into CASES (default: all)")
    ap.add_argument("--likelihood", choices=LIKELIHOODS, default="pooled",
                    help="the selections' likelihood (DiscrepancyModel(likelihood=...)); not with --engineer")
    ap.add_argument("--rest-hold", action="store_true",
                    help="fit the current held in each rest interval as a nuisance (DiscrepancyModel(rest_hold=True)); "
                         "not with --engineer")
    ap.add_argument("--baseline", default=None, metavar="CASES",
                    help="comma-separated indices into CASES (or 'all') also fitted from the clean log's fitted "
                         "model (the change against it), scored in a second table; the clean fits are shared")
    ap.add_argument("--baseline-only", action="store_true",
                    help="fit the --baseline cases only from the clean log's fitted model (their per-log rows known)")
    ap.add_argument("--engineer", action="store_true",
                    help="the engineer's baseline row only: the --cases fitted from the robot's model fitted on "
                         "its healthy runs (never the injected one), scored in their own table")
    ap.add_argument("--cache", type=Path, default=None,
                    help="with --engineer: folder keeping the baselines and clean suspect fits (delete it when "
                         "the workflow's code changes)")
    ap.add_argument("--identify", action="store_true",
                    help="with --engineer: the baseline is `ur5fault identify` on the healthy runs (the robot's drive "
                         "parameters), then the workflow from them, and every fit starts from those parameters")
    args = ap.parse_args()
    jobs = args.jobs
    if (args.cache is not None or args.identify) and not args.engineer:
        ap.error("--cache and --identify are used by --engineer only")
    if args.engineer:
        if args.likelihood != "pooled" or args.rest_hold:
            ap.error("--likelihood and --rest-hold are used by the per-log tables only")
        if args.baseline is not None or args.baseline_only:
            ap.error("--engineer is its own table; give it without --baseline")
        engineer_table(list(range(len(CASES))) if args.cases is None else [int(i) for i in args.cases.split(",")],
                       jobs, args.cache, args.identify)
        return
    from_clean = (set() if args.baseline is None else set(range(len(CASES))) if args.baseline == "all"
                  else {int(i) for i in args.baseline.split(",")})
    if args.baseline_only and not from_clean:
        ap.error("--baseline-only needs --baseline CASES")
    chosen = (sorted(from_clean) if args.baseline_only else range(len(CASES)) if args.cases is None
              else [int(i) for i in args.cases.split(",")])
    clean: dict[str, DiscrepancyModel] = {}
    results = {False: ([], {}), True: ([], {})}
    print("| log | injected | named as | estimate - clean | truth | error | extra findings | unexplained | wall |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for ci in chosen:
        name, effects = CASES[ci]
        base = read(name)
        if name not in clean:
            t, c = time.perf_counter(), time.process_time()
            clean[name] = DiscrepancyModel(jobs=jobs, likelihood=args.likelihood, rest_hold=args.rest_hold).fit(base)
            print(f"| {name} | clean | {', '.join(f.candidate.label for f in clean[name].findings_ if f.kept)} "
                  f"| | | | | {len(clean[name].unexplained_)} | {time.perf_counter() - t:.0f} s "
                  f"(CPU {time.process_time() - c:.0f} s) |", flush=True)
        log = base
        for kind, j, v in effects:
            if kind == "local_friction" and "centre_deg" not in v:
                v["centre_deg"] = busy_angle_deg(base, j)
            log = inject(log, kind, j, **v)
        ways = (True,) if args.baseline_only else (False, True)
        for baseline in ways if ci in from_clean else (False,):
            score(name, effects, log, clean[name], baseline, jobs, *results[baseline], likelihood=args.likelihood,
                  rest_hold=args.rest_hold)
    for baseline, (rows, per_kind) in results.items():
        if rows:
            summarise(rows, per_kind, "fitted from the clean log's model" if baseline else "each log on its own")


def score(name: str, effects, log, clean, baseline: bool, jobs: int, rows: list, per_kind: dict,
          likelihood: str = "pooled", rest_hold: bool = False) -> None:
    """Fit one injected log (from the clean fit's model when ``baseline``) and print its rows."""
    t, c = time.perf_counter(), time.process_time()
    m = DiscrepancyModel(jobs=jobs, likelihood=likelihood, rest_hold=rest_hold).fit(
        log, base_effects=baseline_of(clean) if baseline else ())
    wall = f"{time.perf_counter() - t:.0f} s (CPU {time.process_time() - c:.0f} s)"
    label = f"{name} (from clean fit)" if baseline else name
    injected = {(NAMED_AS[k][0], j) for k, j, _ in effects if k in NAMED_AS}
    before = set() if baseline else kept_keys(clean)
    extra = kept_keys(m) - before - injected - {("torque_constant", j) for _, j in injected}
    for kind, j, v in effects:
        jn = JOINT_NAMES[j]
        if kind == "local_friction":
            ok, where = worn_region_found(m, jn, v["centre_deg"])
            print(f"| {label} | {kind} {jn} {v['amplitude_A']} A at {v['centre_deg']:.0f} deg | {where} | | | "
                  f"{'found' if ok else 'missed'} | {len(extra)} | {len(m.unexplained_)} | {wall} |",
                  flush=True)
            per_kind.setdefault(kind, []).append((ok, float("nan"), bool(extra)))
            continue
        effect, par, to_size = NAMED_AS[kind]
        truth = to_size(v[par])
        est, alt = named_change(m, None if baseline else clean, effect, j)
        err = float("nan") if est is None else (est - truth) / truth
        ok = est is not None and abs(err) <= 0.25
        how = ("alternative" if alt else "named") if est is not None else "not named"
        shown = "-" if est is None else f"{est:.4g}"
        extras = ", ".join(f"{e} {'robot' if k is None else JOINT_NAMES[k]}" for e, k in sorted(extra, key=str))
        print(f"| {label} | {kind} {jn} {v[par]:g} | {how} | {shown} | {truth:.4g} | {100 * err:+.0f} % | "
              f"{extras or 0} | {len(m.unexplained_)} | {wall} |", flush=True)
        per_kind.setdefault(kind, []).append((ok, err, bool(extra)))
    rows.append((name, effects, m, extra))


def summarise(rows: list, per_kind: dict, how: str) -> None:
    print(f"\n{how}:\n")
    print("| effect kind | cases | named, joint and size within 25 % | median abs size error | cases with an extra "
          "finding |")
    print("| --- | --- | --- | --- | --- |")
    for kind, res in sorted(per_kind.items()):
        errs = [abs(e) for _, e, _ in res if np.isfinite(e)]
        print(f"| {kind} | {len(res)} | {sum(r[0] for r in res)} | "
              f"{'-' if not errs else f'{100 * float(np.median(errs)):.0f} %'} | {sum(r[2] for r in res)} |")
    print(f"\nall effects: {sum(r[0] for res in per_kind.values() for r in res)} of "
          f"{sum(len(res) for res in per_kind.values())} named; cases with an extra finding: "
          f"{sum(bool(r[3]) for r in rows)} of {len(rows)}")


if __name__ == "__main__":
    main()
