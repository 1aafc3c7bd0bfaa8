"""Tasks spread over this process and ``jobs - 1`` worker processes (joblib's reusable loky executor).

The calling process works too: it would otherwise sit idle while the workers simulate, and every worker costs a
start-up (importing ur5fault with pandas, MuJoCo and numba, loading the cached compiled step loop: about 1.3 s of
CPU, docs/performance.md).  With ``jobs = 2`` one worker is started instead of two, and the calling process starts
on its share at once.  Its share is fixed before anything starts: tasks from the end of the list, about ``1 / jobs``
of the tasks' total cost; the workers take the others in order.  (Taking unstarted tasks back from the workers by
cancelling their futures would balance better, but loky's executor, shut down after an interruption, trips over
cancelled futures it still holds.)  A task's result does not depend on where it ran.

:func:`map_balanced` decides the split as it goes instead (the workers fed one task at a time from the costly end,
this process taking from the cheap end), for batches whose tasks' costs are known but whose processes may start
late or run slower (replays of logs: one task per run); :func:`submit` starts one task on a worker now.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

#: how often a worker process checks that the process that started it is still alive [s]
PARENT_POLL_S = 1.0

#: how often :func:`map_balanced` checks that its feeder thread is alive while it waits for the workers [s]
#: (a liveness check, not a deadline: any value well under a task's length)
_POLL_S = 1.0


def one_blas_thread():
    """Context limiting BLAS (numpy's OpenBLAS) to one thread in this process while a task runs.

    A task is one core's work and the tasks' processes already fill the cores; OpenBLAS would otherwise spread
    every product over all of them (its default: the machine's cores), so the small products of a task (a twin
    feature fit: 8,400 x 22 matrices) wait on threads that the other processes keep busy.  Measured on the
    2-core machine under load: 120 ms of CPU per current fit with two threads, 18 ms with one
    (docs/performance.md).  One thread also makes a product's rounding independent of the machine's core count:
    OpenBLAS splits a long inner dimension over its threads and adds the parts in another order.
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def return_freed_memory() -> bool:
    """Hand the memory this process has freed back to the system (glibc's ``malloc_trim(0)``; elsewhere nothing).

    A campaign process frees a batch's arrays when the batch is done, but glibc keeps the freed heap for reuse: a
    worker's resident size then wanders 60-120 MB above what it holds and creeps up from batch to batch (the
    diagnostics campaign's batches, one process: 319-375 MiB after each, 258 MiB trimmed, flat over 10 batches).
    loky, with psutil installed, restarts a worker whose resident size has grown 300 MB past its first task's and
    warns of a memory leak. Returns whether the call was made."""
    import ctypes

    try:  # the symbols the process has loaded (libc among them), without find_library's subprocess
        trim = ctypes.CDLL(None).malloc_trim
    except (OSError, AttributeError, TypeError):  # not glibc (macOS, musl), or no process handle (Windows)
        return False
    trim.argtypes, trim.restype = [ctypes.c_size_t], ctypes.c_int
    trim(0)
    return True


def runs_on_one_blas_thread(f):
    """Decorator: ``f`` runs under :func:`one_blas_thread` (a workflow whose own process does small products while
    its workers fill the cores, e.g. the discrepancy fit's selections beside its replays)."""
    import functools

    @functools.wraps(f)
    def wrapper(*args, **kwargs):
        with one_blas_thread():
            return f(*args, **kwargs)

    return wrapper


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


def ignore_interrupt(parent_pid: int | None = None) -> None:
    """A worker process's start: Ctrl-C is the calling process's to handle (it stops the workers and says so in one
    line). A terminal sends it to every process of its group, and a worker it stopped printed its own
    ``KeyboardInterrupt`` traceback after that line. The worker also exits when ``parent_pid``, the process that
    started it (given by that process: a worker starting after its parent was killed would otherwise take its new
    parent, init, for it and watch it for ever), is gone (:func:`watch_parent`)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    watch_parent(os.getppid() if parent_pid is None else parent_pid)


def watch_parent(parent_pid: int) -> None:
    """In a worker process: exit as soon as ``parent_pid`` is no longer its parent. A parent killed by SIGKILL (an
    out-of-memory killer) runs no handler that could stop its workers: they were left running, idle, holding their
    memory (one of 294 MB still there 7 minutes after a `discrepancy --jobs 2` was killed)."""
    if os.getppid() != parent_pid:  # gone before this worker started its task
        os._exit(1)
    if any(t.name == "ur5fault-parent-watch" for t in threading.enumerate()):
        return

    def watch() -> None:
        while True:
            time.sleep(PARENT_POLL_S)
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="ur5fault-parent-watch", daemon=True).start()


def _executor(jobs: int):
    """The ``jobs - 1`` worker processes: joblib's own reusable executor, not loky's bare one (both are loky's one
    process-wide executor, and a ``joblib.Parallel`` called later in this process, e.g. a life campaign after a
    campaign, reuses it and needs the temporary-folder manager only joblib's factory gives it), its workers
    started by :func:`ignore_interrupt`."""
    from joblib.executor import get_memmapping_executor

    return get_memmapping_executor(jobs - 1, initializer=ignore_interrupt, initargs=(os.getpid(),))


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

    k = own_share([1.0] * len(tasks) if cost is None else [float(c) for c in cost], jobs)
    executor = _executor(jobs)
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


def map_balanced(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int, cost: Sequence[float]) -> list[Any]:
    """``[fn(*t) for t in tasks]``, in the order of the tasks, over this process and ``jobs - 1`` workers with the
    split decided as they go, not fixed before anything starts: the tasks are taken in order of decreasing
    ``cost`` (e.g. simulated seconds), the workers from the front of that order (each kept one task ahead, fed as
    soon as one finishes) and this process from the back, until they meet.  A worker that starts late (its
    start-up, or a task :func:`submit` gave it before) or a process slowed by other jobs on the machine then takes
    fewer tasks instead of leaving the other core idle at the end.  A task's result does not depend on where it
    ran.  Tasks are not cancelled once given to a worker (see the module docstring), so an exception here waits
    for nothing: the workers are stopped.  A worker's failure (its task raised, its process died, the pool could
    not take a task) is raised here before this process starts its next task, not after its whole share."""
    if len(cost) != len(tasks):
        raise ValueError(f"{len(cost)} costs for {len(tasks)} tasks")
    if jobs <= 1 or len(tasks) <= 1:
        return [fn(*t) for t in tasks]
    import queue
    import threading
    from concurrent.futures import Future

    order = sorted(range(len(tasks)), key=lambda i: -float(cost[i]))
    executor = _executor(jobs)
    lock = threading.Lock()
    ends = [0, len(order)]  # the tasks not yet taken: order[ends[0]:ends[1]]
    finished: queue.SimpleQueue = queue.SimpleQueue()  # (task index, future) of the workers, as they finish
    results: queue.SimpleQueue = queue.SimpleQueue()  # the same, passed on by the feeder
    stop = threading.Event()

    def take(front: bool) -> int | None:
        with lock:
            if ends[0] >= ends[1]:
                return None
            if front:
                ends[0] += 1
                return order[ends[0] - 1]
            ends[1] -= 1
            return order[ends[1]]

    def give(i: int) -> None:
        try:
            executor.submit(fn, *tasks[i]).add_done_callback(lambda f, i=i: finished.put((i, f)))
        except Exception as e:  # e.g. the pool broken by a worker that died: task i fails, here
            stop.set()
            failed: Future = Future()
            failed.set_exception(e)
            results.put((i, failed))

    def feed() -> None:  # a worker's task finished: hand its result on and give it the next task
        while (item := finished.get()) is not None:  # never dies on a task: a failure is passed on
            results.put(item)
            if item[1].cancelled() or item[1].exception() is not None:  # nothing more after a failure
                stop.set()
            if not stop.is_set() and (i := take(front=True)) is not None:
                give(i)

    def collect(block: bool) -> bool:
        """Take one worker result into ``out`` (its exception raised here); False if none came."""
        while True:
            try:
                i, f = results.get(timeout=_POLL_S) if block else results.get_nowait()
            except queue.Empty:
                if not block:
                    return False
                if not feeder.is_alive():  # cannot happen (feed catches), but never wait forever on it
                    raise RuntimeError("the task feeder stopped with tasks still on the workers") from None
                continue
            out[i] = f.result()
            return True

    out: list[Any] = [None] * len(tasks)
    n_here = n_got = 0
    feeder = threading.Thread(target=feed, name="ur5fault-task-feeder", daemon=True)
    feeder.start()
    done = False
    try:
        for _ in range(min(jobs - 1, len(tasks) - 1)):  # one task per worker; this process keeps at least one
            i = take(front=True)
            if i is None:
                break
            give(i)
        while True:
            while collect(block=False):  # a worker's failure raised before each task here, not after them all
                n_got += 1
            if (i := take(front=False)) is None:
                break
            out[i] = fn(*tasks[i])
            n_here += 1
        for _ in range(len(tasks) - n_here - n_got):  # every task is taken now: the rest are the workers'
            collect(block=True)
        done = True
    finally:
        stop.set()
        finished.put(None)
        feeder.join()
        if not done:
            executor.shutdown(wait=False, kill_workers=True)
    return out


def submit(fn: Callable[..., Any], args: tuple, jobs: int):
    """``fn(*args)`` started now on a worker process (of the ``jobs - 1`` that :func:`map_balanced` uses), its
    future returned; None when ``jobs <= 1`` (the caller computes it when it needs it).  For work whose inputs are
    known before this process needs its result, so that a worker does it while this process does something
    else."""
    if jobs <= 1:
        return None
    return _executor(jobs).submit(fn, *args)


def stop_workers(jobs: int) -> None:
    """Kill the ``jobs - 1`` worker processes of :func:`submit` and :func:`map_balanced` (loky's one process-wide
    executor) with whatever they are running: for futures of :func:`submit` that no one will read.  Cancelling
    them instead would not stop a task that has started (and see the module docstring).  The next call starts new
    workers."""
    if jobs <= 1:
        return
    _executor(jobs).shutdown(wait=False, kill_workers=True)
