"""The columns of a log file: the required ones, optional groups present in part, names in any case, and which
layout a file's columns are (so that a log read with the wrong ``--format`` is told which one reads it)."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import LogFormatError


def require(columns: Sequence[str], required: Sequence[str], source: str, fmt: str = "") -> None:
    missing = [c for c in required if c not in columns]
    if missing:
        more = f" (and {len(missing) - 1} more)" if len(missing) > 1 else ""
        raise LogFormatError(f"{source}: missing required column {missing[0]!r}{more}{layout_hint(columns, fmt)}")


#: a column each layout's files carry, lower case (how a file read with the wrong --format is told)
LAYOUT_MARKS = {"nist": "robot_time", "rtde": "actual_q_0"}


def layout_hint(columns: Sequence[str], fmt: str) -> str:
    """``"; its columns are the X layout's: give --format X"`` when a file read as ``fmt`` carries another
    layout's mark column (:data:`LAYOUT_MARKS`), else ``""``."""
    names = {c.lower() for c in columns}
    other = [f for f, mark in LAYOUT_MARKS.items() if f != fmt and mark in names]
    return f"; its columns are the {other[0]} layout's: give --format {other[0]}" if other else ""


def joint_numbers(columns: Sequence[str], pattern: str) -> list[int]:
    rx = re.compile(pattern, re.IGNORECASE)
    return [int(m.group(1)) for c in columns if (m := rx.fullmatch(c))]


def have(columns: Sequence[str], wanted: Sequence[str], partial: list[str] | None = None,
          src: str = "") -> list[str]:
    """``wanted`` where every one of them is a column, else none; a group present in part is said in ``partial``
    (a note: one misspelt header otherwise drops the group's other columns without a word)."""
    if all(c in columns for c in wanted):
        return list(wanted)
    present = [c for c in wanted if c in columns]
    if present and partial is not None:
        missing = [c for c in wanted if c not in columns]
        partial.append(f"{src}: {len(present)} of the {len(wanted)} columns {wanted[0]}..{wanted[-1]} are present "
                       f"(missing: {', '.join(missing)}): the group is not used")
    return []


def match_case(columns: Sequence[str], known: Sequence[str], src: str) -> dict[str, str]:
    """Header column -> the name of ``known`` it spells in another case (``TIME``, ``Actual_Q_0``); a name two
    columns spell (``actual_q_2`` and ``ACTUAL_Q_2``) is refused, both named."""
    by_lower: dict[str, list[str]] = {}
    for c in columns:
        by_lower.setdefault(c.lower(), []).append(c)
    rename = {}
    for name in known:
        found = by_lower.get(name.lower(), [])
        if len(found) > 1:
            raise LogFormatError(f"{src}: columns {found[0]!r} and {found[1]!r} differ only in case: which one is "
                                 "meant cannot be told; rename or drop one")
        if found and found[0] != name:
            rename[found[0]] = name
    return rename


def stack(data: Mapping[str, NDArray], cols: Sequence[str]) -> NDArray | None:
    return np.column_stack([data[c] for c in cols]) if cols else None
