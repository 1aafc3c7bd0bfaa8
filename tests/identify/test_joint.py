"""Several logs identified jointly: the signals of each log derived on their own and laid end to end, and no
rest segment or start from rest spanning two logs."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.identify import sensors, stickslip
from ur5fault.identify.signals import derive, derive_all
from ur5fault.logs import read_nist
from ur5fault.sim.engine import DEFAULT_MODEL_PATH
from ur5fault.sim.params import load_params


@pytest.fixture(scope="module")
def parts(nist_path):
    log = read_nist(nist_path)
    return [log.window(0.0, 12.0), log.window(30.0, 40.0)]


def test_joint_signals_are_each_logs_own(parts):
    p = load_params()
    own = [derive(g, p, DEFAULT_MODEL_PATH) for g in parts]
    joint = derive_all(parts, p, DEFAULT_MODEL_PATH)
    assert joint.log_starts == (0, own[0].n) and joint.n == own[0].n + own[1].n
    for name in ("q_target_rad", "qd_target_rad_s", "qdd_target_rad_s2", "current_A", "model_torque_Nm",
                 "temperature_C", "target_torque_Nm"):
        np.testing.assert_array_equal(getattr(joint, name), np.concatenate([getattr(o, name) for o in own]))


def test_no_rest_or_start_spans_two_logs(parts):
    p = load_params()
    # the same log twice: its last samples at rest would run straight into its first ones
    joint = derive_all([parts[0], parts[0]], p, DEFAULT_MODEL_PATH)
    b = joint.log_starts[1]
    for seg in sensors.rest_segments(joint):
        assert joint.same_log(int(seg[0]), int(seg[-1])), (seg[0], seg[-1], b)
    single = derive(parts[0], p, DEFAULT_MODEL_PATH)
    assert len(sensors.rest_segments(joint)) == 2 * len(sensors.rest_segments(single))
    for j in range(6):
        for s in stickslip.starts(joint, j):
            assert joint.same_log(s - int(round(stickslip.MIN_REST_S / joint.period_s)), s)


def test_several_logs_with_the_bandwidth_sweep(parts):
    """``ur5fault identify LOG LOG`` sweeps by default: the sweep replays the first log (it was handed the list of
    logs and failed with an AttributeError unless a payload was fitted)."""
    from ur5fault.identify import identify

    ident = identify(parts, sweep=True, bandwidths_Hz=(4.0, 8.0), sweep_window_s=1.0, n_boot=5)
    assert ident.sweep is not None and ident.sweep.window_s == pytest.approx(1.0, abs=0.01)
    sweep = next(e for e in ident.estimates if e.key == "controller.position_bw_Hz")
    assert f"of {parts[0].source}" in sweep.method, sweep.method


def test_a_best_bandwidth_at_the_end_of_the_candidates_is_said_to_be_there():
    """On the Kufieta runs every resample picks the highest candidate, 3 Hz, an interval [3, 3] that reads as
    certainty: the note says the best may lie beyond, and which log the sweep replayed."""
    from ur5fault.identify.loop import Sweep, sweep_estimate

    def sweep(best):
        return Sweep((1.0, 2.0, 3.0), (0.3, 0.1, 0.02), best, best, best, (1, 2), 16.0, np.zeros((3, 6)), np.zeros(6))

    assert "the highest candidate: the best may lie beyond it" in sweep_estimate(sweep(3.0), "TEST.csv.gz").method
    assert "of TEST.csv.gz" in sweep_estimate(sweep(3.0), "TEST.csv.gz").method
    assert "lowest candidate" in sweep_estimate(sweep(1.0)).method
    assert "beyond" not in sweep_estimate(sweep(2.0)).method
