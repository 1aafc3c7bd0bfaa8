"""MuJoCo's stage timers switched off while ur5fault steps (``with timers_off(): ...``).

The Python bindings set MuJoCo's ``mjcb_time`` to a C clock, so every ``mj_step`` reads the clock about twice per
stage (``TM_START`` / ``TM_END`` in MuJoCo's engine) to fill ``mjData.timer``, which ur5fault never reads.
Measured on the Intel 2-core host (``bench/bench_speed.py``, docs/performance.md "MuJoCo's stage timers"): bare
``mj_step`` of the packaged UR5 about 1.1 us per step slower with the timers than without, a quarter of the step.
The physics does not read the clock: every state is the same bit for bit either way
(``tests/sim/test_mjtimers.py``).

``mjcb_time`` is one pointer for the whole process, so the switch counts its users
(:class:`.switch.CountedSwitch`): the first saves the pointer and clears it, the last puts it back. Threads that
simulate at once leave the timers off until all are done; a viewer's profiler in the same process shows no stage
times meanwhile.
"""

from __future__ import annotations

import ctypes

from .mjlib import LIB
from .switch import CountedSwitch


class TimerSwitch(CountedSwitch):
    """The switched-off timers of one loaded MuJoCo library (``lib``: its ``ctypes.CDLL``)."""

    _OFF = None  # no clock: MuJoCo skips the timing

    def __init__(self, lib: ctypes.CDLL | None) -> None:
        super().__init__()
        self._pointer = ctypes.c_void_p.in_dll(lib, "mjcb_time") if lib is not None else None

    def _available(self) -> bool:
        return self._pointer is not None

    def _read(self) -> int | None:
        return self._pointer.value  # type: ignore[union-attr]

    def _write(self, value: int | None) -> None:
        self._pointer.value = value  # type: ignore[union-attr]

    def is_on(self) -> bool:
        """Whether ``mjcb_time`` is set now (MuJoCo's timers run)."""
        return self._pointer is not None and bool(self._pointer.value)


#: the switch of the MuJoCo library the bindings loaded (one per process, as ``mjcb_time`` is)
SWITCH = TimerSwitch(LIB)
timers_off = SWITCH.off
