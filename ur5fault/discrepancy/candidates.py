"""What may explain a residual: a parameter of an effect of the library, or a term of the dictionary.

A candidate owns one or two coefficients (``n_coef``; a sine-cosine pair for a harmonic) of the
linearised problem and knows the effect that adds it to the model at given coefficients
(:meth:`Candidate.spec`).  Library candidates are parameterised by their deviation from the value that
means "absent" (in a variable where the signals respond about linearly, :data:`TRANSFORMS`); terms by
their coefficients, which their effect takes as they are.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from ..sim.axes import JOINT_NAMES
from ..sim.effects import REGISTRY, EffectSpec, make_effect


def _identity(x: float) -> float:
    return x


def _reciprocal(x: float) -> float:
    return 1.0 / x


#: parameters fitted in a transformed variable in which the signals respond about linearly:
#: a gear's wind-up goes with its compliance, 1 / stiffness  (forward, inverse)
TRANSFORMS: dict[tuple[str, str], tuple[Callable[[float], float], Callable[[float], float]]] = {
    ("gear_stiffness", "scale"): (_reciprocal, _reciprocal)}


@dataclasses.dataclass(frozen=True)
class Candidate:
    """Base of library candidates and dictionary terms.

    Attributes:
        effect: registry name of the effect that adds it to the model.
        joint: 0-based joint it sits on (a link's joint for ``link_mass``), or None (whole robot).
        source: ``"library"`` or ``"dictionary"``.
        local: its columns touch only its own joint's channels.
    """

    effect: str
    joint: int | None

    source = "library"
    n_coef = 1
    local = True

    @property
    def where(self) -> str:
        return JOINT_NAMES[self.joint] if self.joint is not None else "robot"

    @property
    def label(self) -> str:  # pragma: no cover - overridden
        raise NotImplementedError

    def values(self, coef: NDArray) -> dict[str, float]:  # pragma: no cover - overridden
        """The effect's parameter values at ``coef`` (not validated: a fit may leave the valid range)."""
        raise NotImplementedError

    def spec(self, coef: NDArray) -> EffectSpec:
        return make_effect(self.effect, None if self.joint is None else self.joint + 1, **self.values(coef))

    def range_problem(self, coef: NDArray) -> str | None:
        """Why the values at ``coef`` cannot go into a model (outside an effect parameter's valid range), or None."""
        eff = REGISTRY[self.effect]
        for key, v in self.values(coef).items():
            p = eff.param(key)
            if not (np.isfinite(v) and p.lo <= v <= p.hi):
                return f"fitted {self.effect}.{key} = {v:.4g} is outside its valid range {p.range_text()}"
        return None

    def bounds(self) -> tuple[NDArray, NDArray]:  # pragma: no cover - overridden
        raise NotImplementedError


@dataclasses.dataclass(frozen=True)
class LibraryCandidate(Candidate):
    """One parameter of one effect of the registry, with the probe value simulated to linearise it."""

    param: str = ""
    x0: float = 0.0  # value meaning "absent" (or the nominal)
    probe: float = 0.0

    @property
    def local(self) -> bool:  # type: ignore[override]
        return self.joint is not None

    @property
    def label(self) -> str:
        return f"{self.where}: {self.effect}.{self.param}"

    def _tf(self):
        return TRANSFORMS.get((self.effect, self.param), (_identity, _identity))

    def value(self, coef: NDArray | float) -> float:
        """Parameter value at coefficient ``coef`` (the deviation from ``x0`` in the fitted variable)."""
        fwd, inv = self._tf()
        return float(inv(fwd(self.x0) + float(np.ravel(coef)[0])))

    def coef(self, value: float) -> float:
        fwd, _ = self._tf()
        return fwd(value) - fwd(self.x0)

    def values(self, coef: NDArray) -> dict[str, float]:
        return {self.param: self.value(coef)}

    def bounds(self) -> tuple[NDArray, NDArray]:
        p = REGISTRY[self.effect].param(self.param)
        a, b = self.coef(p.lo), self.coef(p.hi)
        return np.array([min(a, b)]), np.array([max(a, b)])


@dataclasses.dataclass(frozen=True)
class TermCandidate(Candidate):
    """A dictionary term: effect parameters ``keys`` take the coefficients, ``fixed`` the rest.

    Attributes:
        family: dictionary family (``joint_harmonic``, ``coulomb``, ...), for reports and tests.
        keys: effect parameters that take the coefficients, in order.
        fixed: the effect's other parameters (a harmonic's periods per revolution, a width).
        to_param: factor from coefficient to parameter value (e.g. s -> ms).
        signal_per_coef: size of the term in the signal per unit coefficient (current per torque), for
            sentences; ``unit`` the coefficient's unit.
    """

    family: str = ""
    keys: tuple[str, ...] = ()
    fixed: tuple[tuple[str, float], ...] = ()
    to_param: float = 1.0
    unit: str = ""
    signal: str = "current_A"
    signal_per_coef: float = 1.0
    local_: bool = True
    lower: float | None = None  # a tighter lower bound of the (single) coefficient than the effect's range

    source = "dictionary"

    @property
    def n_coef(self) -> int:  # type: ignore[override]
        return len(self.keys)

    @property
    def local(self) -> bool:  # type: ignore[override]
        return self.local_

    @property
    def label(self) -> str:
        extra = "".join(f", {k}={v:g}" for k, v in self.fixed)
        return f"{self.where}: {self.family}{extra}"

    def values(self, coef: NDArray) -> dict[str, float]:
        return {**{k: float(c) * self.to_param for k, c in zip(self.keys, np.ravel(coef))}, **dict(self.fixed)}

    def bounds(self) -> tuple[NDArray, NDArray]:
        ps = [REGISTRY[self.effect].param(k) for k in self.keys]
        lo = np.array([p.lo / self.to_param for p in ps])
        if self.lower is not None:
            lo = np.maximum(lo, self.lower)
        return lo, np.array([p.hi / self.to_param for p in ps])
