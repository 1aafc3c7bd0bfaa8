"""Life campaigns on a tiny fleet: resumed after an interruption, the inspections are bit-identical
to an uninterrupted fleet's (and to one run on another number of processes)."""

from __future__ import annotations

import re

import pandas as pd
import pytest

from ur5fault.campaign.store import CampaignChangedError
from ur5fault.health.prognostics.fleet import run_life
from ur5fault.health.prognostics.spec import build_life
from ur5fault.util.lock import FolderLockedError, Lock

from tiny_fleet import TINY, run_tables


def _sidecars(folder):
    return {p.name: p.read_text() for p in sorted((folder / "runs").glob("*.sha256"))}


@pytest.mark.slow
def test_resumed_fleet_is_bit_identical_to_an_uninterrupted_one(tmp_path):
    camp = build_life(TINY, "tiny")
    whole = run_life(camp, tmp_path / "whole", jobs=1, progress=False, note=None)
    assert whole["state"] == "complete" and whole["n_failed"] >= 2
    assert whole["inspections_per_unit"]["min"] >= 2
    # interrupted after two rounds, then resumed (on two processes instead of one)
    part = run_life(camp, tmp_path / "resumed", jobs=1, progress=False, note=None, max_rounds=2)
    assert part["state"] == "running" and len(run_tables(tmp_path / "resumed")) == 6
    # a file of the interrupted run damaged as by a kill during a write, and a stale temporary left behind
    (tmp_path / "resumed" / "runs" / "u00001_i0001.parquet").write_bytes(b"PAR1 cut")
    (tmp_path / "resumed" / "runs" / ".u00001_i0002.parquet.x.tmp").write_bytes(b"")
    said = []
    again = run_life(camp, tmp_path / "resumed", jobs=2, progress=False, note=said.append)
    assert again["state"] == "complete"
    # 6 inspections stored, u00001's second damaged: its first is kept (the resume said "0 finished" only)
    assert any("0 finished, 3 to run (5 stored inspections kept)" in s for s in said), said
    a, b = run_tables(tmp_path / "whole"), run_tables(tmp_path / "resumed")
    assert a.keys() == b.keys()
    for name in a:
        assert a[name].equals(b[name]), name        # every value and the recorded identity
        assert a[name].schema.metadata == b[name].schema.metadata
    assert _sidecars(tmp_path / "whole") == _sidecars(tmp_path / "resumed")   # the files' bytes, hashed
    ia = pd.read_parquet(tmp_path / "whole" / "inspections.parquet")
    ib = pd.read_parquet(tmp_path / "resumed" / "inspections.parquet")
    pd.testing.assert_frame_equal(ia, ib, check_exact=True)
    # the ground truth: wear grows, the unit stops at its first failed inspection, rul counts down to it
    for _, g in ia.groupby("unit_id"):
        assert (g[[f"backlash_deg_j{j}" for j in range(1, 7)]].diff().dropna() >= 0).all().all()
        if not g["censored"].iloc[0]:
            assert g["failed"].tolist() == [False] * (len(g) - 1) + [True]
            assert (g["rul_cycles"] == g["eol_cycles"] - g["cycles"]).all() and g["rul_cycles"].iloc[-1] == 0
    assert (ia.groupby("unit_id")["split"].nunique() == 1).all()


@pytest.mark.slow
def test_a_changed_wear_law_is_not_mistaken_for_stored_inspections(tmp_path):
    camp = build_life(TINY, "tiny")
    run_life(camp, tmp_path, jobs=1, progress=False, note=None, max_rounds=1)
    changed = build_life({**TINY, "life": {**TINY["life"], "wear": {"backlash_rate_deg_per_MJ": 0.02}}}, "tiny")
    with pytest.raises(CampaignChangedError, match=r"u00000_i0000.parquet: made under other settings \(wear"
                                                   r".backlash_rate_deg_per_MJ: 0.01 in the file, 0.02 now\)"):
        run_life(changed, tmp_path, jobs=1, progress=False, note=None, max_rounds=1)
    m = run_life(changed, tmp_path, jobs=1, progress=False, note=None, max_rounds=1, replace_changed=True)
    assert m["state"] == "running"


