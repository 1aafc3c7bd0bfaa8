"""Tasks spread over this process and ``jobs - 1`` worker processes (joblib's reusable loky executor).

The calling process works too: it would otherwise sit idle while the workers simulate, and every worker costs a
start-up (importing ur5fault with pandas, MuJoCo and numba, loading the cached compiled step loop: about 1.3 s of
CPU, docs/performance.md).  With ``jobs = 2`` one worker is started instead of two, and the calling process starts
on its first task at once.  Tasks are taken in order by the workers and from the end by the calling process
(a task a worker has not started is cancelled there and run here), so uneven tasks still keep every process busy.
A task's result does not depend on where it ran.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from typing import Any


def iter_tasks(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int) -> Iterator[tuple[int, Any]]:
    """``(index, fn(*tasks[index]))`` for every task as it finishes, over this process and ``jobs - 1`` workers
    (``jobs <= 1``: here, in order).  ``fn`` and the tasks' arguments must be picklable; an exception of a task is
    raised here."""
    if jobs <= 1 or len(tasks) <= 1:
        for i, t in enumerate(tasks):
            yield i, fn(*t)
        return
    from concurrent.futures import as_completed

    from joblib.externals.loky import get_reusable_executor

    executor = get_reusable_executor(max_workers=jobs - 1)
    futures = {executor.submit(fn, *t): i for i, t in enumerate(tasks[1:], start=1)}
    pending = sorted(futures, key=futures.__getitem__)
    try:
        yield 0, fn(*tasks[0])
        while pending and pending[-1].cancel():  # from the end: what no worker has started yet
            f = pending.pop()
            yield futures[f], fn(*tasks[futures[f]])
        for f in as_completed(pending):
            yield futures[f], f.result()
    finally:
        for f in pending:  # an exception or an interruption here: nothing more is started
            f.cancel()


def map_tasks(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int) -> list[Any]:
    """``[fn(*t) for t in tasks]`` by :func:`iter_tasks`, in the order of the tasks."""
    out: list[Any] = [None] * len(tasks)
    for i, r in iter_tasks(fn, tasks, jobs):
        out[i] = r
    return out
