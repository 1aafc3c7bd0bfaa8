"""The healthy closed loop against the real UR5: replay the NIST log's target trajectory
(its 0.726 kg payload, tool offset and joint temperatures) and compare the joint tracking
error with the measured one.

The position-loop bandwidth was identified on the first 32 s of this log
(docs/parameters.md); the whole log is replayed here, and the part not used for the
identification is checked on its own as well.  The motor current is compared with the
measured one on the held-out end of the log (the discrepancy workflow's last 40 %), against
UR's own model, and at rest with the stick-slip (LuGre) law and with the smooth-sign law.
"""

import numpy as np
import pytest

from ur5fault.logs import read_nist
from ur5fault.twin.replay import LogReplay
from ur5fault.twin.residuals import conditions, held_out_mask

# replays the whole real log: long; `make test-fast` skips it
pytestmark = pytest.mark.slow

UR_MODEL_RMS_A = np.array([0.237, 0.524, 0.348, 0.158, 0.123, 0.122])  # whole log, data/nist-ur5/README.md


def _replay(log, friction=None):
    """The log replayed once (noise seed 1): samples 1..n of the log, ``Replayed``."""
    return LogReplay(log, {"friction": friction} if friction else None, seed=1).run([()])[0]


@pytest.fixture(scope="module")
def replay(nist_path):
    log = read_nist(nist_path)
    return log, _replay(log)


def _rms_deg(err, sel):
    return np.degrees(np.sqrt(np.mean(err[sel] ** 2, axis=0)))


def test_tracking_error_within_factor_three_of_the_real_robot(replay):
    log, res = replay
    n = res.y.shape[0]  # samples 1..n of the log (sample 0 is the initial state)
    sim_err = log.q_target_rad[1 : n + 1] - res.position_rad
    meas_err = log.q_target_rad[1 : n + 1] - log.q_actual_rad[1 : n + 1]
    for name, sel in (("whole log", slice(None)), ("held-out 32-63 s", log.t_s[1 : n + 1] - log.t_s[0] >= 32.0)):
        sim, meas = _rms_deg(sim_err, sel)[:5], _rms_deg(meas_err, sel)[:5]
        ratio = sim / meas
        print(f"{name}: sim {np.round(sim, 4)} deg, measured {np.round(meas, 4)} deg, ratio {np.round(ratio, 2)}")
        assert np.all((ratio > 1 / 3) & (ratio < 3)), f"{name}: ratio {ratio}"
    # the measured figures quoted in the issue, as a check on the reading of the log
    np.testing.assert_allclose(_rms_deg(meas_err, slice(None))[:5], [0.0072, 0.0077, 0.0055, 0.0076, 0.0060], atol=1e-4)


def _current_rms(log, res, mask):
    n = res.y.shape[0]
    err = np.where(mask, res.current_A - log.current_A[1 : n + 1], np.nan)
    return np.sqrt(np.nanmean(err**2, axis=0))


def test_held_out_current_against_urs_own_model(replay):
    """The nominal model (nothing fitted to the current) on the held-out end of the log, against UR's
    model (its target current) on the same samples.  Below UR's on J1-J3 and J5; J4 (a gravity-load
    offset at rest) and J6 (a constant -0.12 A offset in the log) are not, docs/validation.md."""
    log, res = replay
    n = res.y.shape[0]
    held = held_out_mask(n)
    sim = _current_rms(log, res, held)
    ur = np.sqrt(np.mean((log.target_current_A[1 : n + 1] - log.current_A[1 : n + 1])[held[:, 0]] ** 2, axis=0))
    print("held-out current RMS [A]: sim", np.round(sim, 3), " UR", np.round(ur, 3))
    whole = np.ones((n, 6), bool)
    print("whole-log current RMS [A]: sim", np.round(_current_rms(log, res, whole), 3), " UR",
          np.round(np.sqrt(np.mean((log.target_current_A[1 : n + 1] - log.current_A[1 : n + 1]) ** 2, axis=0)), 3))
    assert np.all(sim[:3] < 0.8 * ur[:3])
    assert sim[4] < ur[4]
    assert np.all(sim < 1.3 * ur)


def test_stick_slip_law_holds_the_current_at_rest(replay):
    """At rest the real drives keep the current their integrators wound up to against static friction;
    the smooth sign lets the joint creep and the current relax, the LuGre law holds it."""
    log, res = replay
    smooth = _replay(log, {"model": "smooth"})
    n = res.y.shape[0]
    rest = conditions(log, n, log.current_A[1 : n + 1])["at rest"]
    lugre_rms, smooth_rms = _current_rms(log, res, rest), _current_rms(log, smooth, rest)
    print("at-rest current RMS [A]: LuGre", np.round(lugre_rms, 3), " smooth sign", np.round(smooth_rms, 3))
    assert np.all(lugre_rms[:2] < 0.75 * smooth_rms[:2])  # shoulder_pan, shoulder_lift
    assert np.all(lugre_rms[:3] < UR_MODEL_RMS_A[:3])
