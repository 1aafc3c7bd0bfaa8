"""Exception family of ur5fault.

Every error a user can cause (bad YAML, unknown joint, value out of range) is a
:class:`Ur5FaultError`; the subclasses also derive from the matching built-in
(:class:`ValueError`, :class:`KeyError`) so callers can catch either.  Messages
name the offending field, its value and the valid choices or range, in one line.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


def close_names(name: object, choices: Iterable[str], n: int = 3) -> list[str]:
    """The ``choices`` a mistyped ``name`` is likely meant to be (at most ``n``, closest first; none for a name that
    is not a string): the "did you mean" of every unknown-name message."""
    return difflib.get_close_matches(name, list(choices), n=n, cutoff=0.6) if isinstance(name, str) else []


def did_you_mean(name: object, choices: Iterable[str], n: int = 3) -> str:
    """``" (did you mean 'default'?)"``, or ``""`` when no choice is close to ``name``."""
    close = close_names(name, choices, n)
    return f" (did you mean {' or '.join(map(repr, close))}?)" if close else ""


class Ur5FaultError(Exception):
    """Base class of every error ur5fault raises on bad input."""

    def __str__(self) -> str:  # KeyError would otherwise quote the message
        return str(self.args[0]) if self.args else ""


class ParameterError(Ur5FaultError, ValueError):
    """A parameter has a wrong type or a value outside its valid range."""


#: names an unknown-name error lists in full; above it, the first half of them and how many more (a campaign's
#: feature table has about 400 health features: the line filled a screen)
MAX_LISTED = 80


class UnknownNameError(Ur5FaultError, KeyError):
    """A name (joint, effect, YAML key, trajectory) does not exist."""

    def __init__(self, kind: str, name: object, choices: Iterable[str], where: str = "") -> None:
        self.kind, self.name, self.choices = kind, name, sorted(choices)
        loc = f"{where}: " if where else ""
        listed = self.choices if len(self.choices) <= MAX_LISTED else [
            *self.choices[:MAX_LISTED // 2], f"... ({len(self.choices) - MAX_LISTED // 2} more)"]
        super().__init__(f"{loc}unknown {kind} {name!r}{did_you_mean(name, self.choices)}; valid: "
                         f"{', '.join(listed)}")


class ConfigFileError(Ur5FaultError, ValueError):
    """A configuration file cannot be read or parsed."""


class StoredResultError(ConfigFileError):
    """A stored result can be neither read as written nor made again (e.g. a run whose campaign, edited by hand,
    no longer validates)."""


class LogFormatError(Ur5FaultError, ValueError):
    """A measured log lacks a column, has NaN or non-monotonic time, or is not a UR5."""
