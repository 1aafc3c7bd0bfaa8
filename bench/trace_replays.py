"""Every batch of replays a command simulates, timed: where a workflow's simulated seconds and serial stretches go.

Runs a ``ur5fault`` command (``discrepancy``, ``identify``, ``monitor``, ...) in this process with
``LogReplay.run_batches`` and ``MultiReplay.run_batches`` (which ``run`` calls) and their ``prefetch`` wrapped; each
call prints one line to stderr: its start and wall time since the command began [s], the CPU time it took over
this process and its worker processes (read from ``/proc``: on a loaded machine the wall time measures the other
jobs too), its runs, samples and simulated seconds asked for (a prefetched replay is taken, not simulated again),
and the replay's simulated seconds so far.  The gaps between the lines are this process's own work (fitting,
judging, the report) while no replay runs.

Each batch is also tagged with its purpose (the workflow's functions that asked for it, read from the call stack:
``screen``, ``probe_batch``, ``polish``, ``rescreen``, ``list_rivals``, ...), and every replay asked for is checked
against those asked before by content (its log, its effects' repr, its samples): ``same`` when an earlier replay
of the same effects reached as far (it could have been taken instead of simulated), ``longer`` when an earlier one
of the same effects stopped short of it (its prefix is the earlier one).  At the end one table per purpose.

    python bench/trace_replays.py discrepancy data/nist-ur5/ur5testresult_halfspeed_payload1.6lb_1.csv.gz \\
        --format nist --out /tmp/d --jobs 2 --quiet
"""

from __future__ import annotations

import inspect
import os
import sys
import time
from collections import defaultdict


def cpu_s() -> float:
    """CPU seconds (user + system) of this process and of its live child processes (the workers)."""
    tick = os.sysconf("SC_CLK_TCK")
    total = time.process_time()
    me = str(os.getpid())
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if fields[1] == me:  # ppid
            total += (int(fields[11]) + int(fields[12])) / tick  # utime, stime
    return total


def purpose() -> str:
    """The workflow's functions on the call stack below ``fit`` (outermost first): what a batch is for."""
    names = []
    for fr in inspect.stack()[2:]:
        mod = fr.frame.f_globals.get("__name__", "")
        if fr.function == "fit" or not mod.startswith("ur5fault.discrepancy"):
            if fr.function == "fit":
                break
            continue
        if mod.endswith("multilog"):
            continue
        names.append(fr.function)
    names = [n for n in reversed(names) if n not in ("evaluate", "__call__", "evaluator")]
    return ">".join(dict.fromkeys(names)) or "other"


def main(argv: list[str]) -> int:
    import ur5fault.discrepancy.multilog as multilog
    import ur5fault.twin.replay as replay
    from ur5fault.cli import main as cli
    from ur5fault.discrepancy.multilog import MultiReplay
    from ur5fault.twin.replay import LogReplay

    t0 = time.perf_counter()
    seen: dict[tuple[int, str], int] = {}  # (log replay, effects) -> most samples asked so far
    table: dict[str, list[float]] = defaultdict(lambda: [0, 0.0, 0, 0.0, 0, 0.0, 0, 0.0])
    what = ["other"]

    def traced_requests(simulate_requests):
        def wrapper(reqs, jobs, progress=None):
            row = table[what[0]]
            for rp, e, n in reqs:
                key, s_ = (id(rp), repr(rp.base + tuple(e))), n * rp.log.period_s
                held = rp.holds(tuple(e), n)
                row[0] += 1
                row[1] += s_
                if held:
                    row[2] += 1
                    row[3] += s_
                elif key in seen and seen[key] >= n:
                    row[4] += 1
                    row[5] += s_
                elif key in seen:
                    row[6] += 1
                    row[7] += seen[key] * rp.log.period_s
                seen[key] = max(seen.get(key, 0), n)
            return simulate_requests(reqs, jobs, progress)
        return wrapper

    replay.simulate_requests = traced_requests(replay.simulate_requests)
    multilog.simulate_requests = replay.simulate_requests

    def traced(run_batches):
        def wrapper(self, batches, progress=None):
            what[0] = purpose()
            t, c = time.perf_counter(), cpu_s()
            out = run_batches(self, batches, progress)
            parts = []
            sim_s = 0.0
            for (sets, _), res in zip(batches, out):
                n_samples = res[0].y.shape[0] if res else 0
                sim_s += len(sets) * n_samples * self.log.period_s
                parts.append(f"{len(sets)} runs x {n_samples} samples")
            print(f"replays [{what[0]}]: start {t - t0:7.2f} s, wall {time.perf_counter() - t:6.2f} s, "
                  f"CPU {cpu_s() - c:6.2f} s "
                  f"(this process and its workers; at start {c:.2f} s), {' + '.join(parts)} = "
                  f"{sim_s:.1f} simulated s (asked; simulated so far in all: {self.simulated_s:.1f} s)",
                  file=sys.stderr, flush=True)
            return out
        return wrapper

    def traced_prefetch(prefetch):
        def wrapper(self, effect_sets, n=None):
            print(f"prefetch: start {time.perf_counter() - t0:7.2f} s, {len(effect_sets)} runs on a worker",
                  file=sys.stderr, flush=True)
            return prefetch(self, effect_sets, n)
        return wrapper

    for cls in (LogReplay, MultiReplay):  # run() goes through run_batches()
        cls.run_batches = traced(cls.run_batches)
        cls.prefetch = traced_prefetch(cls.prefetch)
    rc = cli(argv)
    print("purpose | replays asked | asked s | taken prefetched | same as earlier (s) | longer than earlier (prefix s)",
          file=sys.stderr)
    for k, (n, s_, nh, sh, nd, sd, nl, sl) in table.items():
        print(f"{k} | {n} | {s_:.1f} | {nh} ({sh:.1f} s) | {nd} ({sd:.1f} s) | {nl} ({sl:.1f} s)", file=sys.stderr)
    print(f"command: {time.perf_counter() - t0:.2f} s wall after imports, {cpu_s():.2f} s CPU of this process and its "
          "live workers", file=sys.stderr)
    return rc


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
