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
