"""A dropped finding gives its joint's place back (``ur5fault/discrepancy/rescreen.py``): on a linearised
problem made here, the joint whose finding was dropped gets the library effect its residual holds, and a joint
whose place is still taken gets nothing."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.discrepancy.judging import Finding
from ur5fault.discrepancy.rescreen import freed_joints, indistinguishable_held_out, select_on_freed
from ur5fault.discrepancy.search import columns_of
from ur5fault.discrepancy.statistics import effective_n

N = 4000


def _problem(seed: int = 3):
    """Columns on one signal x 6 joints: a Coulomb-like shape and an offset on joint 0, an offset on joint 1;
    the residual holds 0.8 x the Coulomb shape on joint 0 and white noise of unit sigma everywhere."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) * 0.008
    speed = np.sin(2 * np.pi * t / 7.0) + 0.3 * np.sin(2 * np.pi * t / 2.3)
    cands = [LibraryCandidate("coulomb_friction", 0, param="scale", x0=1.0, probe=1.5),
             LibraryCandidate("current_sensor_offset", 0, param="offset_A", x0=0.0, probe=0.1),
             LibraryCandidate("current_sensor_offset", 1, param="offset_A", x0=0.0, probe=0.1)]
    X = np.zeros((3, N, 6))
    X[0, :, 0] = 20.0 * np.tanh(speed / 0.05)
    X[1, :, 0] = 10.0
    X[2, :, 1] = 10.0
    e = rng.normal(size=(N, 6))
    e[:, 0] += 0.8 * X[0, :, 0]
    return cands, X, e


def _finding(c, kept: bool) -> Finding:
    return Finding(c, np.array([0.1]), np.array([0.01]), None, kept=kept, reason="" if kept else "dropped")


def test_the_joint_of_a_dropped_finding_gets_its_place_back_and_the_effect_is_named():
    cands, X, e = _problem()
    viscous = LibraryCandidate("viscous_friction", 0, param="scale", x0=1.0, probe=1.5)
    findings = [_finding(viscous, kept=False), _finding(cands[2], kept=True)]
    assert freed_joints(findings, 1) == [0]
    chosen, _ = select_on_freed(X, e, cands, columns_of(cands), findings, max_effects=1)
    assert [k for k, _ in chosen] == [0]
    assert chosen[0][1][0] == pytest.approx(0.8, rel=0.05)


def test_a_joint_whose_place_is_taken_gets_nothing():
    cands, X, e = _problem()
    viscous = LibraryCandidate("viscous_friction", 0, param="scale", x0=1.0, probe=1.5)
    # the same residual, but joint 0's finding is kept: its budget of one is spent
    findings = [_finding(viscous, kept=True), _finding(cands[2], kept=True)]
    assert freed_joints(findings, 1) == []
    assert select_on_freed(X, e, cands, columns_of(cands), findings, max_effects=1)[0] == []
    # with a budget of two, the kept finding leaves a place
    assert [k for k, _ in select_on_freed(X, e, cands, columns_of(cands), findings + [_finding(cands[1], False)],
                                          max_effects=2)[0]] == [0]


def test_a_dropped_effect_is_not_offered_again():
    cands, X, e = _problem()
    findings = [_finding(cands[0], kept=False)]
    chosen, trace = select_on_freed(X, e, cands, columns_of(cands), findings, max_effects=1)
    assert all(k != 0 for k, _ in chosen)
    assert all(v.label != cands[0].label for v in trace)


def test_a_dropped_robot_wide_finding_frees_every_joint_with_a_place():
    cands, _, _ = _problem()
    payload = LibraryCandidate("payload", None, param="mass_kg", x0=0.0, probe=0.5)
    # joint 1 keeps its offset (its budget of one is spent); the payload acted on every joint and is dropped
    findings = [_finding(payload, kept=False), _finding(cands[2], kept=True)]
    assert freed_joints(findings, 1) == [None, 0, 2, 3, 4, 5]


def test_the_held_out_part_tells_a_rival_apart_only_beyond_the_naming_bar():
    """Two held-out residuals of white unit noise (n_eff = n): a rival that leaves an extra constant c on the
    joint's channel raises the residual sum by n c^2, i.e. n log(1 + c^2) in effective samples; the bar is 10."""
    rng = np.random.default_rng(5)
    n = 2000
    e = rng.normal(size=(n, 1))
    e -= e.mean()
    e /= np.sqrt(np.mean(e**2))  # exactly unit RMS, zero mean: rss = n
    # n log(1 + c^2) = 10 at c^2 = exp(10 / n) - 1; a little below and above it
    c_bar = np.sqrt(np.exp(10.0 / n) - 1.0)
    n_eff = effective_n(e)
    assert n_eff == pytest.approx(n, rel=0.1)  # white noise: (nearly) no autocorrelation discount
    below, above = 0.5 * c_bar * np.sqrt(n / n_eff), 2.0 * c_bar * np.sqrt(n / n_eff)
    assert indistinguishable_held_out(e, e + below)
    assert not indistinguishable_held_out(e, e + above)
    # a rival that fits the held-out part better is never the worse one
    assert indistinguishable_held_out(e + above, e)
