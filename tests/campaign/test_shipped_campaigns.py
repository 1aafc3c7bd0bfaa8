"""Every campaign file shipped in campaigns/ loads and validates (a typo in one is found here, not by a user
after a long run); the other-motions campaign of the diagnostics benchmark draws no motion the training
campaign trains on."""

from __future__ import annotations

import pytest

from tests.conftest import CAMPAIGNS
from ur5fault.campaign.spec import load_campaign
from ur5fault.health.prognostics.spec import is_life_file, load_life

FILES = sorted(CAMPAIGNS.glob("*.yaml"))


def test_there_are_shipped_campaigns():
    assert {"default.yaml", "diagnostics.yaml", "diagnostics_other_motions.yaml"} <= {f.name for f in FILES}


@pytest.mark.parametrize("path", FILES, ids=[f.name for f in FILES])
def test_shipped_campaign_loads(path, tmp_path):
    if is_life_file(path):
        life = load_life(path, tmp_path / "out")
        assert life.max_inspections >= 1
    else:
        camp = load_campaign(path, tmp_path / "out")
        assert camp.name == path.stem  # one name per file: a report or manifest names the campaign it came from


def _motion_seeds(name):
    return {run.cond["trajectory"]["seed"] for run in load_campaign(CAMPAIGNS / name).runs}


def test_other_motions_are_not_the_training_motions():
    train, other = _motion_seeds("diagnostics.yaml"), _motion_seeds("diagnostics_other_motions.yaml")
    assert train and other and not (train & other)
    assert len(other) >= 20  # enough motions that one motion does not decide the figure


@pytest.mark.parametrize("name", ["paper", "paper.yaml"])
def test_a_users_copy_in_the_working_folder_wins_by_either_name(name, tmp_path, monkeypatch):
    """docs/usage.md: copy a shipped campaign, edit it, run it by name. `paper` ran the shipped paper.yaml while
    the user's edited paper.yaml sat in the working folder (only `paper.yaml` found it)."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper.yaml").write_text("name: paper\nsweep: {backlash.joint: [2], backlash.backlash_deg: [0.3]}\n")
    camp = load_campaign(name, tmp_path / "out")
    assert len(camp.runs) == 2  # the copy's one fault and its healthy twin, not the shipped 18 + 1


def test_a_shipped_name_without_a_copy_is_the_shipped_campaign(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert len(load_campaign("paper", tmp_path / "out").runs) == 19
    # by either suffix: `campaign run paper.yml` was refused with "no shipped campaign of that name; did you mean
    # 'paper'?" (the lookup kept the .yml)
    for name in ("paper.yaml", "paper.yml"):
        assert len(load_campaign(name, tmp_path / "out").runs) == 19


def test_campaign_show_prints_a_shipped_campaign_to_copy(tmp_path, monkeypatch, capsys):
    """A wheel user could not see or copy a shipped campaign (the README pointed into the installed package): `ur5fault
    campaign show NAME` prints its file, whose copy loads as the same campaign; an unknown name is one line naming the
    shipped ones. The shipped file is printed even beside a user's file of that name (that one they have)."""
    from ur5fault.cli import main

    monkeypatch.chdir(tmp_path)
    (tmp_path / "paper.yaml").write_text("name: mine\n")
    for path in FILES:
        assert main(["campaign", "show", path.stem]) == 0
        assert capsys.readouterr().out == path.read_text(encoding="utf-8"), path.name
    assert main(["campaign", "show", "default.yaml"]) == 0
    (tmp_path / "my.yaml").write_text(capsys.readouterr().out)
    copy, shipped = load_campaign(tmp_path / "my.yaml", tmp_path / "a"), load_campaign("default", tmp_path / "a")
    assert copy.name == "default" and [r.run_id for r in copy.runs] == [r.run_id for r in shipped.runs]
    assert main(["campaign", "show", "defaul"]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == ("ur5fault: error: unknown shipped campaign 'defaul' (did you mean "
                                         f"'default'?); valid: {', '.join(f.stem for f in FILES)}\n")


def test_campaign_list_names_every_shipped_campaign_with_its_opening_sentence(capsys, monkeypatch):
    """A newcomer had no way to see which campaigns ship (a name was guessed at `campaign run`): `ur5fault campaign
    list` prints each shipped file's name and the first sentence of the comment the file opens with, wrapped to the
    terminal under its start (the longer ones ran to 380 characters on one line)."""
    from ur5fault.cli import main

    monkeypatch.setenv("COLUMNS", "90")
    assert main(["campaign", "list"]) == 0
    cap = capsys.readouterr()
    lines = cap.out.splitlines()
    entries = []  # each campaign's lines joined: a line that does not start with a name continues the one above
    for line in lines:
        if not line:
            break
        if line.startswith(" "):
            entries[-1] += " " + line.strip()
        else:
            entries.append(line)
    assert cap.err == "" and all(len(line) <= 90 for line in lines), max(map(len, lines))
    assert [e.split()[0] for e in entries] == [f.stem for f in FILES]
    for path, entry in zip(FILES, entries):
        comment = " ".join(" ".join(t[1:] for t in path.read_text().splitlines() if t.startswith("#")).split())
        about = entry[len(path.stem):].strip()
        assert about and about.endswith(".") and comment.startswith(about), (path.name, about)
    assert entries[FILES.index(CAMPAIGNS / "paper.yaml")].split(None, 1)[1] == (
        "The seed paper's figures: Fig. 3, alpha = 0.1 deg on each joint in turn; Fig. 4, the shoulder at several "
        "alpha.")
    assert lines[len(lines) - 3:] == ["", "run one: ur5fault campaign run NAME",
                                      "its whole file, a copy to edit: ur5fault campaign show NAME > my.yaml"]


@pytest.mark.parametrize("typed, meant", [("defualt", "default"), ("papr.yaml", "paper")])
def test_a_mistyped_shipped_campaign_name_gets_did_you_mean(typed, meant, tmp_path, monkeypatch, capsys):
    """`campaign run defualt` listed every shipped name without saying which was meant: a near miss is named, with
    the command that lists them; a name near none still lists them all."""
    from ur5fault.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["campaign", "run", typed]) == 2
    cap = capsys.readouterr()
    assert cap.out == "" and cap.err == (f"ur5fault: error: {typed}: no such file, and no shipped campaign of that "
                                         f"name; did you mean {meant!r}? (`ur5fault campaign list` lists them)\n")
    assert main(["campaign", "run", "zzz"]) == 2
    assert capsys.readouterr().err == ("ur5fault: error: zzz: no such file, and no shipped campaign of that name "
                                       f"(shipped: {', '.join(f.stem for f in FILES)}; `ur5fault campaign list` "
                                       "describes them)\n")