@pytest.mark.slow
def test_an_edited_life_campaign_that_drops_units_is_refused_and_a_split_edit_is_said(tmp_path):
    """A life campaign edited and run into its folder: fewer units would leave stored units behind and replace
    the table without them (refused, naming the first difference, until --replace-changed); a split seed edited
    keeps every stored inspection and says so, and that prognose's earlier report is of the earlier table."""
    camp = build_life(TINY, "tiny")
    assert run_life(camp, tmp_path, jobs=1, progress=False, note=None)["state"] == "complete"
    (tmp_path / "benchmark").mkdir()
    fewer = build_life({**TINY, "life": {**TINY["life"], "units": 2}}, "tiny")
    with pytest.raises(CampaignChangedError, match=r"another version of life campaign 'tiny' \(life.units: 3 in "
                                                   r"the folder's manifest, 2 now; 1 stored unit\(s\) \(u00002\)"):
        run_life(fewer, tmp_path, jobs=1, progress=False, note=None)
    resplit = build_life({**TINY, "split": {**TINY["split"], "seed": 1}}, "tiny")
    said = []
    m = run_life(resplit, tmp_path, jobs=1, progress=False, note=said.append)
    assert m["state"] == "complete" and m["split"]["seed"] == 1
    assert any("another version of life campaign 'tiny' (split.seed: 0 in the folder's manifest, 1 now)" in s
               for s in said), said
    assert any("0 to run" in s for s in said), said  # the split is no input of an inspection: nothing simulated
    assert any(s.endswith("reports on the earlier version's inspections: run `ur5fault prognose "
                          f"{tmp_path}` again once this campaign is complete") for s in said), said
    said.clear()
    run_life(resplit, tmp_path, jobs=1, progress=False, note=said.append)  # the same campaign again: no note
    assert not any("another version" in s or "earlier version" in s for s in said), said
    m = run_life(fewer, tmp_path, jobs=1, progress=False, note=said.append, replace_changed=True)
    assert m["n_units"] == 2 and any("left as strays: --replace-changed" in s for s in said), said
    # that campaign run again (a resume, the command a stopped run prints): the strays its --replace-changed left are
    # not another version's loss (a review found every rerun refused)
    said.clear()
    assert run_life(fewer, tmp_path, jobs=1, progress=False, note=said.append)["n_units"] == 2
    assert not any("another version" in s or "earlier version" in s for s in said), said


def test_a_second_writer_is_refused(tmp_path):
    camp = build_life(TINY, "tiny")
    with Lock(tmp_path), pytest.raises(FolderLockedError):
        run_life(camp, tmp_path, jobs=1, progress=False, note=None)


@pytest.mark.slow
def test_a_fleet_rerun_stopped_before_its_end_is_not_read_as_its_result(tmp_path):
    """A rerun of a changed life campaign writes its manifest ``running`` first; stopped before its end, the
    earlier fleet's inspections table (sound by its checksum) is refused by `prognose`'s reader, not benchmarked
    under the new wear law."""
    from ur5fault.health.prognostics.benchmark import load_inspections
    from ur5fault.util.io import StoredFileError

    camp = build_life(TINY, "tiny")
    assert run_life(camp, tmp_path, jobs=1, progress=False, note=None)["state"] == "complete"
    assert len(load_inspections(tmp_path)[0])
    changed = build_life({**TINY, "life": {**TINY["life"], "wear": {"backlash_rate_deg_per_MJ": 0.02}}}, "tiny")
    m = run_life(changed, tmp_path, jobs=1, progress=False, note=None, max_rounds=1, replace_changed=True)
    assert m["state"] == "running" and (tmp_path / "inspections.parquet").exists()
    with pytest.raises(StoredFileError, match=r"inspections.parquet: the life campaign in .* is not complete "
                                              r"\(its manifest says 'running'"):
        load_inspections(tmp_path)


