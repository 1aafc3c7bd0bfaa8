"""MuJoCo's log file switched off while ur5fault steps (``with no_log_file(): ...``).

An unstable run makes MuJoCo warn ("Nan, Inf or huge value in QACC ..."). By default MuJoCo (4.0) writes every
warning to the console *and* appends it to ``MUJOCO_LOG.TXT`` in the working folder, so a user's folder gained a
file from any run that ended in a protective stop. ur5fault records such a run's status and reason in its result
(``status``, ``reason``), and the console still shows the warning; only the file is switched off.

The switch is MuJoCo's own ``MjLogConfig`` (C-level: no Python callback, which the compiled loop's threads could
not call without the GIL). It is one setting for the whole process, so the switch counts its users as
:mod:`.mjtimers` does: the first saves the setting, the last puts it back. MuJoCo builds without ``MjLogConfig``
(before 4.0) keep their behaviour.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import mujoco


class LogFileSwitch:
    """Counts the users of MuJoCo's switched-off log file (``config``: the bindings' ``MjLogConfig`` class)."""

    def __init__(self, config: Any) -> None:
        self._config = config
        self._lock = threading.Lock()
        self._users = 0
        self._saved: bool | None = None

    def _set(self, on: bool) -> None:
        c = self._config.get()
        c.logto_file = on
        c.set()

    @contextmanager
    def off(self) -> Iterator[None]:
        """No ``MUJOCO_LOG.TXT`` written inside the block; the setting back as it was after the last user leaves."""
        if self._config is None:
            yield
            return
        with self._lock:
            if self._users == 0:
                self._saved = bool(self._config.get().logto_file)
                self._set(False)
            self._users += 1
        try:
            yield
        finally:
            with self._lock:
                self._users -= 1
                if self._users == 0:
                    self._set(bool(self._saved))

    def writes_file(self) -> bool:
        """Whether MuJoCo writes its log file now."""
        return self._config is not None and bool(self._config.get().logto_file)


#: the switch of the loaded MuJoCo (one per process, as its log configuration is)
SWITCH = LogFileSwitch(getattr(mujoco, "MjLogConfig", None))
no_log_file = SWITCH.off
