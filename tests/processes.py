"""A process's children and liveness read from /proc (Linux): the tests that a killed command leaves no worker."""

from __future__ import annotations

from pathlib import Path


def children(pid: int) -> list[int]:
    """The pids of ``pid``'s child processes (none once it is gone)."""
    try:
        return [int(x) for x in Path(f"/proc/{pid}/task/{pid}/children").read_text().split()]
    except OSError:
        return []


def cmdline(pid: int) -> bytes:
    """The command line of a living process; empty for one that is gone or a zombie."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text().split()
        return b"" if stat[2] == "Z" else Path(f"/proc/{pid}/cmdline").read_bytes()
    except (OSError, IndexError):
        return b""


def workers_outliving_a_kill(argv: list[str], marker: bytes, settle_s: float, expect: int | None = None) -> list[int]:
    """Start ``argv`` in a session of its own, wait for its worker processes (children whose command line holds
    ``marker``; ``expect`` of them when given), let them work ``settle_s``, SIGKILL the process alone (as an
    out-of-memory killer does) and return the workers still alive 30 s later (a worker still importing under load
    notices only when its task starts)."""
    import os
    import signal
    import subprocess
    import time

    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        deadline, workers = time.time() + 120, []
        while time.time() < deadline and not workers:
            time.sleep(0.3)
            workers = [p for p in children(proc.pid) if marker in cmdline(p)]
        assert workers and (expect is None or len(workers) == expect), f"workers seen: {workers}"
        time.sleep(settle_s)
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        deadline = time.time() + 30.0
        while time.time() < deadline and any(cmdline(p) for p in workers):
            time.sleep(0.2)
        return [p for p in workers if cmdline(p)]
    finally:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
