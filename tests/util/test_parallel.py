"""Tasks over this process and worker processes (ur5fault/util/parallel.py) against the plain map."""

from __future__ import annotations

import os
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

import joblib
import joblib.executor
import pytest
from processes import workers_outliving_a_kill

from ur5fault.util.parallel import iter_tasks, map_balanced, map_tasks, own_share, submit


def _task(k: int) -> tuple[int, int]:
    return k * k, os.getpid()


def _fails(k: int) -> int:
    if k == 1:
        raise ValueError(f"task {k} fails")
    return k


def _interrupt_handler() -> tuple[object, int]:
    import signal

    return signal.getsignal(signal.SIGINT), os.getpid()


def test_workers_leave_ctrl_c_to_this_process():
    """A terminal's Ctrl-C reaches every process of its group: a worker it stopped printed its own
    KeyboardInterrupt traceback after the command's one-line message. Workers now ignore it, whichever way they
    were started; this process keeps its handler."""
    import signal

    own = signal.getsignal(signal.SIGINT)  # whatever this process was started with (a background job: ignored)
    handler, pid = submit(_interrupt_handler, (), jobs=2).result()
    assert pid != os.getpid() and handler == signal.SIG_IGN
    got = map_tasks(_interrupt_handler, [()] * 4, jobs=2)  # this process takes the last task, a worker the others
    assert {p for _, p in got} - {os.getpid()} and all(h == signal.SIG_IGN for h, p in got if p != os.getpid())
    assert signal.getsignal(signal.SIGINT) == own


def test_results_in_task_order_equal_the_plain_map_and_both_processes_work():
    tasks = [(k,) for k in range(7)]
    out = map_tasks(_task, tasks, jobs=2)
    assert [v for v, _ in out] == [k * k for k in range(7)]
    here = [k for k, (_, pid) in enumerate(out) if pid == os.getpid()]
    assert here == [4, 5, 6]  # this process: the last tasks, 3 of the 7 (half the cost, rounded down)
    assert len({pid for _, pid in out}) == 2  # and one worker the rest


def test_this_process_takes_about_its_share_of_the_cost_from_the_end():
    assert own_share([1, 1], 2) == 1
    assert own_share([1, 1, 1, 1], 2) == 2
    assert own_share([5, 1, 1, 1, 1, 1], 2) == 1  # the long first task alone on the worker
    assert own_share([1, 1, 1, 6], 2) == 3  # the long last task alone here
    assert own_share([1, 1, 1, 1, 1, 1], 3) == 4  # a third of the cost
    assert own_share([1, 9], 2) == 1  # at least one task each


def test_one_job_or_one_task_runs_here_in_order():
    assert map_tasks(_task, [(3,)], jobs=2) == [(9, os.getpid())]
    assert map_tasks(_task, [(k,) for k in range(3)], jobs=1) == [(k * k, os.getpid()) for k in range(3)]


def test_a_failing_task_raises_here():
    with pytest.raises(ValueError, match="task 1 fails"):  # a worker's task
        map_tasks(_fails, [(k,) for k in range(4)], jobs=2)
    assert map_tasks(_task, [(k,) for k in range(2)], jobs=2)[1][0] == 1  # the next call starts a new worker


def _slow_here(k: int, pid: int) -> int:
    if os.getpid() == pid:  # this process's share: slow enough for the worker to finish its task meanwhile
        time.sleep(1.0)
    return k


def test_a_workers_result_comes_out_before_this_process_finishes_its_own_share():
    # a caller that writes each result as it comes (a campaign) must not hold the workers' finished tasks
    # until this process's share is done: a kill in between would lose them
    tasks = [(k, os.getpid()) for k in range(4)]
    order = [i for i, _ in iter_tasks(_slow_here, tasks, jobs=2, cost=[1, 1, 1, 1])]
    assert sorted(order) == [0, 1, 2, 3]
    assert order.index(0) < order.index(3)  # task 0 (worker) before this process's last task (3)


def test_joblib_parallel_after_the_tasks_in_the_same_process():
    # both use loky's one process-wide executor: a joblib.Parallel after iter_tasks (a life campaign after a
    # campaign in one session) failed on the executor iter_tasks had made without joblib's factory
    assert [v for v, _ in map_tasks(_task, [(k,) for k in range(4)], jobs=2)] == [0, 1, 4, 9]
    with joblib.parallel_backend("loky"):
        out = joblib.Parallel(n_jobs=2)(joblib.delayed(_task)(k) for k in range(4))
    assert [v for v, _ in out] == [0, 1, 4, 9]
    assert [v for v, _ in map_tasks(_task, [(k,) for k in range(4)], jobs=2)] == [0, 1, 4, 9]  # and back


