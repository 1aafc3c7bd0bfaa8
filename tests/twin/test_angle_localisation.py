"""Localising a residual in joint angle: a worn region of a gear (a friction rise over ~10 deg of the travel)
is found where it is, and pure noise finds no region."""

from __future__ import annotations

import numpy as np

from ur5fault.twin.residuals import UNEXPLAINED_FACTOR, angle_region, rms_by_angle


def _sweep(n=20000, seed=0):
    rng = np.random.default_rng(seed)
    q = np.deg2rad(40.0 + 80.0 * 0.5 * (1 - np.cos(np.linspace(0, 12 * np.pi, n))))  # 40..120 deg, back and forth
    return q, rng.normal(0.0, 0.01, n)


def test_a_local_rise_is_found_in_its_region_of_the_travel():
    q, r = _sweep()
    deg = np.rad2deg(q)
    r = r + np.where(np.abs(deg - 77.0) < 5.0, 0.25, 0.0)  # 0.25 over 72..82 deg
    floor = np.sqrt(2.0) * 0.01
    # the joint's overall RMS stays below the unexplained level: only the region shows it
    region = angle_region(r, q, UNEXPLAINED_FACTOR * floor)
    assert region is not None
    assert 70.0 <= region["from_deg"] <= 72.0 and 82.0 <= region["to_deg"] <= 85.0, region
    assert region["rms"] > 10 * region["rms_elsewhere"]


def test_pure_noise_has_no_region_above_the_unexplained_level():
    for seed in range(5):
        q, r = _sweep(seed=seed)
        assert angle_region(r, q, UNEXPLAINED_FACTOR * np.sqrt(2.0) * 0.01) is None


def test_bins_with_too_few_samples_are_not_judged():
    q = np.deg2rad(np.r_[np.full(100, 10.0), np.full(3, 50.0)])
    r = np.r_[np.zeros(100), np.full(3, 9.0)]
    bins = rms_by_angle(r, q)
    assert [b[:2] for b in bins] == [(10.0, 15.0)]


def test_gear_reversals_are_told_apart_by_part_of_the_log():
    """A gear torque that stays on one side over the fitted part and crosses zero after it: a backlash can show
    in the held-out part only (the report says so)."""
    from ur5fault.twin.residuals import gear_reversals

    t = np.r_[np.full(600, 20.0) + np.sin(np.linspace(0, 9, 600)), 20.0 * np.cos(np.linspace(0, 6, 400))]
    assert gear_reversals(t, 600) == {"fitted": False, "held_out": True}
    assert gear_reversals(t, 1000) == {"fitted": True, "held_out": False}
    assert gear_reversals(np.full(100, 3.0), 50) == {"fitted": False, "held_out": False}
    assert gear_reversals(np.zeros(10), 5) == {"fitted": False, "held_out": False}  # no load: no reversal
    # a swing under 5 % of the peak to the other side is not a reversal
    assert gear_reversals(np.r_[np.full(50, 20.0), np.full(50, -0.5)], 50)["held_out"] is False


def test_the_report_says_when_the_fitted_part_could_not_show_it():
    from ur5fault.discrepancy.report import _why_not_fitted

    u = {"rms_fit": 3e-5, "held_out_only": True, "gear_reverses": {"fitted": False, "held_out": True}}
    text = _why_not_fitted(u)
    assert "Not in the fitted part" in text and "reverses in the held-out part only" in text
    assert "reverses" not in _why_not_fitted({**u, "gear_reverses": {"fitted": True, "held_out": True}})
    assert _why_not_fitted({**u, "held_out_only": False}) == ""
