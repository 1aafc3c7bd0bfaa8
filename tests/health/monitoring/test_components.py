"""The variance components of runs and blocks (ur5fault/health/monitoring/components.py), hand-computed."""

import numpy as np
import pytest

from ur5fault.health.monitoring.components import Components, components


def test_the_reference_sums_the_variance_components_and_counts_welch_satterthwaites_df():
    """Two runs of 50 blocks (``k`` 100, ``sum w^2`` 0.5, ``mean(1/m)`` 0.02), one block's noise 1 with design
    effect 2 (48 within degrees of freedom), the runs' means' variance 0.1 (1 degree of freedom): the runs'
    offsets ``tau^2 = 0.1 - 1 x 2 x 0.02 = 0.06``. A log of 20 blocks: its blocks' noise ``2 / 20 = 0.1``, the
    mean's ``2 / 100 = 0.02``, the runs' offsets ``1.5 x 0.06 = 0.09``; in the mean squares ``1.5 x 0.1 + (0.1 +
    0.02 - 1.5 x 0.04) x 1 = 0.21``, the same, at ``0.21^2 / (0.15^2 / 1 + 0.06^2 / 48)`` degrees of freedom. The
    log's own SE replaces only its blocks' noise where larger (0.2: 0.21; 0.5: 0.25 + 0.11). A log of 1000 blocks:
    the within part ``0.002 + 0.02 - 0.06`` below 0 is taken as 0: ``0.15`` at 1 degree of freedom. One run: no
    offsets seen, the within part alone at its 48 degrees of freedom; a log of one block never narrower than one
    block."""
    c = Components(0.5, 1.0, 2.0, 48.0, 0.1, 1.0, 100, 0.5, 0.02)
    assert c.between_var == pytest.approx(0.06)
    ref = c.reference(20)
    assert ref.mean == 0.5 and ref.k == pytest.approx(1.0 + 0.21**2 / (0.15**2 + 0.06**2 / 48))
    assert (ref.log_var, ref.mean_var, ref.run_var) == (pytest.approx(0.1), pytest.approx(0.02), pytest.approx(0.09))
    assert ref.variance(0.2) == pytest.approx(0.21) and ref.variance(0.5) == pytest.approx(0.36)
    long = c.reference(1000)
    assert long.variance(0.0) == pytest.approx(0.15) and long.k == pytest.approx(2.0)
    one = Components(0.0, 1.0, 2.0, 48.0, 0.0, 0.0, 50, 1.0, 0.02)
    assert one.reference(20).variance(0.0) == pytest.approx(0.1 + 0.04) and one.reference(20).k == pytest.approx(49)
    assert one.reference(1).variance(0.0) == pytest.approx(1.04)


def test_components_of_runs_that_sit_apart_and_of_blocks_that_do_not():
    """Hand-made runs: three runs of 40 alternating blocks ``+-1`` about levels 0, 1, 2 (no autocorrelation beyond
    the alternation, clipped at 0: design effect 1 with ``min_lag`` 1): the within variance is ``40 / (40 - 1)``
    per run pooled (sum of squares 120 over ``3 x 39``), the runs' means' sample variance 1, ``tau^2 = 1 - 1.026 /
    40``; with ``var`` twice the blocks' pooled sample variance both mean squares double. Blocks worth under one
    within degree of freedom give none."""
    alt = np.tile([1.0, -1.0], 20)
    seqs = [alt + level for level in (0.0, 1.0, 2.0)]
    c = components(seqs, 1.0, 1)
    assert c.within_de == pytest.approx(1.0) and c.within_var == pytest.approx(120 / 117)
    assert c.between_ms == pytest.approx(1.0) and c.between_df == 2.0 and c.within_df == pytest.approx(117)
    assert c.between_var == pytest.approx(1.0 - 120 / 117 / 40)
    pooled = float(np.concatenate(seqs).var(ddof=1))
    twice = components(seqs, 1.0, 1, var=2 * pooled)
    assert twice.within_var == pytest.approx(2 * c.within_var) and twice.between_ms == pytest.approx(2.0)
    assert components([np.array([1.0]), np.array([2.0])], 1.5, 1) is None  # one block per run
