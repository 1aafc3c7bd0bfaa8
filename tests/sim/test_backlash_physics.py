"""The paper's physics (sec. 3, Figs. 3-4) emerging from the model, not imposed on it.

Shoulder backlash 0.05, 0.1, 0.2 deg against the healthy twin (same noise seed) on the
2 kg pick-and-place.
"""

import numpy as np
import pytest

from conftest import torque_reversal_times

J = 1  # shoulder_lift_joint


def mismatch(res, i):
    """Motor-vs-joint encoder mismatch at the joint side [rad]: q_M,FB / N - q_FB."""
    return res["q_M_FB_rad"][i, :, J] / 101.0 - res["q_FB_rad"][i, :, J]


def test_all_runs_ok(shoulder_backlash_batch):
    _, res = shoulder_backlash_batch
    assert res.status == ("ok",) * 4


def test_encoder_mismatch_is_not_the_gear_ratio_alone_and_its_excursion_is_alpha(shoulder_backlash_batch):
    alphas, res = shoulder_backlash_batch
    healthy = np.ptp(mismatch(res, 0))  # gear wind-up under load (T / k) and noise
    for i, a in enumerate(alphas[1:], start=1):
        extra = np.ptp(mismatch(res, i)) - healthy
        assert extra == pytest.approx(np.radians(a), rel=0.15), f"alpha={a} deg"
        # the mismatch is not explained by the healthy gear wind-up: it jumps by alpha
        assert np.max(np.abs(mismatch(res, i) - mismatch(res, 0))) > 0.8 * np.radians(a)


def _spikes(res, i, reversals):
    t = res.t_s
    di = np.abs(res["i_FB_A"][i, :, J] - res["i_FB_A"][0, :, J])
    near = np.zeros_like(t, dtype=bool)
    for tr in reversals:
        near |= np.abs(t - tr) < 0.3
    return di, near


def test_current_spikes_at_torque_reversals_grow_with_alpha(shoulder_backlash_batch):
    alphas, res = shoulder_backlash_batch
    reversals = torque_reversal_times(res.t_s, res["T_gear_Nm"][0, :, J])
    assert len(reversals) >= 2  # the trajectory reverses the shoulder torque (gravity sign change)
    heights = []
    for i in range(1, len(alphas)):
        di, near = _spikes(res, i, reversals)
        heights.append(di[near].max())
        # the spikes sit at the reversals: away from them the current is the healthy one
        assert di[~near].max() < 0.1 * di[near].max()
    assert heights[0] > 10 * 0.012  # ten times the current-sensor noise sigma
    assert heights[0] < heights[1] < heights[2], f"spike heights {heights} must grow with alpha"


def test_tcp_deviation_grows_with_alpha(shoulder_backlash_batch):
    alphas, res = shoulder_backlash_batch
    dev = [np.nanmax(np.linalg.norm(res.tcp_m[i] - res.tcp_m[0], axis=-1)) for i in range(len(alphas))]
    assert dev[0] == 0.0
    assert dev[1] < dev[2] < dev[3]


def test_base_clearance_is_crossed_when_the_next_move_starts():
    """The base carries no gravity torque.  With friction that sticks, its link holds through the place
    dwell with the teeth on the flank they last pushed; when the return move starts the motor must first
    cross the whole clearance while the link stays put, so the link falls behind its healthy twin by
    most of alpha right then (the paper's > 0.5 mm TCP deviation for the base)."""
    from ur5fault import RunSpec, Simulator, make_effect, pick_and_place

    alpha = np.radians(0.1)
    runs = [RunSpec("h", 0), RunSpec("b", 0, (make_effect("backlash", 1, backlash_deg=0.1),))]
    res = Simulator().run(pick_and_place(), runs)
    t = res.t_s
    qd_set = np.gradient(res.q_set_rad[:, 0], t)
    moving = np.abs(qd_set) > 1e-3
    starts = t[1:][moving[1:] & ~moving[:-1]]
    lag = np.abs(res["q_rad"][1, :, 0] - res["q_rad"][0, :, 0])
    k = int(np.argmax(lag))
    reversing = [s for s in starts if np.sign(qd_set[np.searchsorted(t, s) + 50]) < 0]
    assert lag[k] > 0.5 * alpha  # 0.76 alpha (with the smooth sign, which creeps: 0.14 alpha, mid-dwell)
    assert any(0.0 <= t[k] - s < 0.5 for s in reversing), f"largest lag at t={t[k]:.2f} s, moves start {starts}"
    # through the dwell before it, the teeth stayed on the flank last pushed: theta_rel has not crossed half
    # of the clearance (measured: it stays above 0.90 alpha with the friction identified by `ur5fault identify`;
    # the smooth sign let it creep across to 0)
    th_rel = res["q_M_rad"][1, :, 0] / 101.0 - res["q_rad"][1, :, 0]
    s = max(x for x in reversing if x <= t[k])
    dwell = (t > s - 1.0) & (t < s)
    assert np.all(th_rel[dwell] > 0.5 * alpha), th_rel[dwell].min() / alpha
