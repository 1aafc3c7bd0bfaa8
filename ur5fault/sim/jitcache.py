"""numba's on-disk cache of ur5fault's compiled functions, verified on read.

numba (``cache=True``) keeps each function's machine code in ``__pycache__/<module>.<function>-<line>.py<ver>``
``.nbi`` (an index) and ``.<n>.nbc`` (the code), pickled with no checksum.  Found by flipping a byte in the middle
of every ``.nbc`` of a fresh cache and running one simulation (numba 0.68.1): ``RuntimeError: LLVM bitcode parsing
error``; truncated files give ``UnpicklingError: pickle data was truncated``.  Either stops every later simulation
until someone deletes the files by hand, and a flip that still parses would run other machine code than was
compiled.

:func:`protect` gives a module's cached functions a cache file that stores a SHA-256 of each index and code
record before it and checks it on reading: a record that fails it (or cannot be unpickled) is treated as absent,
so numba compiles the function again and overwrites it - a damaged cache costs one compilation, never a wrong
result or a human.  The checked files carry their own names (``.sha256.nbi``, ``.sha256.<n>.nbc``), so a process
reading numba's plain files never meets the checked format, nor the reverse.

It replaces an attribute numba keeps private (``Dispatcher._cache._cache_file``); with a numba whose cache is laid
out otherwise, :func:`protect` leaves the function as numba made it and says so once in the log.
"""

from __future__ import annotations

import hashlib
import logging
import pickle
import warnings
from types import ModuleType

_log = logging.getLogger(__name__)
#: marks a record written by :class:`_CheckedFile` (then its SHA-256, then numba's own bytes)
MAGIC = b"ur5fault-sha256\n"
#: added to numba's file names for the checked files
SUFFIX = ".sha256"
_DIGEST = 32


def _checked_file_class():
    from numba.core.caching import IndexDataCacheFile

    class _CheckedFile(IndexDataCacheFile):
        """numba's index/data cache file with a SHA-256 before each record (see the module docstring)."""

        def _dump(self, obj) -> bytes:
            data = super()._dump(obj)
            return MAGIC + hashlib.sha256(data).digest() + data

        def _load_index(self) -> dict:
            try:
                with open(self._index_path, "rb") as f:
                    version = pickle.load(f)
                    payload = unwrap(f.read())
                if version != self._version or payload is None:
                    return {}  # another numba, or a damaged index: every function compiled again
                stamp, overloads = pickle.loads(payload)
            except FileNotFoundError:
                return {}
            except Exception:  # noqa: BLE001 - any damage to the file means: compile again
                _log.warning("%s: numba cache index damaged; compiling again", self._index_path)
                return {}
            return overloads if stamp == self._source_stamp else {}

        def _load_data(self, name: str):
            path = self._data_path(name)
            with open(path, "rb") as f:
                payload = unwrap(f.read())
            try:
                if payload is None:
                    raise ValueError("checksum")
                return pickle.loads(payload)
            except Exception:  # noqa: BLE001 - numba's load() treats an OSError as an absent entry
                _log.warning("%s: numba cache file damaged; compiling again", path)
                raise OSError(f"{path}: damaged") from None

    return _CheckedFile


def unwrap(raw: bytes) -> bytes | None:
    """numba's bytes of a checked record, or None when it is not one or fails its SHA-256."""
    head = len(MAGIC) + _DIGEST
    if len(raw) < head or not raw.startswith(MAGIC):
        return None
    data = raw[head:]
    return data if hashlib.sha256(data).digest() == raw[len(MAGIC):head] else None


def protect(*modules: ModuleType) -> None:
    """Give every cached numba function of ``modules`` the checked cache file (idempotent)."""
    from numba.core.dispatcher import Dispatcher

    cls = None
    for mod in modules:
        for obj in vars(mod).values():
            cache = getattr(obj, "_cache", None) if isinstance(obj, Dispatcher) else None
            old = getattr(cache, "_cache_file", None)
            if old is None or type(old).__name__ == "_CheckedFile":
                continue
            cls = cls or _checked_file_class()
            try:
                base = old._index_name[:-len(".nbi")]
                cache._cache_file = cls(old._cache_path, base + SUFFIX, old._source_stamp)
            except AttributeError:  # pragma: no cover - a numba whose cache file is laid out otherwise
                warnings.warn("this numba's cache files cannot be checksummed by ur5fault; left as numba makes them",
                              RuntimeWarning, stacklevel=2)  # shown once: one place in the code
