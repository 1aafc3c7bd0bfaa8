"""The healthy closed loop against the real UR5: replay the NIST log's target trajectory
(its 0.726 kg payload, tool offset and joint temperatures) and compare the joint tracking
error with the measured one.

The position-loop bandwidth was identified on the first 32 s of this log
(docs/parameters.md); the whole log is replayed here, and the part not used for the
identification is checked on its own as well.
"""

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator
from ur5fault.logs import read_nist
from ur5fault.params import load_params

# replays the whole real log: long; `make test-fast` skips it
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def replay(nist_path):
    log = read_nist(nist_path)
    p = load_params(overrides={"tcp_offset_m": list(log.tcp_offset_m),
                               "joint_temperature_C": log.temperature_C.mean(axis=0).tolist()})
    res = Simulator(p).run(log.to_trajectory(), [RunSpec("nist", 1)], log_period_s=log.period_s)
    return log, res


def _rms_deg(err, sel):
    return np.degrees(np.sqrt(np.mean(err[sel] ** 2, axis=0)))


def test_tracking_error_within_factor_three_of_the_real_robot(replay):
    log, res = replay
    n = res.t_s.size  # samples 1..n of the log (sample 0 is the initial state)
    sim_err = log.q_target_rad[1 : n + 1] - res["q_FB_rad"][0]
    meas_err = log.q_target_rad[1 : n + 1] - log.q_actual_rad[1 : n + 1]
    for name, sel in (("whole log", slice(None)), ("held-out 32-63 s", res.t_s >= 32.0)):
        sim, meas = _rms_deg(sim_err, sel)[:5], _rms_deg(meas_err, sel)[:5]
        ratio = sim / meas
        print(f"{name}: sim {np.round(sim, 4)} deg, measured {np.round(meas, 4)} deg, ratio {np.round(ratio, 2)}")
        assert np.all((ratio > 1 / 3) & (ratio < 3)), f"{name}: ratio {ratio}"
    # the measured figures quoted in the issue, as a check on the reading of the log
    np.testing.assert_allclose(_rms_deg(meas_err, slice(None))[:5], [0.0072, 0.0077, 0.0055, 0.0076, 0.0060], atol=1e-4)


def test_replay_current_is_close_to_the_measured_one(replay):
    """Not a requirement of the core, a sanity check: the simulated current error is of the
    order of UR's own model error on this run (0.24-0.52 A on J1-J3)."""
    log, res = replay
    n = res.t_s.size
    rms = np.sqrt(np.mean((res["i_FB_A"][0] - log.current_A[1 : n + 1]) ** 2, axis=0))
    print("current RMS error sim vs measured [A]:", np.round(rms, 3))
    assert np.all(rms[:3] < 0.6)
