"""A life campaign in which no unit reaches its failure criterion: every unit censored at max_cycles. Its manifest
stays strict JSON (no NaN for the life of units that did not fail) and the command line says no unit failed."""

from __future__ import annotations

import json

import pandas as pd
import yaml

from ur5fault.cli import main
from ur5fault.health.prognostics.life_store import life_stats

from tiny_fleet import TINY


def _strict(text):
    def refuse(name):
        raise ValueError(f"{name} in strict JSON")

    return json.loads(text, parse_constant=refuse)


def test_life_stats_of_failed_units_only():
    assert life_stats(pd.Series([float("nan"), float("nan")])) == {"median": None, "min": None, "max": None}
    assert life_stats(pd.Series([3.0e5, float("nan"), 5.0e5])) == {"median": 4.0e5, "min": 3.0e5, "max": 5.0e5}


def test_a_fleet_with_no_failure_writes_strict_json(tmp_path, capsys):
    # two inspections per unit and a 5 mm criterion that 100 000 cycles of wear at this rate cannot reach
    spec = {**TINY, "out": str(tmp_path / "fleet"),
            "life": {**TINY["life"], "units": 2, "max_cycles": 100_000,
                     "failure": {"feature": "tcp_dev_max_mm", "threshold": 5.0}}}
    path = tmp_path / "life.yaml"
    path.write_text(yaml.safe_dump(spec))
    assert main(["campaign", "run", str(path), "--quiet", "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert "2 failed" not in out and "0 failed, 2 censored" in out and "no unit failed within 100000 cycles" in out
    m = _strict((tmp_path / "fleet" / "manifest.json").read_text())
    assert m["n_failed"] == 0 and m["eol_cycles"] == {"median": None, "min": None, "max": None}


def test_a_unit_whose_wear_leaves_the_effects_ranges_is_censored_not_a_crash(tmp_path, capsys):
    """Wear constants the file check accepts (here a Coulomb factor rising by 10 per Mcycle of ageing) took a unit
    that never fails past coulomb_friction.scale's declared [0, 10]: the fleet stopped with "... is out of range
    [0, 10] -" at every resume (a newcomer probe). The unit now ends censored at its last inspection in range, and
    the summary says why it stopped before max_cycles."""
    from ur5fault.health.prognostics.fleet import beyond_model
    from ur5fault.health.prognostics.spec import load_life

    spec = {**TINY, "out": str(tmp_path / "fleet"), "duration_s": 0.3,
            "life": {**TINY["life"], "units": 2, "max_cycles": 2_000_000,
                     "failure": {"feature": "tcp_dev_max_mm", "threshold": 50.0},
                     "wear": {"backlash_rate_deg_per_MJ": 0.01, "friction_per_Mcycle": 10.0}}}
    path = tmp_path / "life.yaml"
    path.write_text(yaml.safe_dump(spec))
    assert main(["campaign", "run", str(path), "--quiet", "--jobs", "1"]) == 0
    out = capsys.readouterr().out
    assert "0 failed, 2 censored (0 at 2000000 cycles, 2 where their next wear state lay beyond" in out, out
    m = _strict((tmp_path / "fleet" / "manifest.json").read_text())
    assert m["n_censored_beyond_model"] == 2
    df = pd.read_parquet(tmp_path / "fleet" / "inspections.parquet")
    # 1 + 10 x cycles/1e6 <= 10 up to 900 000 cycles: inspections at 0, 100 000, ..., 900 000, then censored
    assert sorted(df.groupby("unit_id")["cycles"].max()) == [900_000, 900_000]
    assert (df["friction_scale_j1"] <= 10.0).all()
    # prognose on it: no failed unit, and the advice says why a longer max_cycles would not help
    assert main(["prognose", str(tmp_path / "fleet"), "--out", str(tmp_path / "b")]) == 2
    err = capsys.readouterr().err
    assert "2 unit(s) were censored where their wear left the simulator's effect ranges" in err, err
    camp = load_life(path)
    why = beyond_model(camp, [0.0] * 6, 1_000_000)
    assert why is not None and "coulomb_friction.scale = 11.0 is out of range [0, 10]" in why and not why.endswith("-")