def test_balanced_results_in_task_order_equal_the_plain_map():
    tasks = [(k,) for k in range(7)]
    cost = [1, 5, 2, 2, 9, 1, 3]
    out = map_balanced(_task, tasks, 2, cost)
    assert [v for v, _ in out] == [k * k for k in range(7)]
    assert len({pid for _, pid in out}) == 2  # both processes worked
    assert map_balanced(_task, tasks, 1, cost) == [(k * k, os.getpid()) for k in range(7)]
    with pytest.raises(ValueError, match="3 costs for 2 tasks"):
        map_balanced(_task, tasks[:2], 2, [1, 1, 1])


def _slow_here_fast_there(k: int, pid: int) -> tuple[int, int]:
    if os.getpid() == pid:
        time.sleep(2.0)
    return k, os.getpid()


def test_balanced_a_slow_process_takes_fewer_tasks():
    """The split is decided as the tasks finish: while this process spends 2 s on its first task (the cheapest),
    the warm worker takes every other one, from the most costly down."""
    map_balanced(_task, [(k,) for k in range(2)], 2, [1, 1])  # the worker started and warm
    tasks = [(k, os.getpid()) for k in range(6)]
    out = map_balanced(_slow_here_fast_there, tasks, 2, cost=[6, 5, 4, 3, 2, 1])
    assert [k for k, _ in out] == list(range(6))
    assert [k for k, pid in out if pid == os.getpid()] == [5]


def test_balanced_a_failing_task_raises_here_and_the_next_call_works():
    with pytest.raises(ValueError, match="task 1 fails"):
        map_balanced(_fails, [(k,) for k in range(4)], 2, [4, 3, 2, 1])  # task 1: a worker's
    assert [v for v, _ in map_balanced(_task, [(k,) for k in range(3)], 2, [1, 1, 1])] == [0, 1, 4]


def test_submit_runs_on_a_worker_or_not_at_all():
    assert submit(_task, (3,), 1) is None
    v, pid = submit(_task, (3,), 2).result()
    assert v == 9 and pid != os.getpid()


def _outcome_within(seconds: float, call) -> dict:
    """``call()`` on a thread: its value or exception, failing the test (instead of hanging it) when it has neither
    after ``seconds`` -- a guard against a hang, far above the time the call takes."""
    box: dict = {}

    def run() -> None:
        try:
            box["value"] = call()
        except BaseException as e:  # noqa: BLE001 -- handed to the test
            box["error"] = e

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"no result and no exception after {seconds} s: the call hangs"
    return box


def _fails_there(k: int, pid: int, marker: str, how: str, ran: list) -> int:
    """Task 0 fails on the worker (raises, or its process dies) after leaving ``marker``; every task of this
    process waits for the marker, then takes 0.5 s (time for the failure to reach this process)."""
    if os.getpid() != pid:
        if k == 0:
            Path(marker).touch()
            if how == "exit":
                os._exit(3)
            raise ValueError("task 0 fails on the worker")
        time.sleep(0.5)
        return k
    for _ in range(600):  # at most 60 s: the guard below fails first
        if Path(marker).exists():
            break
        time.sleep(0.1)
    ran.append(k)
    time.sleep(0.5)
    return k


@pytest.fixture
def thread_errors(monkeypatch):
    """Exceptions that escape a thread (the task feeder) during the test."""
    caught: list = []
    monkeypatch.setattr(threading, "excepthook", lambda args: caught.append(args.exc_value))
    return caught


@pytest.mark.parametrize("how, error", [("raise", ValueError), ("exit", BrokenProcessPool)])
def test_balanced_a_workers_failure_is_raised_before_this_processes_next_task(tmp_path, thread_errors, how, error):
    """A worker's task that raises, or kills its process: the exception reaches the caller after at most this
    process's current task (one, or two on a slow machine), not after its whole share (20 of the 40 tasks); no
    feeder thread is left and none died; the next call starts a new worker."""
    ran: list[int] = []
    tasks = [(k, os.getpid(), str(tmp_path / "failed"), how, ran) for k in range(40)]
    got = _outcome_within(60, lambda: map_balanced(_fails_there, tasks, 2, cost=[40 - k for k in range(40)]))
    assert isinstance(got.get("error"), error), got
    assert 1 <= len(ran) <= 2, ran
    assert not [t for t in threading.enumerate() if t.name == "ur5fault-task-feeder"]
    assert thread_errors == []
    assert [v for v, _ in map_balanced(_task, [(k,) for k in range(3)], 2, [1, 1, 1])] == [0, 1, 4]


