"""The current held at rest as a nuisance (``discrepancy/rest_hold.py``): one free constant per long enough rest
interval of a joint's current, projected out beside the drift.  Synthetic logs and linear problems, no
simulation; expected values computed by hand in the tests."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from stand_in_candidates import Col

from ur5fault.discrepancy import DiscrepancyModel
from ur5fault.discrepancy.drift import Drift
from ur5fault.discrepancy.rest_hold import indicators, intervals, min_hold_s, of_log
from ur5fault.discrepancy.search import columns_of, judge
from ur5fault.discrepancy.statistics import BlockGram
from ur5fault.errors import ParameterError

PERIOD_S = 0.008
N = 2500  # 20 s at 125 Hz, the screened part
SIGNALS = ("current_A", "position_rad")


def test_the_minimum_hold_is_the_position_loops_two_percent_settling_time():
    assert min_hold_s(1.5) == pytest.approx(4.0 / (2.0 * math.pi * 1.5))  # 0.424 s
    assert min_hold_s(1.5) == pytest.approx(0.4244, abs=1e-4)
    with pytest.raises(ValueError):
        min_hold_s(0.0)


def test_intervals_and_their_indicators():
    rest = np.zeros(100, dtype=bool)
    rest[0:12] = True     # 12 samples from the start
    rest[30:33] = True    # 3: too short
    rest[50:60] = True    # 10: exactly the minimum
    rest[95:] = True      # 5 up to the end: too short
    assert intervals(rest, 10) == [(0, 12), (50, 60)]
    assert intervals(rest, 3) == [(0, 12), (30, 33), (50, 60), (95, 100)]
    R = indicators(np.stack([rest, np.zeros(100, dtype=bool)], 1), 10)
    assert R[0].shape == (100, 2) and R[1].shape == (100, 0)
    assert np.allclose(R[0].T @ R[0], np.eye(2))
    assert np.allclose(R[0][:12, 0], 1.0 / np.sqrt(12.0)) and np.allclose(R[0][12:, 0], 0.0)


def stop_and_go_log(stops_s: list[tuple[float, float]], n: int = N):
    """A stand-in log (what ``twin.residuals.conditions`` reads): joint 0's target moves at 0.2 rad/s except
    during ``stops_s`` ((start, length) [s]); the other joints never move."""
    t = np.arange(n + 2) * PERIOD_S
    speed = np.full(n + 2, 0.2)
    for a, d in stops_s:
        speed[(t >= a) & (t < a + d)] = 0.0
    q = np.zeros((n + 2, 6))
    q[:, 0] = np.cumsum(speed) * PERIOD_S
    return SimpleNamespace(q_target_rad=q, period_s=PERIOD_S, temperature_C=None)


def test_a_stop_shorter_than_the_settling_time_gets_no_constant():
    """A 0.3 s pause (< 0.424 s) keeps its samples in the fit; a 1.0 s stop gets one constant; a joint still over
    the whole log gets one constant over all of it."""
    log = stop_and_go_log([(3.0, 0.3), (8.0, 1.0)])
    R = of_log(log, N, 1.5)
    assert R[0].shape[1] == 1
    on = np.flatnonzero(R[0][:, 0])
    # the stop's samples: its target speed at rest (np.gradient smears the edges by a sample)
    assert abs(on.size - 125) <= 2 and abs(on[0] * PERIOD_S - 8.0) <= 2 * PERIOD_S
    assert np.all(R[0][int(3.0 / PERIOD_S) : int(3.3 / PERIOD_S), 0] == 0.0)
    assert all(R[j].shape == (N, 1) for j in range(1, 6))


def test_an_offset_is_seen_in_motion_beside_the_held_currents():
    """One joint's current: a 4-sigma offset throughout, plus in each of eight 1.2 s stops a random held current
    (stiction: up to 40 sigma).  Judged beside the drift alone, the offset's estimate takes the held currents'
    mean share; with the held currents as a nuisance it is the offset, estimated from the samples in motion."""
    rng = np.random.default_rng(71)
    stops = [(1.0 + 2.4 * k, 1.2) for k in range(8)]
    log = stop_and_go_log(stops)
    hold = of_log(log, N, 1.5)
    assert hold[0].shape[1] == 8
    offset = 4.0
    held = rng.uniform(-40.0, 40.0, 8)
    at_rest = np.zeros(N)
    for k in range(8):
        at_rest[hold[0][:, k] > 0] = held[k]
    e = np.zeros((N, 12))
    e[:, 0] = offset + at_rest + rng.standard_normal(N)
    X = np.zeros((1, N, 12))
    X[0, :, 0] = 1.0
    cands, cols = [Col("offset", 0)], columns_of([Col("offset", 0)])

    plain = Drift(N, PERIOD_S, SIGNALS)
    Xp, ep = plain.remove(X), plain.remove(e)
    vp = judge(BlockGram.build(Xp, ep), ep, Xp, cands, cols, [], 0)
    # the plain drift is zero-mean, so the constant's estimate is the residual's mean: offset + the held share
    by_hand = offset + at_rest.mean()
    assert vp.theta[0] == pytest.approx(by_hand, abs=0.2)
    assert abs(vp.theta[0] - offset) > 1.0

    with_hold = Drift(N, PERIOD_S, SIGNALS, hold=hold)
    assert with_hold.dof == plain.dof + 8 + 5  # the eight stops; the five still joints one constant each
    Xh, eh = with_hold.remove(X), with_hold.remove(e)
    assert np.allclose(eh[:, 0], with_hold.remove(e - at_rest[:, None])[:, 0])  # the held currents leave nothing
    vh = judge(BlockGram.build(Xh, eh), eh, Xh, cands, cols, [], 0)
    assert vh.accepted, vh.reason
    # motion holds 2500 - 8 x 150 = 1300 samples of unit noise: the offset to within 4 / sqrt(1300) = 0.11
    assert vh.theta[0] == pytest.approx(offset, abs=0.15)


def test_a_joint_still_over_the_whole_log_has_no_identifiable_constant():
    """Held at rest throughout, an offset and the held current are one shape: the column vanishes."""
    hold = of_log(stop_and_go_log([]), N, 1.5)
    d = Drift(N, PERIOD_S, SIGNALS, hold=hold)
    X = np.zeros((1, N, 12))
    X[0, :, 3] = 1.0  # an offset on wrist_1, still
    assert np.allclose(d.remove(X)[0, :, 3], 0.0, atol=1e-9)


def test_the_weighted_removal_takes_the_held_currents_too():
    hold = of_log(stop_and_go_log([(2.0, 1.0)]), N, 1.5)
    d = Drift(N, PERIOD_S, SIGNALS, hold=hold)
    s = np.ones((N, 12))
    s[hold[0][:, 0] == 0, 0] = 5.0  # in motion five times the scale at rest
    e = np.zeros((N, 12))
    e[hold[0][:, 0] > 0, 0] = 7.0
    assert np.allclose(d.remove_weighted(e / s, s)[:, 0], 0.0, atol=1e-9)


def test_rest_hold_is_an_option_off_by_default():
    assert DiscrepancyModel().rest_hold is False
    assert DiscrepancyModel(rest_hold=True).rest_hold is True
    with pytest.raises(ParameterError, match="True or False"):
        DiscrepancyModel(rest_hold="yes")
