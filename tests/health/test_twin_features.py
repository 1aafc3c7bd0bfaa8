"""Twin residual features (ur5fault/health/twin_features.py): near zero on a healthy run against its twin
(independent noise), and the projections of a known injected fault at the size physics says.

The expected sizes come from how each fault enters the drive, not from the feature code: a current-sensor
offset o is carried by the reading while the loops hold the true current where the motion needs it
(residual o); a gain g multiplies the reading of an unchanged current (residual (g - 1) i); a resolver
offset o reads the link o too high, the position loop puts the link o lower and the motor follows it,
so the encoder mismatch falls by o.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.health.twin_features import FEATURE_UNITS, NUISANCE_UNITS, twin_features
from ur5fault.health.twin_regressors import REGRESSOR_EFFECTS

pytestmark = pytest.mark.slow

#: simulated time of the batch [s]
DURATION_S = 2.5


@pytest.fixture(scope="module")
def batch():
    from ur5fault.config import parse_trajectory

    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")
    load = (make_effect("payload", mass_kg=1.0), make_effect("temperature", temperature_C=30.0))
    runs = [
        RunSpec("healthy", 11, load),
        RunSpec("offset", 11, load + (make_effect("current_sensor_offset", 2, offset_A=0.2),)),
        RunSpec("gain", 11, load + (make_effect("current_sensor_gain", 2, gain=1.1),)),
        RunSpec("resolver", 11, load + (make_effect("resolver_offset", 4, offset_deg=0.3),)),
        # the torque-constant loss that raises the shoulder's reading as much as the gain above does
        RunSpec("torque", 11, load + (make_effect("torque_constant", 2, scale=1 / 1.1),)),
        RunSpec("twin", 12345, load),
        RunSpec("quiet twin", 12345, load + REGRESSOR_EFFECTS),  # its current and gear torque: the regressors
    ]
    sim = Simulator()
    res = sim.run(traj, runs, duration_s=DURATION_S)
    assert all(s == "ok" for s in res.status)
    names = ("q_FB_rad", "q_M_FB_rad", "i_FB_A")
    twin = {**{n: res[n][5] for n in names}, **{n: res[n][6] for n in ("i_q_A", "T_gear_Nm")}}
    return {rid: twin_features(res.t_s, res.q_set_rad, {n: res[n][i] for n in names}, twin, sim.params)
            for i, rid in enumerate(("healthy", "offset", "gain", "resolver", "torque"))}


def test_schema_and_units(batch):
    assert list(batch["healthy"]) == list(FEATURE_UNITS)
    per_joint = [n for n in FEATURE_UNITS if not n.startswith(tuple(f"twin_est_{k}" for k in NUISANCE_UNITS))]
    assert all(name.endswith(tuple(f"_j{j}" for j in range(1, 7))) for name in per_joint)
    assert len(FEATURE_UNITS) - len(per_joint) == 2 * len(NUISANCE_UNITS)


def test_healthy_run_is_zero_mean_within_noise(batch):
    f = batch["healthy"]
    for j in range(1, 7):
        # 2.5 s at 1 kHz of two independent sensor streams (0.012 A each): the mean of the residual
        # over all samples has a standard error near 0.012 * sqrt(2 / 2500) = 3.4e-4 A; filtered noise
        # is correlated over a few samples, so allow 0.005 A
        assert abs(f[f"twin_est_current_offset_A_j{j}"]) < 0.005, j
        # a resolver-offset size estimate of a healthy run: well under the smallest fault of the dataset (0.005 deg)
        assert abs(f[f"twin_est_mismatch_offset_rad_j{j}"]) < math.radians(0.002), j
        for cond in ("rest", "speed", "reversal", "accel"):
            v = f[f"twin_current_mean_A_{cond}_j{j}"]
            assert np.isnan(v) or abs(v) < 0.03, (j, cond, v)


def test_current_sensor_offset_projects_to_its_size(batch):
    assert batch["offset"]["twin_est_current_offset_A_j2"] == pytest.approx(0.2, abs=0.01)
    assert abs(batch["offset"]["twin_est_current_offset_A_j1"]) < 0.005  # other joints untouched


def test_current_sensor_gain_projects_to_its_size(batch):
    assert batch["gain"]["twin_est_current_gain_err_j2"] == pytest.approx(0.1, abs=0.01)
    assert abs(batch["healthy"]["twin_est_current_gain_err_j2"]) < 0.01


def test_current_noise_ratio_tells_a_gain_from_a_torque_constant_loss(batch):
    """The sensor's noise enters before its gain: a gain of 1.1 makes the reading's noise 1.1 times louder, a
    torque-constant loss that raises the reading as much leaves the sensor's noise as it was.  The two runs share
    their noise stream, so their ratio is sharp; each against the twin's independent stream is within the
    estimate's sampling error (the joints rest for a few hundred of the 2,500 samples: about 5 % of the ratio)."""
    key = "twin_current_noise_ratio_rest_j{}"
    gain, torque = batch["gain"][key.format(2)], batch["torque"][key.format(2)]
    assert gain / torque == pytest.approx(1.1, abs=0.02)
    assert gain == pytest.approx(1.1, abs=0.15) and torque == pytest.approx(1.0, abs=0.15)
    # the two faults' current residuals are the same shape: their gain estimates agree
    assert batch["torque"]["twin_est_current_gain_err_j2"] == pytest.approx(0.1, abs=0.02)
    for j in (1, 3, 4, 5, 6):
        for run in ("healthy", "gain", "torque"):
            assert batch[run][key.format(j)] == pytest.approx(1.0, abs=0.15), (run, j)


