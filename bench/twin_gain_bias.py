"""Wrist 2's current-gain estimate on healthy and faulty runs with the digital twin of twin format 2 (its own
sensor noise, an independent seed: what campaigns and ``ur5fault diagnose`` use) and of a "format 3" twin (no
sensor noise, ``NOISE_FREE``: measured, not adopted); docs/diagnostics.md, "Wrist 2's gain estimate on healthy
runs" and "A noise-free twin, measured".  ("Format 3" here is that rejected noise-free twin, not the twin residuals
format 3 campaigns now record, whose regressors come from noise-free twins: its third column, "noisy reading,
noise-free regressors"; bench/twin_regressors.py.)  Two parts.

1. ``--features FILE``: the healthy runs of a diagnostics table, ``twin_est_current_gain_err_j5`` by payload bin
   and its correlation with the nuisance columns and the estimate's own SE.
2. A small simulated set (one pick-and-place motion at 0, 1, 2 and 3 kg): healthy runs, a wrist-2 torque
   constant 0.8 and a current-sensor gain 1.1 (noise seed 11), and at 2 kg a payload CoM shift, each fitted
   (:func:`ur5fault.health.twin_features.current_fit`) against (a) a noisy twin (seed 12345, the format-2 twin:
   its noisy reading subtracted, its noisy motor current as the regressor) and (b) the noise-free twin (format 3);
   then the SE calibration: healthy runs of five noise seeds (21-25; format-2 twins 1021-1025) per payload, the
   spread of their estimates against the mean reported SE.

    PYTHONPATH=. python bench/twin_gain_bias.py [--features results/diagnostics/features.parquet]
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from ur5fault import RunSpec, Simulator, make_effect
from ur5fault.config import parse_trajectory
from ur5fault.health.twin_features import current_fit
from ur5fault.sim.effects import NOISE_FREE

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


PAYLOADS_KG = (0.0, 1.0, 2.0, 3.0)
#: noise seeds of the SE calibration's healthy runs; their format-2 twins have these + OLD_TWIN_SEED_OFFSET
SEEDS = (21, 22, 23, 24, 25)
OLD_TWIN_SEED_OFFSET = 1000
#: each case's true wrist-2 gain estimate (1/scale - 1 for a torque constant, gain - 1 for a sensor gain)
TRUTH = {"healthy": "0", "K_t 0.8": "+0.25", "gain 1.1": "+0.10", "CoM dz 5 cm": "0", "CoM dx 2 cm": "0"}


def _load(kg: float) -> tuple:
    return make_effect("payload", mass_kg=kg), make_effect("temperature", temperature_C=30.0)


def _gain(res, i: int, k: int, kg: float, sim, held, r: int | None = None) -> tuple[float, float, float]:
    """Wrist 2's gain estimate and its SE for run ``i`` against twin ``k`` (the residual and the regressors both
    from that twin, or the regressors from twin ``r``), and the CoM-x estimate [m]."""
    r = k if r is None else r
    resid = res["i_FB_A"][i] - res["i_FB_A"][k]
    twin = {"i_q_A": res["i_q_A"][r], "T_gear_Nm": res["T_gear_Nm"][r]}
    coef, se, nu = current_fit(res.t_s, res.q_set_rad, resid, twin, sim.params, kg, held)
    return float(coef[WRIST_2, 1]), float(se[WRIST_2, 1]), float(nu[0, 0])


def simulated() -> None:
    traj = parse_trajectory({"name": "random_pick_and_place", "seed": 3}, "trajectory")
    cases: dict[str, tuple[str, float, tuple]] = {}  # run id -> (case, payload kg, extra effects)
    for kg in PAYLOADS_KG:
        cases[f"healthy, {kg:.0f} kg"] = ("healthy", kg, ())
        cases[f"K_t 0.8, {kg:.0f} kg"] = ("K_t 0.8", kg, (make_effect("torque_constant", 5, scale=0.8),))
        cases[f"gain 1.1, {kg:.0f} kg"] = ("gain 1.1", kg, (make_effect("current_sensor_gain", 5, gain=1.1),))
    cases["CoM dz 5 cm, 2 kg"] = ("CoM dz 5 cm", 2.0, (make_effect("payload_com", dz_m=0.05),))
    cases["CoM dx 2 cm, 2 kg"] = ("CoM dx 2 cm", 2.0, (make_effect("payload_com", dx_m=0.02),))
    specs = [RunSpec(rid, 11, _load(kg) + eff) for rid, (_, kg, eff) in cases.items()]
    for kg in PAYLOADS_KG:
        specs += [RunSpec(f"old twin {kg:.0f}", 12345, _load(kg)),
                  RunSpec(f"new twin {kg:.0f}", 12345, _load(kg) + (NOISE_FREE,))]
        specs += [RunSpec(f"seed {s} {kg:.0f}", s, _load(kg)) for s in SEEDS]
        specs += [RunSpec(f"old twin {s} {kg:.0f}", s + OLD_TWIN_SEED_OFFSET, _load(kg)) for s in SEEDS]
    sim = Simulator()
    res = sim.run(traj, specs, duration_s=DURATION_S)
    assert all(st == "ok" for st in res.status), res.status
    held = traj.gripped(res.t_s)
    ids = {r.run_id: i for i, r in enumerate(specs)}
    noise = sim.params.sensors.current_noise_A[WRIST_2]
    for kg in PAYLOADS_KG:
        old, new = (res["i_q_A"][ids[f"{w} twin {kg:.0f}"]][:, WRIST_2] for w in ("old", "new"))
        print(f"wrist 2, {kg:.0f} kg: RMS twin motor current {np.sqrt(np.mean(old ** 2)):.4f} A (format 2), "
              f"{np.sqrt(np.mean(new ** 2)):.4f} A (format 3), their difference {np.std(old - new):.4f} A; "
              f"current-sensor noise sigma {noise} A")
    print("| wrist-2 gain estimate (truth) | format-2 twin (own noise) | format-3 twin (noise-free) | "
          "noisy twin's reading, noise-free twin's regressors | CoM x est. [m], format 3 |")
    print("| --- | --- | --- | --- | --- |")
    for rid, (case, kg, _) in cases.items():
        out, com = [], float("nan")
        for w in ("old", "new", "both"):
            k = ids[f"{'new' if w == 'new' else 'old'} twin {kg:.0f}"]
            r = ids[f"new twin {kg:.0f}"] if w == "both" else None
            g, se, com_x = _gain(res, ids[rid], k, kg, sim, held, r)
            out.append(f"{g:+.3f} (SE {se:.3f})")
            com = com_x if w == "new" else com
        print(f"| {rid} ({TRUTH[case]}) | {out[0]} | {out[1]} | {out[2]} | {com:+.4f} |")
    print(f"SE calibration, healthy runs of noise seeds {SEEDS[0]}-{SEEDS[-1]} (one motion): mean estimate, sd "
          "across seeds, mean reported SE, sd / mean SE")
    for kg in PAYLOADS_KG:
        line = []
        for w in ("old", "new", "both"):
            est = np.array([_gain(res, ids[f"seed {s} {kg:.0f}"],
                                  ids[f"new twin {kg:.0f}" if w == "new" else f"old twin {s} {kg:.0f}"],
                                  kg, sim, held, ids[f"new twin {kg:.0f}"] if w == "both" else None)[:2]
                            for s in SEEDS])
            sd, se = est[:, 0].std(ddof=1), est[:, 1].mean()
            line.append(f"{est[:, 0].mean():+.3f} sd {sd:.3f} SE {se:.3f} ratio {sd / se:.1f}")
        print(f"  {kg:.0f} kg: format 2: {line[0]}; format 3: {line[1]}; noisy reading + noise-free regressors: "
              f"{line[2]}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--features", help="a diagnostics features.parquet (its healthy runs are tabulated)")
    args = ap.parse_args()
    if args.features:
        table(args.features)
    simulated()


if __name__ == "__main__":
    main()
