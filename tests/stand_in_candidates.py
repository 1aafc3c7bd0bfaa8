"""Stand-in library candidates for the discrepancy statistics' tests: shapes whose columns a test writes by hand."""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class Offset:
    """A stand-in library candidate: a constant on one channel (one coefficient, any value allowed)."""

    joint: int = 0
    source: str = "library"
    n_coef: int = 1

    @property
    def label(self) -> str:
        return f"offset on joint {self.joint}"

    def bounds(self):
        return np.full(1, -np.inf), np.full(1, np.inf)


@dataclasses.dataclass(frozen=True)
class Col:
    """A stand-in candidate of any label: on ``joint`` (None: the robot's), ``n_coef`` coefficients, unbounded."""

    label: str
    joint: int | None = None
    n_coef: int = 1

    def bounds(self):
        return np.full(self.n_coef, -np.inf), np.full(self.n_coef, np.inf)
