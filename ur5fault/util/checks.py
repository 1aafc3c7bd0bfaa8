"""Small named checks of single values at the public edge (YAML files, command-line options).

Each returns the value in its canonical Python type or raises :class:`ParameterError` with one
line naming where the value came from, the value (shortened) and what is valid.  No bool passes
as a number and no string passes as a number: the strict YAML loader (:mod:`ur5fault.util.yamlsafe`)
already reads ``1e9`` as the number it means, so a string here is a quoted value or a typo.  numpy scalars
(``np.float64``, ``np.int64``, ``np.bool_``) pass wherever the Python value they hold would, and come back as
that Python value: values taken from arrays are numbers, not strangers.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np

from ..errors import ParameterError

_MAX_REPR = 60


def short(value: Any) -> str:
    """``repr(value)`` cut to one short line (a 1 MB string or a deep list stays readable)."""
    text = " ".join(repr(value).split())
    return text if len(text) <= _MAX_REPR else text[: _MAX_REPR - 3] + "..."


def is_real(value: Any) -> bool:
    """A real number: a Python or numpy integer or float; never a bool (``np.bool_`` is no number either)."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_integer(value: Any) -> bool:
    """A Python or numpy integer; never a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def as_bool(value: Any) -> bool | None:
    """``value`` as a Python bool if it is one (``True``, ``np.True_``); else None."""
    return bool(value) if isinstance(value, (bool, np.bool_)) else None


#: the units of a number without one (a factor, a share, a ratio), which messages leave out: ``[0, 10] -`` read as
#: a line cut off
DIMENSIONLESS = ("", "-")


def range_text(lo: float, hi: float, unit: str = "", lo_open: bool = False) -> str:
    """``[lo, hi] unit`` (``(lo, hi] unit`` with ``lo_open``) as messages write a valid range; a dimensionless unit
    (:data:`DIMENSIONLESS`) left out."""
    return f"{'(' if lo_open else '['}{lo:g}, {hi:g}]" + ("" if unit in DIMENSIONLESS else f" {unit}")


def check_number(value: Any, where: str, lo: float = -math.inf, hi: float = math.inf, unit: str = "", *,
                 lo_open: bool = False) -> float:
    """A finite real number in ``[lo, hi]`` (``(lo, hi]`` with ``lo_open``); ints are accepted."""
    rng = range_text(lo, hi, unit, lo_open)
    if not is_real(value):
        raise ParameterError(f"{where} = {short(value)} must be a number in {rng}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond the float range
        raise ParameterError(f"{where} = {short(value)} is out of range {rng}") from None
    if not math.isfinite(v):
        raise ParameterError(f"{where} = {short(value)} must be a finite number in {rng}")
    if (v <= lo if lo_open else v < lo) or v > hi:
        raise ParameterError(f"{where} = {short(value)} is out of range {rng}")
    return v


def check_int(value: Any, where: str, lo: int, hi: int, what: str = "an integer") -> int:
    """An integer in ``[lo, hi]``; a float with an integral value (``1e9``) is the integer it means."""
    if is_real(value) and not is_integer(value):
        v = float(value)
        if math.isfinite(v) and v.is_integer() and abs(v) < 2**53:
            value = int(v)
    if not is_integer(value) or not lo <= value <= hi:
        raise ParameterError(f"{where} = {short(value)} must be {what} in [{lo}, {hi}]")
    return int(value)


def check_count(value: Any, option: str, least: int) -> int:
    """A command-line count (``--jobs``, ``--max-effects``): a whole number of at least ``least``, refused in the
    campaign commands' words, ``--jobs 0: must be a whole number of at least 1``."""
    if not is_integer(value) or value < least:
        raise ParameterError(f"{option} {value!r}: must be a whole number of at least {least}")
    return int(value)


def check_bool(value: Any, where: str) -> bool:
    """``true`` or ``false`` (YAML also reads ``yes``/``no`` as these); never a string or a number."""
    flag = as_bool(value)
    if flag is None:
        raise ParameterError(f"{where} = {short(value)} must be true or false")
    return flag


def check_text(value: Any, where: str, max_len: int = 200) -> str:
    """A non-empty single-line string of at most ``max_len`` characters."""
    if not isinstance(value, str) or not value.strip() or len(value) > max_len or "\n" in value or "\0" in value:
        raise ParameterError(f"{where} = {short(value)} must be a non-empty one-line text of at most "
                             f"{max_len} characters")
    return str(value)


def check_name(value: Any, where: str) -> str:
    """A campaign's (or life campaign's) name: one-line text naming a folder inside ``results/``, the default
    folder ``results/NAME`` (``study/v1`` is one; ``../x`` or an absolute path would write elsewhere than
    results/, and a name of dots into results/ itself)."""
    name = check_text(value, where)
    parts = name.replace("\\", "/").split("/")
    if name.startswith(("/", "\\")) or name[1:2] == ":" or ".." in parts or all(p.strip(". ") == "" for p in parts):
        raise ParameterError(f"{where} = {short(value)} must name a folder inside results/ (no .. part, not an "
                             "absolute path, not only dots): the default folder is results/NAME; for a folder "
                             "elsewhere give out: or --out")
    return name
