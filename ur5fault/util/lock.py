"""The lock of an output folder, ``OUT/.lock`` (a campaign's, a fleet's, a result folder's of
:mod:`ur5fault.util.results`): one writer at a time, and nothing left that only deleting a file by hand could
clear.

The lock is an operating-system lock (``flock``) held on the open file ``OUT/.lock``, not the
file's existence: the kernel releases it when its process ends however it ends (SIGKILL, a crash,
a full disk), so there is no stale lock to take over and no race between two processes that both
find one (two processes can never both hold it).  A file left behind by a killed process, an empty
file left by a failed write on a full disk, or the host/pid file of an older ur5fault, is simply
not held and the next campaign takes it.  The holder writes its host and pid into the file for
``campaign status``; that text is information, never the lock itself.

Only local file systems are supported for the output folder of a running campaign (``flock`` on
NFS is emulated by some clients and not by others); Dask workers return rows to the campaign
process, which alone writes the folder.  ``fcntl`` (Python's standard library) is used directly:
the ``filelock`` package wraps the same call and would add a dependency without adding a
guarantee on POSIX systems, which are the ones MuJoCo campaigns run on here.
"""

from __future__ import annotations

import errno
import fcntl
import os
import socket
from pathlib import Path

from ..errors import Ur5FaultError
from .io import OutputError

LOCK_NAME = ".lock"


class FolderLockedError(Ur5FaultError, RuntimeError):
    """Another process is writing the same output folder."""


class Lock:
    """Hold ``OUT/.lock`` for the duration of a ``with`` block (refused at once when held). ``what`` names the
    writer in the refusal (``campaign``: "another campaign is writing this folder"); ``name``: another lock file in
    ``out`` (one output file's, ``.NAME.lock``: :func:`ur5fault.util.results.file_lock`, whose refusal names the
    ``subject`` file)."""

    def __init__(self, out: Path, what: str = "campaign", name: str = LOCK_NAME, subject: Path | None = None) -> None:
        self.path = Path(out) / name
        self.what = what
        self.subject = subject  # the one file this lock guards (None: the folder)
        self._fd: int | None = None

    def __enter__(self) -> Lock:
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{self.path.parent}: cannot create the output folder ({exc.strerror})") from None
        for _ in range(100):  # only repeats when a holder removed the file between our open and our lock
            fd = self._open()
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                os.close(fd)
                if exc.errno in (errno.EWOULDBLOCK, errno.EAGAIN, errno.EACCES):
                    owner = lock_owner(self.path)
                    raise FolderLockedError(
                        f"{self.subject or self.path.parent}: another {self.what} is writing "
                        f"{'it' if self.subject else 'this folder'} (host "
                        f"{owner[0] if owner else '?'}, pid {owner[1] if owner else '?'}); wait for it or choose "
                        "another --out") from None
                raise OutputError(f"{self.path}: cannot lock ({exc.strerror})") from None
            if _same_file(fd, self.path):
                self._fd = fd
                break
            os.close(fd)  # the file we locked was unlinked by its previous holder: lock the new one
        else:  # pragma: no cover - a folder whose lock file is replaced a hundred times in a row
            raise FolderLockedError(f"{self.path}: could not take the lock (the file keeps being replaced)")
        try:
            os.ftruncate(self._fd, 0)
            os.write(self._fd, f"{socket.gethostname()} {os.getpid()}\n".encode())
        except OSError as exc:
            self._release()
            raise OutputError(f"{self.path}: cannot write the lock ({exc.strerror})") from None
        return self

    def _open(self) -> int:
        try:
            return os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        except OSError as exc:
            raise OutputError(f"{self.path}: cannot create the lock ({exc.strerror})") from None

    def _release(self) -> None:
        if self._fd is None:
            return
        try:  # remove the file while still holding the lock, so no one locks the old inode after us
            self.path.unlink(missing_ok=True)
        except OSError:
            pass  # a read-only folder by now: the file stays, unheld, and the next campaign takes it
        os.close(self._fd)
        self._fd = None

    def __exit__(self, *exc) -> None:
        self._release()


def _same_file(fd: int, path: Path) -> bool:
    try:
        st = os.stat(path)
    except OSError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def lock_owner(path: Path) -> tuple[str, int] | None:
    """(host, pid) written in a lock file, or None when absent or unreadable."""
    try:
        host, pid = Path(path).read_text().split()
        return host, int(pid)
    except (OSError, ValueError):
        return None


def lock_holder(out: Path) -> tuple[str, int] | None | bool:
    """Who holds the lock of ``out``: (host, pid) as written by the holder, True when it is held
    but the holder's text is not readable yet, None when no process holds it (whatever file lies there)."""
    path = Path(out) / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        return lock_owner(path) or True
    else:
        fcntl.flock(fd, fcntl.LOCK_UN)
        return None
    finally:
        os.close(fd)
