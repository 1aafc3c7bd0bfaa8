"""MuJoCo's log file switched off while ur5fault steps (``with no_log_file(): ...``).

An unstable run makes MuJoCo warn ("Nan, Inf or huge value in QACC ..."). By default MuJoCo (4.0) writes every
warning to the console *and* appends it to ``MUJOCO_LOG.TXT`` in the working folder, so a user's folder gained a
file from any run that ended in a protective stop. ur5fault records such a run's status and reason in its result
(``status``, ``reason``), and the console still shows the warning; only the file is switched off.

The switch is MuJoCo's own ``MjLogConfig`` (C-level: no Python callback, which the compiled loop's threads could
not call without the GIL). It is one setting for the whole process, so the switch counts its users
(:class:`.switch.CountedSwitch`, as :mod:`.mjtimers` does): the first saves the setting, the last puts it back.
MuJoCo builds without ``MjLogConfig`` (before 4.0) keep their behaviour.
"""

from __future__ import annotations

from typing import Any

import mujoco

from .switch import CountedSwitch


class LogFileSwitch(CountedSwitch):
    """MuJoCo's switched-off log file (``config``: the bindings' ``MjLogConfig`` class, or None without one)."""

    _OFF = False  # logto_file

    def __init__(self, config: Any) -> None:
        super().__init__()
        self._config = config

    def _available(self) -> bool:
        return self._config is not None

    def _read(self) -> bool:
        return bool(self._config.get().logto_file)

    def _write(self, value: bool) -> None:
        c = self._config.get()
        c.logto_file = bool(value)
        c.set()

    def writes_file(self) -> bool:
        """Whether MuJoCo writes its log file now."""
        return self._config is not None and self._read()


#: the switch of the loaded MuJoCo (one per process, as its log configuration is)
SWITCH = LogFileSwitch(getattr(mujoco, "MjLogConfig", None))
no_log_file = SWITCH.off
