"""Frozen, validated parameter objects (the mechanism; the values live in ``data/*.yaml``).

A parameter class is a frozen dataclass whose fields are declared with :func:`param`,
which records the unit, the valid range and whether the field holds one value per joint.
Construction checks every value and rejects a bad one with a message naming the
field, the value and the valid range.  :meth:`Validated.from_dict` builds an object
from a YAML mapping, rejecting unknown keys with the list of valid ones.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, TypeVar

from ..errors import ParameterError, UnknownNameError
from ..util.checks import is_real, range_text, short
from .axes import N_JOINTS

T = TypeVar("T", bound="Validated")


def param(
    lo: float = -math.inf,
    hi: float = math.inf,
    *,
    unit: str = "",
    per_joint: bool = True,
    choices: tuple[str, ...] | None = None,
    doc: str = "",
    default: Any = dataclasses.MISSING,
    lo_open: bool = False,
    length: int | None = None,
) -> Any:
    """Declare a parameter field.

    Args:
        lo, hi: inclusive valid range (``lo_open`` makes ``lo`` exclusive).
        unit: SI unit shown in messages and docs, e.g. ``"N*m/rad"``.
        per_joint: the field is a tuple of one value per joint (a scalar in YAML is
            broadcast to all joints).
        choices: for string fields, the allowed values.
        doc: one-line meaning, used by the docs.
        default: default value; absent means the field is required.
        length: the field is a tuple of exactly this many values (e.g. 3 for a vector);
            overrides ``per_joint``.
    """
    n = length if length is not None else (N_JOINTS if per_joint else None)
    meta = dict(lo=lo, hi=hi, unit=unit, length=n, choices=choices, doc=doc, lo_open=lo_open)
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def declared_range(cls: type, name: str) -> tuple[float, float]:
    """The range ``[lo, hi]`` the field ``name`` of the parameter class ``cls`` declares (:func:`param`; whether
    ``lo`` is open is the declaration's ``lo_open``)."""
    meta = next(f.metadata for f in dataclasses.fields(cls) if f.name == name)
    return float(meta["lo"]), float(meta["hi"])


def _range_text(meta: Mapping[str, Any]) -> str:
    return range_text(meta["lo"], meta["hi"], meta["unit"], bool(meta.get("lo_open")))


def _check_scalar(where: str, value: Any, meta: Mapping[str, Any]) -> Any:
    if meta["choices"] is not None:
        if not isinstance(value, str) or value not in meta["choices"]:
            raise ParameterError(f"{where} = {value!r} is not valid; choose one of: {', '.join(meta['choices'])}")
        return value
    if not is_real(value):
        raise ParameterError(f"{where} = {value!r} must be a number in {_range_text(meta)}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond the float range (10**400 written out in a YAML file)
        raise ParameterError(f"{where} = {short(value)} is out of range {_range_text(meta)}") from None
    lo, hi = meta["lo"], meta["hi"]
    bad_lo = v <= lo if meta.get("lo_open") else v < lo
    if not math.isfinite(v) or bad_lo or v > hi:
        raise ParameterError(f"{where} = {value!r} is out of range {_range_text(meta)}")
    return v


@dataclasses.dataclass(frozen=True)
class Validated:
    """Base of frozen parameter objects; subclasses declare fields with :func:`param`."""

    def __post_init__(self) -> None:
        prefix = type(self).__name__
        for f in dataclasses.fields(self):
            meta = f.metadata
            if "unit" not in meta:  # nested Validated objects check themselves
                continue
            value = getattr(self, f.name)
            where = f"{prefix}.{f.name}"
            n = meta["length"]
            if n is not None:
                if n == N_JOINTS and (isinstance(value, str) or is_real(value)):
                    # a scalar applies to every joint: checked once, under its own name (not as element [1])
                    value = (_check_scalar(where, value, meta),) * N_JOINTS
                if isinstance(value, (str, int, float)) or is_real(value) or not hasattr(value, "__len__"):
                    raise ParameterError(f"{where} = {value!r} must be a list of {n} values")
                value = tuple(value)
                if len(value) != n:
                    what = " (one per joint)" if n == N_JOINTS else ""
                    raise ParameterError(f"{where} needs {n} values{what}, got {len(value)}")
                value = tuple(_check_scalar(f"{where}[{j + 1}]", v, meta) for j, v in enumerate(value))
            else:
                value = _check_scalar(where, value, meta)
            object.__setattr__(self, f.name, value)

    @classmethod
    def from_dict(cls: type[T], data: Mapping[str, Any] | None, where: str = "") -> T:
        """Build from a mapping (e.g. parsed YAML), rejecting unknown keys.

        Nested parameter objects are built recursively; missing keys keep the
        field's default (a required field without a value is an error).
        """
        data = dict(data or {})
        if not isinstance(data, dict):
            raise ParameterError(f"{where or cls.__name__}: expected a mapping, got {type(data).__name__}")
        known = {f.name: f for f in dataclasses.fields(cls)}
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            path = f"{where}.{key}" if where else str(key)
            if key not in known:
                raise UnknownNameError("key", key, known, where or cls.__name__)
            ftype = _nested_type(cls, key)
            if ftype is not None:
                if not isinstance(value, Mapping):
                    keys = ", ".join(f.name for f in dataclasses.fields(ftype))  # the keys, not the class's name
                    raise ParameterError(f"{path} = {short(value)}: expected a mapping of its keys ({keys})")
                kwargs[key] = ftype.from_dict(value, path)
            else:
                kwargs[key] = value
        try:
            return cls(**kwargs)
        except TypeError as exc:  # a required key is missing
            missing = str(exc).split("argument", 1)[-1].strip(": ")
            raise ParameterError(f"{where or cls.__name__}: missing required key {missing}") from None
        except ParameterError as exc:  # name the key path instead of the class
            if where and str(exc).startswith(cls.__name__ + "."):
                raise ParameterError(where + str(exc)[len(cls.__name__):]) from None
            raise

    def replace(self: T, **changes: Any) -> T:
        """Return a copy with ``changes`` applied (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python mapping (tuples become lists) suitable for YAML/JSON."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            if isinstance(v, Validated):
                out[f.name] = v.to_dict()
            elif isinstance(v, tuple):
                out[f.name] = list(v)
            else:
                out[f.name] = v
        return out


def _nested_type(cls: type, name: str) -> type[Validated] | None:
    hints = getattr(cls, "__nested__", {})
    return hints.get(name)
