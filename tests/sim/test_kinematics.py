"""MuJoCo forward kinematics of ur5fault/models/ur5.xml against the independent DH reference (reference_ur5)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import reference_ur5 as ref
from conftest import JOINT_NAMES, MODEL_XML

N_CONFIGS = 200
TOL_POS_M = 1e-9
TOL_ROT = 1e-9


@pytest.fixture()
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MODEL_XML))


def qpos_index(model: mujoco.MjModel) -> np.ndarray:
    """qpos addresses of the six UR joints, in DH order."""
    return np.array([model.jnt_qposadr[model.joint(name).id] for name in JOINT_NAMES])


def test_joint_layout(model: mujoco.MjModel) -> None:
    from ur5fault import JOINT_NAMES as PACKAGE_JOINT_NAMES

    assert model.nq == 6 and model.nv == 6
    assert PACKAGE_JOINT_NAMES == JOINT_NAMES  # the package's joint order is the MJCF's DH order
    for name in JOINT_NAMES:
        assert model.jnt_type[model.joint(name).id] == mujoco.mjtJoint.mjJNT_HINGE, name


def test_reference_dh_known_pose() -> None:
    """Hand-computed flange pose at q = 0 (all links stretched along -x of the base)."""
    T = ref.dh_fk(np.zeros(6))
    # Frame 1 = Rx(pi/2): z1 = -y0, so a2, a3 run along x0 and d4 along -y0.
    # Frame 4 = Rx(pi): z4 = -z0, so d5 runs down.  Frame 5 = Rx(pi/2): z5 = -y0, so d6 along -y0.
    # => p = (a2 + a3, -(d4 + d6), d1 - d5) = (-0.81725, -0.19145, -0.005491), R6 = Rx(pi/2).
    np.testing.assert_allclose(T[:3, 3], [-0.81725, -0.19145, 0.089159 - 0.09465], atol=1e-12)
    np.testing.assert_allclose(T[:3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-12)


def test_flange_matches_dh_reference(model: mujoco.MjModel) -> None:
    data = mujoco.MjData(model)
    idx = qpos_index(model)
    site = model.site("flange").id
    rng = np.random.default_rng(20240601)
    qs = rng.uniform(-np.pi, np.pi, size=(N_CONFIGS, 6))
    max_pos = 0.0
    max_rot = 0.0
    for q in qs:
        data.qpos[:] = 0.0
        data.qpos[idx] = q
        mujoco.mj_kinematics(model, data)
        T = ref.dh_fk(q)
        max_pos = max(max_pos, float(np.max(np.abs(data.site_xpos[site] - T[:3, 3]))))
        max_rot = max(max_rot, float(np.max(np.abs(data.site_xmat[site].reshape(3, 3) - T[:3, :3]))))
    print(f"flange vs DH over {N_CONFIGS} configs: max |dp| = {max_pos:.3e} m, max |dR| = {max_rot:.3e}")
    assert max_pos < TOL_POS_M, f"flange position differs from DH by {max_pos:.3e} m"
    assert max_rot < TOL_ROT, f"flange rotation differs from DH by {max_rot:.3e}"


def test_comparison_detects_a_micrometre_length_error(model: mujoco.MjModel) -> None:
    """Negative control: a 1 um change of a3 in the model must be far outside the tolerance."""
    model.body_pos[model.body("wrist_1_link").id, 0] -= 1e-6
    data = mujoco.MjData(model)
    q = np.random.default_rng(5).uniform(-np.pi, np.pi, 6)
    data.qpos[qpos_index(model)] = q
    mujoco.mj_kinematics(model, data)
    err = np.max(np.abs(data.site_xpos[model.site("flange").id] - ref.dh_fk(q)[:3, 3]))
    assert err > 100 * TOL_POS_M
