"""The RUL benchmark end to end on a synthetic fleet whose degradation is known (fast), so the
pipeline's files and its ranking of the estimators can be checked without simulation."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

from ur5fault.cli import main
from ur5fault.health.features import FEATURE_UNITS
from ur5fault.health.prognostics.benchmark import run_prognose
from ur5fault.health.prognostics.life_store import add_life_labels


def synthetic_fleet(n_units: int = 24, seed: int = 0) -> pd.DataFrame:
    """Units whose backlash (and with it the mismatch feature and the TCP deviation) grows linearly at a
    unit-specific rate (lognormal sigma 0.3), inspected every 1000 cycles to 0.5 mm."""
    rng = np.random.default_rng(seed)
    rows = []
    for u in range(n_units):
        rate = 1e-4 * np.exp(0.3 * rng.standard_normal())      # mm per cycle
        split = "test" if u % 3 == 0 else "train"
        n, k = 0, 0
        while True:
            dev = rate * n + 0.005 * abs(rng.standard_normal())
            row = {c: 0.0 for c in FEATURE_UNITS}
            row.update(unit_id=f"u{u:03d}", inspection=k, cycles=n, split=split, status="ok", tcp_dev_max_mm=dev,
                       enc_mismatch_hyst_rad_j2=1e-3 * rate * n + 2e-6 * rng.standard_normal(),
                       failed=bool(dev >= 0.5))
            rows.append(row)
            if row["failed"]:
                break
            n, k = n + 1000, k + 1
    return add_life_labels(pd.DataFrame(rows))


def test_benchmark_files_and_the_model_beats_the_population_baseline(tmp_path, capsys):
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = synthetic_fleet()
    assert (df.groupby("unit_id")["split"].nunique() == 1).all()
    df.to_parquet(fleet / "inspections.parquet")
    assert main(["prognose", str(fleet), "--out", str(tmp_path / "bench")]) == 0
    m = json.loads((tmp_path / "bench" / "metrics.json").read_text())
    assert {"rul_alpha_cone.png", "health_index.png"} <= {p.name for p in (tmp_path / "bench").iterdir()}
    w, n = m["estimators"]["wiener"], m["estimators"]["naive"]
    assert m["dataset"]["n_test_units"] == 8 and m["dataset"]["n_train_units"] == 16
    # unit-to-unit spread of 30 % defeats a population life, not a unit's own history
    assert w["rmse_cycles"]["0.5"] < 0.5 * n["rmse_cycles"]["0.5"]
    assert w["alpha_lambda_accuracy"] >= 0.75
    assert 0.5 <= w["interval_coverage_90"] <= 1.0
    assert "RUL RMSE" in capsys.readouterr().out
    # predictions only for held-out units, and every pre-failure inspection of each
    pred = pd.read_parquet(tmp_path / "bench" / "predictions_wiener.parquet")
    test_ids = set(df.loc[df["split"] == "test", "unit_id"])
    assert set(pred["unit_id"]) == test_ids
    assert len(pred) == int(((df["split"] == "test") & (df["rul_cycles"] > 0)).sum())
    # without --out the report goes inside the campaign folder, as `ur5fault benchmark DIR`'s (was DIR/..: a user's
    # results/mylife wrote results/benchmark, shared by every life campaign there)
    assert main(["prognose", str(fleet)]) == 0
    assert (fleet / "benchmark" / "metrics.json").is_file() and not (tmp_path / "benchmark").exists()


def test_benchmark_is_deterministic_under_its_seed(tmp_path):
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    synthetic_fleet(12, 1).to_parquet(fleet / "inspections.parquet")
    a = run_prognose(fleet, tmp_path / "a", seed=3)
    b = run_prognose(fleet, tmp_path / "b", seed=3)
    assert a["estimators"] == b["estimators"]
    assert a["goals"]["baseline"] == "wiener"  # without the twin, the feature-only baseline is judged


def test_a_report_replaced_with_replace_is_said_replaced(tmp_path, capsys):
    """`prognose --replace` over an earlier report said "wrote", where simulate, show and plot say "replaced"."""
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    synthetic_fleet(12, 1).to_parquet(fleet / "inspections.parquet")
    out = tmp_path / "bench"
    assert main(["prognose", str(fleet), "--out", str(out)]) == 0
    cap = capsys.readouterr()  # the result line on stdout, as every command's (was on stderr)
    assert cap.out.splitlines()[-1].startswith(f"wrote {out}/report.md, metrics.json and figures in ")
    assert "metrics.json and figures" not in cap.err
    assert main(["prognose", str(fleet), "--out", str(out), "--replace"]) == 0
    cap = capsys.readouterr()
    last = cap.out.splitlines()[-1]
    assert last.startswith(f"replaced {out}/report.md, metrics.json and figures in "), last
    assert "metrics.json and figures" not in cap.err
    assert "replaced" not in json.loads((out / "metrics.json").read_text())  # said, not stored


def test_a_folder_without_inspections_gets_advice_it_can_follow(tmp_path, capsys):
    """A fault campaign's folder, an unfinished life campaign's and a plain file: each refused in one line that says
    what the folder holds (the advice to run a life campaign into it was refused by `campaign run` there)."""
    fault = tmp_path / "fault"
    fault.mkdir()
    (fault / "manifest.json").write_text(json.dumps({"name": "default", "kind": "fault", "state": "complete"}))
    life = tmp_path / "life"
    life.mkdir()
    (life / "manifest.json").write_text(json.dumps({"name": "lt", "kind": "life", "state": "running",
                                                    "campaign_file": "lt.yaml"}))
    (tmp_path / "afile").write_text("x")
    for folder, words in ((fault, "holds the fault campaign 'default', not a life campaign"),
                          (life, f"the life campaign 'lt' in {life} has not finished (state 'running'): resume it "
                                 f"with `ur5fault campaign run lt.yaml --out {life}`"),
                          (tmp_path / "afile", "afile: a file, not a folder"),
                          (tmp_path / "empty", "run a life campaign into")):
        assert main(["prognose", str(folder), "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], err


def test_a_fault_campaign_folder_is_refused_before_its_earlier_benchmark(tmp_path, capsys):
    """`prognose DIR` of a fault campaign whose DIR/benchmark holds `ur5fault benchmark`'s report was refused with
    "--out DIR/benchmark/report.md: an earlier result is there; give --replace", not why (a newcomer probe)."""
    fault = tmp_path / "fault"
    (fault / "benchmark").mkdir(parents=True)
    (fault / "manifest.json").write_text(json.dumps({"name": "default", "kind": "fault", "state": "complete"}))
    (fault / "benchmark" / "report.md").write_text("a diagnostics report")
    assert main(["prognose", str(fault)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a life campaign" in err[0] and "earlier result" not in err[0], err


def test_a_gap_in_the_failure_feature_is_named_not_blamed_on_the_fleet_size(tmp_path, capsys):
    """A NaN in tcp_dev_max_mm of a hand-edited table was refused with the estimators' numpy message and the advice
    "(a larger fleet, shorter inspection intervals or a longer max_cycles)", which no fleet size fixes."""
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    df = synthetic_fleet(12, 1)
    df.loc[df.index[:3], "tcp_dev_max_mm"] = np.nan
    df.to_parquet(fleet / "inspections.parquet")
    assert main(["prognose", str(fleet), "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "tcp_dev_max_mm is missing (NaN) or infinite in 3 inspection(s)" in err[0], err
    assert "larger fleet" not in err[0]
    # a gap in the fleet's own record (cycles, true clearance) likewise (the estimators' numpy message before)
    for col in ("backlash_deg_j3", "cycles"):
        df = synthetic_fleet(12, 1)
        for j in range(1, 7):
            df[f"backlash_deg_j{j}"] = 0.0
        df.loc[df.index[:2], col] = np.nan
        df.to_parquet(fleet / "inspections.parquet")
        assert main(["prognose", str(fleet), "--out", str(tmp_path / f"b_{col}")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"the fleet's record {col} is missing (NaN) or infinite in 2 inspection(s)" in err[0]


def test_the_resume_advice_for_an_unfinished_life_campaign_carries_yes_where_campaign_run_asks_it(tmp_path, capsys):
    """`prognose` on an unfinished prognostics_small campaign advised `ur5fault campaign run
    .../prognostics_small.yaml --out life1` without --yes, which `campaign run` refuses for that fleet (over 1000
    runs): the advice is `campaign status`'s command, --yes in it exactly where the fleet needs it."""
    from importlib.resources import files

    import yaml

    from tiny_fleet import TINY

    small = files("ur5fault") / "campaigns" / "prognostics_small.yaml"
    for data, file, yes in ((yaml.safe_load(small.read_text()), str(small), True), (TINY, "tiny.yaml", False)):
        life = tmp_path / data["name"]
        life.mkdir()
        (life / "manifest.json").write_text(json.dumps({"name": data["name"], "kind": "life", "state": "running",
                                                        "campaign_file": file, "campaign_data": data}))
        assert main(["prognose", str(life), "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        command = f"`ur5fault campaign run {file} --out {life}{' --yes' if yes else ''}`"
        assert len(err) == 1 and f"resume it with {command}" in err[0], err
