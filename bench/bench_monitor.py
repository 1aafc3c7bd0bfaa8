"""Monitoring without false alarms (docs/monitoring.md): ``ur5fault monitor``'s verdicts on every real run.

    python bench/bench_monitor.py [--jobs N] [--no-identify] [--out results/bench_monitor.json] [--cache FILE]
        [--no-pairing]

``--cache FILE``: keep the replayed log parts (and the identified overlay) in FILE, a pickle, and reuse them when
it exists: the verdicts can then be recomputed in seconds after a change to the monitor's rules (not to its
replay, :mod:`ur5fault.health.monitoring.observe`, nor to identify: delete the file then). The parts that set a
baseline are screened whole (the paired statistics), the monitored ones on their first 20 s; a cache whose
baseline parts are screened on 20 s only is refused.

*Kufieta robot* (data/kufieta-ur5, payload 0 kg, TCP at the flange). The baseline overlay is ``ur5fault
identify`` fitted jointly on the five undisturbed runs :data:`BASE_RUNS` (``--no-identify``: the packaged
model). Each of those runs is monitored against the residual statistics of the other four (leave one out: a run
never sets its own thresholds; the overlay was fitted with it, which the statistics do not use); the undisturbed
Movement_No5_Acc_slow_no_disturbance against all five; every other run against all six undisturbed runs (the
five and that one, which repeats the pushed run's task: the task pairing of the monitor): TEST, the pushed
Movement_No5_Acc_slow_w_disturbance and Movement_No10_Standstill_WDist, and TEST with a current-sensor gain
injected on one joint (the logged current of that joint times :data:`GAINS`). And, events only, the quiet No5
run's and TEST's last part against their first part (:data:`SPLIT_S`) and the five. ``--no-pairing``: the same
judged by the motion's spread alone (the monitor before the task pairing).

*NIST robot* (data/nist-ur5, one log): the packaged model (fitted on this log), the baseline statistics from its
first :data:`~ur5fault.twin.residuals.FIT_FRACTION` of log time (as its two halves, :func:`halves`), the rest
monitored; and the rest with a gain injected.

*Push labels* (:mod:`monitor_labels`): the moving run's from UR's own current model against the paired
undisturbed run (sharing the reference run with the monitor, not the model) and against the run's own other
cycles (sharing no reference); the standstill run's from the tool accelerometer (and, for comparison, the
earlier labels from UR's model). A label is *found* when an event on one of its joints starts and ends within
0.5 s of it.

*Channels compared*: the events judged on both residuals (current and position, each at half the false-alarm
probability), on the current alone (the earlier monitor) and on the position alone; and per channel alone, how far
the largest transient of each undisturbed run and of each labelled push reaches, as a multiple of that channel's
limit (at the whole false-alarm probability): a channel separates the pushes from the model's error where the
undisturbed runs stay below 1 and the pushes exceed it.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO / "tests"))  # real_hidden: faults written into a real log's measured current
from monitor_labels import (  # noqa: E402  (the bench folder on the path first)
    PUSHED,
    QUIET,
    STANDSTILL,
    accel_labels,
    cycle_labels,
    found,
    labels,
    read,
    standing_start,
    ur_smoothed,
)

NIST_LOG = REPO / "data" / "nist-ur5" / "ur5testresult_halfspeed_payload1.6lb_1.csv.gz"
BASE_RUNS = ("Movement_No1", "Movement_No2", "Movement_No3_Acc", "Movement_No4_Acc", "Movement_No8_Singularity_Free_1")
OTHER_RUNS = (QUIET, "TEST", PUSHED, STANDSTILL)
#: injected current-sensor gains (joint index, gain) on TEST and on the NIST log's rest
GAINS = ((1, 1.2), (1, 1.5), (3, 1.2), (3, 1.5))
#: faults written into runs that repeat a baseline run's task (tests/real_hidden.py), sizes a maintenance engineer
#: cares about (issue 18: gains >= 5 %, offsets >= 0.05 A): (kind, parameter, sizes)
HIDDEN = (("current_sensor_gain", "gain", (1.05, 1.1, 1.2)), ("current_sensor_offset", "offset_A", (0.05, 0.1)))
#: the joints they are written on (0-based): shoulder_lift and wrist_1, as :data:`GAINS`
HIDDEN_JOINTS = (1, 3)
#: the effects a change may be named by for each injected kind (a current-sensor gain g reads as a torque
#: constant 1/g: the monitor lists them as alternatives)
READS_AS = {"current_sensor_gain": {"current_sensor_gain", "torque_constant"},
            "current_sensor_offset": {"current_sensor_offset"}}
#: the event channels of each design compared
VARIANTS = {"current only": ("current",), "both channels": ("current", "position"), "position only": ("position",)}
JOINTS = ("shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint", "wrist_1_joint", "wrist_2_joint",
          "wrist_3_joint")
UNDISTURBED = 8  # 5 baseline runs (leave one out), the undisturbed No5 run, TEST, NIST's rest
#: the undisturbed runs that repeat their own task, split: their first part [s] (three cycles of No5, two of
#: TEST) joins the baseline, the rest is monitored (events only: a part's change estimates would need its own
#: screening)
SPLIT_S = {QUIET: 18.0, "TEST": 12.0}


def part_of(obs, t0: float, t1: float):
    """The samples ``t0 <= t < t1`` of a replayed log part, without its screened candidates (events only)."""
    keep = (obs.t_s >= t0) & (obs.t_s < t1)
    cut = {f: getattr(obs, f)[keep] for f in ("t_s", "residual_A", "moving", "logged", "speed_rad_s",
                                              "accel_rad_s2", "position_residual_rad", "target_rad")}
    return dataclasses.replace(obs, name=f"{obs.name}[{t0:g}-{min(t1, obs.t_s[-1]):g} s]", cands=(),
                               X=np.zeros((0, 2, obs.e.shape[1])), e=obs.e[:2], **cut)


def head_of(obs, t1: float):
    """The samples ``t < t1`` of a replayed log part with its screened rows (a baseline part: change statistics
    too); the rows are the whole replay's, so the part is simulated from the robot's real initial state."""
    keep = obs.t_s < t1
    m = int(keep[: obs.e.shape[0]].sum())
    cut = {f: getattr(obs, f)[keep] for f in ("t_s", "residual_A", "moving", "logged", "speed_rad_s",
                                              "accel_rad_s2", "position_residual_rad", "target_rad")}
    return dataclasses.replace(obs, name=f"{obs.name}[0-{t1:g} s]", X=obs.X[:, :m], e=obs.e[:m], **cut)


def tail_of(obs, t0: float):
    """The samples ``t >= t0`` of a replayed log part screened whole, with its screened rows (:func:`head_of`'s
    other side)."""
    keep = obs.t_s >= t0
    m0 = int((~keep).sum())  # the part's samples are in time order
    cut = {f: getattr(obs, f)[keep] for f in ("t_s", "residual_A", "moving", "logged", "speed_rad_s",
                                              "accel_rad_s2", "position_residual_rad", "target_rad")}
    return dataclasses.replace(obs, name=f"{obs.name}[{t0:g}-{obs.t_s[-1]:g} s]", X=obs.X[:, m0:], e=obs.e[m0:], **cut)


def halves(obs):
    """A baseline part screened whole as two observations at its middle: a baseline needs two for its event
    limits' tail (each normalised by the spread fitted on the other; :data:`~ur5fault.health.monitoring.baseline.
    MIN_RUNS`). NIST's one log gives one part; before this the bench fitted the baseline on that part alone."""
    assert obs.e.shape[0] == obs.n, "a part screened on its first 20 s only"
    t = 0.5 * float(obs.t_s[0] + obs.t_s[-1])
    return [head_of(obs, t), tail_of(obs, t)]


def unpaired(baseline):
    """``baseline`` without its task statistics: every log judged by the motion's spread and its changes by the
    baseline's block estimates (the earlier monitor)."""
    return dataclasses.replace(baseline, task_scale=np.full_like(baseline.task_scale, np.nan),
                               task_tail=np.full_like(baseline.task_tail, np.nan), paired_candidates={})


def unpaired_changes(baseline):
    """``baseline`` without its paired change statistics: changes judged by its block estimates alone (the
    change test before the paired one), events as with them."""
    return dataclasses.replace(baseline, paired_candidates={})


def with_sigma(obs, log, params):
    """``obs`` with its current residual's weights (a part replayed before :class:`Observed` kept them): the
    replay's sensor sigma under the same overlay (:func:`ur5fault.twin.replay.residual_sigma`)."""
    from ur5fault.twin.replay import replay_params, residual_sigma

    if obs.current_sigma_A is not None:
        return obs
    return dataclasses.replace(obs, current_sigma_A=residual_sigma(replay_params(log, params), ("current_A",))[0])


def hidden(obs, log, kind: str, joint: int, **size: float):
    """``obs`` (a replay of ``log``) as the replay of ``log`` with ``kind`` injected into its measured current
    (:func:`tests.real_hidden.inject`). The replay is driven by the log's targets and initial state, not its
    currents, so only the residuals change: the measured current's change is added to them (checked against a
    full replay of an injected log: identical columns, residuals to 1e-15 A; docs/monitoring.md)."""
    from real_hidden import inject as inject_hidden

    bad = inject_hidden(log, kind, joint, **size)
    n_all = log.t_s.size - 1
    t_all = log.t_s[1:] - log.t_s[0]
    lo = int(np.searchsorted(t_all, obs.t_s[0] - 1e-9))
    delta = (bad.current_A - log.current_A)[1 : n_all + 1][lo : lo + obs.n]
    e = obs.e.copy()
    e[:, :6] += delta[: e.shape[0]] / obs.current_sigma_A
    what = ", ".join(f"{k} {v:g}" for k, v in size.items())
    return dataclasses.replace(obs, name=f"{obs.name} + {kind} J{joint + 1} ({what})",
                               residual_A=obs.residual_A + delta, e=e)


def reach(baseline, obs, channel: str, t_window: tuple[float, float] | None = None,
          joints: list[str] | None = None) -> float:
    """The largest ``|h| / limit`` of one channel judged alone (at the whole false-alarm probability) on a log
    part, within ``t_window`` [s] and on ``joints`` (default: everywhere): >= 1 would be an event."""
    from ur5fault.health.monitoring.verdict import judged_transients
    from ur5fault.sim.axes import JOINT_NAMES

    hs, lims, judged, _ = judged_transients(baseline, obs, (channel,))
    ratio = np.abs(hs[channel]) / lims[channel]
    rows = judged.copy()
    if t_window is not None:
        rows &= (obs.t_s >= t_window[0]) & (obs.t_s <= t_window[1])
    cols = [JOINT_NAMES.index(j) for j in joints] if joints else list(range(6))
    return float(ratio[rows][:, cols].max()) if rows.any() else float("nan")


def inject(log, joint: int, gain: float):
    cur = log.current_A.copy()
    cur[:, joint] *= gain
    return dataclasses.replace(log, current_A=cur, source=f"{log.source} x{gain:g} J{joint + 1}")


def _observe(log, params, part_s=None, baseline=False):
    """A log part replayed and screened as the monitor does: a baseline part whole
    (:data:`~ur5fault.health.monitoring.observe.BASELINE_SCREEN_S`), a monitored one on its first
    :data:`~ur5fault.discrepancy.model.SCREEN_S`."""
    from ur5fault.discrepancy.model import SCREEN_S
    from ur5fault.health.monitoring import observe
    from ur5fault.health.monitoring.observe import BASELINE_SCREEN_S

    return observe(log, params, part_s=part_s, screen_s=BASELINE_SCREEN_S if baseline else SCREEN_S)


def monitored(obs):
    """A baseline part as a monitored log: its screened rows cut to the first
    :data:`~ur5fault.discrepancy.model.SCREEN_S`, as :func:`_observe` screens a monitored part (the same replay
    and screen, so the same rows)."""
    from ur5fault.discrepancy.model import SCREEN_S

    m = min(obs.e.shape[0], max(2, round(SCREEN_S / obs.period_s)))
    return dataclasses.replace(obs, X=obs.X[:, :m], e=obs.e[:m])


def separable(base, paired: bool = False) -> dict[str, dict[str, float]]:
    """Per joint, the smallest current-sensor offset [A] and gain change [-] the change test can tell from the
    baseline's blocks (``paired``: from its paired difference-estimates, the paired test's, for a log paired over
    the whole screened 20 s): the bar times the prediction interval's width with the new log's own standard error
    taken as 0 (a lower bound: a real log's SE adds to it)."""
    from ur5fault.discrepancy.model import SCREEN_S
    from ur5fault.health.monitoring.changes import bar, block_reference
    from ur5fault.health.monitoring.paired import for_log
    from ur5fault.sim.axes import JOINT_NAMES

    # the paired test's reference for a log paired over its whole screened 20 s
    refs = for_log(base.paired_candidates, SCREEN_S) if paired else block_reference(base.candidates)
    out = {}
    for j in JOINT_NAMES:
        row = {}
        for key, label in (("offset_A", f"{j}: current_sensor_offset.offset_A"),
                           ("gain", f"{j}: current_sensor_gain.gain")):
            if label in refs:
                row[key] = float(bar(refs[label].k) * np.sqrt(refs[label].variance(0.0)))
        out[j] = row
    return out


def hit(entry: dict, kind: str, joint: int) -> bool:
    """``entry`` is "changed" on ``joint`` (0-based) with ``kind`` or what reads alike named, or among its
    alternatives."""
    from ur5fault.sim.axes import JOINT_NAMES

    for ch in entry["changes"]:
        if ch["joint"] == JOINT_NAMES[joint] and READS_AS[kind] & {ch["effect"], *(a["effect"] for a in
                                                                                 ch["alternatives"])}:
            return True
    return False


def change_text(entry: dict) -> str:
    return "; ".join(f"{c['joint'].split('_joint')[0]}: {c['effect']}.{c['parameter']} = {c['value']:.4g} "
                     f"({c['interval'][0]:.4g}..{c['interval'][1]:.4g}), {c['distance']:.2f}x bar, "
                     f"{c.get('reference', 'blocks')}" for c in entry["changes"]) or "-"


def repeated_cases(cases) -> list[dict]:
    """Per run that repeats a baseline run's task (``(robot, baseline, obs, log)``): the run as logged and with
    each fault of :data:`HIDDEN` on each of :data:`HIDDEN_JOINTS`, judged with the paired change test ("after")
    and by the baseline's block estimates alone ("before")."""
    from ur5fault.health.monitoring import assess
    from ur5fault.health.monitoring.paired import paired_seconds
    from ur5fault.health.monitoring.task import reference

    rows = []
    for robot, base, obs, log in cases:
        refs = list(zip(base.task_target_rad, base.task_residual_A))
        paired_s = paired_seconds(obs, reference(obs.target_rad, refs, obs.period_s)[0])
        variants = [(None, None, None, None, obs)] + [
            (kind, param, j, v, hidden(obs, log, kind, j, **{param: v}))
            for kind, param, sizes in HIDDEN for j in HIDDEN_JOINTS for v in sizes]
        for kind, _, j, v, o in variants:
            after, before = assess(base, o), assess(unpaired_changes(base), o)
            row = {"robot": robot, "log": o.name, "kind": kind, "joint": j, "size": v,
                   "screened_paired_s": paired_s, "after": after, "before": before}
            if kind is not None:
                row["found_after"], row["found_before"] = hit(after, kind, j), hit(before, kind, j)
            rows.append(row)
            print(f"| {robot} | {'-' if kind is None else f'{kind} J{j + 1} {v:g}'} | {before['verdict']}: "
                  f"{change_text(before)} | {after['verdict']}: {change_text(after)} |", flush=True)
    return rows


def main(argv=None) -> int:
    import joblib

    from ur5fault.health.monitoring import assess, fit_baseline
    from ur5fault.health.monitoring.baseline import overlay_sha256
    from ur5fault.health.monitoring.verdict import judged_transients
    from ur5fault.logs import read_nist
    from ur5fault.sim.params import load_params
    from ur5fault.twin.residuals import FIT_FRACTION

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-identify", action="store_true", help="the packaged model as the Kufieta baseline overlay")
    ap.add_argument("--out", default=str(REPO / "results" / "bench_monitor.json"))
    ap.add_argument("--cache", help="pickle of the replayed parts: written if absent, reused if present")
    ap.add_argument("--no-pairing", action="store_true",
                    help="judge every log by the motion's spread alone (the monitor before the task pairing)")
    ap.add_argument("--held-pose", action="store_true",
                    help="replay each CB2 log's rest stretches at the pose the controller holds "
                         "(cb2_rest_target.held_pose), identification included; the push labels from the logs as read")
    args = ap.parse_args(argv)
    from cb2_rest_target import held_pose

    def read_replayed(name):
        return held_pose(read(name))[0] if args.held_pose else read(name)

    t0 = time.perf_counter()
    cached = None
    if args.cache and Path(args.cache).exists():
        import pickle

        with open(args.cache, "rb") as f:
            cached = pickle.load(f)
        if cached["no_identify"] != args.no_identify:
            ap.error(f"{args.cache} was written with{'' if cached['no_identify'] else 'out'} --no-identify")
        if cached.get("held_pose", False) != args.held_pose:
            ap.error(f"{args.cache} was written with{'' if cached.get('held_pose') else 'out'} --held-pose")
    params = {}
    if cached is not None:
        params = cached["params"]
    elif not args.no_identify:
        from ur5fault.identify import identify

        print("identifying on", ", ".join(BASE_RUNS), file=sys.stderr, flush=True)
        params = identify([read_replayed(n) for n in BASE_RUNS], load_params(), sweep=False, n_boot=20).overlay(
            load_params())["params"]
    t_ident = time.perf_counter() - t0
    read_logs = {n: read(n) for n in BASE_RUNS + OTHER_RUNS}  # the push labels' (never replayed)
    logs = {n: read_replayed(n) for n in BASE_RUNS + OTHER_RUNS}
    injected = [inject(logs["TEST"], j, g) for j, g in GAINS]
    nist = read_nist(NIST_LOG)
    span = float(nist.t_s[-1] - nist.t_s[0])
    split = FIT_FRACTION * span
    nist_inj = [inject(nist, j, g) for j, g in GAINS]
    tasks = [(logs[n], params, None) for n in BASE_RUNS + OTHER_RUNS] + [(lg, params, None) for lg in injected] + \
        [(nist, {}, (0.0, split)), (nist, {}, (split, span + 1))] + [(lg, {}, (split, span + 1)) for lg in nist_inj]
    # the parts that set a baseline (the five, the quiet No5 run, NIST's first part) are screened whole
    whole = {*range(len(BASE_RUNS)), len(BASE_RUNS) + OTHER_RUNS.index(QUIET), len(tasks) - len(GAINS) - 2}
    if cached is not None:
        obs = cached["obs"]
        if any(obs[i].e.shape[0] < obs[i].n for i in whole):
            ap.error(f"{args.cache} holds baseline parts screened on their first 20 s only (written before they "
                     f"were screened whole); delete it")
    else:
        print(f"replaying {len(tasks)} log parts", file=sys.stderr, flush=True)
        obs = joblib.Parallel(n_jobs=args.jobs)(joblib.delayed(_observe)(*t, i in whole)
                                                for i, t in enumerate(tasks))
        if args.cache:
            import pickle

            from ur5fault.util.io import write_bytes_atomic

            write_bytes_atomic(Path(args.cache), pickle.dumps({"no_identify": args.no_identify,
                                                               "held_pose": args.held_pose, "params": params,
                                                               "obs": obs, "identify_s": t_ident}))
    # parts replayed before Observed kept its current weights get them from the same overlay
    obs = [with_sigma(o, lg, p) for o, (lg, p, _) in zip(obs, tasks)]
    quiet_tail = cached.get("quiet_tail") if cached is not None else None
    if quiet_tail is None:  # the quiet No5 run's last part, screened on its own (its change estimates)
        print("replaying the quiet No5 run's last part", file=sys.stderr, flush=True)
        quiet_tail = _observe(logs[QUIET], params, (SPLIT_S[QUIET], np.inf))
        if args.cache:
            import pickle

            from ur5fault.util.io import write_bytes_atomic

            write_bytes_atomic(Path(args.cache), pickle.dumps({"no_identify": args.no_identify,
                                                               "held_pose": args.held_pose, "params": params,
                                                               "obs": obs, "identify_s": t_ident,
                                                               "quiet_tail": quiet_tail}))
    quiet_tail = with_sigma(quiet_tail, logs[QUIET], params)
    # a cache written before the parts kept their model's Stribeck speed: the same value observe() takes from the
    # replay's parameters (the overlays here do not set the friction law's stribeck_rate_s_per_rad)
    from ur5fault.health.monitoring.conditions import stribeck_speed

    assert "stribeck_rate_s_per_rad" not in params.get("friction", {})
    obs, (quiet_tail,) = ([o if o.stribeck_speed_rad_s is not None else
                           dataclasses.replace(o, stribeck_speed_rad_s=stribeck_speed(load_params())) for o in group]
                          for group in (obs, [quiet_tail]))
    k = len(BASE_RUNS)
    base_obs, other_obs = obs[:k], obs[k : k + len(OTHER_RUNS)]
    inj_obs = obs[k + len(OTHER_RUNS) : k + len(OTHER_RUNS) + len(GAINS)]
    nist_base, nist_rest, nist_inj_obs = obs[-len(GAINS) - 2], obs[-len(GAINS) - 1], obs[-len(GAINS):]
    quiet_obs, test_obs = other_obs[OTHER_RUNS.index(QUIET)], other_obs[OTHER_RUNS.index("TEST")]
    sha = overlay_sha256(params, ())
    strip = unpaired if args.no_pairing else (lambda b: b)
    loo = [strip(fit_baseline(base_obs[:i] + base_obs[i + 1 :], sha)) for i in range(k)]
    full = strip(fit_baseline(base_obs, sha))
    # every other Kufieta run against all six undisturbed runs of the robot (the five and the quiet No5 run, the
    # one that repeats the pushed run's task)
    full6 = strip(fit_baseline([*base_obs, quiet_obs], sha))
    nb = strip(fit_baseline(halves(nist_base), overlay_sha256({}, ())))
    splits = [(o, SPLIT_S[name]) for o, name in ((quiet_obs, QUIET), (test_obs, "TEST"))]
    judged = [("kufieta, leave one out", loo[i], monitored(o)) for i, o in enumerate(base_obs)] + \
        [("kufieta", full, monitored(quiet_obs))] + \
        [("kufieta", full6, o) for o in other_obs + inj_obs if o is not quiet_obs] + \
        [("nist, first part vs rest", nb, o) for o in [nist_rest, *nist_inj_obs]] + \
        [("kufieta, own first part + the five vs its rest (events only)",
          strip(fit_baseline([*base_obs, part_of(o, 0.0, t)], sha)), part_of(o, t, np.inf)) for o, t in splits]
    undisturbed = {o.name for o in [*base_obs, quiet_obs, test_obs, nist_rest]}
    pushed_obs = other_obs[OTHER_RUNS.index(PUSHED)]
    split_base = strip(fit_baseline([*base_obs, head_of(quiet_obs, SPLIT_S[QUIET])], sha))
    print("\nFaults written into runs that repeat a baseline run's task (before: the baseline's block estimates "
          "alone; after: the paired change test)\n\n| robot | fault | before | after |\n| --- | --- | --- | --- |")
    repeated = repeated_cases([("kufieta, pushed No5 vs the six", full6, pushed_obs, logs[PUSHED]),
                               ("kufieta, quiet No5's last part vs its first + the five", split_base, quiet_tail,
                                logs[QUIET]),
                               ("nist, rest vs first part", nb, nist_rest, nist)])
    quiet = ur_smoothed(read_logs[QUIET])
    label_sets = {PUSHED: labels(read_logs[PUSHED], quiet),
                  f"{PUSHED} (own cycles)": cycle_labels(read_logs[PUSHED], read_logs[QUIET]),
                  STANDSTILL: accel_labels(STANDSTILL),
                  f"{STANDSTILL} (UR residual labels, earlier)": labels(read_logs[STANDSTILL],
                                                                         quiet[standing_start(read_logs[QUIET])])}
    by_name = {o.name: (b, o) for _, b, o in judged}
    print("\nPer channel alone: the largest transient as a multiple of its limit (>= 1: an event)")
    separation: dict = {}
    for c in ("current", "position"):
        healthy = {o.name: reach(b, o, c) for _, b, o in judged if o.name in undisturbed or "events only" in _}
        pushed = {}
        for name, labs in label_sets.items():
            b, o = by_name[f"{name.split(' ')[0]}.csv.gz"]
            pushed[name] = [reach(b, o, c, (lab["t_start_s"] - 0.5, lab["t_end_s"] + 0.5), lab["joints"])
                            for lab in labs]
        separation[c] = {"undisturbed": healthy, "labels": pushed}
        print(f"  {c}: undisturbed runs " + ", ".join(f"{n}: {v:.2f}" for n, v in healthy.items()))
        for name, v in pushed.items():
            print(f"    labels of {name}: " + ", ".join(f"{x:.2f}" for x in v))
    variants = {}
    for variant, channels in VARIANTS.items():
        results = [(robot, assess(b, o, channels)) for robot, b, o in judged]
        by = {e["log"]: e for _, e in results}
        pushes = {}
        for name, labs in label_sets.items():
            ev = by[f"{name.split(' ')[0]}.csv.gz"]["events"]
            pushes[name] = [{**lab, "found": found(lab, ev)} for lab in labs]
        variants[variant] = {"results": [{"robot": r, **e} for r, e in results], "pushes": pushes}
        quiet_alarms = sum(e["verdict"] != "consistent" for _, e in results if e["log"] in undisturbed)
        split_alarms = sum(e["verdict"] != "consistent" for r, e in results if "events only" in r)
        print(f"\n## {variant}: {quiet_alarms} of {UNDISTURBED} undisturbed runs not consistent "
              f"({split_alarms} of {len(splits)} split runs); labels found: "
              + "; ".join(f"{n}: {sum(x['found'] for x in p)} of {len(p)}" for n, p in pushes.items()))
        print("\n| robot | log | verdict | changes | events |\n| --- | --- | --- | --- | --- |")
        for robot, e in results:
            ch = "; ".join(f"{c['joint']}: {c['effect']}.{c['parameter']} = {c['value']:.3g} "
                           f"({c['interval'][0]:.3g}..{c['interval'][1]:.3g})" for c in e["changes"]) or "-"
            ev = "; ".join(f"{x['t_start_s']:.2f}-{x['t_end_s']:.2f} s "
                           f"{','.join(j.split('_joint')[0] for j in x['joints'])} "
                           f"({'+'.join(x['channels'])}) {x['peak_A']:.2f} A {x['peak_rad'] * 1e3:.3f} mrad"
                           for x in e["events"]) or "-"
            print(f"| {robot} | {e['log']} | {e['verdict']} | {ch} | {ev} |")
        for name, labs in pushes.items():
            print(f"\n{name}: {sum(lab['found'] for lab in labs)} of {len(labs)} labelled pushes found")
            for lab in labs:
                print(f"  {lab['t_start_s']:.2f}-{lab['t_end_s']:.2f} s {', '.join(lab['joints'])}: "
                      f"{'found' if lab['found'] else 'missed'}")
    sep = {"kufieta": separable(full), "nist": separable(nb),
           "kufieta, paired (the six)": separable(full6, paired=True),
           "kufieta, paired (the five + the quiet No5 run's first 18 s)": separable(split_base, paired=True),
           "nist, paired": separable(nb, paired=True)}
    blocks = {name: {j: b.paired_candidates.get(f"{j}: current_sensor_gain.gain", (0, 0, 0, 0))[2] for j in JOINTS}
              for name, b in (("the six", full6), ("split", split_base), ("nist", nb))}
    print("\npaired blocks per baseline (gain candidates): " + str(blocks))
    paired = {o.name: float((judged_transients(b, o)[3] & judged_transients(b, o)[2]).sum() * o.period_s)
              for _, b, o in judged}
    print("\nseconds judged against a paired baseline run: " + ", ".join(f"{n}: {v:.1f}" for n, v in paired.items()))
    for robot, rows in sep.items():
        print(f"\n{robot}: smallest separable change (lower bound), offset [A] / gain [-]: " + "; ".join(
            f"{j.split('_joint')[0]} {r.get('offset_A', float('nan')):.3f} / {r.get('gain', float('nan')):.3f}"
            for j, r in rows.items()))
    out = {"overlay": params, **variants["current only"], "variants": variants, "channel_reach": separation,
           "paired_s": paired, "no_pairing": args.no_pairing, "repeated_task_faults": repeated,
           "separable": sep, "paired_blocks": blocks, "identify_s": t_ident, "wall_s": time.perf_counter() - t0}
    from ur5fault.util.io import write_json_atomic

    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(Path(args.out), json.loads(json.dumps(out, default=float)))
    print(f"\nwall {out['wall_s']:.0f} s (identification {t_ident:.0f} s); wrote {args.out}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
