"""MuJoCo inverse dynamics of ur5fault/models/ur5.xml against an independent Newton-Euler reference (reference_ur5)."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import reference_ur5 as ref
from conftest import JOINT_NAMES, MODEL_XML

N_SAMPLES = 100
TOL_TAU_NM = 1e-6
# Payload for the loaded check: CoM at (0, 0, 0.15) m in the tool body, which sits at the flange.
PAYLOAD_MASS_KG = 2.0
PAYLOAD_POS_FLANGE_M = np.array([0.0, 0.0, 0.15])
PAYLOAD_INERTIA_DIAG_KGM2 = np.array([1.0e-3, 2.0e-3, 3.0e-3])  # distinct, so axis mix-ups show


@pytest.fixture()
def model() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(MODEL_XML))


def random_states(seed: int, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Seeded (q [rad], qd [rad/s], qdd [rad/s^2]) samples, each of shape (n, 6)."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, size=(n, 6))
    qd = rng.uniform(-2.0, 2.0, size=(n, 6))
    qdd = rng.uniform(-5.0, 5.0, size=(n, 6))
    return q, qd, qdd


def mujoco_inverse(model: mujoco.MjModel, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """qfrc_inverse [N m] for each sample, shape (n, 6), in DH joint order."""
    data = mujoco.MjData(model)
    qadr = np.array([model.jnt_qposadr[model.joint(n).id] for n in JOINT_NAMES])
    vadr = np.array([model.jnt_dofadr[model.joint(n).id] for n in JOINT_NAMES])
    out = np.empty_like(q)
    for k in range(q.shape[0]):
        data.qpos[qadr] = q[k]
        data.qvel[vadr] = qd[k]
        data.qacc[vadr] = qdd[k]
        mujoco.mj_inverse(model, data)
        out[k] = data.qfrc_inverse[vadr]
    return out


def reference_inverse(q: np.ndarray, qd: np.ndarray, qdd: np.ndarray, **payload: object) -> np.ndarray:
    return np.array([ref.rnea(q[k], qd[k], qdd[k], gravity=9.82, **payload) for k in range(q.shape[0])])


def test_model_gravity_is_ur_value(model: mujoco.MjModel) -> None:
    np.testing.assert_allclose(model.opt.gravity, [0.0, 0.0, -9.82], atol=0.0)


def test_reference_gravity_torque_is_gradient_of_potential() -> None:
    """Self-check of the reference, no MuJoCo: at rest, tau = dV/dq (central differences)."""
    rng = np.random.default_rng(7)
    h = 1e-6
    for q in rng.uniform(-np.pi, np.pi, size=(10, 6)):
        tau = ref.rnea(q, np.zeros(6), np.zeros(6))
        grad = np.array(
            [
                (ref.gravity_potential(q + h * e) - ref.gravity_potential(q - h * e)) / (2 * h)
                for e in np.eye(6)
            ]
        )
        np.testing.assert_allclose(tau, grad, atol=1e-7)


def test_reference_mass_matrix_symmetric_positive_definite() -> None:
    """Self-check of the reference: M(q) columns from rnea(q, 0, e_j, gravity=0) form an SPD matrix."""
    rng = np.random.default_rng(11)
    for q in rng.uniform(-np.pi, np.pi, size=(10, 6)):
        M = np.column_stack([ref.rnea(q, np.zeros(6), e, gravity=0.0) for e in np.eye(6)])
        np.testing.assert_allclose(M, M.T, atol=1e-12)
        assert np.linalg.eigvalsh(M).min() > 0.0


def test_inverse_dynamics_matches_rnea(model: mujoco.MjModel) -> None:
    q, qd, qdd = random_states(seed=2024, n=N_SAMPLES)
    err = np.abs(mujoco_inverse(model, q, qd, qdd) - reference_inverse(q, qd, qdd))
    per_joint = np.array2string(err.max(0), precision=2)
    print(f"no payload: max |tau_mj - tau_ref| = {err.max():.3e} N m (per joint {per_joint})")
    assert err.max() < TOL_TAU_NM, f"max torque difference {err.max():.3e} N m, per joint {err.max(0)}"


def test_inverse_dynamics_with_payload_matches_rnea(model: mujoco.MjModel) -> None:
    payload = model.body("payload").id
    # Put the payload explicitly where the test says it is: (0, 0, 0.15) m in the tool body, CoM at
    # the body origin, principal axes aligned with the body.
    model.body_pos[payload] = PAYLOAD_POS_FLANGE_M
    model.body_quat[payload] = [1.0, 0.0, 0.0, 0.0]
    model.body_ipos[payload] = 0.0
    model.body_iquat[payload] = [1.0, 0.0, 0.0, 0.0]
    model.body_mass[payload] = PAYLOAD_MASS_KG
    model.body_inertia[payload] = PAYLOAD_INERTIA_DIAG_KGM2
    mujoco.mj_setConst(model, mujoco.MjData(model))

    # The tool body must coincide with the flange (DH frame 6) for the flange-frame payload position to hold.
    data = mujoco.MjData(model)
    data.qpos[:] = np.random.default_rng(3).uniform(-np.pi, np.pi, 6)
    mujoco.mj_kinematics(model, data)
    tool = model.body("tool").id
    flange = model.site("flange").id
    np.testing.assert_allclose(data.xpos[tool], data.site_xpos[flange], atol=1e-12)
    np.testing.assert_allclose(data.xmat[tool], data.site_xmat[flange], atol=1e-12)

    q, qd, qdd = random_states(seed=4048, n=N_SAMPLES)
    tau_mj = mujoco_inverse(model, q, qd, qdd)
    tau_ref = reference_inverse(
        q,
        qd,
        qdd,
        payload_mass_kg=PAYLOAD_MASS_KG,
        payload_pos_flange_m=PAYLOAD_POS_FLANGE_M,
        payload_inertia_flange_kgm2=np.diag(PAYLOAD_INERTIA_DIAG_KGM2),
    )
    err = np.abs(tau_mj - tau_ref)
    print(f"2 kg payload: max |tau_mj - tau_ref| = {err.max():.3e} N m")
    assert err.max() < TOL_TAU_NM, f"max torque difference {err.max():.3e} N m, per joint {err.max(0)}"
    # The payload must actually matter, or the comparison above would prove nothing about it.
    tau_unloaded = reference_inverse(q, qd, qdd)
    assert np.abs(tau_ref - tau_unloaded).max() > 1.0


def test_comparison_detects_a_small_model_error(model: mujoco.MjModel) -> None:
    """Negative control: a 1 % forearm mass error must exceed the tolerance by far."""
    model.body_mass[model.body("forearm_link").id] *= 1.01
    q, qd, qdd = random_states(seed=2024, n=20)
    err = np.abs(mujoco_inverse(model, q, qd, qdd) - reference_inverse(q, qd, qdd))
    assert err.max() > 1e3 * TOL_TAU_NM
