"""Wrist 2's gain estimate of healthy and faulty runs with the payload's centre of mass shifted, for four kinds of
CoM columns in the twins' current fit (docs/diagnostics.md, "The unknown payload CoM from the other joints"):

* ``gravity``: the CoM's gravity torque in closed form (twin residuals format 3, ``twin_fit.com_columns``);
* ``inverse dynamics``: gravity and the payload's inertia, MuJoCo's ``mj_inverse`` of the commanded motion with
  the CoM moved +-1 cm (central differences), over ``K_t N``;
* ``CoM twins``: the motor current of noise-free twins with the CoM moved 3 cm along each flange axis minus the
  unshifted one's (twin residuals format 4, ``twin_regressors.com_effects``);

each in the joint fit over all six joints (the campaign's) and leave-one-joint-out for wrist 2 (the CoM and
latency estimated from the other five joints with their own columns free, wrist 2's predicted CoM current
subtracted, then wrist 2's offset, gain and Coulomb fitted alone).  Runs at 2 kg, 4 s (the reduced campaign's
length), noise seed 11 against a noisy twin at 12345, regressors from the noise-free twin.

    PYTHONPATH=. python bench/com_columns_compare.py [--seeds 3 5]
"""

from __future__ import annotations

import argparse

import mujoco
import numpy as np

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.config import parse_trajectory
from ur5fault.health.twin_features import commanded_motion, projection_columns
from ur5fault.health.twin_fit import RCOND_NUISANCE, com_columns, hac_fit, latency_column, noise_scale
from ur5fault.health.twin_regressors import COM_AXES, REGRESSOR_EFFECTS, com_difference, com_effects
from ur5fault.sim.inverse_dynamics import place_payload
from ur5fault.sim.trajectories.ik import model_path

WRIST_2 = 4
KG = 2.0


def inverse_dynamics_columns(q, qd, qdd, params, kg: float, held) -> np.ndarray:
    """CoM columns ``(n, 6, 3)`` [A/m] from ``mj_inverse`` (gravity + inertia), central differences of +-1 cm."""
    m = mujoco.MjModel.from_xml_path(model_path())
    tcp = np.asarray(params.tcp_offset_m, float)
    m.site_pos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tcp")] = tcp
    place_payload(m, kg, tcp)
    body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "payload")
    d = mujoco.MjData(m)
    out = np.empty((q.shape[0], 6, 3))
    for k in range(3):
        tau = []
        for s in (0.01, -0.01):
            m.body_ipos[body] = 0.0
            m.body_ipos[body, k] = s
            t = np.empty((q.shape[0], 6))
            for i in range(q.shape[0]):
                d.qpos[:], d.qvel[:], d.qacc[:] = q[i], qd[i], qdd[i]
                mujoco.mj_inverse(m, d)
                t[i] = d.qfrc_inverse[:6]
            tau.append(t)
        out[:, :, k] = (tau[0] - tau[1]) / 0.02
    per_amp = np.asarray(params.motor.torque_constant_Nm_per_A) * np.asarray(params.gear.ratio)
    return out / per_amp[None, :, None] * np.asarray(held, float)[:, None, None]


def fit(resid, cols, nuisance, leave=None) -> tuple[float, np.ndarray]:
    """Wrist 2's gain estimate and the CoM estimate [m]: the joint fit, or leave-one-joint-out for ``leave``."""
    n = resid.shape[0]
    per = np.zeros((n, 6, 18))
    for j in range(6):
        for k, c in enumerate(cols):
            per[:, j, 3 * j + k] = c[:, j]
    w = 1.0 / noise_scale(resid)
    x, y = np.concatenate([per, nuisance], axis=2) * w[None, :, None], resid * w[None, :]
    if leave is None:
        f = hac_fit(x, y, RCOND_NUISANCE)
        return float(f.coef[3 * WRIST_2 + 1]), f.coef[18:21]
    keep = [i for i in range(6) if i != leave]
    nu = hac_fit(x[:, keep], y[:, keep], RCOND_NUISANCE).coef[18:]
    r = resid[:, leave] - nuisance[:, leave, :] @ nu
    own = hac_fit(np.stack([c[:, leave] for c in cols], axis=1)[:, None, :], r[:, None], RCOND_NUISANCE)
    return float(own.coef[1]), nu[:3]


