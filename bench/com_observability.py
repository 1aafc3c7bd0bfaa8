"""Can the payload centre-of-mass shift's torque on one joint be predicted from the other five joints?
(docs/diagnostics.md, "The unknown payload CoM from the other joints"; issue 19.)

For random_pick_and_place motions (the diagnostics campaign's family), the sensitivity of every joint's torque to a
shift of the payload's CoM along the flange's x, y, z is computed by MuJoCo's inverse dynamics (``mj_inverse`` of
the commanded motion, central differences of +-1 cm in ``body_ipos`` of the payload), split into its gravity part
(``qvel = qacc = 0``) and the rest (inertial), in motor current [A per cm] (``/ (K_t N)``), while the payload is held.
Then per joint j, leave-one-joint-out: the shift is estimated by least squares from the other joints' columns,
each joint weighted by its current-sensor noise sigma (a white-noise model, one sample per 1 ms log step), and

* ``cond``: the condition number of the other joints' weighted 3 columns (and their singular values, A/cm / sigma);
* ``pred SD``: the SD [A] of joint j's predicted CoM current over the held samples, from that estimate's covariance,
  RMS over time, beside ``rms`` [A per cm of each axis] of joint j's own CoM current;
* ``wrist-2 gain error``: projected on joint j's gain column (the twin's motor current here: the inverse-dynamics
  current of the motion) and offset column, what a shift of 1 cm along each axis reads as a gain error when (a)
  nothing corrects it, (b) the other joints' estimate (exact, gravity-only columns as the twin fit has them today)
  corrects it: the gravity-only model's inertial miss.

    PYTHONPATH=. python bench/com_observability.py [--seeds 0 1 2 3] [--kg 2.0]
"""

from __future__ import annotations

import argparse

import mujoco
import numpy as np

from ur5fault.config import parse_trajectory
from ur5fault.sim.inverse_dynamics import place_payload
from ur5fault.sim.params import load_params
from ur5fault.sim.trajectories.ik import model_path

STEP_M = 0.01
NAMES = ("J1 base", "J2 shoulder", "J3 elbow", "J4 wrist 1", "J5 wrist 2", "J6 wrist 3")


def torques(m, d, q, qd, qdd) -> np.ndarray:
    out = np.empty_like(q)
    for k in range(q.shape[0]):
        d.qpos[:], d.qvel[:], d.qacc[:] = q[k], qd[k], qdd[k]
        mujoco.mj_inverse(m, d)
        out[k] = d.qfrc_inverse
    return out


