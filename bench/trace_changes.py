"""What the change tests see on the injected faults and the undisturbed runs of the monitor's bench (issue 17;
docs/monitoring.md).

    python bench/trace_changes.py --cache FILE

``FILE``: the cache of replayed log parts that ``bench/bench_monitor.py --cache FILE`` writes (this script never
replays). Three parts:

* per case of a few injected faults (the baseline and monitored part of the bench: NIST's first part against its
  rest; the Kufieta runs repeating the No5 task), per candidate of the injected joint that reads like the fault:
  the log's estimate and its jackknife standard error, the reference's mean, the baseline's prediction of the
  log's standard deviation and the mean's (:class:`~ur5fault.health.monitoring.changes.Reference`), its number of
  (effective) blocks, Student's bar, the prediction interval's half-width and the distance in multiples of the bar
  (>= 1 and the workflow's acceptance: a change), for the paired test and the block test;
* every undisturbed run of the bench judged as the bench judges it: the largest distance of any accepted
  candidate (the margin to a false "changed");
* every injected fault of the bench (the 8 gains, the 30 faults on runs repeating a baseline task): on its joint,
  the candidate that reads like it furthest beyond its bar, whether the estimate reads the fault's size (a miss
  with the estimate near the size is a bar too high; far under it, an estimate too small), and the prediction
  interval's parts.

Every distance is given as the monitor computes it and as it was computed before the log's noise was counted once
(``se^2`` added to the baseline's prediction instead of the larger of the two), from the same reference.
"""

from __future__ import annotations

import argparse
import dataclasses
import pickle
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "bench"))
sys.path.insert(0, str(REPO / "tests"))
from bench_monitor import (  # noqa: E402
    BASE_RUNS,
    GAINS,
    HIDDEN,
    HIDDEN_JOINTS,
    NIST_LOG,
    OTHER_RUNS,
    READS_AS,
    SPLIT_S,
    halves,
    head_of,
    hidden,
    monitored,
    with_sigma,
)
from monitor_labels import PUSHED, QUIET, read  # noqa: E402


def old_distance(est, ref, share: float = 1.0) -> float:
    """The distance with the log's noise counted twice (its ``se^2`` added to the baseline's prediction of it)."""
    from ur5fault.health.monitoring.changes import bar

    return abs(est.theta - ref.mean) / float(np.sqrt(est.se**2 + ref.log_var + ref.mean_var)) / bar(ref.k, share)


def row(test: str, label: str, est, refs, share: float = 1.0) -> str:
    from ur5fault.health.monitoring.changes import _distance, bar

    if label not in refs:
        return f"| {test} | {label.split(': ')[1]} | {est.theta:.4g} | {est.se:.2g} | - (no statistics) | | | | | |"
    ref = refs[label]
    limit = bar(ref.k, share)
    half = limit * float(np.sqrt(ref.variance(est.se)))
    return (f"| {test} | {label.split(': ')[1]} | {est.theta:.4g} | {est.se:.2g} | {ref.mean:.4g} / "
            f"{np.sqrt(ref.log_var):.2g} / {np.sqrt(ref.mean_var):.2g} / {ref.k:.1f} | {limit:.1f} | {half:.3g} | "
            f"{_distance(est, ref, share):.2f} | {old_distance(est, ref, share):.2f} | "
            f"{'yes' if est.accepted else 'no: ' + est.reason} |")


def judged(base, obs) -> tuple[dict, list[tuple]]:
    """``assess(base, obs)`` and what its change tests judged: per call of ``find_changes``, ``(reference, share,
    {label: (estimate, Reference)})`` for the accepted candidates with statistics (those it measures)."""
    from ur5fault.health.monitoring import assess, verdict

    calls = []
    real = verdict.find_changes

    def spy(obs, est, outside, base, reference="blocks", share=1.0):
        calls.append((reference, share, {lb: (e, base[lb]) for lb, e in est.items()
                                         if lb in base and e.accepted and np.isfinite(e.se)}))
        return real(obs, est, outside, base, reference, share)

    verdict.find_changes = spy
    try:
        out = assess(base, obs)
    finally:
        verdict.find_changes = real
    return out, calls


def largest(calls, labels=None) -> tuple[float, float, str]:
    """The largest distance (now, before) among the judged candidates (``labels``: only those), and its label and
    test."""
    from ur5fault.health.monitoring.changes import _distance

    best = (0.0, 0.0, "-")
    for test, share, cands in calls:
        for lb, (e, ref) in cands.items():
            if labels is None or lb in labels:
                d = _distance(e, ref, share)
                if d > best[0]:
                    best = (d, old_distance(e, ref, share), f"{lb} ({test})")
    return best


