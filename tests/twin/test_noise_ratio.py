"""The current-noise ratio of the twin features (ur5fault/twin/residuals.py, :func:`noise_ratio`) on
synthetic readings whose noise is known: a smooth motion plus white noise of chosen size."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.twin.residuals import MIN_NOISE_SAMPLES, noise_ratio


def _readings(sigma_meas: float, sigma_twin: float, n: int = 20_000, seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 1e-3
    motion = 2.0 * np.sin(2 * np.pi * 0.5 * t)[:, None] * np.ones(6)  # 2 A at 0.5 Hz: ~4e-5 A per ms squared
    return (1.3 * motion + sigma_meas * rng.standard_normal((n, 6)),
            motion + sigma_twin * rng.standard_normal((n, 6)))


def test_ratio_is_the_ratio_of_the_noises_whatever_the_motion_does():
    # the measured reading is 1.3 x the twin's in its motion too: the ratio sees only the noise
    meas, twin = _readings(0.012, 0.010)
    # relative standard error of one RMS of 20,000 second differences ~ sqrt(1.94 / (2 * 20,000)) = 0.7 %
    assert noise_ratio(meas, twin) == pytest.approx(np.full(6, 1.2), rel=0.03)


def test_mask_selects_samples_and_too_few_give_nan():
    meas, twin = _readings(0.02, 0.01)
    mask = np.zeros(meas.shape, bool)
    mask[:5000, :3] = True  # joints 1-3: 4,998 stencils; joints 4-6: none
    mask[:MIN_NOISE_SAMPLES + 1, 3] = True  # joint 4: one stencil short
    r = noise_ratio(meas, twin, mask)
    assert r[:3] == pytest.approx(np.full(3, 2.0), rel=0.05)
    assert np.isnan(r[3:]).all()


def test_nan_samples_are_skipped_and_a_noiseless_twin_gives_nan():
    meas, twin = _readings(0.01, 0.01)
    meas[100:200] = np.nan
    r = noise_ratio(meas, twin)
    assert np.isfinite(r).all() and r == pytest.approx(np.ones(6), rel=0.03)
    twin[:, 2] = np.round(twin[:, 2], 0) * 0.0  # a twin reading without noise
    assert np.isnan(noise_ratio(meas, twin)[2])
