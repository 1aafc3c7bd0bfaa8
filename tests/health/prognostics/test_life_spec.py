"""Life-campaign files: validation with one-line errors, the split by unit, the fleet's draws."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ur5fault.cli import main
from ur5fault.errors import ParameterError, UnknownNameError
from ur5fault.health.prognostics.spec import build_life, is_life_file, split_units

from conftest import as_numpy

BASE = {"name": "t", "life": {"units": 20, "seed": 3, "interval_cycles": 1000, "max_cycles": 10000,
                              "duty": {"trajectories": ["pick_and_place"], "payload_kg": [0.5, 2.0]}}}


def _with(**life):
    return {**BASE, "life": {**BASE["life"], **life}}


def test_split_is_by_unit_and_never_puts_a_unit_on_both_sides():
    camp = build_life({**BASE, "split": {"test_fraction": 0.3, "seed": 1}}, "t")
    test = {u.unit_id for u in camp.units if u.split == "test"}
    train = {u.unit_id for u in camp.units if u.split == "train"}
    assert len(test) == 6 and len(train) == 14 and not test & train
    assert split_units(5, 0.01, 0).count("test") == 1          # at least one held-out unit
    assert split_units(5, 0.95, 0).count("train") == 1         # at least one unit to fit on


def test_fleet_draws_are_deterministic_and_do_not_depend_on_fleet_size():
    a = build_life(BASE, "t")
    b = build_life(_with(units=40), "t")
    assert [(u.payload_kg, u.temperature_C) for u in a.units] == [(u.payload_kg, u.temperature_C) for u in b.units[:20]]
    assert all(0.5 <= u.payload_kg <= 2.0 for u in a.units)
    assert len({u.payload_kg for u in a.units}) == 20


@pytest.mark.parametrize("life, match", [
    ({"units": 1}, "life.units"),
    ({"interval_cycles": 0}, "life.interval_cycles"),
    ({"max_cycles": 10}, "life.max_cycles"),
    ({"failure": {"feature": "tcp_dev_max_m"}}, r"life.failure.feature: unknown feature 'tcp_dev_max_m' "),
    ({"failure": {"threshold": -1}}, "life.failure.threshold"),
    ({"wear": {"unit_sigma": -1}}, "life.wear.unit_sigma"),
    ({"wear": {"backlash_rate_deg_per_MJ": float("nan")}}, r"^t: life.wear.backlash_rate_deg_per_MJ = nan"),
    ({"wear": {"backlash_rate_deg_per_MJ": "fast"}}, r"^t: life.wear.backlash_rate_deg_per_MJ = 'fast' must be a "
                                                     r"number in \(0, 1\]$"),
    ({"wear": {"rate": 1}}, "life.wear"),
    ({"wear": {"unit_sigma": np.True_}}, r"^t: life.wear.unit_sigma = np.True_ must be a number in \[0, 2\]$"),
    ({"duty": {"payload_kg": [2, 1]}}, "life.duty.payload_kg"),
    ({"duty": {"trajectories": ["nowhere"]}}, "trajector"),
    ({"lifetime": 3}, "lifetime"),
])
def test_bad_life_files_are_refused_naming_the_key(life, match):
    with pytest.raises((ParameterError, UnknownNameError), match=match):
        build_life(_with(**life), "t")


def test_a_life_file_of_numpy_numbers_is_the_one_of_the_numbers_they_hold():
    """A life mapping built from numpy results: `wear: {friction_per_deg: np.int64(5)}` was refused as no number, and
    the manifest's copy of the mapping held `np.int64(20)` as the text "20" (JSON's default=str), which a status check
    rebuilding the campaign from it refuses; a unit's trajectory kept its numpy option."""
    spec = _with(wear={"friction_per_deg": 5, "unit_sigma": 0.3},
                 duty={"trajectories": [{"name": "random_pick_and_place", "seed": 3}], "payload_kg": [0.5, 2.0]})
    plain, numpy = build_life(spec, "t"), build_life(as_numpy(spec), "t")
    assert numpy == plain and numpy.text == plain.text and json.dumps(numpy.data) == json.dumps(plain.data)
    assert numpy.data["life"]["units"] == 20 and type(numpy.wear.friction_per_deg) is int
    assert type(numpy.units[0].trajectory["seed"]) is int


