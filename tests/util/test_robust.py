"""The one robust spread (ur5fault/util/robust.py) against hand-computed values."""

from __future__ import annotations

import numpy as np

from ur5fault.util.robust import MAD_SCALE, robust_spread


def test_median_mad_and_count_per_column_over_finite_values():
    x = np.array([[1.0, np.nan, np.nan], [2.0, 5.0, np.nan], [4.0, 7.0, np.nan], [10.0, np.inf, np.nan]])
    med, scale, n = robust_spread(x)
    # column 0: median 3, |x - 3| = 2, 1, 1, 7 -> MAD 1.5; column 1: 5, 7 -> median 6, MAD 1; column 2: none
    np.testing.assert_array_equal(n, [4, 2, 0])
    np.testing.assert_allclose(med[:2], [3.0, 6.0])
    np.testing.assert_allclose(scale[:2], [1.5 * MAD_SCALE, 1.0 * MAD_SCALE])
    assert np.isnan(med[2]) and np.isnan(scale[2])
    assert abs(MAD_SCALE - 1 / 0.6744897501960817) < 1e-4  # 1 / Phi^-1(3/4)