def fault_row(name: str, base, obs, kind: str, joint: int, size: float) -> str:
    """One injected fault judged as the monitor judges it: on its joint, the candidate reading like it furthest
    beyond its bar (now / before), and the fault's own candidate (a gain's or an offset's): its estimate against
    the baseline's mean as a share of the fault's size (``theta`` is the gain's change or the offset), its
    acceptance by the workflow's test, and the prediction interval's half-width as a share of the size. The miss's
    reason: *estimate* where the estimate reads under half the size or the workflow rejects it, *bar* where it
    reads at least half and the half-width is larger."""
    from ur5fault.health.monitoring.changes import _distance, bar
    from ur5fault.sim.axes import JOINT_NAMES

    out, calls = judged(base, obs)
    j = JOINT_NAMES[joint]
    alike = {lb for _, _, c in calls for lb in c if lb.startswith(f"{j}: ") and
             lb.split(": ")[1].split(".")[0] in READS_AS[kind]}
    d_now, d_before, which = largest(calls, alike)
    own = f"{j}: {kind}.{'gain' if kind == 'current_sensor_gain' else 'offset_A'}"
    delta = size - 1.0 if kind == "current_sensor_gain" else size
    found = any(c["joint"] == j and READS_AS[kind] & {c["effect"], *(a["effect"] for a in c["alternatives"])}
                for c in out["changes"])
    cell, why = "- (not accepted by the workflow's test, or no statistics)", ""
    est_ref = None
    for test, share, cands in calls:
        if own in cands:
            est_ref = (test, share, *cands[own])
            break
    if est_ref is None:
        why = "" if found else "estimate (not accepted)"
    else:
        test, share, e, ref = est_ref
        reads = (e.theta - ref.mean) / delta
        half = bar(ref.k, share) * float(np.sqrt(ref.variance(e.se))) / abs(delta)
        cell = (f"{test}: reads {reads:.2f} of the size, half-width {half:.2f} of it "
                f"(predicted sd {np.sqrt(ref.log_var):.2g}, SE {e.se:.2g}, mean's sd {np.sqrt(ref.mean_var):.2g}, "
                f"bar {bar(ref.k, share):.1f}), distance {_distance(e, ref, share):.2f}")
        why = "" if found else ("estimate" if reads < 0.5 else "bar")
    return (f"| {name} | {kind.split('_')[-1]} {size:g} on {j.split('_joint')[0]} | {'yes' if found else 'no'} | "
            f"{d_now:.2f} / {d_before:.2f} ({which}) | {cell} | {why} |")


def trace(name: str, base, obs, joint: int) -> None:
    from ur5fault.health.monitoring import paired
    from ur5fault.health.monitoring.changes import block_reference, estimates
    from ur5fault.health.monitoring.task import reference
    from ur5fault.sim.axes import JOINT_NAMES

    labels = [f"{JOINT_NAMES[joint]}: {x}" for x in ("current_sensor_gain.gain", "torque_constant.scale",
                                                    "current_sensor_offset.offset_A")]
    m = obs.e.shape[0]
    logged = obs.logged[:m]
    print(f"\n### {name}\n\n| test | candidate | estimate | SE | reference mean / predicted sd / mean's sd / k | "
          f"bar | half-width | distance | before | accepted |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- "
          f"| --- |")
    on = np.zeros(m, bool)
    if base.paired_candidates:
        refs = list(zip(base.task_target_rad, base.task_residual_A))
        ref = reference(obs.target_rad, refs, obs.period_s)[0]
        on = paired.difference(obs, ref)[1]
    if on.any():
        est = paired.estimates(obs, ref, logged)
        secs = float((logged & on).sum() * obs.period_s)
        stats = paired.for_log(base.paired_candidates, secs)
        de = ", ".join(f"{lb.split(': ')[1]} {base.paired_candidates[lb][3]:.2f}"
                       for lb in labels if lb in base.paired_candidates)
        print(f"| design effect | {de} | | | | | | | | |")
        print(f"| paired ({secs:.1f} s) | | | | | | | | | |")
        for lb in labels:
            if lb in est:
                print(row("paired", lb, est[lb], stats))
    rest = logged & ~on
    if rest.sum() * obs.period_s >= 5.0 or not on.any():
        est = estimates(obs, rest)
        print(f"| blocks ({rest.sum() * obs.period_s:.1f} s) | | | | | | | | | |")
        for lb in labels:
            if lb in est:
                print(row("blocks", lb, est[lb], block_reference(base.candidates)))


