"""Tasks spread over this process and ``jobs - 1`` worker processes (joblib's reusable loky executor).

The calling process works too: it would otherwise sit idle while the workers simulate, and every worker costs a
start-up (importing ur5fault with pandas, MuJoCo and numba, loading the cached compiled step loop: about 1.3 s of
CPU, docs/performance.md).  With ``jobs = 2`` one worker is started instead of two, and the calling process starts
on its first task at once.  Tasks are taken in order by the workers and from the end by the calling process
(a task a worker has not started is cancelled there and run here), so uneven tasks still keep every process busy.
Results come back in the order of the tasks, and a task's result does not depend on where it ran.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any


def map_tasks(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int) -> list[Any]:
    """``[fn(*t) for t in tasks]`` over this process and ``jobs - 1`` workers (``jobs <= 1``: here, in order).
    ``fn`` and the tasks' arguments must be picklable; an exception of a task is raised here."""
    if jobs <= 1 or len(tasks) <= 1:
        return [fn(*t) for t in tasks]
    from joblib.externals.loky import get_reusable_executor

    executor = get_reusable_executor(max_workers=jobs - 1)
    futures = [executor.submit(fn, *t) for t in tasks[1:]]
    out: list[Any] = [fn(*tasks[0])]
    here: dict[int, Any] = {}
    for i in range(len(futures) - 1, -1, -1):  # from the end: what no worker has started yet
        if not futures[i].cancel():
            break
        here[i] = fn(*tasks[i + 1])
    out += [here[i] if i in here else f.result() for i, f in enumerate(futures)]
    return out
