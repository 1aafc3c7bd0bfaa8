"""A log taken at a slower logger's rate (MeasuredLog.every, diagnosis.rate.at_training_rate): every k-th sample
from the k-th, only for a whole k >= 2 on the same clock (tests/health/test_diagnose.py: a simulated 0.5 ms log so
taken is the 1 ms log of the same run, and diagnosed alike)."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.health.diagnosis.rate import at_training_rate
from ur5fault.logs.measured import MeasuredLog


def _log(n: int = 100, period_s: float = 0.001) -> MeasuredLog:
    t = np.arange(n) * period_s
    q = np.outer(t, np.arange(1, 7))
    return MeasuredLog(source="log.csv", t_s=t, q_target_rad=q, q_actual_rad=q + 1.0, current_A=-q,
                       temperature_C=np.full((n, 6), 30.0), logged=np.arange(n) % 7 != 3, payload_kg=1.0,
                       tcp_offset_m=(0.0, 0.0, 0.0), notes=("read",))


def test_every_keeps_each_kth_row_of_every_per_sample_array():
    log = _log()
    e = log.every(4, "kept every 4th")
    assert e.t_s.size == 25 and e.period_s == pytest.approx(0.004)
    for name in ("t_s", "q_target_rad", "q_actual_rad", "current_A", "temperature_C", "logged"):  # rows 3, 7, ..., 99
        np.testing.assert_array_equal(getattr(e, name), getattr(log, name)[3::4])
    assert e.notes == ("read", "kept every 4th") and e.payload_kg == 1.0 and e.target_current_A is None
    assert log.every(1).t_s.size == 100
    with pytest.raises(ValueError):
        log.every(0)


@pytest.mark.parametrize("trained_s, kept", [(0.004, 4), (0.002, 2), (0.011, 11), (0.0115, None), (0.0035, None),
                                             (0.001, None), (0.0005, None), (None, None)])
def test_only_a_whole_multiple_of_the_logs_period_is_taken(trained_s, kept):
    log = _log()
    out = at_training_rate(log, trained_s)
    if kept is None:  # the same rate, a slower log, no whole multiple, or no period recorded: as it is
        assert out is log
    else:
        assert out.period_s == pytest.approx(trained_s) and out.t_s.size == 100 // kept
        suffix = {2: "nd", 4: "th", 11: "th"}[kept]
        assert out.notes[-1] == (f"log.csv: sampled every 1 ms; every {kept}{suffix} sample kept, as the detector's "
                                 f"training runs were logged every {trained_s * 1e3:g} ms (its rate-dependent features "
                                 "are on their scale at that rate only)")
