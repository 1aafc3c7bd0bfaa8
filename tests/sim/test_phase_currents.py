"""A result's phase currents (ur5fault/sim/result.py, computed when first asked for): inverse Park/Clarke of the
logged d/q currents at the motor's electrical angle (pole pairs x motor angle), NaN on DC-equivalent joints.
Expected values by hand: i_a = i_d cos(th) - i_q sin(th), b and c at th -/+ 120 deg."""

from __future__ import annotations

import math

import numpy as np

from ur5fault.sim.result import SimResult


def _result(i_d: float, i_q: float, q_motor: float, pole_pairs: float) -> SimResult:
    shape = (1, 1, 6)
    signals = {"i_d_A": np.full(shape, i_d), "i_q_A": np.full(shape, i_q), "q_M_rad": np.full(shape, q_motor)}
    pmsm = np.array([[True, True, True, True, True, False]])
    return SimResult(t_s=np.array([1e-3]), q_set_rad=np.zeros((1, 6)), signals=signals, tcp_m=np.zeros((1, 1, 3)),
                     tcp_des_m=np.zeros((1, 1, 3)), motor_pole_pairs=np.full((1, 6), pole_pairs),
                     motor_is_pmsm=pmsm, run_ids=("r",), seeds=(0,), status=("ok",), reason=("",), effects=((),),
                     meta={})


def test_phase_currents_by_hand():
    # 2 pole pairs at a motor angle of pi/4: electrical angle pi/2; i_q = 1 A only
    res = _result(0.0, 1.0, math.pi / 4, 2.0)
    ph = res.phase_currents_A
    assert ph.shape == (1, 1, 6, 3)
    np.testing.assert_allclose(ph[0, 0, 0], [-1.0, 0.5, 0.5], atol=1e-12)
    assert np.all(np.isnan(ph[0, 0, 5]))  # DC-equivalent joint
    # i_d = 2 A only, electrical angle 0: the a phase carries it, b and c -1 A each
    np.testing.assert_allclose(_result(2.0, 0.0, 0.0, 4.0).phase_currents_A[0, 0, 2], [2.0, -1.0, -1.0], atol=1e-12)


def test_phase_currents_are_computed_once():
    res = _result(0.0, 1.0, 0.3, 2.0)
    assert res.phase_currents_A is res.phase_currents_A
