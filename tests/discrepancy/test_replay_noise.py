"""The scatter a finding's estimate gets from the model's own replays (``ur5fault/discrepancy/replay_noise.py``):
the RMS of estimates made here on residuals of known coefficients, and replays under other noise seeds that
differ from the workflow's own by the sensor noise alone."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.discrepancy.replay_noise import NULL_REPLAYS, null_residuals, null_seeds, replay_scatter, with_scatter
from ur5fault.logs import read_nist
from ur5fault.twin import LogReplay

from conftest import NIST_LOG

N = 3000


def _columns():
    """Two findings' columns on a (N, 12) residual: a one-coefficient shape on channel 0, a sine-cosine pair on
    channel 7."""
    t = np.arange(N) * 0.008
    X = np.zeros((3, N, 12))
    X[0, :, 0] = np.tanh(np.sin(2 * np.pi * t / 5.0) / 0.05)
    X[1, :, 7] = np.sin(2 * np.pi * t / 3.0)
    X[2, :, 7] = np.cos(2 * np.pi * t / 3.0)
    return X, [[0], [1, 2]]


def test_the_scatter_is_the_rms_of_the_estimates_about_zero():
    X, cols = _columns()
    thetas = np.array([[0.3, 1.0, -2.0], [-0.1, 0.5, 0.0], [0.2, -1.0, 2.0], [0.0, 0.5, 1.0]])
    nulls = [np.tensordot(th, X, axes=1) for th in thetas]  # noise-free: each null's estimate is its theta
    got = replay_scatter(X, nulls, cols)
    np.testing.assert_allclose(got[0], np.sqrt(np.mean(thetas[:, :1] ** 2, axis=0)), rtol=1e-9)
    np.testing.assert_allclose(got[1], np.sqrt(np.mean(thetas[:, 1:] ** 2, axis=0)), rtol=1e-9)
    # a bias counts: estimates that all read 0.2 scatter by 0.2 about zero, not by 0
    biased = replay_scatter(X, [np.tensordot([0.2, 0.0, 0.0], X, axes=1)] * 3, cols)
    assert biased[0] == pytest.approx([0.2])


def test_white_noise_scatters_as_the_least_squares_standard_error():
    X, cols = _columns()
    rng = np.random.default_rng(3)
    got = replay_scatter(X, [rng.normal(size=(N, 12)) for _ in range(400)], cols)
    # one column of unit noise: se = 1 / |x|
    assert got[0][0] == pytest.approx(1.0 / np.linalg.norm(X[0]), rel=0.1)


def test_fewer_than_two_replays_give_no_scatter_and_leave_the_standard_error():
    X, cols = _columns()
    assert replay_scatter(X, [np.zeros((N, 12))], cols) == [None, None]
    np.testing.assert_array_equal(with_scatter(np.array([0.3]), None), [0.3])
    np.testing.assert_allclose(with_scatter(np.array([0.3, 0.4]), np.array([0.4, 0.3])), [0.5, 0.5])


@pytest.fixture(scope="module")
def replay():
    return LogReplay(read_nist(NIST_LOG).window(10.0, 14.0), seed=11)


def test_a_replay_under_its_own_seed_is_the_workflows_replay(replay):
    before = replay.n_simulated
    own = replay.run([()], 200)[0]
    again = replay.run_seeds((), 200, [replay.seed])[0]
    np.testing.assert_array_equal(again.y, own.y)
    assert replay.n_simulated - before == 2


def test_replays_under_other_seeds_differ_from_it_by_the_sensor_noise(replay):
    own = replay.run([()], 200)[0]
    seeds = null_seeds(replay.seed)
    assert len(seeds) == NULL_REPLAYS and replay.seed not in seeds and len(set(seeds)) == NULL_REPLAYS
    nulls = null_residuals(replay, (), own.y, 200)
    assert len(nulls) == NULL_REPLAYS
    for e in nulls:
        assert e.shape == (200, len(replay.signals) * 6)
        # weighted by the sensor sigma: two independent noise streams differ by sqrt(2) sigma on the angle
        # reading; the current differs by more (1.5-1.9 here): the loops feed the noise back into the drive
        rms = np.sqrt(np.mean(e**2, axis=0))
        assert np.all((rms[6:] > 1.2) & (rms[6:] < 1.7)), rms
        assert np.all((rms[:6] > 1.3) & (rms[:6] < 2.5)), rms
    assert not np.array_equal(nulls[0], nulls[1])


def test_a_joint_fit_of_two_logs_replays_each_under_the_other_seeds():
    import dataclasses

    from ur5fault.discrepancy.multilog import MultiReplay

    log = read_nist(NIST_LOG)
    a, b = (dataclasses.replace(log.window(t, t + 2.0), source=f"part{t:.0f}.csv") for t in (10.0, 20.0))
    mr = MultiReplay([a], [b], 0.6, seed=11)
    own = mr.run([()], mr.n_samples)[0]
    again, other = mr.run_seeds((), mr.n_samples, [mr.seed, mr.seed + 1])
    np.testing.assert_array_equal(again.y, own.y)
    assert other.y.shape == own.y.shape and not np.array_equal(other.y, own.y)
    assert mr.n_simulated == 6  # two logs, three replays each


def _polished(theta: float, rng):
    """A polished fit of one finding (a Coulomb-like column on joint 0's current, 10 sensor sigmas per unit)
    whose residual is white noise: what ``judging.final_verdicts`` reads."""
    from ur5fault.discrepancy.candidates import LibraryCandidate
    from ur5fault.discrepancy.judging import Finding
    from ur5fault.discrepancy.refinement import Refined

    t = np.arange(N) * 0.008
    J = np.zeros((1, N, 12))
    J[0, :, 0] = 10.0 * np.tanh(np.sin(2 * np.pi * t / 5.0) / 0.05)
    e = rng.normal(size=(N, 12))  # what the finding at theta leaves
    cand = LibraryCandidate("coulomb_friction", 0, param="scale", x0=1.0, probe=1.5)
    return Refined(np.array([theta]), J, None, e, None, None, []), [Finding(cand, np.array([theta]),
                                                                            np.zeros(1), None)]


def test_the_final_check_drops_a_finding_within_its_replays_scatter_and_keeps_one_beyond_it():
    from ur5fault.discrepancy.judging import final_verdicts

    rng = np.random.default_rng(4)
    pol, kept = _polished(0.05, rng)
    n_fit = 2000
    quiet = [rng.normal(size=(n_fit, 12)) for _ in range(NULL_REPLAYS)]  # replays differing by sensor noise only
    assert final_verdicts(kept, pol, n_fit, nulls=quiet) == []
    f = kept[0]
    assert f.verdict.accepted and not f.within_scatter and f.verdict.z > 10 and 0 < f.replay_scatter[0] < 0.005
    assert final_verdicts(kept, pol, n_fit) == [] and f.replay_scatter is None  # without nulls: the jackknife alone
    se_jackknife = f.se.copy()
    # replays that scatter the estimate by 0.05 (their residuals hold the finding's own shape at +-0.05)
    loud = [e + s * pol.J[0, :n_fit] for e, s in zip(quiet, (0.05, -0.05, 0.05, -0.05))]
    failed = final_verdicts(kept, pol, n_fit, nulls=loud)
    assert failed == kept and f.within_scatter and not f.verdict.accepted
    assert f.replay_scatter[0] == pytest.approx(0.05, rel=0.05)
    assert f.se[0] == pytest.approx(np.hypot(se_jackknife[0], f.replay_scatter[0]), rel=1e-6)
    assert "with the scatter of its replays under other noise seeds" in f.verdict.reason


def test_a_finding_dropped_within_its_replays_scatter_frees_no_place_for_the_re_screen():
    from ur5fault.discrepancy.candidates import LibraryCandidate
    from ur5fault.discrepancy.judging import Finding
    from ur5fault.discrepancy.rescreen import freed_joints

    gone = Finding(LibraryCandidate("breakaway_friction", 0, param="scale", x0=1.0, probe=1.5), np.array([0.005]),
                   np.array([0.002]), None, kept=False, reason="within the scatter", within_scatter=True)
    other = Finding(LibraryCandidate("coulomb_friction", 2, param="scale", x0=1.0, probe=1.5), np.array([0.3]),
                    np.array([0.01]), None, kept=False, reason="does not generalise")
    assert freed_joints([gone], 1) == [] and freed_joints([gone, other], 1) == [2]
