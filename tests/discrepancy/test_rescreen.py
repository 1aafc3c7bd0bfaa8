"""A dropped finding gives its joint's place back (``ur5fault/discrepancy/rescreen.py``): on a linearised
problem made here, the joint whose finding was dropped gets the library effect its residual holds, and a joint
whose place is still taken gets nothing."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.discrepancy.judging import Finding
from ur5fault.discrepancy.rescreen import freed_joints, select_on_freed
from ur5fault.discrepancy.search import columns_of

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
