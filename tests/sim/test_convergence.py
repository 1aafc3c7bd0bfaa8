"""Numerical convergence: halving the physics step changes nothing that matters, on every joint.

Over the whole 2 kg pick-and-place, a healthy run and a shoulder-backlash run (alpha = 0.1 deg,
same noise seed) are simulated at the default step and at half of it.  Per run and joint:

* the resolver reading moves by less than 10 % of that joint's tracking-error RMS (RMS of the
  difference over the run; the wrists included, whose stick-slip once made this fail);
* the motor current reading moves by less than 0.02 A RMS;
* the paper's features (max TCP deviation of the faulty run from its twin, peak currents) by < 2 %.

The smooth-sign law is checked the same way in a slow case.
"""

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect, pick_and_place
from ur5fault.sim.params import load_params

# two full pick-and-place runs at two physics steps: long; `make test-fast` skips it
pytestmark = pytest.mark.slow

RUNS = [RunSpec("healthy", 11), RunSpec("bl", 11, (make_effect("backlash", "shoulder_lift_joint", backlash_deg=0.1),))]


def simulate(dt, model=None):
    over = {"physics_dt_s": dt}
    if model is not None:
        over["friction"] = {"model": model}
    res = Simulator(load_params(overrides=over)).run(pick_and_place(), RUNS, log_period_s=1e-3)
    assert res.status == ("ok", "ok")
    return res


def halving(model=None):
    dt = load_params().physics_dt_s
    return simulate(dt, model), simulate(dt / 2, model)


@pytest.fixture(scope="module")
def both():
    return halving()


def check_every_joint(a, b):
    track = np.sqrt(np.mean((a.q_set_rad - a["q_FB_rad"]) ** 2, axis=1))  # (runs, joints)
    dq = np.sqrt(np.mean((a["q_FB_rad"] - b["q_FB_rad"]) ** 2, axis=1))
    di = np.sqrt(np.mean((a["i_FB_A"] - b["i_FB_A"]) ** 2, axis=1))
    print("resolver change / tracking-error RMS per run and joint:\n", np.round(dq / track, 4))
    print("current change RMS [A]:\n", np.round(di, 4))
    assert np.all(dq < 0.1 * track)
    assert np.all(di < 0.02)


def test_every_joint_converged(both):
    check_every_joint(*both)


def test_tcp_deviation_converged(both):
    d1, d2 = (np.max(np.linalg.norm(r.tcp_m[1] - r.tcp_m[0], axis=-1)) for r in both)
    print(f"max TCP deviation: {d1 * 1e3:.4f} mm at dt, {d2 * 1e3:.4f} mm at dt/2")
    assert d1 > 1e-4  # the fault is visible at all
    assert abs(d1 - d2) / d2 < 0.02


def test_peak_currents_converged(both):
    i1, i2 = (np.max(np.abs(r["i_q_A"]), axis=1) for r in both)  # (runs, joints)
    rel = np.abs(i1 - i2) / i2
    print("peak |i_q| relative change per run and joint:", np.round(rel, 4))
    assert np.all(rel < 0.02)


@pytest.mark.slow
def test_smooth_sign_law_converged_on_every_joint():
    check_every_joint(*halving("smooth"))
