"""Why the twin's current-gain estimate on wrist 2 is biased on healthy runs (docs/diagnostics.md, "Wrist 2's
gain estimate on healthy runs").  An explanation, not a fix: two parts.

1. ``--features FILE``: the healthy runs of a diagnostics table, ``twin_est_current_gain_err_j5`` by payload bin
   and its correlation with the nuisance columns and the estimate's own SE.
2. A small simulated set (one pick-and-place motion, 0 and 2 kg, noise seed 11 against the twin's 12345):
   healthy runs, a payload CoM shift, a wrist-2 torque constant 0.8 and a current-sensor gain 1.1, each fitted
   (:func:`ur5fault.health.twin_features.current_fit`) with the regressors taken from (a) the noisy twin's
   motor current, as the campaign does, and (b) the same twin simulated without sensor noise.

    PYTHONPATH=. python bench/twin_gain_bias.py --features results/diagnostics/features.parquet
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np
import pandas as pd

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.config import parse_trajectory
from ur5fault.health.twin_features import current_fit

GAIN_J5 = "twin_est_current_gain_err_j5"
NUISANCE = ("payload_kg", "payload_com_dx_m", "payload_com_dy_m", "payload_com_dz_m", "delay_ms", "temperature_C")
#: simulated time: the whole motion of random_pick_and_place seed 3 (picked at 0.87 s, released at 5.21 s)
DURATION_S = 6.3
#: wrist 2 (0-based index of the fit's arrays)
WRIST_2 = 4


def table(path: str) -> None:
    df = pd.read_parquet(path)
    h = df[df["fault"] == "healthy"].copy()
    print(f"{len(h)} healthy runs; {GAIN_J5}: median {h[GAIN_J5].median():+.3f}, 5-95 % "
          f"{h[GAIN_J5].quantile(0.05):+.3f} to {h[GAIN_J5].quantile(0.95):+.3f}")
    for j in range(1, 7):
        print(f"  j{j}: median {h[f'twin_est_current_gain_err_j{j}'].median():+.4f}")
    h["payload_bin"] = pd.cut(h["payload_kg"], [-0.01, 0.1, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
    print(h.groupby("payload_bin", observed=True)[GAIN_J5].describe()[["count", "25%", "50%", "75%"]].round(3))
    for c in (*NUISANCE, f"twin_est_current_gain_err_se_j{WRIST_2 + 1}"):
        print(f"  Pearson r with {c}: {np.corrcoef(h[c], h[GAIN_J5])[0, 1]:+.3f}"
              f" (Spearman {h[c].corr(h[GAIN_J5], method='spearman'):+.3f})")


def simulated() -> None:
    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")

    def load(kg):
        return make_effect("payload", mass_kg=kg), make_effect("temperature", temperature_C=30.0)

    cases = {  # run id -> (payload kg, extra effects)
        "healthy 0 kg": (0.0, ()),
        "K_t 0.8, 0 kg": (0.0, (make_effect("torque_constant", 5, scale=0.8),)),
        "gain 1.1, 0 kg": (0.0, (make_effect("current_sensor_gain", 5, gain=1.1),)),
        "healthy 2 kg": (2.0, ()),
        "CoM dz 5 cm, 2 kg": (2.0, (make_effect("payload_com", dz_m=0.05),)),
        "CoM dx 2 cm, 2 kg": (2.0, (make_effect("payload_com", dx_m=0.02),)),
        "K_t 0.8, 2 kg": (2.0, (make_effect("torque_constant", 5, scale=0.8),)),
        "gain 1.1, 2 kg": (2.0, (make_effect("current_sensor_gain", 5, gain=1.1),)),
    }
    specs = [RunSpec(rid, 11, load(kg) + eff) for rid, (kg, eff) in cases.items()]
    specs += [RunSpec("twin 0 kg", 12345, load(0.0)), RunSpec("twin 2 kg", 12345, load(2.0))]
    sim = Simulator()
    res = sim.run(traj, specs, duration_s=DURATION_S)
    s = sim.params.sensors
    quiet = {f.name: tuple(0.0 for _ in getattr(s, f.name)) for f in dataclasses.fields(s) if "_noise_" in f.name}
    clean_sim = Simulator(dataclasses.replace(sim.params, sensors=dataclasses.replace(s, **quiet)))
    clean = clean_sim.run(traj, [RunSpec("clean 0 kg", 1, load(0.0)), RunSpec("clean 2 kg", 1, load(2.0))],
                          duration_s=DURATION_S)
    assert all(st == "ok" for st in (*res.status, *clean.status))
    held = traj.gripped(res.t_s)
    ids = [r.run_id for r in specs]
    for kg, c in ((0.0, 0), (2.0, 1)):
        k = ids.index(f"twin {kg:.0f} kg")
        noisy, quiet_iq = res["i_q_A"][k][:, WRIST_2], clean["i_q_A"][c][:, WRIST_2]
        print(f"wrist 2, {kg:.0f} kg: RMS twin motor current {np.sqrt(np.mean(noisy ** 2)):.4f} A, of the noise-free"
              f" twin {np.sqrt(np.mean(quiet_iq ** 2)):.4f} A, their difference {np.std(noisy - quiet_iq):.4f} A;"
              f" current-sensor noise sigma {s.current_noise_A[WRIST_2]} A")
    print("truth: K_t 0.8 -> 1/0.8 - 1 = +0.25, gain 1.1 -> +0.10, healthy 0")
    print(f"{'case':20s} {'noisy-twin regressor':>26s} {'noise-free regressor':>26s}   CoM x est [m]")
    for i, (rid, (kg, _)) in enumerate(cases.items()):
        k = ids.index(f"twin {kg:.0f} kg")
        resid = res["i_FB_A"][i] - res["i_FB_A"][k]
        out = []
        for iq in (res["i_q_A"][k], clean["i_q_A"][0 if kg == 0.0 else 1]):
            coef, se, nu = current_fit(res.t_s, res.q_set_rad, resid, {"i_q_A": iq, "T_gear_Nm": res["T_gear_Nm"][k]},
                                       sim.params, kg, held)
            out.append(f"{coef[WRIST_2, 1]:+.3f} (SE {se[WRIST_2, 1]:.3f})")
        print(f"{rid:20s} {out[0]:>26s} {out[1]:>26s}   {nu[0, 0]:+.4f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--features", help="a diagnostics features.parquet (its healthy runs are tabulated)")
    args = ap.parse_args()
    if args.features:
        table(args.features)
    simulated()


if __name__ == "__main__":
    main()
