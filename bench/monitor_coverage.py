"""Which real runs leave what their monitor baseline covered (docs/monitoring.md, "Where a log leaves what the
baseline runs covered"): the coverage notes of ``ur5fault monitor`` on the Kufieta runs.

    python bench/monitor_coverage.py [--jobs N]

The packaged model (no overlay; the notes read the logs' targets and stated payloads only, not the residual).
Each of the six undisturbed runs of :data:`FIT` is judged against a baseline of the other five (leave one out);
TEST, the pushed Movement_No5 run and the standstill run against all six. Prints the baseline's largest target
speed per joint and each run's verdict and coverage notes (the other notes are left out).
"""

from __future__ import annotations

import argparse

from ur5fault.health.monitoring import assess, fit_baseline, observe
from ur5fault.health.monitoring.observe import BASELINE_SCREEN_S
from ur5fault.logs import read_log
from ur5fault.logs.shipped import shipped_log

FIT = ("Movement_No1", "Movement_No2", "Movement_No3_Acc", "Movement_No4_Acc",
       "Movement_No5_Acc_slow_no_disturbance", "Movement_No8_Singularity_Free_1")
OTHER = ("TEST", "Movement_No5_Acc_slow_w_disturbance", "Movement_No10_Standstill_WDist")
COVERAGE = ("moves beyond", "carries ")  # how the coverage notes begin (health/monitoring/coverage.py)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    obs = {}
    for name in FIT + OTHER:
        log = read_log(shipped_log(f"kufieta/{name}")[0].path, "rtde", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
        obs[name] = observe(log, {}, (), screen_s=BASELINE_SCREEN_S, jobs=args.jobs)
    every = fit_baseline([obs[n] for n in FIT], "packaged")
    print("largest target speed [rad/s]:", every.motion_max[0].round(3).tolist())
    cases = [(n, fit_baseline([obs[m] for m in FIT if m != n], "packaged")) for n in FIT]
    for name, base in cases + [(n, every) for n in OTHER]:
        entry = assess(base, obs[name])
        notes = [x for x in entry["notes"] if x.startswith(COVERAGE)]
        print(f"{name} ({'the other five' if name in FIT else 'all six'}): {entry['verdict']}; "
              f"{notes if notes else 'no coverage note'}")


if __name__ == "__main__":
    main()
