"""Sensor chain: filters (DC gain, ramp, bandwidth), noise, quantisation."""

import numpy as np
import pytest

from ur5fault.sim.drive import sensors

DT = 5e-5


def run_second_order(u_fn, n, f=2000.0, z=0.7):
    c = sensors.second_order_coefficients([f], z, DT)
    y = dy = np.zeros(1)
    u_prev = np.array([u_fn(0)])
    out = []
    for k in range(1, n + 1):
        u = np.array([u_fn(k * DT)])
        y, dy = sensors.second_order_step(y, dy, u_prev, u, c)
        u_prev = u
        out.append((y[0], dy[0]))
    return np.array(out)


def test_second_order_unit_dc_gain_and_exact_ramp_slope():
    out = run_second_order(lambda t: 1.0, 4000)
    assert out[-1, 0] == pytest.approx(1.0, abs=1e-9)
    out = run_second_order(lambda t: 3.0 * t, 4000)
    assert out[-1, 1] == pytest.approx(3.0, rel=1e-6)  # speed estimate unbiased on a ramp
    assert out[-1, 0] == pytest.approx(3.0 * 4000 * DT - 3.0 * 2 * 0.7 / (2 * np.pi * 2000), rel=1e-6)


def test_second_order_attenuates_at_bandwidth_like_the_continuous_filter():
    f, z = 2000.0, 0.7
    n = 20000
    out = run_second_order(lambda t: np.sin(2 * np.pi * f * t), n, f, z)
    t = np.arange(1, n + 1)[-4000:] * DT
    basis = np.c_[np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)]
    amp = np.hypot(*np.linalg.lstsq(basis, out[-4000:, 0], rcond=None)[0])
    # |H(j wn)| = 1 / (2 zeta), times the first-order hold's own gain on a sampled sine, sinc^2(f dt)
    assert amp == pytest.approx(1 / (2 * z) * np.sinc(f * DT) ** 2, rel=1e-3)


def test_first_order_exact_for_step_and_ramp():
    f = 5000.0
    c = sensors.first_order_coefficients([f], DT)
    assert c[0, 0] == pytest.approx(np.exp(-2 * np.pi * f * DT))
    y, u = np.zeros(1), np.zeros(1)
    for k in range(1, 400):
        un = np.array([2.0 * k * DT])
        y = sensors.first_order_step(y, u, un, c)
        u = un
    tau = 1 / (2 * np.pi * f)
    assert y[0] == pytest.approx(2.0 * (399 * DT - tau), rel=1e-9)  # a ramp lags by exactly tau
    y = np.zeros(1)
    for _ in range(3):
        y = sensors.first_order_step(y, np.ones(1), np.ones(1), c)
    assert y[0] == pytest.approx(1 - np.exp(-3 * DT / tau), rel=1e-12)


def test_quantise():
    lsb = np.array([0.5, 0.0])
    np.testing.assert_array_equal(sensors.quantise(np.array([1.26, 1.26]), lsb), [1.5, 1.26])


def test_noise_statistics():
    rng = np.random.default_rng(1)
    z = rng.standard_normal(200000)
    r = sensors.read(np.zeros_like(z), 0.012, z, np.zeros_like(z))
    assert r.std() == pytest.approx(0.012, rel=0.01)
