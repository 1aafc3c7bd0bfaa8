"""Does the twin know where a backlash test run's gear torque reverses?  (issue 19: the backlash alpha_90 "on the
motions where its gear torque reverses".)

    python bench/backlash_flank_check.py [--campaign results/diagnostics] [--joints 3 5]

For every backlash test run of a diagnostics campaign on the given joints, simulates twice without sensor noise and
without the fault: the *twin* (what the robot knows: the run's commanded motion, configured payload mass and
temperature; ``campaign.digital_twin.twin_effects``) and the *truth* (the run's own conditions, the nuisance the
robot does not know included: the payload's centre of mass and the setpoint latency; the run's effects less the
backlash).  Prints per run its size, the feature table's backlash t value and flank share (where the campaign has
it), and per simulation the gear torque's largest and smallest value on the faulty joint [N*m] and its flank share
(``health.twin_features.flank_share``).  Where the twin's flank share is under 2 % the torque only approaches zero
and the clearance is not crossed; where twin and truth disagree, the unknown nuisance decides the flank.

About 1 s of CPU per run (two noise-free 13 s simulations).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pandas as pd

REPO = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    from ur5fault.campaign.digital_twin import twin_effects
    from ur5fault.campaign.identity import run_effects
    from ur5fault.campaign.spec import load_campaign
    from ur5fault.config import parse_trajectory
    from ur5fault.health.twin_features import flank_share
    from ur5fault.sim.effects import make_effect
    from ur5fault.sim.engine import RunSpec, Simulator
    from ur5fault.sim.params import load_params

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--campaign", type=Path, default=REPO / "results" / "diagnostics")
    ap.add_argument("--joints", type=int, nargs="+", default=[3, 5])
    a = ap.parse_args(argv)
    camp = load_campaign(REPO / "campaigns" / "diagnostics.yaml")
    runs = {rc.run_id: rc for rc in camp.runs}
    df = pd.read_parquet(a.campaign / "features.parquet")
    test = df[(df["split"] == "test") & (df["fault"] == "backlash") & df["fault_joint"].isin(a.joints)]
    sim = Simulator(load_params())
    quiet = (make_effect("sensor_noise", scale=0.0),)
    rows = []
    for _, row in test.iterrows():
        rc, j = runs[row["run_id"]], int(row["fault_joint"])
        truth = tuple(e for e in run_effects(camp, rc) if e.name != "backlash") + quiet
        res = sim.run(parse_trajectory(rc.cond["trajectory"], "trajectory"),
                      [RunSpec("truth", 0, truth), RunSpec("twin", 0, twin_effects(camp, rc) + quiet)])
        T = res["T_gear_Nm"]
        share = [flank_share(T[k])[j - 1] for k in (0, 1)]  # truth, twin
        rows.append({"joint": j, "size_deg": row["fault_size"], "t": row.get(f"twin_est_backlash_rad_t_j{j}"),
                     "share_in_table": row.get(f"twin_gear_flank_share_j{j}", np.nan),
                     "twin_max_Nm": T[1, :, j - 1].max(), "twin_min_Nm": T[1, :, j - 1].min(), "twin_share": share[1],
                     "truth_max_Nm": T[0, :, j - 1].max(), "truth_min_Nm": T[0, :, j - 1].min(),
                     "truth_share": share[0]})
    out = pd.DataFrame(rows).sort_values(["joint", "size_deg"])
    print("| " + " | ".join(out.columns) + " |\n|" + " --- |" * len(out.columns))
    for r in out.itertuples(index=False):
        print("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in r) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
