"""The twin features' least-squares machinery (ur5fault/health/twin_fit.py).

Expected values come from outside the code under test: the t-statistic of a coefficient whose true value is
zero is standard normal (for white noise, and - with the Newey-West errors - for correlated noise too, where
the ordinary error would give a spread near sqrt((1 + rho) / (1 - rho))); the payload centre-of-mass columns
are checked against MuJoCo's own inverse dynamics (the gravity torque ``qfrc_bias`` of the model with the
payload's CoM moved), not against the cross products the module writes.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from ur5fault.health.twin_fit import RCOND_NUISANCE, bartlett_lag, com_columns, hac_fit, noise_scale
from ur5fault.sim.params import load_params
from ur5fault.sim.trajectories.ik import model_path


def _columns(rng: np.random.Generator, n: int) -> np.ndarray:
    t = np.linspace(0.0, 4.0, n)
    return np.stack([np.ones(n), np.sin(2.1 * t + rng.uniform(0, 6)), np.sign(np.sin(1.3 * t)),
                     rng.normal(size=n)], axis=1)


def _t_values(rho: float, n_rep: int = 300, n: int = 2000) -> np.ndarray:
    rng = np.random.default_rng(7)
    out = []
    for _ in range(n_rep):
        x = _columns(rng, n)
        e = rng.normal(size=n)
        if rho:
            for k in range(1, n):  # AR(1) noise of unit innovation
                e[k] += rho * e[k - 1]
        out.append(hac_fit(x[:, None, :], e[:, None]).t)
    return np.array(out)


def test_t_value_of_a_zero_coefficient_is_standard_normal_on_white_noise():
    t = _t_values(0.0)
    # 300 draws: the sample SD of N(0, 1) lies within 0.88-1.12 with probability > 0.999
    assert np.all(np.abs(t.std(axis=0) - 1.0) < 0.12), t.std(axis=0)
    assert np.all(np.abs(t.mean(axis=0)) < 4.0 / math.sqrt(300)), t.mean(axis=0)


def test_t_value_stays_near_unit_scale_on_correlated_noise():
    # AR(1) with rho = 0.5: ordinary standard errors would make the t spread sqrt(3) = 1.73 on the constant
    t = _t_values(0.5)
    assert t[:, 0].std() < 1.2, t.std(axis=0)
    assert t[:, 0].std() > 0.8


def test_known_coefficients_are_recovered_with_a_zero_column_left_out():
    rng = np.random.default_rng(1)
    n = 3000
    x = _columns(rng, n)
    x = np.concatenate([x, np.zeros((n, 1))], axis=1)
    y = x @ np.array([0.2, -1.5, 0.05, 3.0, 0.0]) + 0.01 * rng.normal(size=n)
    fit = hac_fit(x[:, None, :], y[:, None])
    # noise 0.01 on 3,000 samples: each coefficient within a few times 0.01 / sqrt(3000) * its column's scale
    assert fit.coef[:4] == pytest.approx([0.2, -1.5, 0.05, 3.0], abs=2e-3)
    assert fit.coef[4] == 0.0 and math.isnan(fit.se[4])
    assert np.all(fit.se[:4] < 1e-3)


def test_rows_with_nan_are_left_out_and_all_nan_gives_nothing():
    rng = np.random.default_rng(2)
    x = _columns(rng, 500)
    y = x @ np.array([1.0, 2.0, 0.0, 0.0])
    y[::7] = np.nan
    assert hac_fit(x[:, None, :], y[:, None]).coef[:2] == pytest.approx([1.0, 2.0], abs=1e-9)
    empty = hac_fit(x[:, None, :], np.full((500, 1), np.nan))
    assert np.all(empty.coef == 0) and np.all(np.isnan(empty.se))


def test_noise_scale_reads_white_noise_under_a_smooth_signal():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 4, 4000)[:, None]
    r = 0.5 * np.sin(3 * t) + 0.02 * rng.normal(size=(4000, 2))
    assert noise_scale(r) == pytest.approx([0.02, 0.02], rel=0.1)


def test_bartlett_lag_rule():
    assert bartlett_lag(100) == 4  # 4 (100 / 100)^(2/9)
    assert bartlett_lag(4000) == 9  # 4 * 40^(2/9) = 9.0...


@pytest.mark.parametrize("q", [[0.3, -1.2, 1.5, -1.9, -1.57, 0.4], [1.0, -0.6, 0.7, -0.2, 0.9, -1.1]])
def test_com_columns_match_mujocos_gravity_torque(q):
    params = load_params()
    mass, delta = 2.5, np.array([0.02, -0.03, 0.05])
    m = mujoco.MjModel.from_xml_path(model_path())
    payload = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "payload")
    m.body_mass[payload] = mass
    m.body_sameframe[payload] = 0  # the compiler marks the CoM at the body origin: let body_ipos move it
    d = mujoco.MjData(m)

    def gravity(ipos):
        m.body_ipos[payload] = ipos
        d.qpos[:] = q
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        return d.qfrc_bias[:6].copy()  # the joint torque that holds the arm still

    dtau = gravity(delta) - gravity(np.zeros(3))
    expect_A = dtau / (np.asarray(params.motor.torque_constant_Nm_per_A) * np.asarray(params.gear.ratio))
    cols = com_columns(np.array([q]), mass, params)[0]  # (6, 3)
    assert cols @ delta == pytest.approx(expect_A, abs=1e-9)
    assert np.all(com_columns(np.array([q]), mass, params, held=np.array([False])) == 0)
    assert np.all(com_columns(np.array([q]), 0.0, params) == 0)


def test_a_nuisance_column_mixed_with_the_others_is_left_out_not_the_fault_columns():
    # a nuisance column that is the constant up to 1e-7 (a CoM torque that stays put in a window): with
    # rcond 1e-4 it is left out (it comes last) and the constant keeps its size; without it the two would
    # share an ill-determined split of the offset
    rng = np.random.default_rng(4)
    n = 2000
    t = np.linspace(0, 4, n)
    x = np.stack([np.ones(n), np.sin(2 * t), 1.0 + 1e-7 * rng.normal(size=n)], axis=1)
    y = 0.3 + 0.5 * np.sin(2 * t) + 0.01 * rng.normal(size=n)
    fit = hac_fit(x[:, None, :], y[:, None], RCOND_NUISANCE)
    assert fit.coef[:2] == pytest.approx([0.3, 0.5], abs=2e-3)
    assert fit.coef[2] == 0.0 and math.isnan(fit.se[2])


def test_a_column_that_is_a_scaled_constant_is_left_out_every_time():
    # the mismatch fit's flank column on a joint whose gear torque never reverses is +-0.5 throughout: the
    # constant column scaled. The data cannot tell the two apart, so the later one is not identified. Deciding
    # it on the normal matrix's eigenvalues at rcond 1e-8 (their ratio 1e-16, rounding's own size) kept 19 of
    # these 60 with a coefficient and a t value drawn from rounding
    rng = np.random.default_rng(0)
    for _ in range(60):
        n = int(rng.integers(2000, 14000))
        t = np.linspace(0.0, n / 1000.0, n)
        x = np.stack([np.ones(n), np.full(n, rng.choice([-0.5, 0.5])),
                      np.sin(rng.uniform(0.5, 3.0) * t) + 0.1 * rng.normal(size=n)], axis=1)
        y = 1e-6 * (0.3 + 0.5 * x[:, 2] + 0.1 * rng.normal(size=n))
        fit = hac_fit(x[:, None, :], y[:, None])
        assert fit.coef[1] == 0.0 and math.isnan(fit.se[1])
        assert fit.coef[[0, 2]] == pytest.approx([0.3e-6, 0.5e-6], abs=0.02e-6)


def test_a_column_apart_from_the_constant_in_one_sample_is_kept():
    # a flank column that differs from its constant at one reversal only still carries that sample: its smallest
    # singular value is ~sqrt(1/n) of the largest, far above rcond
    rng = np.random.default_rng(5)
    n = 5000
    t = np.linspace(0.0, 5.0, n)
    flank = np.full(n, 0.5)
    flank[2500] = -0.5
    x = np.stack([np.ones(n), flank, np.sin(t)], axis=1)
    y = 0.3 + 0.2 * flank + 0.5 * np.sin(t) + 0.001 * rng.normal(size=n)
    fit = hac_fit(x[:, None, :], y[:, None])
    assert np.all(np.isfinite(fit.se))
    # the flank coefficient rests on the one sample: within a few times its noise 0.001
    assert fit.coef == pytest.approx([0.3, 0.2, 0.5], abs=5e-3)
