"""The robust spread every health module takes of a sample: the median absolute deviation about the median, scaled
to a normal distribution's standard deviation."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

#: median absolute deviation -> standard deviation of a normal distribution (1 / Phi^-1(3/4))
MAD_SCALE = 1.4826


def robust_spread(x: ArrayLike) -> tuple[NDArray, NDArray, NDArray]:
    """Per column of ``x`` ``(n_rows, n_columns)``, over its finite values: the median, the robust spread
    (:data:`MAD_SCALE` x the median absolute deviation) and their number (NaN median and spread where there is
    none)."""
    x = np.asarray(x, float)
    n = np.isfinite(x).sum(axis=0)
    med = np.full(x.shape[1], np.nan)
    scale = np.full(x.shape[1], np.nan)
    for k in np.flatnonzero(n):
        c = x[np.isfinite(x[:, k]), k]
        med[k] = np.median(c)
        scale[k] = MAD_SCALE * np.median(np.abs(c - med[k]))
    return med, scale, n