@pytest.mark.parametrize("out", [5, ["a", "b"], ""])
def test_a_life_files_out_must_be_a_folder_name(out):
    """As a campaign file's: a number or a list was a traceback deep in the path handling, and an empty ``out``
    wrote the whole fleet into the working folder among the user's files."""
    with pytest.raises(ParameterError, match=r"^t: out = .* must be a non-empty one-line text"):
        build_life({**BASE, "out": out}, "t")
    assert str(build_life({**BASE, "out": "fleets/a"}, "t").out) == "fleets/a"
    assert str(build_life({**BASE, "out": "fleets/a"}, "t", out="cli").out) == "cli"  # the command line first


@pytest.mark.parametrize("name", ["../../evil", "a/../../b", "..", "/tmp/fleet"])
def test_a_life_files_name_keeps_its_default_folder_inside_results(name):
    """The name is the default folder results/NAME: ``../../evil`` wrote the fleet two folders above results/. A name
    with a subfolder stays inside it, and any name goes where out: or --out sends the fleet."""
    with pytest.raises(ParameterError, match=r"^t: name = .* must name a folder inside results/"):
        build_life({**BASE, "name": name}, "t")
    assert str(build_life({**BASE, "name": "fleet.v2"}, "t").out) == "results/fleet.v2"
    assert str(build_life({**BASE, "name": "study/v1"}, "t").out) == "results/study/v1"
    assert str(build_life({**BASE, "name": name}, "t", out="cli").out) == "cli"


