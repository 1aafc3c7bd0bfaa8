"""Residual weights: a zero noise is never a weight (identify writes resolver_noise_rad: 0 for a
controller whose positions are quantised and identical at rest; discrepancy --model then ended in
`LinAlgError: SVD did not converge` after divide-by-zero warnings)."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.errors import ParameterError
from ur5fault.sim.params import load_params
from ur5fault.twin.replay import residual_sigma

SIGNALS = ("current_A", "position_rad", "mismatch_rad")


def test_packaged_noise_is_the_weight_where_it_exceeds_the_rounding_error():
    p = load_params()
    sigma = residual_sigma(p, SIGNALS)
    np.testing.assert_array_equal(sigma[0], p.sensors.current_noise_A)
    np.testing.assert_array_equal(sigma[1], p.sensors.resolver_noise_rad)


def test_zero_identified_noise_is_weighed_by_the_quantisation_step():
    p = load_params(overrides={"sensors": {"resolver_noise_rad": [0.0] * 6, "resolver_counts_per_rev": 2**16}})
    sigma = residual_sigma(p, SIGNALS)
    step = 2 * np.pi / 2**16
    np.testing.assert_allclose(sigma[1], step / np.sqrt(12.0))  # uniform rounding error over one step
    assert np.all(np.isfinite(1.0 / sigma))


def test_a_signal_with_neither_noise_nor_step_is_refused():
    p = load_params(overrides={"sensors": {"current_noise_A": [0.0] * 6, "current_lsb_A": 0.0}})
    with pytest.raises(ParameterError, match="current_noise_A and sensors.current_lsb_A are both 0 on "
                                             "shoulder_pan_joint"):
        residual_sigma(p, SIGNALS)
