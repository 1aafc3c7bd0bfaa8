"""Tasks spread over this process and ``jobs - 1`` worker processes (joblib's reusable loky executor).

The calling process works too: it would otherwise sit idle while the workers simulate, and every worker costs a
start-up (importing ur5fault with pandas, MuJoCo and numba, loading the cached compiled step loop: about 1.3 s of
CPU, docs/performance.md).  With ``jobs = 2`` one worker is started instead of two, and the calling process starts
on its share at once.  Its share is fixed before anything starts: tasks from the end of the list, about ``1 / jobs``
of the tasks' total cost; the workers take the others in order.  (Taking unstarted tasks back from the workers by
cancelling their futures would balance better, but loky's executor, shut down after an interruption, trips over
cancelled futures it still holds.)  A task's result does not depend on where it ran.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any


def own_share(cost: Sequence[float], jobs: int) -> int:
    """Index of the first task this process runs: tasks from the end whose cost fits ``1 / jobs`` of the total
    (at least one, and at least one left for the workers)."""
    n = len(cost)
    share = sum(cost) / jobs
    k, mine = n - 1, cost[-1]
    while k > 1 and mine + cost[k - 1] <= share:
        k -= 1
        mine += cost[k]
    return k


def iter_tasks(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int, cost: Sequence[float] | None = None
               ) -> Iterator[tuple[int, Any]]:
    """``(index, fn(*tasks[index]))`` for every task as it finishes, over this process and ``jobs - 1`` workers
    (``jobs <= 1``: here, in order).  ``cost``: each task's relative cost (default: equal), for this process's
    share.  ``fn`` and the tasks' arguments must be picklable; an exception of a task is raised here (and the
    workers are stopped)."""
    if jobs <= 1 or len(tasks) <= 1:
        for i, t in enumerate(tasks):
            yield i, fn(*t)
        return
    from concurrent.futures import as_completed

    from joblib.executor import get_memmapping_executor

    k = own_share([1.0] * len(tasks) if cost is None else [float(c) for c in cost], jobs)
    # joblib's own reusable executor, not loky's bare one: both are loky's one process-wide executor, and a
    # ``joblib.Parallel`` called later in this process (a life campaign after a campaign) reuses it and needs the
    # temporary-folder manager only joblib's factory gives it
    executor = get_memmapping_executor(jobs - 1)
    futures = {executor.submit(fn, *t): i for i, t in enumerate(tasks[:k])}
    done = False
    try:
        for i in range(k, len(tasks)):
            yield i, fn(*tasks[i])
            for f in [f for f in futures if f.done()]:  # the workers' finished tasks now, not after this
                yield futures.pop(f), f.result()          # process's whole share: a caller writing as it
        for f in as_completed(futures):                   # goes keeps them if it is killed meanwhile
            yield futures[f], f.result()
        done = True
    finally:
        if not done:  # an exception, an interruption or the caller stopped early: nothing more runs
            executor.shutdown(wait=False, kill_workers=True)


def map_tasks(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int, cost: Sequence[float] | None = None
              ) -> list[Any]:
    """``[fn(*t) for t in tasks]`` by :func:`iter_tasks`, in the order of the tasks."""
    out: list[Any] = [None] * len(tasks)
    for i, r in iter_tasks(fn, tasks, jobs, cost):
        out[i] = r
    return out
