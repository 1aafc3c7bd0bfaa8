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
