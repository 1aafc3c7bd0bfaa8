"""Discovery: a dictionary of physically meaningful candidate terms, computed from the replayed states,
for the sparse regression of what the library leaves (PySINDy's candidate-library idea; the selection is
the workflow's own forward selection with an information criterion, see ``search.py``).

Columns are the terms' quasi-static effect on the readings, weighted by the sensor noise:

* link torques ``T(t)`` (``torque_*`` effects: harmonics of the joint angle, Coulomb-,
  Stribeck-like, viscous, speed-squared, a torque held at rest in the direction of the last motion,
  inertia) appear in the motor current as ``T / (K_t N)``: the
  speed loop's integrator makes the motor supply them at frequencies below its bandwidth (15-60 Hz,
  far above a joint's motion); the simulation of the selected terms then corrects what is faster;
* the model's own gravity torque on a joint, and its partial derivatives in each link's mass (at the
  link's centre of mass) and centre of mass (link frame), from MuJoCo's Jacobians at the replayed angles;
* sensor terms: the current's drift with the logged joint temperature, and time shifts of the current
  and position readings (``-dy/dt`` per second of shift).

Dictionary families and their searched values are module constants; every term names the effect that
adds it to the model.
"""

from __future__ import annotations

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..sim.axes import N_JOINTS
from ..sim.effects import REGISTRY
from ..sim.engine import Simulator
from ..sim.inverse_dynamics import place_payload
from ..sim.terms import coulomb, harmonic, last_motion_sign, quadratic, rest_weight, stribeck
from ..twin.replay import LogReplay, Replayed
from .candidates import TermCandidate

#: periods per joint revolution searched for ripples periodic in the joint angle (assumption: a gear's
#: eccentricity or wear shows at low orders; 12 covers the strain-wave gear's two-lobe harmonics)
JOINT_PERIODS = tuple(range(1, 13))
#: Ripples periodic in the *motor* angle are left to the library's ``cogging`` effect, which acts on the
#: rotor: at the joints' speeds they are tens of hertz, faster than the speed loop, and a link-side term of
#: the same shape would misplace them in the drive chain (tried: 26 % low and half the gap left).
#: width of the Coulomb-like term's smooth sign [rad/s] (the registry's default of ``torque_coulomb``)
COULOMB_WIDTH_RAD_S = REGISTRY["torque_coulomb"].absent("width_rad_s")
#: Stribeck speeds searched [rad/s] (assumption: the span of published Stribeck speeds of harmonic drives)
STRIBECK_SPEEDS_RAD_S = (0.02, 0.05, 0.1, 0.2)
#: speed below which a joint counts as at rest for the holding term [rad/s] (the registry's default of
#: ``torque_holding``; assumption: well below the slowest commanded motion, above the replay's vibration)
HOLDING_SPEED_RAD_S = REGISTRY["torque_holding"].absent("speed_rad_s")
#: a temperature column is formed when the joint's logged temperature moves at least this much [K]
MIN_TEMPERATURE_SPAN_K = 0.5
#: a column whose unit coefficient changes the weighted residual's sum of squares by less than this is
#: no candidate (its term cannot act on these readings)
MIN_COLUMN_NORM2 = 1e-6
#: a link-mass term may take at most this share of the link's modelled mass away (a lighter link, not none)
MAX_MASS_LOSS = 0.9
#: samples of the centred moving average that smooths numerical derivatives of the replayed states
DERIVATIVE_SMOOTHING = 5


