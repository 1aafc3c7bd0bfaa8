"""A current offset, a current gain and a torque constant on one joint are simulated as rivals of each other
whatever share of the finding's improvement they take (``rivals.CURRENT_FAMILY``).  Synthetic linear problem, no
simulation; expected values computed by hand."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from ur5fault.discrepancy.rivals import CURRENT_FAMILY, in_place
from ur5fault.discrepancy.search import columns_of

N = 2500  # 20 s at 125 Hz, the screened part of a log


@dataclasses.dataclass(frozen=True)
class Effect:
    """A stand-in library candidate on joint 0: its effect's name, one coefficient, any value allowed."""

    effect: str
    joint: int = 0
    source: str = "library"
    n_coef: int = 1

    @property
    def label(self) -> str:
        return f"{self.effect} on joint {self.joint}"

    def bounds(self):
        return np.full(1, -np.inf), np.full(1, np.inf)


def test_an_offset_is_simulated_as_a_rival_of_a_gain_whatever_its_share():
    """A joint's current of one sign, 1 + 0.75 sin (2 Hz): a gain's column is the current, an offset's a constant.
    The residual is 5 x the current plus unit noise; the gain is the finding.  The offset alone takes
    1 / (1 + 0.75^2 / 2) = 78 % of the gain's improvement (hand-computed), below the 90 % share, so it is offered as
    a rival only as a member of the current family, at its own estimate 5 x the current's mean (5)."""
    rng = np.random.default_rng(4)
    t = np.arange(N) / 125.0
    current = 1.0 + 0.75 * np.sin(2 * np.pi * 2.0 * t)
    e = (5.0 * current + rng.standard_normal(N))[:, None]
    cands = [Effect("current_sensor_gain"), Effect("current_sensor_offset")]
    X = np.stack([current[:, None], np.ones((N, 1))])
    e_named = e - 5.0 * current[:, None]
    share = (np.sum(e) ** 2 / N) / (np.sum(e[:, 0] * current) ** 2 / np.sum(current**2))
    assert share == pytest.approx(1.0 / (1.0 + 0.75**2 / 2.0), abs=0.01)
    taken = {cands[0].label}
    assert in_place(X, e, e_named, cands, columns_of(cands), taken, 0) == []
    got = in_place(X, e, e_named, cands, columns_of(cands), taken, 0, family=CURRENT_FAMILY)
    assert [k for k, _ in got] == [1]
    assert got[0][1][0] == pytest.approx(5.0, abs=0.1)
