"""Motor models: the DC-equivalent motor against MuJoCo's native dcmotor actuator
(an independent implementation) and analytic limits; the PMSM in d-q."""

import mujoco
import numpy as np
import pytest

from ur5fault.sim.drive.motor import back_emf_constant, electrical_step, phase_currents
from ur5fault.sim.drive.power import limit_voltage, voltage_limit

R, L, KT, J, DT = 0.5, 6e-4, 0.135, 1e-3, 5e-5


def ours(v, t_end, kt=KT, ke=KT, cross=0.0, v_d=0.0):
    decay = np.exp(-R * DT / L)
    gain = (1 - decay) / R
    i_d = i_q = w = 0.0
    ws, iqs = [], []
    for _ in range(int(round(t_end / DT))):
        i_d, i_q = electrical_step(i_d, i_q, v_d, v, w, decay, gain, cross, ke)
        w = w + DT * kt * i_q / J
        ws.append(w)
        iqs.append(i_q)
    return np.array(ws), np.array(iqs), i_d


def mujoco_dcmotor(v, t_end):
    xml = f"""<mujoco><option timestep="{DT}"/><worldbody><body><joint name="j" axis="0 0 1"/>
    <inertial pos="0 0 0" mass="1" diaginertia="{J} {J} {J}"/></body></worldbody>
    <actuator><dcmotor joint="j" resistance="{R}" motorconst="{KT}" inductance="{L}"/></actuator></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.ctrl[0] = v
    ws, cur = [], []
    for _ in range(int(round(t_end / DT))):
        mujoco.mj_step(m, d)
        ws.append(d.qvel[0])
        cur.append(d.act[0])
    return np.array(ws), np.array(cur)


def test_dc_motor_matches_mujoco_dcmotor():
    w_ours, i_ours, _ = ours(24.0, 0.3)
    w_mj, i_mj = mujoco_dcmotor(24.0, 0.3)
    # speed run-up (time constant J R / K^2 = 27 ms) agrees to 0.5 % of the final speed at every step
    assert np.max(np.abs(w_ours - w_mj)) < 5e-3 * w_mj[-1]
    assert np.max(np.abs(i_ours - i_mj)) < 5e-3 * np.max(np.abs(i_mj))
    assert w_ours[-1] == pytest.approx(24.0 / KT, rel=1e-3)  # no-load speed V / K_e


def test_locked_rotor_current_is_the_rl_step_response():
    decay = np.exp(-R * DT / L)
    i = 0.0
    for _ in range(40):
        i = electrical_step(0.0, i, 0.0, 12.0, 0.0, decay, (1 - decay) / R, 0.0, KT)[1]
    t = 40 * DT
    assert i == pytest.approx(12.0 / R * (1 - np.exp(-t * R / L)), rel=1e-12)


def test_pmsm_with_zero_d_voltage_reaches_the_dc_speed_of_its_back_emf():
    ke = back_emf_constant(np.array(KT), np.array(True))
    assert ke == pytest.approx(KT / 1.5)
    w, _, i_d = ours(10.0, 0.6, kt=KT, ke=ke, cross=5 * L)
    # at steady state with v_d = 0 the cross-coupling makes a small i_d; speed close to V / K_e
    assert w[-1] == pytest.approx(10.0 / ke, rel=0.05)
    assert abs(i_d) < 0.5


def test_phase_currents_amplitude_invariant_and_balanced():
    th = np.linspace(0, 4 * np.pi, 200)
    ph = phase_currents(np.zeros_like(th), np.full_like(th, 3.0), th)
    np.testing.assert_allclose(ph.sum(axis=-1), 0.0, atol=1e-12)
    np.testing.assert_allclose(np.max(np.abs(ph), axis=0), 3.0, rtol=1e-3)


def test_inverter_limits():
    lim = voltage_limit(48.0, np.array([False, True]))
    np.testing.assert_allclose(lim, [48.0, 48.0 / np.sqrt(3.0)])
    vd, vq = limit_voltage(np.array([30.0, 30.0]), np.array([40.0, 40.0]), lim)
    np.testing.assert_allclose(np.hypot(vd, vq), lim)
    np.testing.assert_allclose(vd / vq, 0.75)  # direction kept
    vd, vq = limit_voltage(np.array([0.0]), np.array([5.0]), np.array([48.0]))
    assert vq[0] == 5.0
