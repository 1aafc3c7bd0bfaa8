"""Every batch of replays a command simulates, timed: where a workflow's simulated seconds and serial stretches go.

Runs a ``ur5fault`` command (``discrepancy``, ``identify``, ``monitor``, ...) in this process with
``LogReplay.run`` and ``MultiReplay.run`` wrapped; each batch prints one line to stderr: its start and wall time
since the command began [s], its runs, samples and simulated seconds.  The gaps between the lines are this
process's own work (fitting, judging, the report) while no replay runs.

    python bench/trace_replays.py discrepancy data/nist-ur5/ur5testresult_halfspeed_payload1.6lb_1.csv.gz \\
        --format nist --out /tmp/d --jobs 2 --quiet
"""

from __future__ import annotations

import sys
import time


def main(argv: list[str]) -> int:
    from ur5fault.cli import main as cli
    from ur5fault.discrepancy.multilog import MultiReplay
    from ur5fault.twin.replay import LogReplay

    t0 = time.perf_counter()

    def traced(run):
        def wrapper(self, effect_sets, n=None, progress=None):
            t = time.perf_counter()
            out = run(self, effect_sets, n, progress)
            n_samples = out[0].y.shape[0] if out else 0
            sim_s = len(effect_sets) * n_samples * self.log.period_s
            print(f"replays: start {t - t0:7.2f} s, wall {time.perf_counter() - t:6.2f} s, {len(effect_sets)} runs x "
                  f"{n_samples} samples = {sim_s:.1f} simulated s", file=sys.stderr, flush=True)
            return out
        return wrapper

    LogReplay.run = traced(LogReplay.run)
    MultiReplay.run = traced(MultiReplay.run)
    rc = cli(argv)
    print(f"command: {time.perf_counter() - t0:.2f} s wall after imports", file=sys.stderr)
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
