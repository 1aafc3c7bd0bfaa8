"""Where the twin fits' regressors come from, measured (docs/diagnostics.md, "Regressors free of the twin's noise").

One pick-and-place motion (seed 3, 6.3 s), off-grid payloads 0.5 / 1.5 / 2.2 / 2.5 kg at 40 degC: a healthy run and
a wrist-2 torque constant of 0.8 (truth +0.25; noise seed 11), the twin (its own noise, seed 12345), the same twin
without sensor noise, and noise-free twins on the 1 kg grid at 28 degC.  Wrist 2's gain estimate
(:func:`ur5fault.health.twin_features.current_fit`, the residual always measured - noisy twin reading) with four
regressor sources:

1. the noisy twin's own motor current and gear torque (twin format 2);
2. the exact noise-free twin at the run's payload and temperature (what ``ur5fault diagnose`` now replays);
3. the 1 kg grid's interpolation with the viscous friction moved to 40 degC
   (:class:`ur5fault.health.twin_regressors.RegressorGrid`: what a campaign now uses, twin format 3);
4. a closed form from the commanded motion, **not adopted**: MuJoCo's inverse dynamics of the commanded angles,
   speeds and accelerations with the payload at the TCP while held + eq. (2)'s steady friction at the commanded
   speed (smooth sign, temperature) + the rotor's inertia, over ``K_t N`` (:func:`closed_form`).

Also the correlation of the grid's and the closed form's current with the exact noise-free twin's, per joint.

    PYTHONPATH=. python bench/twin_regressors.py
"""

from __future__ import annotations

import numpy as np

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.config import parse_trajectory
from ur5fault.health.twin_features import current_fit
from ur5fault.health.twin_regressors import REGRESSOR_EFFECTS, RegressorGrid, payload_grid
from ur5fault.sim.drive.friction import stribeck_level, viscous_coefficient
from ur5fault.sim.inverse_dynamics import inverse_dynamics_Nm, payload_model
from ur5fault.sim.trajectories.ik import model_path

PAYLOADS_KG = (0.5, 1.5, 2.2, 2.5)
TEMPERATURE_C = 40.0
GRID_TEMPERATURE_C = 28.0
DURATION_S = 6.3
WRIST_2 = 4


def closed_form(q, dt, params, payload_kg, held, temperature_C):
    """``(i_A, T_gear_Nm)`` of the commanded motion in closed form (module docstring, item 4)."""
    qd = np.gradient(q, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    m = payload_model(model_path(), payload_kg, params.tcp_offset_m)
    loaded = inverse_dynamics_Nm(m, q, qd, qdd)
    empty = inverse_dynamics_Nm(payload_model(model_path(), 0.0, params.tcp_offset_m), q, qd, qdd)
    tau = np.where(np.asarray(held, bool)[:, None], loaded, empty)
    fr, mo, ratio = params.friction, params.motor, np.asarray(params.gear.ratio)
    level = stribeck_level(qd, np.asarray(fr.coulomb_Nm), np.asarray(fr.static_Nm), fr.stribeck_rate_s_per_rad)[0]
    fv = viscous_coefficient(fr.viscous_Nms_per_rad, fr.viscous_temp_coeff_per_K, temperature_C, fr.reference_temp_C)
    friction = level * np.tanh(qd / np.asarray(fr.sign_smoothing_rad_s)) + fv * qd
    rotor = np.asarray(mo.rotor_inertia_kgm2) * ratio**2 * qdd
    link = 1.0 - np.asarray(fr.motor_side_share)
    return (tau + friction + rotor) / (np.asarray(mo.torque_constant_Nm_per_A) * ratio), tau + link * friction


def main() -> None:
    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")

    def load(kg, temp):
        return make_effect("payload", mass_kg=kg), make_effect("temperature", temperature_C=temp)

    grid = payload_grid(PAYLOADS_KG)
    specs = [RunSpec(f"grid {kg:g}", 0, load(kg, GRID_TEMPERATURE_C) + REGRESSOR_EFFECTS) for kg in grid]
    for kg in PAYLOADS_KG:
        specs += [RunSpec(f"healthy {kg:g}", 11, load(kg, TEMPERATURE_C)),
                  RunSpec(f"K_t 0.8 {kg:g}", 11, load(kg, TEMPERATURE_C) + (make_effect("torque_constant", 5,
                                                                                         scale=0.8),)),
                  RunSpec(f"twin {kg:g}", 12345, load(kg, TEMPERATURE_C)),
                  RunSpec(f"quiet {kg:g}", 12345, load(kg, TEMPERATURE_C) + REGRESSOR_EFFECTS)]
    sim = Simulator()
    res = sim.run(traj, specs, duration_s=DURATION_S)
    assert all(s == "ok" for s in res.status), res.status
    ids = {r.run_id: i for i, r in enumerate(specs)}
    held = traj.gripped(res.t_s)
    dt = float(res.t_s[1] - res.t_s[0])
    qd = np.gradient(res.q_set_rad, dt, axis=0)
    k = [ids[f"grid {kg:g}"] for kg in grid]
    reg = RegressorGrid(np.asarray(grid), GRID_TEMPERATURE_C, res["i_q_A"][k], res["T_gear_Nm"][k], qd, sim.params)
    print("correlation with the exact noise-free twin's motor current, joints 1-6: grid interpolation | closed form")
    sources = {}
    for kg in PAYLOADS_KG:
        quiet = ids[f"quiet {kg:g}"]
        twin = ids[f"twin {kg:g}"]
        sources[kg] = {"noisy twin (format 2)": (res["i_q_A"][twin], res["T_gear_Nm"][twin]),
                       "exact noise-free twin": (res["i_q_A"][quiet], res["T_gear_Nm"][quiet]),
                       "1 kg grid (format 3)": reg.signals(kg, TEMPERATURE_C),
                       "closed form": closed_form(res.q_set_rad, dt, sim.params, kg, held, TEMPERATURE_C)}
        exact = res["i_q_A"][quiet]
        r = [[np.corrcoef(sources[kg][s][0][:, j], exact[:, j])[0, 1] for j in range(6)]
             for s in ("1 kg grid (format 3)", "closed form")]
        print(f"  {kg:g} kg: " + " ".join(f"{v:.3f}" for v in r[0]) + " | " + " ".join(f"{v:.3f}" for v in r[1]))
    names = list(next(iter(sources.values())))
    print("| wrist-2 gain estimate (truth) | " + " | ".join(names) + " |")
    print("| --- " * (len(names) + 1) + "|")
    for kg in PAYLOADS_KG:
        for case, truth in (("healthy", "0"), ("K_t 0.8", "+0.25")):
            resid = res["i_FB_A"][ids[f"{case} {kg:g}"]] - res["i_FB_A"][ids[f"twin {kg:g}"]]
            cells = []
            for s in names:
                i_a, torque = sources[kg][s]
                coef, se, _ = current_fit(res.t_s, res.q_set_rad, resid, {"i_q_A": i_a, "T_gear_Nm": torque},
                                          sim.params, kg, held)
                cells.append(f"{coef[WRIST_2, 1]:+.3f} (SE {se[WRIST_2, 1]:.3f})")
            print(f"| {case}, {kg:g} kg ({truth}) | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