def test_resolver_offset_lowers_the_mismatch_by_its_size(batch):
    assert math.degrees(batch["resolver"]["twin_est_mismatch_offset_rad_j4"]) == pytest.approx(-0.3, abs=0.005)


#: a payload CoM shift and a current-sensor offset of about the same motor current on wrist 1: 3 kg shifted 3 cm
#: sideways puts 3 * 9.82 * 0.03 = 0.88 N*m on the wrist while the tool points down, 0.88 / (K_t N) ~ 0.07 A
COM_KG, COM_DX_M, OFFSET_A = 3.0, 0.03, 0.07
#: the whole motion: the payload is picked up at 0.87 s and released at 5.21 s (the twin's current steps with the
#: payload's weight at both, which is what tells a held payload's CoM from a constant offset)
COM_DURATION_S = 6.3


@pytest.fixture(scope="module")
def com_batch():
    from ur5fault.config import parse_trajectory

    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")
    load = (make_effect("payload", mass_kg=COM_KG), make_effect("temperature", temperature_C=30.0))
    runs = [
        RunSpec("com", 11, load + (make_effect("payload_com", dx_m=COM_DX_M),)),
        RunSpec("offset", 11, load + (make_effect("current_sensor_offset", 4, offset_A=OFFSET_A),)),
        RunSpec("twin", 12345, load),
        RunSpec("quiet twin", 12345, load + REGRESSOR_EFFECTS),
    ]
    sim = Simulator()
    res = sim.run(traj, runs, duration_s=COM_DURATION_S)
    assert all(s == "ok" for s in res.status)
    names = ("q_FB_rad", "q_M_FB_rad", "i_FB_A")
    twin = {**{n: res[n][2] for n in names}, **{n: res[n][3] for n in ("i_q_A", "T_gear_Nm")}}
    held = traj.gripped(res.t_s)
    assert held.any() and not held.all()  # the payload is picked up within the simulated time
    return {rid: twin_features(res.t_s, res.q_set_rad, {n: res[n][i] for n in names}, twin, sim.params, COM_KG, held)
            for i, rid in enumerate(("com", "offset"))}


def test_payload_com_is_not_reported_as_a_current_offset(com_batch):
    com, off = com_batch["com"], com_batch["offset"]
    assert off["twin_est_current_offset_A_j4"] == pytest.approx(OFFSET_A, abs=0.1 * OFFSET_A)
    # the CoM shift: its own estimate, not a wrist-1 offset of its current size
    # (within 20 %: the per-joint gain columns take a share of the CoM's step, the twin's current stepping with
    # the payload's weight at the same instants)
    assert com["twin_est_payload_com_x_m"] == pytest.approx(COM_DX_M, rel=0.2)
    assert abs(com["twin_est_current_offset_A_j4"]) < 0.2 * OFFSET_A
    assert abs(off["twin_est_payload_com_x_m"]) < 0.005
    # and the offset stands out by many standard errors where the CoM's estimate of it does not
    assert off["twin_est_current_offset_A_t_j4"] > 3 * abs(com["twin_est_current_offset_A_t_j4"])


def test_standard_errors_and_t_values_are_consistent(com_batch):
    f = com_batch["offset"]
    for j in range(1, 7):
        for name in ("current_offset_A", "current_gain_err", "coulomb_scale_err", "mismatch_offset_rad"):
            v, se, t = (f[f"twin_est_{name}{s}_j{j}"] for s in ("", "_se", "_t"))
            assert (se > 0 and t == pytest.approx(v / se)) or (math.isnan(se) and math.isnan(t) and v == 0.0), \
                (name, j, v, se, t)
        assert f[f"twin_est_current_offset_A_se_j{j}"] > 0  # the constant column is always identified
    # the tool keeps pointing down: a CoM shift along it moves no joint torque, so it is not identified
    assert math.isnan(f["twin_est_payload_com_z_m_t"]) and f["twin_est_payload_com_z_m"] == 0.0


