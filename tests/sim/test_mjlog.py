"""MuJoCo's log file off while ur5fault steps (sim/mjlog.py): an unstable run leaves no MUJOCO_LOG.TXT in the
working folder (its status says what happened), the setting is back after the run, and nested users and an
exception restore it."""

from __future__ import annotations

import mujoco
import pytest

from ur5fault import RunSpec, Simulator, pick_and_place
from ur5fault.sim.mjlog import SWITCH, no_log_file
from ur5fault.sim.params import load_params

pytestmark = pytest.mark.skipif(not hasattr(mujoco, "MjLogConfig"), reason="MuJoCo without MjLogConfig (< 4.0)")


@pytest.fixture
def writes_file():
    """The premise: this MuJoCo writes its warnings to a file by default (4.0 does, MUJOCO_LOG.TXT)."""
    if not SWITCH.writes_file():
        pytest.skip("this MuJoCo writes no log file by default")


@pytest.mark.parametrize("stepper", ["compiled", "loop"])
def test_an_unstable_run_leaves_no_log_file_in_the_working_folder(writes_file, tmp_path, monkeypatch, stepper):
    monkeypatch.chdir(tmp_path)
    # docs/usage.md's example: 15 N*m*s/rad of gear damping on every joint makes the wrists' gear mode unstable
    params = load_params(overrides={"gear": {"damping_Nms_per_rad": 15}})
    res = Simulator(params, stepper=stepper).run(pick_and_place(), [RunSpec("a", 0)], duration_s=0.05)
    assert res.status == ("protective_stop",)
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
    assert SWITCH.writes_file()  # back as it was


def test_nested_users_and_an_exception_restore_the_setting(writes_file):
    with no_log_file():
        with no_log_file():
            assert not SWITCH.writes_file()
        assert not SWITCH.writes_file()  # the outer user is still stepping
    assert SWITCH.writes_file()
    with pytest.raises(RuntimeError):
        with no_log_file():
            raise RuntimeError("a run failed")
    assert SWITCH.writes_file()