def test_cli_bad_life_file_is_one_line_exit_2(tmp_path, capsys):
    f = tmp_path / "life.yaml"
    f.write_text("name: x\nlife:\n  units: 1\n")
    assert is_life_file(f)
    assert main(["campaign", "run", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ur5fault: error: ") and err.count("\n") == 1 and "life.units" in err


def test_cli_refuses_campaign_options_a_life_campaign_does_not_take(tmp_path, capsys):
    f = tmp_path / "life.yaml"
    f.write_text("name: x\nlife:\n  units: 3\n")
    assert main(["campaign", "run", str(f), "--out", str(tmp_path / "o"), "--threshold-mm", "0.3"]) == 2
    assert "--threshold-mm does not apply to a life campaign" in capsys.readouterr().err


def test_a_life_campaign_that_could_run_for_days_starts_only_with_yes(tmp_path, capsys):
    """As a fault campaign over 2e9 physics steps: the bound (every unit inspected to max_cycles, and its reference
    run) is given in one line before anything runs; past a fault campaign's hard limit (1e12 steps) not even --yes
    starts it."""
    f = tmp_path / "big.yaml"
    f.write_text("name: big\nlife:\n  units: 10000\n  interval_cycles: 1000\n  max_cycles: 999000\n")
    out = tmp_path / "o"
    assert main(["campaign", "run", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    # 10000 units x (1000 inspections + a reference) of the 13 s pick-and-place at 50 us: 2.6e5 steps each
    assert err.count("\n") == 1 and "up to 10010000 runs (10000 units x up to 1000 inspections" in err, err
    assert "2.6e+12 physics steps" in err and "above the limit of 1e+12 physics steps" in err and not out.exists()
    f.write_text("name: big\nlife:\n  units: 2000\n  interval_cycles: 1000\n  max_cycles: 99000\n")
    assert main(["campaign", "run", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err  # 2000 x 101 x 2.6e5 = 5.25e10 steps: below the limit, above 2e9
    assert err.count("\n") == 1 and "5.25e+10 physics steps" in err and "needs --yes to start" in err, err
    assert not out.exists()
    from ur5fault.health.prognostics.spec import load_life, upper_bound

    small = tmp_path / "small.yaml"
    small.write_text("name: s\nlife:\n  units: 2\n  interval_cycles: 1000\n  max_cycles: 1000\n  duty: "
                     "{payload_kg: [0.5, 0.6]}\nduration_s: 0.2\n")
    runs, steps = upper_bound(load_life(small))
    assert runs == 2 * 3 and steps == 6 * 4000  # 2 units x (2 inspections + a reference), 0.2 s / 50 us
    # duration_s past the trajectory's 13 s: the whole duration is simulated (the robot holds its last setpoint)
    small.write_text(small.read_text().replace("duration_s: 0.2", "duration_s: 600"))
    assert upper_bound(load_life(small)) == (6, 6 * 12_000_000)



@pytest.mark.parametrize("life", ["life: {}", "life:", "life: {seed: 3}"])
def test_a_life_section_that_leaves_the_fleet_to_its_defaults_starts_only_with_yes(tmp_path, capsys, monkeypatch,
                                                                                   life):
    """`life: {}` ran the 100-unit default fleet (up to 5200 runs, 1.35e9 steps) without a word, under the 2e9 steps a
    life campaign's --yes was asked at (a newcomer probe): refused as any campaign over 1000 runs, in one line naming
    the default fleet and how to state another; --yes starts it (and its resume advice carries --yes)."""
    import ur5fault.health.prognostics.fleet as fleet

    started = []
    monkeypatch.setattr(fleet, "run_life", lambda camp, out, **kw: started.append(camp) or {"state": "interrupted"})
    f = tmp_path / "empty.yaml"
    f.write_text(f"name: empty\n{life}\n")
    out = tmp_path / "o"
    assert main(["campaign", "run", str(f), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ur5fault: error: life campaign empty: up to 5200 runs (100 units x up to 51 inspections")
    assert err.count("\n") == 1 and "more than 1000 runs or 2e+09 steps needs --yes to start" in err, err
    assert ("life.units, life.interval_cycles, life.max_cycles not given: the defaults size this fleet (100 units "
            "inspected every 80000 cycles up to 4000000 cycles): state them in the file's life section, or give --yes "
            "to run it") in err
    assert not started and not out.exists()
    assert main(["campaign", "run", str(f), "--out", str(out), "--yes"]) == 1  # the stub stops it early
    assert len(started) == 1 and len(started[0].units) == 100
    assert capsys.readouterr().out.strip().endswith(f"--out {out} --yes")


def test_a_life_campaign_over_1000_runs_starts_only_with_yes_as_a_fault_campaign(tmp_path, capsys):
    """One rule for both kinds (campaign.limits.beyond_confirmation): over 1000 runs, however few steps each; the
    size stated in full, so no word of defaults."""
    f = tmp_path / "many.yaml"
    f.write_text("name: many\nduration_s: 0.2\nlife: {units: 30, interval_cycles: 200000, max_cycles: 8000000}\n")
    assert main(["campaign", "run", str(f), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "up to 1260 runs (30 units x up to 41 inspections" in err, err
    # 30 units x (41 inspections + a reference) x 4000 steps (0.2 s at 50 us): 5.04e6, far below 2e9
    assert "5.04e+06 physics steps" in err and "needs --yes to start" in err and "not given" not in err
    assert not (tmp_path / "o").exists()
    # one name, one meaning: the fault campaign's reason is campaign.limits.confirmation_needed(camp, estimate), the
    # life campaign's its own name; both end in the one sentence of the rule
    import ur5fault.health.prognostics.spec as spec
    from ur5fault.campaign.limits import needs_yes_because

    assert not hasattr(spec, "confirmation_needed")
    why = spec.life_confirmation_needed(spec.load_life(f))
    assert err == f"ur5fault: error: {why}\n" and why.endswith(needs_yes_because("")[1:]), why

def test_cli_prognose_without_inspections_is_one_line_exit_2(tmp_path, capsys):
    assert main(["prognose", str(tmp_path / "nowhere")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("ur5fault: error: ") and err.count("\n") == 1 and "inspections.parquet" in err
    # the command it names works from an installed wheel (a shipped campaign by name, no checkout path)
    assert f"`ur5fault campaign run prognostics --out {tmp_path / 'nowhere'} --yes`" in err and "campaigns/" not in err
