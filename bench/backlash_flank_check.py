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


def campaign_spec(folder: Path) -> Path:
    """The campaign YAML a campaign folder's manifest names (relative to the repository where it is relative)."""
    import json

    name = json.loads((folder / "manifest.json").read_text()).get("campaign_file")
    if not name:
        raise SystemExit(f"{folder}: its manifest names no campaign file; give --spec")
    name = Path(name)
    return name if name.is_absolute() else REPO / name


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
    ap.add_argument("--spec", type=Path, default=None,
                    help="the campaign's YAML (default: the spec the campaign folder's manifest names)")
    ap.add_argument("--predictions", type=Path, default=None,
                    help="a benchmark's predictions.parquet scoring these runs (default: <campaign>/benchmark/ or "
                         "benchmark_transfer/predictions.parquet where it exists): the runs it scored, each run's "
                         "flag and the alpha_90 table")
    a = ap.parse_args(argv)
    camp = load_campaign(a.spec or campaign_spec(a.campaign))
    runs = {rc.run_id: rc for rc in camp.runs}
    df = pd.read_parquet(a.campaign / "features.parquet")
    predictions = a.predictions or next((p for p in (a.campaign / "benchmark" / "predictions.parquet",
                                                     a.campaign / "benchmark_transfer" / "predictions.parquet")
                                          if p.exists()), None)
    # the runs a benchmark scored (every run of another campaign, `benchmark --test`), else the test split
    scored = (df["run_id"].isin(pd.read_parquet(predictions, columns=["run_id"])["run_id"]) if predictions
              else df["split"] == "test")
    test = df[scored & (df["fault"] == "backlash") & df["fault_joint"].isin(a.joints)]
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
        rows.append({"run_id": row["run_id"], "joint": j, "size_deg": row["fault_size"],
                     "t": row.get(f"twin_est_backlash_rad_t_j{j}"),
                     "share_in_table": row.get(f"twin_gear_flank_share_j{j}", np.nan),
                     "twin_max_Nm": T[1, :, j - 1].max(), "twin_min_Nm": T[1, :, j - 1].min(), "twin_share": share[1],
                     "truth_max_Nm": T[0, :, j - 1].max(), "truth_min_Nm": T[0, :, j - 1].min(),
                     "truth_share": share[0]})
    out = pd.DataFrame(rows)
    if predictions is not None:
        out = with_flags(out, predictions)
    out = out.sort_values(["joint", "size_deg"])
    print("| " + " | ".join(out.columns) + " |\n|" + " --- |" * len(out.columns))
    for r in out.itertuples(index=False):
        print("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in r) + " |")
    if "flagged_run" in out:
        print(alpha_table(out))
    return 0


def with_flags(out: pd.DataFrame, predictions: Path) -> pd.DataFrame:
    """``out`` with each run's run-level flag (``flagged_run`` of a benchmark's ``predictions.parquet``: the flags
    the benchmark's alpha_90 is read from)."""
    pred = pd.read_parquet(predictions, columns=["run_id", "flagged_run"])
    flags = out.merge(pred, on="run_id", how="left", validate="one_to_one")
    if flags["flagged_run"].isna().any():
        raise SystemExit(f"{predictions}: not every backlash test run is scored there (another campaign's file?)")
    return flags


def alpha_table(out: pd.DataFrame) -> str:
    """Per joint, the benchmark's alpha_90 rule (``thresholds.backlash_thresholds``: logistic fit in log alpha,
    the run-level flags) over the runs whose gear torque reverses, read three ways: all runs, the twin's flank
    share as the feature table has it (what the benchmark and ``diagnose`` read, no label) and the run's own (the
    truth, nuisance included)."""
    from ur5fault.health.diagnostics.thresholds import backlash_thresholds
    from ur5fault.health.twin_features import FLANK_SHARE

    def a90(rows: pd.DataFrame, j: int) -> str:
        if rows.empty:
            return "- (0 runs)"
        test = pd.DataFrame({"fault": "backlash", "fault_joint": j, "fault_size": rows["size_deg"].to_numpy(float)})
        v = backlash_thresholds(test, rows["flagged_run"].to_numpy(bool), pd.DataFrame())["per_joint"][str(j)]
        text = v.get("alpha_90_bound") or (f"{v['alpha_90_deg']:.3g}" if np.isfinite(v["alpha_90_deg"]) else "-")
        return f"{text} ({v['detected']}/{v['n_test']})"

    lines = ["", "alpha_90 [deg] (flagged / runs) over the runs whose gear torque reverses:", "",
             "| joint | all runs | the table's (twin's) flank share > 2 % | run's own flank share > 2 % "
             "| runs: twin reverses, the run not |",
             "| --- | --- | --- | --- | --- |"]
    for j, rows in out.groupby("joint"):
        # the feature table's share where it has one (what the benchmark reads: since twin format 11 with the
        # payload CoM the current fit found fed back), else the twin simulated here (no CoM fed back)
        table = rows["share_in_table"].astype(float)
        twin = (table if table.notna().all() else rows["twin_share"]) > FLANK_SHARE
        truth = rows["truth_share"] > FLANK_SHARE
        lines.append(f"| {j} | {a90(rows, j)} | {a90(rows[twin], j)} | {a90(rows[truth], j)} | "
                     f"{int((twin & ~truth).sum())} |")
    return "\n".join(lines)


if __name__ == "__main__":
    raise SystemExit(main())