class _PoolThatBreaks:
    """An executor whose first task runs (on a thread) and whose next submit raises, as loky's does once a worker
    has died: the feeder thread meets the failure, not the caller."""

    def __init__(self) -> None:
        self.pool = ThreadPoolExecutor(1)
        self.n_submitted = 0

    def submit(self, fn, *args):
        self.n_submitted += 1
        if self.n_submitted > 1:
            raise BrokenProcessPool("a worker process died")
        return self.pool.submit(fn, *args)

    def shutdown(self, wait: bool = True, kill_workers: bool = False) -> None:
        self.pool.shutdown(wait=wait)


def _slow_square(k: int) -> int:
    time.sleep(0.2)
    return k * k


def test_balanced_a_task_the_pool_refuses_fails_the_call_instead_of_hanging_it(monkeypatch, thread_errors):
    """The feeder gives the worker its next task and ``submit`` raises: that task fails the call (the feeder used
    to die there, and the caller waited forever for the task it had taken)."""
    pool = _PoolThatBreaks()
    monkeypatch.setattr(joblib.executor, "get_memmapping_executor", lambda n_workers, **_: pool)
    got = _outcome_within(60, lambda: map_balanced(_slow_square, [(k,) for k in range(6)], 2, [6, 5, 4, 3, 2, 1]))
    assert isinstance(got.get("error"), BrokenProcessPool), got
    assert pool.n_submitted == 2  # the failure stopped the feeding
    assert not [t for t in threading.enumerate() if t.name == "ur5fault-task-feeder"]
    assert thread_errors == []


def test_one_blas_thread_limits_blas_in_its_context_and_restores_it():
    import numpy  # noqa: F401  (loads the BLAS the limit reaches)
    from threadpoolctl import threadpool_info

    from ur5fault.util.parallel import one_blas_thread

    def blas_threads() -> list[int]:
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    before = blas_threads()
    with one_blas_thread():
        assert blas_threads() and all(n == 1 for n in blas_threads())
    assert blas_threads() == before


def test_blas_one_thread_decorator_limits_blas_while_the_function_runs_and_restores_it():
    import numpy  # noqa: F401  (loads the BLAS the limit reaches)
    from threadpoolctl import threadpool_info

    from ur5fault.discrepancy.model import DiscrepancyModel
    from ur5fault.util.parallel import runs_on_one_blas_thread

    def blas_threads() -> list[int]:
        return [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]

    @runs_on_one_blas_thread
    def inside(x: int) -> tuple[int, list[int]]:
        return x + 1, blas_threads()

    before = blas_threads()
    got, threads = inside(1)
    assert got == 2 and threads and all(n == 1 for n in threads)
    assert blas_threads() == before
    assert inside.__name__ == "inside"
    # the discrepancy fit runs under it (its Gram products, docs/performance.md)
    assert DiscrepancyModel.fit.__wrapped__.__name__ == "fit"


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc_trim; elsewhere a no-op")
def test_freed_memory_goes_back_to_the_system():
    """Arrays freed below a live allocation stay in glibc's heap (the resident size does not fall) until
    return_freed_memory hands them back: what keeps a campaign worker's size flat from batch to batch."""
    import numpy as np

    from ur5fault.util.parallel import return_freed_memory

    def resident_mib():
        return int(Path("/proc/self/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20

    arrays = [np.ones(8000) for _ in range(4000)]  # 64 kB each: below the mmap threshold, from the heap
    held = resident_mib()
    del arrays[::2]  # holes between live arrays: nothing the heap can give back from its top
    kept = resident_mib()
    assert return_freed_memory() is True
    after = resident_mib()
    assert kept > held - 60 and after < kept - 80, (held, kept, after)  # 125 MiB freed in the holes


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize("settle_s", [2.0, 0.0], ids=["working", "still-starting"])
def test_workers_exit_when_the_calling_process_is_killed(tmp_path, settle_s):
    """SIGKILL of a process spreading tasks (as `discrepancy --jobs 2` does; an out-of-memory killer sends it): its
    loky worker exited only with it by SIGTERM, and one was found still running, idle, 7 minutes after a kill. Killed
    while the worker still imports, the worker took init, its new parent, for the one to watch (a re-verification
    found one 9 minutes later): the parent's pid is now given to it."""
    code = ("import time\nfrom ur5fault.util.parallel import iter_tasks\n"
            "for _ in iter_tasks(time.sleep, [(60.0,), (60.0,)], jobs=2):\n    pass\n")
    lingering = workers_outliving_a_kill([sys.executable, "-c", code], b"LokyProcess", settle_s)  # not its tracker
    assert not lingering, "a worker outlived the process that started it"
