"""Several logs of one robot on one sample axis: the joint replay equals each log's own replay row for row,
and per-log scores are the RMS over each log's own held-out rows, computed here by hand."""

from __future__ import annotations

import numpy as np
import pytest

from ur5fault.discrepancy import DiscrepancyModel
from ur5fault.discrepancy.model import WORKFLOW_SEED
from ur5fault.discrepancy.multilog import MultiReplay
from ur5fault.discrepancy.report import summary
from ur5fault.errors import ParameterError
from ur5fault.logs import read_nist
from ur5fault.sim.axes import JOINT_NAMES
from ur5fault.twin import LogReplay


@pytest.fixture(scope="module")
def windows(nist_path):
    log = read_nist(nist_path)
    return [log.window(a, a + 5.0) for a in (0.0, 20.0, 40.0)]


def _named(logs, names):
    import dataclasses

    return [dataclasses.replace(g, source=n) for g, n in zip(logs, names)]


def test_joint_axis_is_each_logs_own_replay(windows):
    a, b, c = _named(windows, ["a", "b", "c"])
    mr = MultiReplay([a, b], [c], 0.6, seed=WORKFLOW_SEED)
    fa, fb = int(a.t_s.size - 1) * 6 // 10, int(b.t_s.size - 1) * 6 // 10
    assert mr.n_fit == fa + fb and mr.n_samples == a.t_s.size + b.t_s.size + c.t_s.size - 3
    joint = mr.run([()], mr.n_samples)[0]
    own = [LogReplay(g, seed=WORKFLOW_SEED).run([()], g.t_s.size - 1)[0] for g in (a, b, c)]
    # order: fit parts of a, b; the rest of a, b; c whole
    parts = [own[0].y[:fa], own[1].y[:fb], own[0].y[fa:], own[1].y[fb:], own[2].y]
    np.testing.assert_array_equal(joint.y, np.concatenate(parts))
    np.testing.assert_array_equal(mr.measured(mr.n_samples)[mr.rows(2)],
                                  LogReplay(c, seed=WORKFLOW_SEED).measured(c.t_s.size - 1))
    # a shorter run simulates only what it needs and agrees with the full one
    short = mr.run([()], fa + 3)[0]
    np.testing.assert_array_equal(short.y, joint.y[: fa + 3])
    assert mr.rows(0, "held_out").size == a.t_s.size - 1 - fa and mr.rows(2, "fit").size == 0


def test_tasks_over_two_processes_equal_one_process(windows):
    """``jobs=2``: the logs' tasks split between this process and a worker (util/parallel.py), bit for bit."""
    from ur5fault.sim.effects import make_effect

    a, b, c = _named(windows, ["a", "b", "c"])
    sets = [(), (make_effect("coulomb_friction", 2, scale=1.5),)]
    one = MultiReplay([a, b], [c], 0.6, seed=WORKFLOW_SEED).run(sets, 400)
    two = MultiReplay([a, b], [c], 0.6, seed=WORKFLOW_SEED, jobs=2).run(sets, 400)
    for x, y in zip(one, two):
        assert x.status == y.status
        np.testing.assert_array_equal(x.y, y.y)
        np.testing.assert_array_equal(x.torque_gear_Nm, y.torque_gear_Nm)


@pytest.mark.slow  # a whole (library-only) fit of three 5 s logs
def test_per_log_summary_scores_each_log_on_its_own_rows(windows):
    a, b, c = _named(windows, ["a.csv", "b.csv", "c.csv"])
    model = DiscrepancyModel(max_effects=0, max_terms=0).fit([a, b], hold_out=[c])
    s = summary(model)
    assert set(s["per_log"]) == {"a.csv", "b.csv", "c.csv"}
    assert [s["per_log"][k]["role"] for k in ("a.csv", "b.csv", "c.csv")] == ["fit", "fit", "held_out"]
    for key in ("rms_before", "rms_after", "rms_fit_before", "named", "rms_controller_model_current_A"):
        assert key in s  # today's keys kept
    # what each log assumes, each named by its own log (the joint axis named them "a.csv + b.csv + c.csv")
    params = model.replay_.params
    assert s["log_assumptions"] == list(dict.fromkeys(
        n for g in (a, b, c) for n in g.assumptions(params.joint_temperature_C))), s["log_assumptions"]
    # by hand: the held-out log replayed alone under the (empty) model
    rc = LogReplay(c, seed=WORKFLOW_SEED)
    sim = rc.run([()], c.t_s.size - 1)[0].y
    meas = rc.measured(c.t_s.size - 1)
    want = np.sqrt(np.mean((meas[:, 0, 1] - sim[:, 0, 1]) ** 2))
    got = s["per_log"]["c.csv"]["rms_after"]["current_A"][JOINT_NAMES[1]]
    assert got == pytest.approx(want, rel=1e-12)
    ur = np.sqrt(np.mean((c.target_current_A[1:, 1] - meas[:, 0, 1]) ** 2))
    assert s["per_log"]["c.csv"]["rms_controller_model_current_A"][JOINT_NAMES[1]] == pytest.approx(ur, rel=1e-12)


def test_a_log_given_twice_is_refused(windows):
    with pytest.raises(ParameterError, match="two logs named .*: give each log its own name"):
        MultiReplay([windows[0]], [windows[0]], 0.6, seed=WORKFLOW_SEED)
