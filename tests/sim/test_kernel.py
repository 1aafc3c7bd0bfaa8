"""The compiled drive kernel (fast path) against the numpy reference modules.

They cannot agree bit for bit: libm's tanh and numpy's vectorised tanh differ in the last bit.
So: one step from identical random states agrees to rounding, and over whole runs (noise and
quantisation on) the two differ by no more than the model itself moves when one parameter is
changed by a relative 1e-12 (a self-perturbation baseline: a well-conditioned model amplifies
last-bit differences no more than that; an ill-conditioned one would make both large).
"""

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.sim.drive.state import MEMO_NAMES, PI, STATE_NAMES, XI, NumbaDrive, NumpyDrive, initial_state, pack_params
from ur5fault.sim.params import load_params
from ur5fault.sim.run_arrays import build_run_arrays


@pytest.fixture(scope="module")
def packed():
    sim = Simulator()
    effects = [(), (make_effect("backlash", 2, backlash_deg=0.1),), (make_effect("cogging", 3, amplitude_Nm=0.05),),
               (make_effect("current_sensor_gain", 4, gain=1.1), make_effect("torque_constant", 2, scale=0.8),
                make_effect("motor_harmonic", 5, sin_Nm=0.01, cos_Nm=-0.02, periods_per_rev=3))]
    a = build_run_arrays(sim.params, effects, 2.0)
    P = pack_params(sim.params, sim.gains, a)
    # both friction laws, LuGre with bristle damping, friction on both sides of the gear
    rng = np.random.default_rng(99)
    P[PI["lugre"]] = rng.integers(0, 2, P[PI["lugre"]].shape)
    P[PI["sigma0"]] = rng.uniform(1e3, 1e5, P[PI["sigma0"]].shape)
    P[PI["sigma1"]] = rng.uniform(0.0, 50.0, P[PI["sigma1"]].shape)
    P[PI["share"]] = rng.uniform(0.0, 1.0, P[PI["share"]].shape)
    P[PI["share"]][:, :2] = 0.0  # all on the link: the kernel skips the motor side
    P[PI["load_fric"]] = rng.uniform(0.0, 0.3, P[PI["load_fric"]].shape)  # load-dependent friction ...
    P[PI["load_fric"]][:, 3] = 0.0  # ... and without it (the kernel's memo in use)
    return sim, P


def random_state(P, rng):
    n = P.shape[1]
    q = rng.uniform(-2, 2, (n, 6))
    X = initial_state(P, q, rng.uniform(-30, 30, (n, 6)))
    X += rng.normal(0, 1e-3, X.shape) * (np.abs(X) + 1e-2)
    for row in ("z_l", "z_m"):  # bristles within their range |z| <= T_s / sigma0
        X[XI[row]] = rng.uniform(-1, 1, q.shape) * P[PI["t_static"]] / P[PI["sigma0"]]
    return X, q


@pytest.mark.parametrize("seed", range(5))
def test_one_step_agrees_to_rounding(packed, seed):
    sim, P = packed
    rng = np.random.default_rng(seed)
    X0, q = random_state(P, rng)
    qd = rng.normal(0, 0.3, q.shape)
    qd[0, :2] = [1e-4, -3e-4]  # inside the smooth sign
    qd[1, :2] = 0.0  # at rest
    nz = rng.standard_normal((q.shape[0], 5, 6))
    q_set, qd_set = q + 1e-3, rng.normal(0, 0.5, q.shape)
    outs = []
    for cls in (NumpyDrive, NumbaDrive):
        d = cls(P, X0.copy(), 5e-5, 1e-4, 10.0)
        d.servo(q_set, qd_set, nz)
        tau = d.physics(q, qd).copy()
        d.sensors(q + 1e-5, qd * 0.9 + 1e-4)
        outs.append((d.X.copy(), tau))
    (xa, ta), (xb, tb) = outs
    np.testing.assert_allclose(tb, ta, rtol=1e-12, atol=1e-12)
    for i, name in enumerate(STATE_NAMES):
        if name in MEMO_NAMES:  # the kernel's memo, not model state
            continue
        np.testing.assert_allclose(xb[i], xa[i], rtol=1e-12, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("duration_s", [1.0, pytest.param(None, marks=pytest.mark.slow)], ids=["1s", "whole_run"])
def test_runs_agree_within_the_self_perturbation_baseline(duration_s):
    p = load_params()
    nudged = load_params(overrides={"friction": {"coulomb_Nm": [c * (1 + 1e-12) for c in p.friction.coulomb_Nm]}})
    runs = [RunSpec("h", 3), RunSpec("b", 3, (make_effect("backlash", 2, backlash_deg=0.1),)),
            RunSpec("m", 3, (make_effect("motor_harmonic", 4, sin_Nm=0.012, cos_Nm=-0.008, periods_per_rev=4),
                             make_effect("motor_harmonic", 2, sin_Nm=0.02, cos_Nm=0.01, periods_per_rev=3))),
            RunSpec("l", 3, (make_effect("load_friction", 2, coeff=0.1), make_effect("load_friction", 3, coeff=0.05)))]
    ref = Simulator(p, drive="numpy").run(pick_and_place(), runs, duration_s=duration_s)
    fast = Simulator(p, drive="numba").run(pick_and_place(), runs, duration_s=duration_s)
    base = Simulator(nudged, drive="numba").run(pick_and_place(), runs, duration_s=duration_s)
    assert ref.status == fast.status == base.status == ("ok",) * 4
    for s in ("q_rad", "q_FB_rad", "i_q_A", "i_FB_A", "T_gear_Nm", "T_f_Nm"):
        kernel = np.max(np.abs(fast[s] - ref[s]), axis=(0, 1))  # per joint
        baseline = np.max(np.abs(base[s] - fast[s]))
        print(f"{s}: kernel vs numpy per joint {np.array2string(kernel, precision=2)}, baseline {baseline:.2e}")
        assert np.all(kernel <= 10 * baseline), s


def test_row_tables_consistent():
    assert len(set(PI.values())) == len(PI) and len(set(XI.values())) == len(XI)
