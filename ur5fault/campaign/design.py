"""The draws of a sampled campaign (:mod:`.sampling`): one-dimensional distributions read from YAML,
mapped from unit-interval coordinates, and the unit-cube designs (Latin hypercube or scrambled Sobol)
the coordinates come from."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..errors import ParameterError, UnknownNameError
from ..util.checks import is_integer, is_real
from ..util.yamlsafe import plain

METHODS = ("lhs", "sobol")
DIST_KEYS = ("uniform", "log", "integers", "choices")
#: drawn values are rounded to this many significant digits (readable run lists; far below any effect's
#: resolution)
SIGNIFICANT_DIGITS = 6


@dataclasses.dataclass(frozen=True)
class Dist:
    """A one-dimensional distribution mapped from a unit-interval coordinate."""

    kind: str  # uniform, log, integers, choices, fixed
    args: tuple[Any, ...]
    step: float | None = None

    @property
    def drawn(self) -> bool:
        return self.kind != "fixed"

    def value(self, u: float) -> Any:
        """The value at coordinate ``u`` in [0, 1) (inverse CDF)."""
        k, a = self.kind, self.args
        if k == "fixed":
            return a[0]
        if k == "choices":
            return a[min(int(u * len(a)), len(a) - 1)]
        if k == "integers":
            return int(min(a[0] + int(u * (a[1] - a[0] + 1)), a[1]))
        v = a[0] + u * (a[1] - a[0]) if k == "uniform" else math.exp(math.log(a[0]) + u * math.log(a[1] / a[0]))
        if self.step:
            v = min(max(round(v / self.step) * self.step, a[0]), a[1])
        return float(f"{v:.{SIGNIFICANT_DIGITS}g}")

    def bounds(self) -> tuple[Any, ...]:
        """The extreme values it can give (for validation before any simulation)."""
        if self.kind in ("fixed", "choices"):
            return self.args
        return (self.value(0.0), self.value(1.0 - 1e-12))


def parse_dist(spec: Any, where: str) -> Dist:
    """A distribution from YAML (see the module docstring); from Python, numpy arrays count as the lists they hold."""
    if isinstance(spec, np.ndarray):
        spec = plain(spec)
    if isinstance(spec, list):
        spec = {"uniform": spec}
    if not isinstance(spec, Mapping):
        return Dist("fixed", (plain(spec),))
    keys = [k for k in spec if k in DIST_KEYS]
    extra = [k for k in spec if k not in DIST_KEYS + ("step",)]
    if extra or len(keys) != 1:
        bad = extra[0] if extra else "/".join(keys) or "(none)"
        raise UnknownNameError("distribution", bad, DIST_KEYS, where)
    kind, args = keys[0], spec[keys[0]]
    if isinstance(args, np.ndarray):
        args = plain(args)
    if isinstance(args, list):  # numpy numbers (a list built in Python) as the Python numbers they hold
        args = [plain(v) for v in args]
    step = spec.get("step")
    if step is not None and (not is_real(step) or not 0 < step < math.inf):
        raise ParameterError(f"{where}: step = {step!r} must be a positive finite number")
    step = float(step) if step is not None else None
    if kind == "choices":
        if not isinstance(args, list) or not args:
            raise ParameterError(f"{where}: choices must be a non-empty list")
        return Dist("choices", tuple(args), step)
    if (not isinstance(args, list) or len(args) != 2
            or any(not is_real(v) or not math.isfinite(v) for v in args)):
        raise ParameterError(f"{where}: {kind} = {args!r} must be a list [lo, hi] of two numbers")
    lo, hi = args
    if kind == "integers" and not (is_integer(lo) and is_integer(hi)):
        raise ParameterError(f"{where}: integers = {args!r} must be two integers")
    if not lo <= hi:
        raise ParameterError(f"{where}: {kind} = {args!r} needs lo <= hi")
    if kind == "log" and not lo > 0:
        raise ParameterError(f"{where}: log = {args!r} needs 0 < lo <= hi")
    return Dist(kind, (lo, hi), step)


def unit_design(method: str, n: int, d: int, seed: int) -> np.ndarray:
    """``(n, d)`` points in the unit cube: Latin hypercube (here) or scrambled Sobol (scipy)."""
    if d == 0:
        return np.zeros((n, 0))
    if method == "lhs":
        rng = np.random.default_rng(seed)
        return np.stack([(rng.permutation(n) + rng.random(n)) / n for _ in range(d)], axis=1)
    from scipy.stats import qmc

    try:
        sobol = qmc.Sobol(d, scramble=True, rng=seed)
    except TypeError:  # scipy < 1.15 names it seed
        sobol = qmc.Sobol(d, scramble=True, seed=seed)
    return sobol.random_base2(max(0, math.ceil(math.log2(n))))[:n]