def test_a_criterion_the_unworn_robot_meets_is_said_and_not_benchmarked(tmp_path, capsys):
    """Every unit fails at its first inspection when the healthy robot already meets the failure criterion: the
    run says so, and `prognose` refuses in one line naming the criterion (it ended in numpy's "need at least one
    array to concatenate" after a RuntimeWarning)."""
    import yaml

    from ur5fault.cli import main

    f = tmp_path / "unworn.yaml"
    f.write_text(yaml.safe_dump({**TINY, "life": {**TINY["life"], "failure": {"feature": "tcp_track_max_mm",
                                                                              "threshold": 0.01}}}))
    assert main(["campaign", "run", str(f), "--out", str(tmp_path / "fleet"), "--jobs", "1", "--quiet"]) == 0
    err = capsys.readouterr().err
    assert "note: 3 of 3 units met the failure criterion tcp_track_max_mm >= 0.01 at their first inspection" in err
    assert main(["prognose", str(tmp_path / "fleet"), "--out", str(tmp_path / "pg")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "0 failed training and 0 failed test units with a degradation path" in err \
        and "; 3 units met the failure criterion tcp_track_max_mm >= 0.01 at their first inspection, unworn" in err, err


def test_the_start_line_of_a_new_fleet_says_how_large_it_can_grow(tmp_path):
    """A fleet's start line said only its number of units (an empty `life:` section runs the 100-unit default fleet,
    about 1.35e9 steps, with no other word); a new fleet's now carries its upper bound in runs and physics steps, as
    the --yes refusal states it."""
    from ur5fault.health.prognostics.spec import check_life_limits

    camp = build_life(TINY, "tiny")
    said = []
    m = run_life(camp, tmp_path, jobs=1, progress=False, note=said.append, max_rounds=0)
    assert m["state"] == "running"
    bound, steps = check_life_limits(camp)
    start = [s for s in said if s.startswith("life campaign tiny:")]
    assert len(start) == 1 and start[0].endswith(bound.split(": ", 1)[1]), said
    assert f"{steps:.3g} physics steps" in start[0]


def test_the_progress_bar_of_a_fleet_counts_units(tmp_path, capsys):
    """The bar said `campaign: 1/30 runs (3 %)` while counting finished units (the start line's "up to 1260 runs"
    counts inspections): it says units."""
    run_life(build_life(TINY, "tiny"), tmp_path, jobs=1, progress=True, note=lambda s: None, max_rounds=0)
    lines = capsys.readouterr().err.splitlines()
    assert lines and lines[-1].startswith("campaign: 0/3 units (0 %)"), lines


@pytest.mark.slow
def test_a_fleet_states_a_bound_on_the_rounds_left_not_a_rate(tmp_path, capsys):
    """Units finish when they fail, mostly in the last rounds, so a time left from the rate of finished units was
    meaningless (a newcomer probe): no such estimate; each round states how many more rounds there can be (the
    running unit with the most inspections to go before max_cycles) and the last round's time."""
    run_life(build_life(TINY, "tiny"), tmp_path, jobs=1, progress=True, note=lambda s: None, max_rounds=2)
    last = capsys.readouterr().err.splitlines()[-1]
    # TINY: inspections every 100,000 cycles up to 1,500,000: the next inspection is the third (200,000 cycles), 14
    # inspections of which fit before max_cycles
    assert re.match(r"campaign \(round 2 done, 3 units running, at most 14 more round\(s\) of at most \d+:\d\d "
                    r"each\): 0/3 units \(0 %\), \d+:\d\d elapsed$", last), last
    run_life(build_life(TINY, "tiny"), tmp_path, jobs=1, progress=True, note=lambda s: None)  # resumed to the end
    last = capsys.readouterr().err.splitlines()[-1]
    assert re.match(r"campaign \(round \d+ done, every unit finished\): 3/3 units \(100 %\)", last), last
