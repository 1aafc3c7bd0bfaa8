"""MuJoCo's stage timers switched off while ur5fault steps (``with timers_off(): ...``).

The Python bindings set MuJoCo's ``mjcb_time`` to a C clock, so every ``mj_step`` reads the clock about twice per
stage (``TM_START`` / ``TM_END`` in MuJoCo's engine) to fill ``mjData.timer``, which ur5fault never reads.
Measured on the Intel 2-core host (``bench/bench_speed.py``, docs/performance.md "MuJoCo's stage timers"): bare
``mj_step`` of the packaged UR5 about 1.1 us per step slower with the timers than without, a quarter of the step.
The physics does not read the clock: every state is the same bit for bit either way
(``tests/sim/test_mjtimers.py``).

``mjcb_time`` is one pointer for the whole process, so the switch counts its users: the first saves the pointer and
clears it, the last puts it back.  Threads that simulate at once leave the timers off until all are done; a
viewer's profiler in the same process shows no stage times meanwhile.
"""

from __future__ import annotations

import ctypes
import threading
from collections.abc import Iterator
from contextlib import contextmanager

from .mjlib import LIB


class TimerSwitch:
    """Counts the users of the switched-off timers of one loaded MuJoCo library (``lib``: its ``ctypes.CDLL``)."""

    def __init__(self, lib: ctypes.CDLL | None) -> None:
        self._pointer = ctypes.c_void_p.in_dll(lib, "mjcb_time") if lib is not None else None
        self._lock = threading.Lock()
        self._users = 0
        self._saved: int | None = None

    @contextmanager
    def off(self) -> Iterator[None]:
        """MuJoCo's timers off inside the block, back as they were after the last user leaves."""
        if self._pointer is None:
            yield
            return
        with self._lock:
            if self._users == 0:
                self._saved = self._pointer.value
                self._pointer.value = None
            self._users += 1
        try:
            yield
        finally:
            with self._lock:
                self._users -= 1
                if self._users == 0:
                    self._pointer.value = self._saved

    def is_on(self) -> bool:
        """Whether ``mjcb_time`` is set now (MuJoCo's timers run)."""
        return self._pointer is not None and bool(self._pointer.value)


#: the switch of the MuJoCo library the bindings loaded (one per process, as ``mjcb_time`` is)
SWITCH = TimerSwitch(LIB)
timers_off = SWITCH.off
