"""The 2 kg pick-and-place: what the issue asks of it, checked on the model."""

import mujoco
import numpy as np
import pytest

from ur5fault.engine import DEFAULT_MODEL_PATH
from ur5fault.trajectory import CB3_SETPOINT_PERIOD_S, Trajectory, movej, pick_and_place


@pytest.fixture(scope="module")
def pnp():
    return pick_and_place()


def test_setpoints_at_controller_rate_and_payload_events(pnp):
    assert pnp.setpoint_period_s == CB3_SETPOINT_PERIOD_S
    assert pnp.default_payload_kg == 2.0
    (t_grip, g1), (t_rel, g2) = pnp.payload_events
    assert g1 and not g2 and 0 < t_grip < t_rel < pnp.duration_s
    assert not pnp.gripped(np.array([0.0]))[0] and pnp.gripped(np.array([t_grip + 0.01]))[0]


def test_speed_and_acceleration_within_ur_defaults(pnp):
    qd = np.diff(pnp.q_set_rad, axis=0) / pnp.setpoint_period_s
    qdd = np.diff(qd, axis=0) / pnp.setpoint_period_s
    assert np.abs(qd).max() <= 1.047 + 1e-6
    assert np.abs(qdd).max() <= 1.396 * 1.05  # a sample straddling a phase change


def _move_directions(q, j):
    d = np.sign(np.round(np.diff(q[:, j]), 9))
    d = d[d != 0]
    return d


@pytest.mark.parametrize("j", [0, 1, 2])
def test_velocity_reversals_on_first_three_joints(pnp, j):
    d = _move_directions(pnp.q_set_rad, j)
    assert np.sum(d[1:] != d[:-1]) >= 1


def test_gravity_torque_changes_sign_on_shoulder_and_elbow(pnp):
    m = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    d = mujoco.MjData(m)
    grav = []
    for q in pnp.q_set_rad[::10]:
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        grav.append(d.qfrc_bias.copy())
    grav = np.array(grav)
    for j in (1, 2):
        assert grav[:, j].max() > 5 and grav[:, j].min() < -5, f"joint {j + 1} gravity torque keeps its sign"


def test_tool_points_down_at_pick_and_place(pnp):
    m = mujoco.MjModel.from_xml_path(str(DEFAULT_MODEL_PATH))
    d = mujoco.MjData(m)
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
    from ur5fault.trajectory import PICK, PLACE

    for q in (PICK, PLACE):
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        assert d.site_xmat[site].reshape(3, 3)[2, 2] < -0.999


def test_movej_trapezoid_endpoints():
    q = movej(np.zeros(6), np.full(6, 1.0), 1.0, 1.0, 0.008)
    np.testing.assert_allclose(q[-1], 1.0)
    assert np.all(np.diff(q[:, 0]) > 0)


def test_interpolation_linear_with_slope():
    tr = Trajectory("t", 0.01, np.array([[0.0] * 6, [1.0] * 6, [1.0] * 6]))
    q, qd = tr.interpolate(np.array([0.005, 0.015, 0.5]))
    np.testing.assert_allclose(q[:, 0], [0.5, 1.0, 1.0])
    np.testing.assert_allclose(qd[:, 0], [100.0, 0.0, 0.0])
