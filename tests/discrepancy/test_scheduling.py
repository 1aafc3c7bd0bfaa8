"""How the discrepancy workflow's replays are scheduled changes nothing it finds: the starting model prefetched on
a worker, the runs of a batch spread over two processes by simulated seconds, an alternative replayed over the
fitting part only -- each against the plain path (one process, every replay simulated where it is asked for, the
alternative over the whole log)."""

from __future__ import annotations

import json
from concurrent.futures import wait

import numpy as np
import pytest

from ur5fault.discrepancy import DiscrepancyModel, steps
from ur5fault.discrepancy.library import candidates
from ur5fault.discrepancy.model import WORKFLOW_SEED
from ur5fault.discrepancy.refinement import FindingSet
from ur5fault.discrepancy.report import summary
from ur5fault.logs import read_nist
from ur5fault.twin import LogReplay

#: what a summary holds about how the run went, not what it found
EXECUTION_KEYS = {"wall_s", "wall_s_by_stage", "bare_mj_step_us", "wall_over_mj_steps", "simulated_runs",
                  "simulated_s"}


@pytest.fixture(scope="module")
def short_log(nist_path):
    return read_nist(nist_path).window(0.0, 4.0)


def test_alternatives_over_the_fitting_part_are_the_first_rows_of_the_whole_replay(short_log):
    rp = LogReplay(short_log, seed=WORKFLOW_SEED)
    cands = candidates(short_log.payload_kg, joints=[1, 2], kinds=["current_sensor_offset"], params=rp.params)
    fs = FindingSet(cands[:1])
    theta = [np.zeros(1), np.array([0.05])]
    extra = [(0, cands[1], np.array([0.03]))]
    n_fit = 200
    whole = fs.evaluator(rp)(theta, extra)
    part = fs.evaluator(rp, extra_rows=n_fit)(theta, extra)
    for (sa, ea), (sb, eb) in zip(whole[:2], part[:2]):  # the findings' runs: the whole log either way
        np.testing.assert_array_equal(sa.y, sb.y)
        np.testing.assert_array_equal(ea, eb)
    (sa, ea), (sb, eb) = whole[2], part[2]
    assert eb.shape[0] == n_fit
    np.testing.assert_array_equal(sa.y[:n_fit], sb.y)
    np.testing.assert_array_equal(ea[:n_fit], eb)


def _found(s: dict) -> str:
    """The summary without its execution keys, as JSON (a NaN equals a NaN there)."""
    return json.dumps({k: v for k, v in s.items() if k not in EXECUTION_KEYS}, sort_keys=True)


@pytest.mark.slow  # two whole fits of a 4 s log
def test_a_fit_over_two_processes_finds_what_one_process_finds(short_log):
    """``jobs=2`` (the starting model prefetched before the screening, batches balanced over both processes) against
    ``jobs=1`` (each batch one lockstep batch here): the same summary apart from timings and counts, and the same
    model overlay."""
    one = DiscrepancyModel(jobs=1).fit(short_log)
    two = DiscrepancyModel(jobs=2).fit(short_log)
    assert _found(summary(one)) == _found(summary(two))
    assert one.overlay() == two.overlay()
    # with jobs=2 the starting model's whole-log replay is started before the screening and taken by both the
    # screening (its baseline: the first n_screen_ samples) and the probe batch: one replay of the screened part less
    assert two.n_simulated_runs_ == one.n_simulated_runs_ - 1
    assert two.simulated_s_ == pytest.approx(one.simulated_s_ - one.n_screen_ * short_log.period_s)


def test_an_exception_in_the_fit_stops_its_prefetched_replay(nist_path, monkeypatch):
    """The whole log's starting model (63 s of log), prefetched on a worker, is still being replayed when the
    screening is interrupted: the fit leaves with the exception, holding no prefetched replay, and the worker has
    been stopped -- its future ends with an error instead of a result once the whole log is replayed, so an exiting
    interpreter has nothing to wait for."""
    seen: dict = {}

    def interrupted(rp, *args, **kwargs):
        seen["futures"] = [r for _, r in rp._held.values()]
        seen["running"] = [not f.done() for f in seen["futures"]]
        raise KeyboardInterrupt

    monkeypatch.setattr(steps, "screen_library", interrupted)
    model = DiscrepancyModel(jobs=2)
    with pytest.raises(KeyboardInterrupt):
        model.fit(read_nist(nist_path))
    assert seen["running"] == [True]  # the worker was on it when the fit left
    assert not model.replay_.holds((), 1)
    done, _ = wait(seen["futures"], timeout=60)  # a guard against a hang, not a speed test
    assert len(done) == 1 and seen["futures"][0].exception() is not None  # stopped, not finished
