"""What an effect is: its parameters with units, ranges and "absent" values (:class:`EffectParam`), the
registered effect (:class:`Effect`) and the ``<effect>.<param>`` keys campaigns write (:class:`EffectKey`).
The entries themselves are the one registry, :data:`ur5fault.sim.effects.REGISTRY`."""

from __future__ import annotations

import dataclasses

from ..errors import ParameterError, UnknownNameError
from ..util.checks import DIMENSIONLESS, range_text
from .interfaces import EffectApplier


@dataclasses.dataclass(frozen=True)
class EffectParam:
    """One parameter of an effect: ``name`` carries its unit (``backlash_deg``)."""

    name: str
    unit: str
    lo: float
    hi: float
    absent: float | None  # the value meaning "no effect"; None: a value is required
    doc: str

    def range_text(self) -> str:
        """``[lo, hi] unit`` as messages write it (a factor's unit ``-`` left out: it read as a line cut off)."""
        return range_text(self.lo, self.hi, self.unit)

    def unit_text(self, form: str = " {}") -> str:
        """The unit in ``form`` as messages write it (`` [{}]``: `` [deg]``); nothing for a factor (unit ``-``)."""
        return "" if self.unit in DIMENSIONLESS else form.format(self.unit)


@dataclasses.dataclass(frozen=True)
class Effect:
    """A registered effect.

    Attributes:
        name: registry key, e.g. ``"backlash"``.
        doc: plain-words description used in reports.
        params: its parameters.
        per_joint: the effect sits on one joint (``joint`` required) or on the whole robot.
        apply: ``apply(arrays, row, joint_index_or_None, values)`` changes the run's row
            (:class:`ur5fault.sim.interfaces.EffectApplier`).
        size_params: the parameters whose deviation from "absent" measures the effect's size (their Euclidean
            norm: a harmonic's amplitude from its sine and cosine), the others being its shape or place (a
            period, a width, a centre of mass); empty: every parameter. They share one unit.
        acts_alone: parameters besides the size that change the robot on their own (a link's centre-of-mass
            shift moves the link's own mass); the others only shape the size (a harmonic's period at amplitude 0 is
            no effect), so an effect whose size and these are all at their "absent" values is absent.
    """

    name: str
    doc: str
    params: tuple[EffectParam, ...]
    per_joint: bool
    apply: EffectApplier
    size_params: tuple[str, ...] = ()
    acts_alone: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        units = {self.param(n).unit for n in self.size_params or [p.name for p in self.params]}
        if len(units) != 1:  # a registry entry's error, caught when the package is imported
            raise ParameterError(f"effect {self.name!r}: its size parameters mix units ({', '.join(sorted(units))}); "
                                 "name the ones that measure its size (size_params)")
        for n in self.acts_alone:
            self.param(n)  # an unknown name, caught at import like the units

    def size_parameters(self) -> tuple[EffectParam, ...]:
        """The parameters that measure the effect's size (:attr:`size_params`, or all of them)."""
        return tuple(self.param(n) for n in self.size_params) if self.size_params else self.params

    def param(self, name: str, where: str = "") -> EffectParam:
        for p in self.params:
            if p.name == name:
                return p
        raise UnknownNameError(f"parameter of effect {self.name!r}", name, [p.name for p in self.params], where)

    def absent(self, name: str) -> float:
        """The value of parameter ``name`` that means "no effect" (the registry is its only source)."""
        value = self.param(name).absent
        if value is None:
            raise ParameterError(f"effect {self.name!r}: parameter {name!r} has no absent value")
        return value


@dataclasses.dataclass(frozen=True)
class EffectKey:
    """A ``<effect>.<param>`` key of a campaign sweep or condition (``backlash.backlash_deg``,
    ``backlash.joint``): the effect's registry name and its parameter (or ``joint``)."""

    effect: str
    param: str

    @classmethod
    def parse(cls, key: object) -> EffectKey | None:
        """The key split at its first dot; None for anything else (``seed``, ``payload_kg``, a non-string).
        Whether the effect and parameter exist is the caller's check (with its own message)."""
        if not isinstance(key, str):
            return None
        effect, dot, param = key.partition(".")
        return cls(effect, param) if dot else None

    def __str__(self) -> str:
        return f"{self.effect}.{self.param}"
