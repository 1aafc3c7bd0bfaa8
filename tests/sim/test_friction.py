"""Eq. (2) of the paper read as an odd function of speed, with temperature; the smooth-sign law
and its implicit application."""

import numpy as np
import pytest

from ur5fault.sim.drive.friction import (
    friction_as_printed,
    friction_torque,
    implicit_speed,
    steady_friction,
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


def test_smooth_law_tends_to_the_exact_sign_law():
    w = np.array([-0.5, -0.02, 0.02, 0.5])
    np.testing.assert_allclose(tf(w), steady_friction(w, TC, TS, FV, RATE), rtol=1e-9)


def test_slope_is_the_secant():
    w = np.array([-0.3, -1e-3, 2e-4, 0.05, 1.0])
    torque, slope = friction_torque(w, TC, TS, FV, RATE, EPS)
    np.testing.assert_allclose(slope, torque / w, rtol=1e-12)
    assert friction_torque(0.0, TC, TS, FV, RATE, EPS)[1] == pytest.approx(TS / EPS + FV)


def _creep(load, inertia, dt, t_end=0.05):
    w = 0.0
    for _ in range(int(t_end / dt)):
        torque, slope = friction_torque(w, TC, TS, FV, RATE, EPS)
        w = float(implicit_speed(w, load, torque, slope, inertia, dt))
    return w


@pytest.mark.parametrize("inertia", [1e-4, 1e-2, 2.0])
def test_implicit_step_creeps_at_the_physical_speed_for_any_step(inertia):
    """A load below T_s makes the smooth law creep at the speed where T_f(w) = load.  Solved with
    the load included (as MuJoCo's implicit joint damping does), every step and inertia finds it;
    the former correction T_f / (1 + S dt / M), which left the load out, let a 1e-4 kg*m^2 link
    slide at 0.1-0.3 rad/s depending on the step (the wrists' ill-conditioning)."""
    load = 0.6 * TS
    lo, hi = 0.0, 1.0  # reference: bisection of T_f(w) = load
    for _ in range(200):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if tf(mid) < load else (lo, mid)
    for dt in (5e-5, 2.5e-5, 1e-5):
        assert _creep(load, inertia, dt) == pytest.approx(lo, rel=1e-6)


def test_implicit_step_never_reverses_the_motion_by_itself():
    # unloaded, a few smoothing widths above rest on a light link: the speed decays to 0 without changing sign
    w = 5 * EPS
    for _ in range(100):
        torque, slope = friction_torque(w, TC, TS, FV, RATE, EPS)
        w_new = float(implicit_speed(w, 0.0, torque, slope, 1e-4, 5e-5))
        assert 0.0 <= w_new <= w and (w_new < w or w == 0.0)
        w = w_new


def test_friction_share_decides_what_the_gear_carries():
    """At constant speed the base joint (no gravity torque) needs only its friction: all of it on the link,
    the gear carries it; all of it on the rotor (before the clearance), the gear carries nothing."""
    from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
    from ur5fault.sim.params import load_params

    runs = [RunSpec(f"s{s}", 0, (make_effect("friction_share", 1, motor_side_share=s),)) for s in (0.0, 1.0)]
    res = Simulator().run(pick_and_place(), runs, duration_s=5.6)
    cruise = (res.t_s > 4.0) & (res.t_s < 5.5)  # the base at its constant 0.3 rad/s of the first move
    qd = np.gradient(res.q_set_rad[:, 0], res.t_s)
    assert np.all(np.abs(qd[cruise] - qd[cruise].mean()) < 1e-3) and abs(qd[cruise].mean()) > 0.2
    t_f = res["T_f_Nm"][:, cruise, 0].mean(axis=1)
    t_gear = res["T_gear_Nm"][:, cruise, 0].mean(axis=1)
    f, v = load_params().friction, abs(qd[cruise].mean())  # at the 28 degC reference temperature
    tc, ts, fv = f.coulomb_Nm[0], f.static_Nm[0], f.viscous_Nms_per_rad[0]
    steady = np.sign(qd[cruise].mean()) * ((ts - tc) * (1 - np.tanh(10 * v)) + tc + fv * v)  # eq. (2), read odd
    np.testing.assert_allclose(t_f, steady, rtol=0.01)  # both sides apply eq. (2) at speed
    assert t_gear[0] == pytest.approx(steady, rel=0.05)
    assert abs(t_gear[1]) < 0.05 * abs(steady)


def test_load_levels_add_coeff_times_the_magnitude_of_the_gear_torque():
    from ur5fault.sim.drive.friction import load_levels

    tau = np.array([-40.0, 0.0, 25.0])
    tc, ts = load_levels(TC, TS, 0.05, tau)
    np.testing.assert_allclose(tc, TC + 0.05 * np.array([40.0, 0.0, 25.0]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(ts - tc, TS - TC, rtol=0, atol=1e-12)  # static excess unchanged
    tc0, ts0 = load_levels(TC, TS, 0.0, tau)  # absent: the levels exactly as they were
    assert np.all(tc0 == TC) and np.all(ts0 == TS)


@pytest.mark.slow
def test_load_friction_at_constant_speed_grows_linearly_with_the_gear_torque():
    """The whole chain (compiled path): on the shoulder's constant-speed samples of the pick-and-place, the friction
    with ``load_friction`` minus the friction without it is ``coeff * |T_gear|`` (the LuGre law's steady state with
    its Coulomb level raised by that much; speeds far above the Stribeck range, so g = T_c + coeff |T_gear|)."""
    from ur5fault import RunSpec, Simulator, make_effect, pick_and_place

    coeff = 0.08
    res = Simulator().run(pick_and_place(), [RunSpec("h", 0), RunSpec("l", 0, (make_effect(
        "load_friction", "shoulder_lift_joint", coeff=coeff),))], duration_s=8.0)
    assert res.status == ("ok", "ok")
    j = 1
    q = res["q_rad"][:, :, j]
    dt = np.diff(res.t_s[:2])[0]
    w = np.gradient(q, dt, axis=1)
    a = np.gradient(w, dt, axis=1)
    sel = (np.abs(w[1]) > 0.3) & (np.abs(a[1]) < 0.05) & (np.abs(w[0] - w[1]) < 1e-3)
    assert sel.sum() > 50
    d_tf = (res["T_f_Nm"][1, :, j] - res["T_f_Nm"][0, :, j])[sel]
    load = np.abs(res["T_gear_Nm"][1, :, j])[sel]
    assert np.ptp(load) > 5.0  # the load varies, so the slope is tested, not one point
    slope, icpt = np.polyfit(load, np.sign(w[1, sel]) * d_tf, 1)
    assert slope == pytest.approx(coeff, rel=0.03)
    assert abs(icpt) < 0.02 * coeff * load.mean() + 0.05