def compare(seed: int) -> None:
    traj = parse_trajectory({"name": "random_pick_and_place", "seed": seed}, "trajectory")
    load = (make_effect("payload", mass_kg=KG), make_effect("temperature", temperature_C=28.0))
    com = lambda dx=0.0, dy=0.0, dz=0.0: make_effect("payload_com", dx_m=dx, dy_m=dy, dz_m=dz)  # noqa: E731
    kt, gain = make_effect("torque_constant", 5, scale=0.8), make_effect("current_sensor_gain", 5, gain=1.1)
    cases = {"healthy (0)": (), "dz 5 cm (0)": (com(dz=0.05),), "dx 2 cm (0)": (com(dx=0.02),),
             "dy -3 cm (0)": (com(dy=-0.03),), "dx -3 dy 2 dz 8 cm (0)": (com(-0.03, 0.02, 0.08),),
             "K_t 0.8 (+0.25)": (kt,), "K_t 0.8, dz 5 cm (+0.25)": (kt, com(dz=0.05)),
             "gain 1.1, dz 5 cm (+0.10)": (gain, com(dz=0.05))}
    specs = [RunSpec(c, 11, load + e) for c, e in cases.items()]
    specs += [RunSpec("twin", 12345, load), RunSpec("quiet", 12345, load + REGRESSOR_EFFECTS)]
    specs += [RunSpec(f"quiet {ax}", 12345, load + REGRESSOR_EFFECTS + e) for ax, e in zip(COM_AXES, com_effects())]
    sim = Simulator()
    res = sim.run(traj, specs, duration_s=4.0)
    assert all(s == "ok" for s in res.status), res.status
    ids = {s.run_id: i for i, s in enumerate(specs)}
    held = traj.gripped(res.t_s)
    motion = commanded_motion(res.t_s, res.q_set_rad, sim.params)
    twin = {"i_q_A": res["i_q_A"][ids["quiet"]], "T_gear_Nm": res["T_gear_Nm"][ids["quiet"]]}
    cols, _ = projection_columns(res.t_s, res.q_set_rad, twin, sim.params, motion)
    lat = latency_column(twin["i_q_A"], motion.dt_s)[:, :, None]
    qdd = np.gradient(motion.qd, motion.dt_s, axis=0)
    kinds = {
        "gravity": com_columns(res.q_set_rad, KG, sim.params, held, lambda: motion.flange),
        "inverse dynamics": inverse_dynamics_columns(res.q_set_rad, motion.qd, qdd, sim.params, KG, held),
        "CoM twins": com_difference(res["i_q_A"][[ids[f"quiet {ax}"] for ax in COM_AXES]], twin["i_q_A"]),
    }
    print(f"random_pick_and_place seed {seed}, {KG:g} kg, 4 s: wrist-2 gain estimate (CoM estimate x y z [cm])")
    print("| case (truth) | " + " | ".join(f"{k}, {w}" for k in kinds for w in ("joint", "LOO")) + " |")
    print("| --- " * (1 + 2 * len(kinds)) + "|")
    for c in cases:
        r = res["i_FB_A"][ids[c]] - res["i_FB_A"][ids["twin"]]
        cells = []
        for cc in kinds.values():
            for leave in (None, WRIST_2):
                g, d = fit(r, cols, np.concatenate([cc, lat], axis=2), leave)
                cells.append(f"{g:+.3f} ({d[0] * 100:+.1f} {d[1] * 100:+.1f} {d[2] * 100:+.1f})")
        print(f"| {c} | " + " | ".join(cells) + " |", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 5])
    for seed in ap.parse_args().seeds:
        compare(seed)


if __name__ == "__main__":
    main()
