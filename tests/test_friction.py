"""Eq. (2) of the paper read as an odd function of speed, with temperature."""

import numpy as np
import pytest

from ur5fault.drive.friction import (
    friction_as_printed,
    friction_torque,
    implicit_friction,
    viscous_coefficient,
)

TC, TS, FV, RATE, EPS = 6.8, 8.2, 19.9, 10.0, 1e-3


def tf(w, fv=FV):
    return friction_torque(w, TC, TS, fv, RATE, EPS)[0]


def test_odd_symmetry():
    w = np.linspace(0.0, 3.0, 301)
    np.testing.assert_allclose(tf(-w), -tf(w), rtol=0, atol=1e-12)
    assert tf(0.0) == 0.0


def test_printed_equation_is_not_odd():
    # the reason for the reading we implement: at rest it returns T_s whatever the direction
    assert friction_as_printed(0.0, TC, TS, FV) == pytest.approx(TS)
    assert friction_as_printed(-1.0, TC, TS, FV) != pytest.approx(-friction_as_printed(1.0, TC, TS, FV))


def test_static_value_at_breakaway():
    # the friction level (torque over the smooth sign, viscous part removed) tends to T_s at rest
    for w in (1e-7, -1e-7):
        level = (tf(w) - FV * w) / np.tanh(w / EPS)
        assert level == pytest.approx(TS, rel=1e-5)
    # and a few smoothing widths above zero the torque is within 1.5 % of T_s
    assert tf(5 * EPS) == pytest.approx(TS, rel=0.015)


def test_coulomb_plus_viscous_at_speed():
    w = 1.5  # tanh(15) ~ 1: the Stribeck excess has gone
    assert tf(w) == pytest.approx(TC + FV * w, rel=1e-9)


def test_viscous_slope():
    w1, w2 = 1.0, 2.0
    assert (tf(w2) - tf(w1)) / (w2 - w1) == pytest.approx(FV, rel=1e-6)


def test_stribeck_dip_between_static_and_coulomb():
    w = np.linspace(0.02, 0.5, 50)
    level = tf(w) - FV * w
    assert np.all(np.diff(level) < 0) and level[0] < TS and level[-1] > TC


def test_viscous_falls_with_temperature():
    temps = np.array([10.0, 25.0, 28.0, 40.0, 60.0])
    fv = viscous_coefficient(FV, 0.02, temps, 28.0)
    assert fv[2] == pytest.approx(FV)
    assert np.all(np.diff(fv) < 0)
    assert fv[3] == pytest.approx(FV * np.exp(-0.02 * 12.0))
    # the friction torque at speed falls with it
    assert tf(0.5, fv[-1]) < tf(0.5, fv[0])


def test_implicit_correction_vanishes_with_step_and_limits_near_zero():
    torque, slope = friction_torque(0.3, TC, TS, FV, RATE, EPS)
    assert implicit_friction(torque, slope, 0.5, 1e-9) == pytest.approx(torque, rel=1e-6)
    # near zero speed on a tiny inertia the explicit torque would reverse the motion many times
    # over in one step (unstable); the implicit one brings the speed close to zero (stable)
    w, m, dt = 1e-4, 1e-4, 5e-5
    torque, slope = friction_torque(w, TC, TS, FV, RATE, EPS)
    assert abs(w - torque * dt / m) > 100 * w
    applied = implicit_friction(torque, slope, m, dt)
    assert abs(w - applied * dt / m) < 0.05 * w
