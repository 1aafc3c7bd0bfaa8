"""The friction defaults that only a replay of the real log can decide are re-derived here from the NIST
log (ur5fault/identify/friction_choice.py; docs/parameters.md): the friction law, the motor-side share and
the presliding stiffness.  Each test fails if ``ur5_drive.yaml`` no longer holds the choice the log makes."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.identify.friction_choice import replay
from ur5fault.logs import read_nist
from ur5fault.sim.params import load_params

pytestmark = pytest.mark.slow  # full replays of the 63 s log

#: yaml keys decided here (tests/identify/test_identify.py requires every [nist] key to be re-derived somewhere)
REPLAY_KEYS = ("friction.model", "friction.motor_side_share", "friction.presliding_stiffness_Nm_per_rad")
#: a candidate within this share of the best held-out current RMS (summed over the joints) is a tie
TIE = 0.01


@pytest.fixture(scope="module")
def log(nist_path):
    return read_nist(nist_path)


def _total(row: dict) -> float:
    return float(np.sum(row["held_out"]))


def test_friction_law_is_the_one_the_log_prefers(log):
    smooth = replay(log, {"model": "smooth"}, [{}])[0]
    lugre = replay(log, {"model": "lugre"}, [{}])[0]
    best = "lugre" if _total(lugre) < _total(smooth) else "smooth"
    assert set(load_params().friction.model) == {best}
    if best == "lugre":  # the reason the law was added: it holds the load at rest
        assert lugre["at_rest"][0] < 0.8 * smooth["at_rest"][0]
        assert lugre["at_rest"][1] < 0.8 * smooth["at_rest"][1]


def test_motor_side_share_is_the_one_the_log_prefers(log):
    shares = (0.0, 0.25, 0.5, 0.75, 1.0)
    rows = replay(log, None, [{"share": s} for s in shares])[: len(shares)]
    totals = np.array([_total(r) for r in rows])
    default = set(load_params().friction.motor_side_share)
    assert len(default) == 1
    chosen = shares.index(default.pop())
    assert totals[chosen] <= (1 + TIE) * totals.min(), dict(zip(shares, totals.round(4)))


def test_presliding_stiffness_is_the_one_the_log_prefers(log):
    scales = (0.3, 0.5, 1.0, 2.0)
    rows = replay(log, None, [{"s0": s} for s in scales])[: len(scales)]
    totals = np.array([_total(r) for r in rows])
    assert totals[scales.index(1.0)] <= (1 + TIE) * totals.min(), dict(zip(scales, totals.round(4)))
