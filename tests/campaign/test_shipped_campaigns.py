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
