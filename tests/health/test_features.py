"""Health features on synthetic signals with known answers."""

import numpy as np
import pytest

from ur5fault.health.features import FEATURE_UNITS, moving_average, run_features, sign_changes

DT = 1e-3


def test_moving_average_of_constant_and_ramp():
    x = np.ones((100, 2))
    np.testing.assert_allclose(moving_average(x, 20), 1.0)
    r = np.arange(100.0)[:, None]
    np.testing.assert_allclose(moving_average(r, 21)[30:70, 0], r[30:70, 0])


def test_sign_changes_with_hysteresis():
    x = np.array([1.0, 0.5, 0.05, -0.05, 0.05, -0.5, -1.0, 1.0])
    assert sign_changes(x, 0.1).tolist() == [5, 7]


def synthetic(jump=0.0, spike=0.0, n=4000):
    t = np.arange(n) * DT
    q_set = np.zeros((n, 6))
    q_fb = np.zeros((n, 6))
    ratio = np.full(6, 101.0)
    q_m = np.zeros((n, 6))
    i = np.zeros((n, 6))
    i[:, 1] = np.tanh((t - 2.0) / 0.1)  # a smooth current (torque) reversal at t = 2 s on joint 2
    q_m[:, 1] = np.where(t < 2.0, 0.0, jump) * 101.0  # mismatch jumps by `jump` at the reversal
    k = int(2.0 / DT) + 5
    i[k, 1] += spike
    tcp = np.zeros((n, 3))
    return t, q_set, q_fb, q_m, i, ratio, tcp


def test_hysteresis_width_and_spike_are_measured():
    t, qs, qf, qm, i, ratio, tcp = synthetic(jump=1.7e-3, spike=0.8)
    f = run_features(t, qs, qf, qm, i, ratio, tcp, tcp, tcp + np.array([0.0, 0.0, 1e-3]))
    assert f["enc_mismatch_hyst_rad_j2"] == pytest.approx(1.7e-3)
    assert f["enc_mismatch_p2p_rad_j2"] == pytest.approx(1.7e-3)
    assert f["current_spike_max_A_j2"] == pytest.approx(0.8, rel=0.1)
    assert f["current_spike_count_j2"] == 1.0
    assert f["current_spike_count_j1"] == 0.0
    assert f["tcp_dev_max_mm"] == pytest.approx(1.0)
    assert f["current_crest_j2"] > 10  # one spike on a quiet signal


def test_no_twin_no_deviation_feature_and_units_cover_all():
    t, qs, qf, qm, i, ratio, tcp = synthetic()
    f = run_features(t, qs, qf, qm, i, ratio, tcp, tcp, None)
    assert "tcp_dev_max_mm" not in f
    f = run_features(t, qs, qf, qm, i, ratio, tcp, tcp, tcp)
    assert set(f) == set(FEATURE_UNITS)
