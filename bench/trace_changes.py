"""What the change tests see on a few injected faults the monitor missed (issue 17; docs/monitoring.md).

    python bench/trace_changes.py --cache FILE

``FILE``: the cache of replayed log parts that ``bench/bench_monitor.py --cache FILE`` writes (this script never
replays). For each case, the baseline and monitored part of the bench (NIST's first part against its rest; the
Kufieta runs repeating the No5 task), per candidate of the injected joint that reads like the fault: the log's
estimate and its jackknife standard error, the reference's mean, spread and number of (effective) blocks,
Student's bar, the prediction interval's half-width and the distance in multiples of the bar (>= 1 and the
workflow's acceptance: a change), for the paired test and the block test. The same script runs on the code
before and after a change to the tests (it uses only their public functions).
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
    NIST_LOG,
    OTHER_RUNS,
    SPLIT_S,
    head_of,
    hidden,
    with_sigma,
)
from monitor_labels import PUSHED, QUIET, read  # noqa: E402


def row(test: str, label: str, est, base, share: float = 1.0) -> str:
    from ur5fault.health.monitoring.changes import bar

    if label not in base:
        return f"| {test} | {label.split(': ')[1]} | {est.theta:.4g} | {est.se:.2g} | - (no statistics) | | | | |"
    mean, var, k = base[label]
    limit, inflate = bar(k, share)
    half = limit * float(np.sqrt(est.se**2 + var * inflate))
    d = abs(est.theta - mean) / half
    return (f"| {test} | {label.split(': ')[1]} | {est.theta:.4g} | {est.se:.2g} | {mean:.4g} / {np.sqrt(var):.2g} / "
            f"{k:.1f} | {limit:.1f} | {half:.3g} | {d:.2f} | {'yes' if est.accepted else 'no: ' + est.reason} |")


def trace(name: str, base, obs, joint: int) -> None:
    from ur5fault.health.monitoring import paired
    from ur5fault.health.monitoring.changes import estimates
    from ur5fault.health.monitoring.task import reference
    from ur5fault.sim.axes import JOINT_NAMES

    labels = [f"{JOINT_NAMES[joint]}: {x}" for x in ("current_sensor_gain.gain", "torque_constant.scale",
                                                    "current_sensor_offset.offset_A")]
    m = obs.e.shape[0]
    logged = obs.logged[:m]
    print(f"\n### {name}\n\n| test | candidate | estimate | SE | reference mean / sd / k | bar | half-width | "
          f"distance | accepted |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    on = np.zeros(m, bool)
    if base.paired_candidates:
        refs = list(zip(base.task_target_rad, base.task_residual_A))
        ref = reference(obs.target_rad, refs, obs.period_s)[0]
        on = paired.difference(obs, ref)[1]
    if on.any():
        est = paired.estimates(obs, ref, logged)
        secs = float((logged & on).sum() * obs.period_s)
        stats = base.paired_candidates
        if hasattr(paired, "for_log"):  # the reference for a log of that length (after the autocorrelation change)
            stats = paired.for_log(stats, secs)
            de = ", ".join(f"{lb.split(': ')[1]} {base.paired_candidates[lb][3]:.2f}"
                           for lb in labels if lb in base.paired_candidates)
            print(f"| design effect | {de} | | | | | | | |")
        print(f"| paired ({secs:.1f} s) | | | | | | | | |")
        for lb in labels:
            if lb in est:
                print(row("paired", lb, est[lb], stats))
    rest = logged & ~on
    if rest.sum() * obs.period_s >= 5.0 or not on.any():
        est = estimates(obs, rest)
        print(f"| blocks ({rest.sum() * obs.period_s:.1f} s) | | | | | | | | |")
        for lb in labels:
            if lb in est:
                print(row("blocks", lb, est[lb], base.candidates))


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
    nb = fit_baseline([nist_base], overlay_sha256({}, ()))
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
