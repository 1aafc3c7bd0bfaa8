"""Tasks over this process and worker processes (ur5fault/util/parallel.py) against the plain map."""

from __future__ import annotations

import os
import time

import joblib
import pytest

from ur5fault.util.parallel import iter_tasks, map_tasks, own_share


def _task(k: int) -> tuple[int, int]:
    return k * k, os.getpid()


def _fails(k: int) -> int:
    if k == 1:
        raise ValueError(f"task {k} fails")
    return k


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