def main(argv=None) -> int:
    from ur5fault.health.monitoring import fit_baseline
    from ur5fault.health.monitoring.baseline import overlay_sha256
    from ur5fault.health.monitoring.conditions import stribeck_speed
    from ur5fault.logs import read_nist
    from ur5fault.sim.params import load_params

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cache", required=True)
    args = ap.parse_args(argv)
    with open(args.cache, "rb") as f:
        cached = pickle.load(f)
    params, obs = cached["params"], cached["obs"]
    logs = {n: read(n) for n in BASE_RUNS + OTHER_RUNS}
    nist = read_nist(NIST_LOG)
    k = len(BASE_RUNS)
    # the bench's task order: the Kufieta runs, TEST with its gains, NIST's first part, its rest, its gains
    srcs = [(logs[n], params) for n in BASE_RUNS + OTHER_RUNS] + [(logs["TEST"], params)] * len(GAINS) + \
        [(nist, {})] * (2 + len(GAINS))
    obs = [with_sigma(o, lg, p) for o, (lg, p) in zip(obs, srcs)]
    obs = [o if o.stribeck_speed_rad_s is not None else
           dataclasses.replace(o, stribeck_speed_rad_s=stribeck_speed(load_params())) for o in obs]
    quiet_tail = dataclasses.replace(with_sigma(cached["quiet_tail"], logs[QUIET], params),
                                     stribeck_speed_rad_s=stribeck_speed(load_params()))
    base_obs = obs[:k]
    other = dict(zip(OTHER_RUNS, obs[k : k + len(OTHER_RUNS)]))
    nist_base, nist_rest = obs[-len(GAINS) - 2], obs[-len(GAINS) - 1]
    nist_gain = dict(zip(GAINS, obs[-len(GAINS):]))
    sha = overlay_sha256(params, ())
    nb = fit_baseline(halves(nist_base), overlay_sha256({}, ()))
    full6 = fit_baseline([*base_obs, other[QUIET]], sha)
    split_base = fit_baseline([*base_obs, head_of(other[QUIET], SPLIT_S[QUIET])], sha)
    trace("NIST's rest, gain 1.2 on shoulder_lift (the log's current times 1.2)", nb, nist_gain[(1, 1.2)], 1)
    trace("NIST's rest, gain 1.5 on shoulder_lift", nb, nist_gain[(1, 1.5)], 1)
    trace("NIST's rest, offset 0.1 A on shoulder_lift", nb,
          hidden(nist_rest, nist, "current_sensor_offset", 1, offset_A=0.1), 1)
    trace("quiet No5's last part, offset 0.1 A on wrist_1", split_base,
          hidden(quiet_tail, logs[QUIET], "current_sensor_offset", 3, offset_A=0.1), 3)
    trace("quiet No5's last part, gain 1.2 on shoulder_lift", split_base,
          hidden(quiet_tail, logs[QUIET], "current_sensor_gain", 1, gain=1.2), 1)
    trace("pushed No5, offset 0.05 A on wrist_1", full6,
          hidden(other[PUSHED], logs[PUSHED], "current_sensor_offset", 3, offset_A=0.05), 3)
    trace("TEST, gain 1.2 on shoulder_lift (block test)", full6, obs[k + len(OTHER_RUNS) + GAINS.index((1, 1.2))], 1)

    print("\n### Undisturbed runs: the largest distance of any judged candidate (now / before; >= 1: changed)\n")
    loo = [fit_baseline(base_obs[:i] + base_obs[i + 1 :], sha) for i in range(k)]
    full = fit_baseline(base_obs, sha)
    quiet = [(b, monitored(o)) for b, o in zip(loo, base_obs)] + [(full, monitored(other[QUIET])),
                                                                  (full6, other["TEST"]), (nb, nist_rest)]
    print("| log | largest distance now / before | candidate (test) |\n| --- | --- | --- |")
    for b, o in quiet:
        d_now, d_before, which = largest(judged(b, o)[1])
        print(f"| {o.name} | {d_now:.2f} / {d_before:.2f} | {which} |", flush=True)

    print("\n### Every injected fault: on its joint, the furthest candidate reading like it (now / before)\n")
    print("| run | fault | changed | distance now / before (candidate) | the fault's own candidate | miss: |\n"
          "| --- | --- | --- | --- | --- | --- |")
    test_gains = obs[k + len(OTHER_RUNS) : k + len(OTHER_RUNS) + len(GAINS)]
    for (j, g), o in zip(GAINS, test_gains):
        print(fault_row("TEST vs the six", full6, o, "current_sensor_gain", j, g), flush=True)
    for (j, g), o in nist_gain.items():
        print(fault_row("NIST's rest vs its first part", nb, o, "current_sensor_gain", j, g), flush=True)
    for name, b, o, lg in (("pushed No5 vs the six", full6, other[PUSHED], logs[PUSHED]),
                           ("quiet No5's last part vs its first 18 s + the five", split_base, quiet_tail, logs[QUIET]),
                           ("NIST's rest vs its first part", nb, nist_rest, nist)):
        for kind, param, sizes in HIDDEN:
            for j in HIDDEN_JOINTS:
                for v in sizes:
                    print(fault_row(name, b, hidden(o, lg, kind, j, **{param: v}), kind, j, v), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