def test_the_payload_com_fed_back_puts_the_twins_gear_torque_where_the_robots_is():
    """The twin's gear torque with a known payload CoM shift fed back (twin_fit.com_corrected_torque, the closed-form
    gravity columns) against MuJoCo's: the same run simulated with the shift, both without sensor noise.  While the
    payload is held the fed-back torque takes up most of what the shift does on the joints it loads (the gravity
    moment; not the drive's transient when the payload's weight steps in at the grasp, nor the shift's inertial
    torque: about a quarter of it is left on the shoulder and elbow, an eighth on wrist 2).  A wrong sign would leave
    twice the change, a wrong scale (current for torque) all of it.  An estimate within two standard errors of zero
    is not fed back."""
    from ur5fault.config import parse_trajectory
    from ur5fault.health.twin_features import flank_share
    from ur5fault.health.twin_fit import com_columns, com_corrected_torque

    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")
    load = (make_effect("payload", mass_kg=COM_KG), make_effect("temperature", temperature_C=30.0))
    shift = make_effect("payload_com", dx_m=COM_DX_M, dy_m=-COM_DX_M)
    sim = Simulator()
    res = sim.run(traj, [RunSpec("twin", 12345, load + REGRESSOR_EFFECTS),
                         RunSpec("shifted", 12345, load + (shift,) + REGRESSOR_EFFECTS)], duration_s=COM_DURATION_S)
    assert all(s == "ok" for s in res.status)
    twin, truth = res["T_gear_Nm"][0], res["T_gear_Nm"][1]
    held = traj.gripped(res.t_s)
    cols = com_columns(res.q_set_rad, COM_KG, sim.params, held)
    fed = com_corrected_torque(twin, cols, np.array([COM_DX_M, -COM_DX_M, 0.0]), np.full(3, 1e-3), sim.params)
    change = np.sqrt(np.mean((truth - twin)[held] ** 2, axis=0))  # what the shift does to each joint's torque
    left = np.sqrt(np.mean((truth - fed)[held] ** 2, axis=0))
    loaded = change > 0.1  # N*m: the joints the shift loads (the wrists and the parallel axes)
    assert loaded.sum() >= 3 and np.all(left[loaded] < 0.35 * change[loaded]), (change, left)
    assert abs(flank_share(fed) - flank_share(truth)).max() < abs(flank_share(twin) - flank_share(truth)).max()
    # components within two standard errors of zero are not fed back (nor NaN ones): the twin's torque unchanged
    weak = com_corrected_torque(twin, cols, np.array([COM_DX_M, np.nan, 1.0]), np.array([0.02, 1e-3, np.nan]),
                                sim.params)
    assert weak is twin


def test_the_torque_rebuilt_from_the_features_is_the_one_their_flank_shares_read():
    """``fed_back_torque`` (diagnose's variance inflation) rebuilds from a run's features the gear torque the
    features' own mismatch fit and flank shares read: on a run with a payload CoM shift the current fit finds (fed
    back), its flank shares equal the features' to rounding, and differ from the bare twin's."""
    from ur5fault.config import parse_trajectory
    from ur5fault.health.twin_features import flank_share
    from ur5fault.health.twin_fit import fed_back_torque

    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")
    load = (make_effect("payload", mass_kg=COM_KG), make_effect("temperature", temperature_C=30.0))
    sim = Simulator()
    res = sim.run(traj, [RunSpec("run", 11, load + (make_effect("payload_com", dx_m=COM_DX_M, dy_m=-COM_DX_M),)),
                         RunSpec("twin", 12345, load), RunSpec("quiet twin", 12345, load + REGRESSOR_EFFECTS)],
                  duration_s=COM_DURATION_S)
    names = ("q_FB_rad", "q_M_FB_rad", "i_FB_A")
    twin = {**{n: res[n][1] for n in names}, **{n: res[n][2] for n in ("i_q_A", "T_gear_Nm")}}
    held = traj.gripped(res.t_s)
    f = twin_features(res.t_s, res.q_set_rad, {n: res[n][0] for n in names}, twin, sim.params, COM_KG, held)
    assert abs(f["twin_est_payload_com_x_m_t"]) >= 2 and abs(f["twin_est_payload_com_y_m_t"]) >= 2  # fed back
    shares = np.array([f[f"twin_gear_flank_share_j{j}"] for j in range(1, 7)])
    rebuilt = flank_share(fed_back_torque(res.q_set_rad, twin, sim.params, f, COM_KG, held))
    np.testing.assert_allclose(rebuilt, shares, rtol=0, atol=1e-12)
    assert np.abs(flank_share(twin["T_gear_Nm"]) - shares).max() > 0.01
