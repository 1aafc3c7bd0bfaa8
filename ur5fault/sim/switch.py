"""A process-wide MuJoCo setting turned off while any run of the process steps (:class:`CountedSwitch`).

MuJoCo keeps some settings once per process (the stage-timer callback ``mjcb_time``, the log configuration), so a
run cannot change them for itself alone. The switch counts its users: the first saves the setting and turns it off,
the last puts it back, so nested and concurrent runs leave it as they found it. :mod:`.mjtimers` and :mod:`.mjlog`
are its two uses.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any


class CountedSwitch:
    """Subclasses say how to read the setting (:meth:`_read`), write it (:meth:`_write`), what "off" is
    (:attr:`_OFF`) and whether the loaded MuJoCo has it at all (:meth:`_available`)."""

    _OFF: Any = None

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._users = 0
        self._saved: Any = None

    def _available(self) -> bool:
        raise NotImplementedError

    def _read(self) -> Any:
        raise NotImplementedError

    def _write(self, value: Any) -> None:
        raise NotImplementedError

    @contextmanager
    def off(self) -> Iterator[None]:
        """The setting off inside the block, back as it was after the last user leaves."""
        if not self._available():
            yield
            return
        with self._lock:
            if self._users == 0:
                self._saved = self._read()
                self._write(self._OFF)
            self._users += 1
        try:
            yield
        finally:
            with self._lock:
                self._users -= 1
                if self._users == 0:
                    self._write(self._saved)