def _smooth(x: NDArray, k: int = DERIVATIVE_SMOOTHING) -> NDArray:
    pad = np.pad(x, ((k // 2, k // 2), (0, 0)), mode="edge")
    c = np.cumsum(np.vstack([np.zeros((1, x.shape[1])), pad]), axis=0)
    return (c[k:] - c[:-k]) / k


def _gravity(rp: LogReplay, q: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """Gravity torques at the replayed angles: the model's own ``(n, 6)``; per unit mass at each link's
    centre of mass ``(6, n, 6)``; per metre of each link's centre-of-mass shift along its x, y, z axes
    ``(6, 3, n, 6)`` [N*m]; and the links' masses [kg]."""
    sim = Simulator(rp.params)
    m = sim.model
    tcp = np.asarray(rp.params.tcp_offset_m)
    m.site_pos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")] = tcp
    place_payload(m, rp.log.payload_kg, tcp)
    d = mujoco.MjData(m)
    up = -np.asarray(m.opt.gravity)  # the force that holds 1 kg, per kg
    links = [int(m.jnt_bodyid[j]) for j in range(N_JOINTS)]
    n = q.shape[0]
    own, per_mass, per_shift = np.zeros((n, N_JOINTS)), np.zeros((N_JOINTS, n, N_JOINTS)), np.zeros(
        (N_JOINTS, 3, n, N_JOINTS))
    jacp, jacr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    for i in range(n):
        d.qpos[:] = q[i]
        d.qvel[:] = 0.0
        mujoco.mj_forward(m, d)
        own[i] = d.qfrc_bias[:N_JOINTS]
        # moving a centre of mass by R e_k moves the weight's moment arm by (R e_k) x up: every link and axis in
        # one call (np.cross per vector cost most of this loop)
        arm = np.cross(d.xmat[links].reshape(N_JOINTS, 3, 3).transpose(0, 2, 1), up)  # (link, k, 3)
        for li, b in enumerate(links):
            mujoco.mj_jac(m, d, jacp, jacr, d.xipos[b], b)
            per_mass[li, i] = jacp[:, :N_JOINTS].T @ up
            for k in range(3):
                per_shift[li, k, i] = m.body_mass[b] * (jacr[:, :N_JOINTS].T @ arm[li, k])
    return own, per_mass, per_shift, np.array([m.body_mass[b] for b in links])


def dictionary(rp: LogReplay, sim: Replayed, n: int, joints: list[int]) -> tuple[list[TermCandidate], NDArray]:
    """The dictionary's candidates and weighted columns ``(p, n, n_channels)`` over samples ``1..n``.

    Args:
        rp: the replay (parameters, log, noise sigma).
        sim: the replay under the current model, whose states the terms are functions of.
        n: samples of the fitting part.
        joints: joints whose residual is above the noise floor (joint-local terms only there).
    """
    period = rp.log.period_s
    S = len(rp.signals)
    sig = rp.sigma  # (S, 6)
    ktn = np.asarray(rp.params.motor.torque_constant_Nm_per_A) * rp.gear_ratio  # joint torque per motor ampere
    q = sim.q_rad[:n]
    qd = _smooth(np.gradient(q, period, axis=0))
    qdd = _smooth(np.gradient(qd, period, axis=0))
    didt = _smooth(np.gradient(sim.current_true_A[:n], period, axis=0))
    cands: list[TermCandidate] = []
    cols: list[NDArray] = []

    def add(cand: TermCandidate, per_channel: list[tuple[int, int, NDArray]]) -> None:
        """``per_channel``: (signal index, joint, values (n,) or (k, n)) before weighting."""
        col = np.zeros((cand.n_coef, n, S, N_JOINTS))
        for s, j, v in per_channel:
            col[:, :, s, j] = np.atleast_2d(v) / sig[s, j]
        if np.sum(col**2) < MIN_COLUMN_NORM2:  # e.g. a centre-of-mass shift along the joint's own axis
            return
        cands.append(cand)
        cols.extend(col.reshape(cand.n_coef, n, -1))

    def torque(j: int, family: str, effect: str, keys, values, unit: str, fixed=(), to_param: float = 1.0):
        add(TermCandidate(effect, j, family=family, keys=tuple(keys), fixed=tuple(fixed), to_param=to_param,
                          unit=unit, signal_per_coef=1.0 / ktn[j]), [(0, j, np.atleast_2d(values) / ktn[j])])

    for j in joints:
        for k in JOINT_PERIODS:
            torque(j, "joint_harmonic", "torque_joint_harmonic", ("sin_Nm", "cos_Nm"),
                   np.stack(harmonic(q[:, j], k)), "N*m", (("periods_per_rev", float(k)),))
        torque(j, "coulomb", "torque_coulomb", ("torque_Nm",), coulomb(qd[:, j], COULOMB_WIDTH_RAD_S)[0], "N*m",
               (("width_rad_s", COULOMB_WIDTH_RAD_S),))
        for vs in STRIBECK_SPEEDS_RAD_S:
            torque(j, "stribeck", "torque_stribeck", ("torque_Nm",), stribeck(qd[:, j], vs)[0], "N*m",
                   (("speed_rad_s", vs),))
        hold = last_motion_sign(qd[:, j], HOLDING_SPEED_RAD_S) * rest_weight(qd[:, j], HOLDING_SPEED_RAD_S)[0]
        torque(j, "holding", "torque_holding", ("torque_Nm",), hold, "N*m", (("speed_rad_s", HOLDING_SPEED_RAD_S),))
        torque(j, "viscous", "torque_viscous", ("coeff_Nms_per_rad",), qd[:, j], "N*m*s/rad")
        torque(j, "quadratic", "torque_quadratic", ("coeff_Nms2_per_rad2",), quadratic(qd[:, j])[0], "N*m*s^2/rad^2")
        torque(j, "inertia", "inertia", ("inertia_kgm2",), qdd[:, j], "kg*m^2")
        add(TermCandidate("current_time_shift", j, family="current_time_shift", keys=("shift_ms",), to_param=1e3,
                          unit="s", signal_per_coef=1.0), [(0, j, -didt[:, j])])
        add(TermCandidate("position_time_shift", j, family="position_time_shift", keys=("shift_ms",), to_param=1e3,
                          unit="s", signal="position_rad", signal_per_coef=1.0), [(1, j, -qd[:, j])])
        temp = rp.log.temperature_C
        if temp is not None and np.ptp(temp[1 : n + 1, j]) >= MIN_TEMPERATURE_SPAN_K:
            t_ref = float(rp.params.joint_temperature_C[j])
            add(TermCandidate("current_temperature_drift", j, family="temperature_drift", keys=("coeff_A_per_K",),
                              fixed=(("reference_C", t_ref),), unit="A/K", signal_per_coef=1.0),
                [(0, j, temp[1 : n + 1, j] - t_ref)])
    own, per_mass, per_shift, masses = _gravity(rp, q)
    for j in joints:
        torque(j, "gravity_scale", "torque_gravity_scale", ("scale",), own[:, j], "-")
    for li in range(N_JOINTS):  # a link's mass and centre of mass act on every joint that carries it
        def on_all(values: NDArray) -> list[tuple[int, int, NDArray]]:
            return [(0, i, values[:, i] / ktn[i]) for i in range(N_JOINTS)]

        add(TermCandidate("link_mass", li, family="link_mass", keys=("mass_kg",), unit="kg", local_=False,
                          signal_per_coef=float("nan"), lower=-MAX_MASS_LOSS * float(masses[li])),
            on_all(per_mass[li]))
        for k, key in enumerate(("com_dx_m", "com_dy_m", "com_dz_m")):
            add(TermCandidate("link_mass", li, family="link_com", keys=(key,), unit="m", local_=False,
                              signal_per_coef=float("nan")), on_all(per_shift[li, k]))
    return cands, np.array(cols)
