"""The twin features' commanded motion built once and shared by a batch's runs (ur5fault/health/twin_features.py,
``commanded_motion``): the features of every run are bit for bit those computed from scratch, whichever run the
shared motion served before; a motion of another length is refused.  Synthetic signals, no simulation."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.health.twin_features import commanded_motion, twin_features
from ur5fault.health.twin_fit import com_columns, flange_kinematics
from ur5fault.sim.params import load_params
from ur5fault.twin.residuals import command_conditions, motion_conditions

N = 1500
DT = 1e-3


def _motion():
    t = (np.arange(N) + 1) * DT
    phase = np.linspace(0.0, 1.0, 6)
    q = 0.6 * np.sin(2 * np.pi * 0.8 * t[:, None] + phase) + np.array([0.0, -1.2, 1.4, -1.6, -1.5, 0.3])
    held = (t > 0.3) & (t < 1.2)
    return t, q, held


def _run(rng, scale):
    """A synthetic run and its twin: twin signals smooth, the run's with noise and an offset on joint 3."""
    t, q, _ = _motion()
    i_q = scale * np.cos(2 * np.pi * 0.8 * t[:, None] + np.arange(6))
    torque = 40.0 * i_q
    twin = {"q_FB_rad": q + 1e-5 * rng.standard_normal((N, 6)), "q_M_FB_rad": 101.0 * q,
            "i_FB_A": i_q + 0.012 * rng.standard_normal((N, 6)), "i_q_A": i_q, "T_gear_Nm": torque}
    meas = {"q_FB_rad": q + 1e-5 * rng.standard_normal((N, 6)), "q_M_FB_rad": 101.0 * q + 1e-4,
            "i_FB_A": i_q + 0.012 * rng.standard_normal((N, 6)) + np.array([0, 0, 0.1, 0, 0, 0])}
    return meas, twin


def _same(a: dict, b: dict) -> bool:
    return list(a) == list(b) and all(a[k] == b[k] or (np.isnan(a[k]) and np.isnan(b[k])) for k in a)


@pytest.mark.parametrize("payload_kg", [0.0, 1.5])
def test_shared_motion_gives_the_features_computed_from_scratch(payload_kg):
    params = load_params()
    t, q, held = _motion()
    rng = np.random.default_rng(7)
    runs = [_run(rng, s) for s in (1.0, 0.5, 2.0)]
    motion = commanded_motion(t, q, params)
    shared = [twin_features(t, q, m, tw, params, payload_kg, held, motion) for m, tw in runs]
    alone = [twin_features(t, q, m, tw, params, payload_kg, held) for m, tw in runs]
    assert all(_same(a, b) for a, b in zip(shared, alone))
    assert not _same(shared[0], shared[1])  # the runs differ: the comparison is not of one run with itself


def test_a_motion_of_another_length_is_refused():
    params = load_params()
    t, q, held = _motion()
    meas, twin = _run(np.random.default_rng(1), 1.0)
    other = commanded_motion(t[:-10], q[:-10], params)
    with pytest.raises(ValueError, match="commanded motion of shape"):
        twin_features(t, q, meas, twin, params, 1.0, held, other)


def test_command_conditions_are_the_motion_conditions_without_the_load():
    t, q, _ = _motion()
    qd = np.gradient(q, DT, axis=0)
    qdd = np.gradient(qd, DT, axis=0)
    torque = np.cos(3 * t)[:, None] * np.arange(1, 7)
    full = motion_conditions(qd, qdd, torque, DT)
    cmd = command_conditions(qd, qdd, DT)
    assert list(full) == [*cmd, "under high load"]
    assert all(np.array_equal(full[k], cmd[k]) for k in cmd)
    assert cmd["near velocity reversals"].any() and cmd["at speed"].any()  # the motion reverses: masks not empty


def test_com_columns_from_given_kinematics_equal_their_own():
    params = load_params()
    t, q, held = _motion()
    kin = flange_kinematics(q)
    calls = []

    def given():
        calls.append(1)
        return kin

    a = com_columns(q, 2.0, params, held, given)
    assert np.array_equal(a, com_columns(q, 2.0, params, held)) and calls == [1]
    assert not np.any(com_columns(q, 0.0, params, held, given)) and calls == [1]  # no payload: not asked for
    with pytest.raises(ValueError, match="kinematics of"):
        com_columns(q, 2.0, params, held, lambda: flange_kinematics(q[:-1]))


def test_coulomb_column_is_zero_at_rest_and_the_friction_level_while_moving():
    """A resting target's speed is rounding (~1e-8 rad/s) whose sign is noise: the column held a full friction level
    of random sign on resting samples.  At rest it is 0; moving, sign(w) times the static/Coulomb level over K_t N
    (eq. (2)'s level at 0.5 rad/s written out from the packaged parameters)."""
    params = load_params()
    t = (np.arange(N) + 1) * DT
    q = np.full((N, 6), 0.3) + 1e-9 * np.random.default_rng(3).standard_normal((N, 6))  # at rest, rounding jitter
    q[N // 2 :, 1] += -0.5 * (t[N // 2 :] - t[N // 2])  # joint 2 moves at -0.5 rad/s in the second half
    motion = commanded_motion(t, q, params)
    col = motion.i_coulomb_A
    assert np.all(col[: N // 2 - 2] == 0.0)  # everything at rest in the first half
    assert np.all(col[:, [0, 2, 3, 4, 5]] == 0.0)
    fr, mo = params.friction, params.motor
    level = fr.coulomb_Nm[1] + (fr.static_Nm[1] - fr.coulomb_Nm[1]) * (1.0 - np.tanh(0.5 * fr.stribeck_rate_s_per_rad))
    expect = -level / (mo.torque_constant_Nm_per_A[1] * params.gear.ratio[1])
    np.testing.assert_allclose(col[N // 2 + 5 : -5, 1], expect, rtol=1e-9)