def sensitivity(seed: int, kg: float, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(full, gravity) CoM sensitivities ``(n_held, 6, 3)`` [A per cm] and the nominal current ``(n_held, 6)``."""
    traj = parse_trajectory({"name": "random_pick_and_place", "seed": seed}, "trajectory")
    dt = traj.setpoint_period_s
    q = traj.q_set_rad
    t = np.arange(q.shape[0]) * dt
    held = np.asarray(traj.gripped(t), bool)
    qd = np.gradient(q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    q, qd, qdd = q[held], qd[held], qdd[held]
    m = mujoco.MjModel.from_xml_path(model_path())
    site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")
    tcp = np.asarray(params.tcp_offset_m)
    m.site_pos[site] = tcp
    place_payload(m, kg, tcp)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "payload")
    d = mujoco.MjData(m)
    per_amp = 1.0 / (np.asarray(params.motor.torque_constant_Nm_per_A) * np.asarray(params.gear.ratio))
    zero = np.zeros_like(q)
    nominal = torques(m, d, q, qd, qdd) * per_amp
    sensitivity.nominal_gravity = torques(m, d, q, zero, zero) * per_amp
    full = np.empty((q.shape[0], 6, 3))
    grav = np.empty_like(full)
    for k in range(3):
        tf, tg = [], []
        for s in (+1, -1):
            m.body_ipos[body] = 0.0
            m.body_ipos[body][k] = s * STEP_M
            tf.append(torques(m, d, q, qd, qdd))
            tg.append(torques(m, d, q, zero, zero))
        m.body_ipos[body] = 0.0
        full[:, :, k] = (tf[0] - tf[1]) / 2.0 * per_amp   # per cm (STEP_M = 1 cm)
        grav[:, :, k] = (tg[0] - tg[1]) / 2.0 * per_amp
    return full, grav, nominal


def loo(full: np.ndarray, grav: np.ndarray, nominal: np.ndarray, sigma: np.ndarray, dt_ratio: float) -> None:
    for j in range(6):
        others = [i for i in range(6) if i != j]
        a = (full[:, others, :] / sigma[others, None]).reshape(-1, 3)
        sv = np.linalg.svd(a, compute_uv=False)
        cov = np.linalg.pinv(a.T @ a) / dt_ratio  # per 1 ms log samples: dt_ratio log samples per setpoint
        sj = full[:, j, :]
        pred_var = np.einsum("tk,kl,tl->t", sj, cov, sj)
        rms = np.sqrt(np.mean(sj**2, axis=0))
        ginv = np.sqrt(np.mean((sj - grav[:, j, :]) ** 2, axis=0))
        print(f"  {NAMES[j]:12s} own CoM current rms x/y/z {rms[0]:.4f} {rms[1]:.4f} {rms[2]:.4f} A/cm "
              f"(inertial part {ginv[0]:.4f} {ginv[1]:.4f} {ginv[2]:.4f}); others' sv {sv[0]:.0f} {sv[1]:.0f} "
              f"{sv[2]:.1f}, cond {sv[0] / sv[2]:.1f}; pred SD {np.sqrt(pred_var.mean()):.5f} A")


def gain_reading(full: np.ndarray, grav: np.ndarray, nominal: np.ndarray, sigma: np.ndarray, j: int = 4) -> None:
    """What 1 cm along x, y, z reads as joint j's gain error: uncorrected, and corrected by the other joints'
    exact least-squares estimate with full (inertial) and gravity-only columns (both fitted to the full effect)."""
    others = [i for i in range(6) if i != j]
    x = np.stack([np.ones(full.shape[0]), nominal[:, j]], axis=1)  # offset, gain
    for k, ax in enumerate("xyz"):
        y = full[:, :, k]  # the true effect of 1 cm along ax on every joint
        row = []
        for label, cols in (("uncorrected", None), ("LOO full", full), ("LOO gravity", grav)):
            r = y[:, j].copy()
            if cols is not None:
                a = (cols[:, others, :] / sigma[others, None]).reshape(-1, 3)
                b = (y[:, others] / sigma[others]).reshape(-1)
                est = np.linalg.lstsq(a, b, rcond=None)[0]
                r = r - cols[:, j, :] @ est
            coef = np.linalg.lstsq(x, r, rcond=None)[0]
            row.append(f"{label} {coef[1]:+.3f} (offset {coef[0]:+.4f} A)")
        print(f"    1 cm along {ax}: J{j + 1} gain error " + "; ".join(row))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3])
    ap.add_argument("--kg", type=float, default=2.0)
    args = ap.parse_args()
    params = load_params()
    sigma = np.asarray(params.sensors.current_noise_A, float)
    for seed in args.seeds:
        full, grav, nominal = sensitivity(seed, args.kg, params)
        print(f"seed {seed}, {args.kg} kg, {full.shape[0]} held setpoints; J5 nominal current rms "
              f"{np.sqrt(np.mean(nominal[:, 4] ** 2)):.4f} A (gravity-only part of it rms "
              f"{np.sqrt(np.mean(sensitivity.nominal_gravity[:, 4] ** 2)):.4f})")
        loo(full, grav, nominal, sigma, 8.0)
        for j in (4, 3, 5):
            gain_reading(full, grav, nominal, sigma, j)


if __name__ == "__main__":
    main()
