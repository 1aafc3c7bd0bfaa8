"""The effect ``motor_harmonic``: a rotor torque ``a sin(k th_M) + b cos(k th_M)`` periodic in the motor angle."""

import math

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.errors import ParameterError
from ur5fault.identify.ripple import MAX_RIPPLE_HZ
from ur5fault.sim.drive.motor import ripple_torque
from ur5fault.sim.params import load_params
from ur5fault.sim.run_arrays import build_run_arrays


def test_ripple_torque_is_the_written_formula():
    th = np.array([0.0, 0.3, 2.0, -1.1])
    got = ripple_torque(th, 0.0, 6.0, 0.01, -0.02, 3.0)
    want = [0.01 * math.sin(3 * t) - 0.02 * math.cos(3 * t) for t in th]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)
    # with the cogging effect's own term beside it
    np.testing.assert_allclose(ripple_torque(0.4, 0.05, 6.0, 0.0, 0.0, 1.0), 0.05 * math.sin(2.4), atol=1e-15)


def test_applier_adds_one_period_per_joint_and_refuses_a_second():
    p = load_params()
    a = build_run_arrays(p, [(make_effect("motor_harmonic", 4, sin_Nm=0.01, cos_Nm=0.0, periods_per_rev=3),
                              make_effect("motor_harmonic", 4, sin_Nm=0.002, cos_Nm=-0.004, periods_per_rev=3))], 0.0)
    np.testing.assert_allclose(a.motor_harmonic_Nm[0, 3], [0.012, -0.004])
    assert a.motor_harmonic_per_rev[0, 3] == 3.0 and not np.any(a.motor_harmonic_Nm[0, [0, 1, 2, 4, 5]])
    with pytest.raises(ParameterError, match="one period per joint"):
        build_run_arrays(p, [(make_effect("motor_harmonic", 4, sin_Nm=0.01, periods_per_rev=3),
                              make_effect("motor_harmonic", 4, sin_Nm=0.01, periods_per_rev=5))], 0.0)
    assert make_effect("motor_harmonic", 2, sin_Nm=0.0).is_absent


def test_the_speed_loop_answers_the_ripple_with_minus_T_over_Kt_of_current():
    """Closed loop, against the torque constant (not the code under test): while the joint moves with the ripple
    below ``identify``'s limit (5 Hz), the current's change against the healthy twin (same noise) is
    ``-(a sin + b cos)(k th_M) / K_t`` to within 10 %.  This is what ``identify`` relies on to turn a current
    ripple into the effect's torque."""
    p = load_params()
    a_Nm, b_Nm, k = 0.012, -0.006, 3.0
    runs = [RunSpec("h", 5), RunSpec("m", 5, (make_effect("motor_harmonic", 4, sin_Nm=a_Nm, cos_Nm=b_Nm,
                                                          periods_per_rev=k),))]
    res = Simulator(p).run(pick_and_place(), runs, log_period_s=0.008)
    assert res.status == ("ok", "ok")
    j = 3
    di = res["i_FB_A"][1][:, j] - res["i_FB_A"][0][:, j]
    th = res["q_M_rad"][1][:, j]
    qd = np.gradient(res["q_rad"][1][:, j], res.t_s)
    f_Hz = k * p.gear.ratio[j] * np.abs(qd) / (2 * np.pi)
    mv = (np.abs(qd) > 0.01) & (f_Hz <= MAX_RIPPLE_HZ)
    assert mv.sum() > 100
    X = np.column_stack([np.sin(k * th), np.cos(k * th), np.ones_like(th)])
    c = np.linalg.lstsq(X[mv], di[mv], rcond=None)[0]
    kt = p.motor.torque_constant_Nm_per_A[j]
    np.testing.assert_allclose(c[:2], [-a_Nm / kt, -b_Nm / kt], rtol=0.1)
