"""Tasks over this process and worker processes (ur5fault/util/parallel.py) against the plain map."""

from __future__ import annotations

import os
import time

import pytest

from ur5fault.util.parallel import map_tasks


def _task(k: int, sleep_s: float) -> tuple[int, int]:
    time.sleep(sleep_s)
    return k * k, os.getpid()


def _fails(k: int) -> int:
    if k == 2:
        raise ValueError(f"task {k} fails")
    return k


def test_results_in_task_order_equal_the_plain_map_and_both_processes_work():
    # uneven tasks: the first one long, so the workers take the others from the front while it runs
    tasks = [(k, 0.5 if k == 0 else 0.02) for k in range(7)]
    out = map_tasks(_task, tasks, jobs=2)
    assert [v for v, _ in out] == [k * k for k, _ in tasks]
    pids = {pid for _, pid in out}
    assert os.getpid() in pids and len(pids) == 2  # this process and one worker


def test_one_job_or_one_task_runs_here_in_order():
    assert map_tasks(_task, [(3, 0.0)], jobs=2) == [(9, os.getpid())]
    assert map_tasks(_task, [(k, 0.0) for k in range(3)], jobs=1) == [(k * k, os.getpid()) for k in range(3)]


def test_a_failing_task_raises_here():
    with pytest.raises(ValueError, match="task 2 fails"):
        map_tasks(_fails, [(k,) for k in range(4)], jobs=2)
