"""The compiled loop's pointer helpers (ur5fault/sim/mjlib.py): ``uncounted`` views share their array's memory, keep
its shape and dtype, and refuse an array they cannot view as C-contiguous memory."""

from __future__ import annotations

import numpy as np
import pytest
from numba import njit

from ur5fault.sim.mjlib import uncounted


@njit
def _write_through(a, value):
    v = uncounted(a)
    v.reshape(v.size)[0] = value
    return v.shape, v.sum()


@pytest.mark.parametrize("a", [np.arange(12.0).reshape(3, 4), np.arange(24.0).reshape(2, 3, 1, 4),
                               np.zeros((2, 5), dtype=np.intp)])
def test_an_uncounted_view_is_the_array_itself(a):
    expected_sum = a.sum() - a.flat[0] + 7
    shape, total = _write_through(a, 7)
    assert shape == a.shape
    assert a.flat[0] == 7  # written through the view into the array's own memory
    assert total == expected_sum


def test_a_strided_array_is_refused():
    with pytest.raises(ValueError, match="not C-contiguous"):
        _write_through(np.zeros((4, 6))[:, ::2], 1.0)
