"""Forward kinematics against a real UR5 (CB3) log: NIST run ur5testresult_halfspeed_payload1.6lb_1.

The log gives joint positions (degrees) and the controller's TCP position (metres, base frame). Both
the MuJoCo model and the independent DH reference must reproduce the TCP position to sub-millimetre
RMS, with a tool offset fitted by linear least squares (TCP = p_flange + R_flange @ offset).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

import reference_ur5 as ref
from conftest import JOINT_NAMES, MODEL_XML

Q_COLUMNS = [f"ROBOT_ACTUAL_JOINT_POSITIONS (J{i})" for i in range(1, 7)]  # degrees
TCP_COLUMNS = [f"ROBOT_CARTESIAN_COORD_TOOL ({c})" for c in "xyz"]  # metres, base frame
NOMINAL_TOOL_OFFSET_M = np.array([-0.001, -0.001, 0.1856])  # in the flange frame
TOL_OFFSET_M = 2e-3
TOL_RMS_M = 0.5e-3


@pytest.fixture(scope="module")
def log(nist_path) -> tuple[np.ndarray, np.ndarray]:
    """(q [rad], tcp [m]) from the NIST log, shapes (n_rows, 6) and (n_rows, 3)."""
    import pandas as pd

    frame = pd.read_csv(nist_path)
    q_rad = np.deg2rad(frame[Q_COLUMNS].to_numpy(dtype=float))
    tcp_m = frame[TCP_COLUMNS].to_numpy(dtype=float)
    assert q_rad.shape[0] > 1000 and np.all(np.isfinite(q_rad)) and np.all(np.isfinite(tcp_m))
    return q_rad, tcp_m


@pytest.fixture(scope="module")
def dh_flange(log: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Flange positions [m] (n, 3) and rotations (n, 3, 3) from the independent DH reference."""
    q_rad, _ = log
    T = np.array([ref.dh_fk(q) for q in q_rad])
    return T[:, :3, 3], T[:, :3, :3]


def fit_tool_offset(p_flange: np.ndarray, R_flange: np.ndarray, tcp: np.ndarray) -> np.ndarray:
    """Least-squares tool offset [m] in the flange frame: minimises sum |p + R @ off - tcp|^2."""
    A = R_flange.reshape(-1, 3)
    b = (tcp - p_flange).reshape(-1)
    offset, *_ = np.linalg.lstsq(A, b, rcond=None)
    return offset


def rms_per_axis(residual: np.ndarray) -> np.ndarray:
    return np.sqrt(np.mean(residual**2, axis=0))


def mujoco_tcp(q_rad: np.ndarray, tool_offset_m: np.ndarray) -> np.ndarray:
    """TCP positions [m] (n, 3) from the MuJoCo model with the `tcp` site moved to tool_offset_m."""
    model = mujoco.MjModel.from_xml_path(str(MODEL_XML))
    data = mujoco.MjData(model)
    site = model.site("tcp").id
    tool = model.body("tool").id
    # `tcp` is a child of body `tool`, so site_pos is in the tool frame; that equals the flange frame
    # only if `tool` coincides with the `flange` site (checked below) and the site is not rotated.
    assert model.site_bodyid[site] == tool
    model.site_pos[site] = tool_offset_m
    model.site_quat[site] = [1.0, 0.0, 0.0, 0.0]
    qadr = np.array([model.jnt_qposadr[model.joint(n).id] for n in JOINT_NAMES])
    flange = model.site("flange").id
    out = np.empty((q_rad.shape[0], 3))
    for k, q in enumerate(q_rad):
        data.qpos[qadr] = q
        mujoco.mj_kinematics(model, data)
        if k == 0:
            np.testing.assert_allclose(data.xpos[tool], data.site_xpos[flange], atol=1e-12)
            np.testing.assert_allclose(data.xmat[tool], data.site_xmat[flange], atol=1e-12)
        out[k] = data.site_xpos[site]
    return out


def test_fitted_tool_offset_near_nominal(log, dh_flange) -> None:
    _, tcp = log
    p, R = dh_flange
    offset = fit_tool_offset(p, R, tcp)
    print(f"fitted tool offset [m] (flange frame): {np.array2string(offset, precision=6)}")
    assert np.all(np.abs(offset - NOMINAL_TOOL_OFFSET_M) < TOL_OFFSET_M), offset


@pytest.mark.parametrize("offset_kind", ["fitted", "nominal"])
def test_dh_reference_reproduces_logged_tcp(log, dh_flange, offset_kind: str) -> None:
    q_rad, tcp = log
    p, R = dh_flange
    offset = fit_tool_offset(p, R, tcp) if offset_kind == "fitted" else NOMINAL_TOOL_OFFSET_M
    # tool_fk is the public reference entry point; check it agrees with the batched form on a few rows.
    for k in (0, len(q_rad) // 2, len(q_rad) - 1):
        np.testing.assert_allclose(ref.tool_fk(q_rad[k], offset), p[k] + R[k] @ offset, atol=1e-15)
    residual = p + np.einsum("nij,j->ni", R, offset) - tcp
    rms = rms_per_axis(residual)
    print(
        f"DH reference, {offset_kind} offset: RMS x/y/z = {np.array2string(rms * 1e3, precision=3)} mm,"
        f" max |e| = {np.linalg.norm(residual, axis=1).max() * 1e3:.3f} mm"
    )
    assert np.all(rms < TOL_RMS_M), f"RMS per axis {rms * 1e3} mm"


@pytest.mark.parametrize("offset_kind", ["fitted", "nominal"])
def test_mujoco_model_reproduces_logged_tcp(log, dh_flange, offset_kind: str) -> None:
    q_rad, tcp = log
    p, R = dh_flange
    offset = fit_tool_offset(p, R, tcp) if offset_kind == "fitted" else NOMINAL_TOOL_OFFSET_M
    tcp_mj = mujoco_tcp(q_rad, offset)
    rms = rms_per_axis(tcp_mj - tcp)
    print(
        f"MuJoCo model, {offset_kind} offset: RMS x/y/z = {np.array2string(rms * 1e3, precision=3)} mm,"
        f" max |e| = {np.linalg.norm(tcp_mj - tcp, axis=1).max() * 1e3:.3f} mm"
    )
    assert np.all(rms < TOL_RMS_M), f"RMS per axis {rms * 1e3} mm"
    # And the model agrees with the independent reference on every logged configuration.
    assert np.abs(tcp_mj - (p + np.einsum("nij,j->ni", R, offset))).max() < 1e-9


def test_log_discriminates_the_joint_unit(log, dh_flange) -> None:
    """Negative control: if the log's degrees were misread (here: 1 % scale error), the fit must fail."""
    q_rad, tcp = log
    T = np.array([ref.dh_fk(q) for q in q_rad[::10] * 1.01])
    p, R = T[:, :3, 3], T[:, :3, :3]
    offset = fit_tool_offset(p, R, tcp[::10])
    rms = rms_per_axis(p + np.einsum("nij,j->ni", R, offset) - tcp[::10])
    assert np.any(rms > TOL_RMS_M), rms
