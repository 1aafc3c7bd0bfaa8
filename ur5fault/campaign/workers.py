"""How campaign work reaches worker processes, shared by fault campaigns and life campaigns: the backend
check, the Dask connection, the one dispatch of tasks (here beside loky workers, or on a Dask cluster), the loky
workers' watch on their parent and their shutdown after an interruption."""

from __future__ import annotations

import logging
import os
import sys
import warnings
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from ..errors import ParameterError
from ..util.checks import check_count
from ..util.parallel import iter_tasks, watch_parent
from .limits import effective_jobs

#: where campaign work can run: loky, processes on this machine; dask, a Dask cluster (``campaign run --backend``
#: writes them as a literal so that its help imports nothing: tests/test_cli.py holds the two equal)
BACKENDS = ("loky", "dask")
#: seconds to wait for a Dask scheduler to answer (distributed's own default is 30 s)
DASK_CONNECT_TIMEOUT_S = 10.0


def check_backend(backend: str, scheduler: str | None, jobs: int | None) -> tuple[int, str | None]:
    """The worker count for ``backend`` (``"loky"``: at most the cores available, with a note when capped;
    ``"dask"``: as given), after checking the backend and that Dask, and only Dask, has a scheduler address."""
    if backend not in BACKENDS:
        raise ParameterError(f"backend = {backend!r} is not valid; choose one of: {', '.join(BACKENDS)}")
    if backend == "dask" and not scheduler:
        raise ParameterError("--backend dask needs --scheduler ADDRESS (e.g. tcp://127.0.0.1:8786)")
    if backend != "dask" and scheduler:
        raise ParameterError(f"--scheduler {scheduler} is for --backend dask (the {backend} backend runs on this "
                             "machine and would not use it); add --backend dask or drop --scheduler")
    if backend == "loky":
        return effective_jobs(jobs)
    return (1 if jobs is None else check_count(jobs, "--jobs", 1)), None


def dispatch(fn: Callable[..., Any], tasks: Sequence[tuple], jobs: int, client=None,
             cost: Sequence[float] | None = None) -> Iterator[Any]:
    """``fn(*t)`` for every task, each result as it finishes (not in the tasks' order): on the Dask cluster of
    ``client`` (joblib's dask backend), else in this process beside ``jobs - 1`` loky workers
    (:func:`~ur5fault.util.parallel.iter_tasks`, ``cost`` sets this process's share).  Use it closed
    (``contextlib.closing``): closing it early, an exception or an interruption cancels what is still out and,
    locally, kills the workers."""
    if client is None:
        local = iter_tasks(fn, tasks, jobs, cost)
        try:
            for _, result in local:
                yield result
        except BaseException:
            local.close()
            stop_loky_workers()
            raise
        return
    import joblib

    with joblib.parallel_backend("dask", wait_for_workers_timeout=60):
        remote = joblib.Parallel(n_jobs=-1, return_as="generator_unordered")(joblib.delayed(fn)(*t) for t in tasks)
        try:
            yield from remote
        except BaseException:  # cancel the tasks still out, without joblib's warning after our one-line error
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                remote.close()
            raise


def exit_with_parent(parent_pid: int | None) -> None:
    """In a loky worker process started by ``parent_pid``: exit as soon as that process is gone
    (``parent_pid`` is None on Dask, whose workers belong to their nanny, and equal to our own
    pid when the batch runs in the campaign process itself)."""
    if parent_pid is None or os.getpid() == parent_pid:
        return
    watch_parent(parent_pid)


def note_stderr(message: str) -> None:
    sys.stderr.write(f"ur5fault: note: {message}\n")


def stop_loky_workers() -> None:
    """Kill the worker processes of joblib's reusable loky executor (after an interruption)."""
    try:
        from joblib.externals.loky import reusable_executor
    except ImportError:  # pragma: no cover - joblib without its vendored loky
        return
    executor = getattr(reusable_executor, "_executor", None)
    if executor is not None:
        executor.shutdown(wait=False, kill_workers=True)


def dask_client(scheduler: str, timeout_s: float | None = None):
    """Connect to a Dask scheduler, or fail within ``timeout_s`` (default :data:`DASK_CONNECT_TIMEOUT_S`)
    with one line (and no logged tracebacks)."""
    try:
        from dask.distributed import Client
    except ImportError:  # depends on the installation: say how to get it, no traceback
        raise ParameterError("--backend dask needs dask.distributed: pip install 'dask[distributed]>=2024.1' "
                             "(from a checkout: pip install '.[cluster]')") from None

    timeout_s = DASK_CONNECT_TIMEOUT_S if timeout_s is None else timeout_s

    loggers = [logging.getLogger(name) for name in ("distributed", "distributed.client", "distributed.comm.core")]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        return Client(scheduler, timeout=timeout_s)
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        why = " ".join(str(exc).split())[:160] or type(exc).__name__
        raise ParameterError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler (timeout {timeout_s:g} s: "
                             f"{why}); check the address or start one with `dask scheduler`") from None
    finally:
        for lg, level in zip(loggers, levels):
            lg.setLevel(level)
