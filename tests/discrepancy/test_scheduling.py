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


def test_alternatives_replayed_after_the_judgement_equal_those_of_the_probe_batch(short_log):
    """The kept findings' alternatives replayed over the fitting part after the judgement
    (:func:`steps.alternatives_of_kept`, with the prefetch the workflow starts) against the same alternatives
    replayed in the probe batch (``probe_batch(..., extra)``, as before): the same sizes bit for bit, the probe
    batch's other replays unchanged, and the alternative of a finding the judgement dropped never replayed."""
    from ur5fault.discrepancy.judging import Finding
    from ur5fault.discrepancy.judging import alternatives as judged_alternatives
    from ur5fault.discrepancy.refinement import probe_batch
    from ur5fault.discrepancy.search import columns_of

    rp = LogReplay(short_log, seed=WORKFLOW_SEED, jobs=2)
    cands = candidates(short_log.payload_kg, joints=[1, 2], kinds=["current_sensor_offset", "current_sensor_gain"],
                       params=rp.params)
    off1, off2, gain1, gain2 = (next(c for c in cands if (c.effect, c.joint) == key) for key in (
        ("current_sensor_offset", 1), ("current_sensor_offset", 2), ("current_sensor_gain", 1),
        ("current_sensor_gain", 2)))
    found = [off1, off2]
    fs = FindingSet(found)
    theta0 = np.array([0.05, -0.03])
    alts = [(0, gain1, np.array([0.02])), (1, gain2, np.array([-0.01]))]
    n_fit = 300
    before = fs.evaluator(rp, extra_rows=n_fit)
    old = probe_batch(before, theta0, fs.probes(theta0), fs.bounds(), n_fit, alts, before)

    new = probe_batch(fs.evaluator(rp), theta0, fs.probes(theta0), fs.bounds(), n_fit)
    np.testing.assert_array_equal(old.J, new.J)
    np.testing.assert_array_equal(old.e, new.e)
    ref = steps.RefineRecord(found, new, new.sim0, alts, fs, fs.alternative_sets(np.clip(theta0, *fs.bounds()), alts))
    kept = [Finding(off1, np.array([0.05]), np.zeros(1), None)]  # the judgement kept the first, dropped the second
    assert steps.kept_alternatives(ref, kept) == [0]
    rp.prefetch([ref.alt_sets[a] for a in steps.kept_alternatives(ref, kept)], n_fit)
    n0 = rp.n_simulated
    steps.alternatives_of_kept(rp, ref, kept, n_fit)
    assert rp.n_simulated == n0  # taken from the prefetch
    rp.close()

    want = judged_alternatives(fs, [0], 0, old, old.J[:, :n_fit], columns_of(found), n_fit, alts)
    assert len(want) == len(kept[0].alternatives) == 1
    (c_want, th_want), (c_got, th_got) = want[0], kept[0].alternatives[0]
    assert c_got == c_want == gain1
    np.testing.assert_array_equal(th_got, th_want)
    # replayed here without a prefetch (one process): the same
    again = [Finding(off1, np.array([0.05]), np.zeros(1), None)]
    rp1 = LogReplay(short_log, seed=WORKFLOW_SEED)
    steps.alternatives_of_kept(rp1, ref, again, n_fit)
    assert rp1.n_simulated == 1  # the kept finding's alternative only
    np.testing.assert_array_equal(again[0].alternatives[0][1], th_want)


@pytest.mark.slow  # two whole fits of a 4 s log
def test_rivals_prefetched_beside_the_rescreen_are_taken_and_change_nothing(short_log, monkeypatch):
    """With ``jobs=2`` part of the rivals' replays start on a worker before the re-screen (``model.py``,
    :func:`rivals.rival_plan`); when the re-screen leaves the final model as it is, ``list_rivals`` takes every one
    of them: the same summary and overlay as ``jobs=1``, and no replay simulated that the fit does not use (the run
    count one less than one process's, the starting model's prefetch, as in the test above).  The short log's fit
    has no rivals of its own, so each kept finding is given one by the linearised preselection here: its joint's
    first library candidate not listed already, at a small size."""
    from ur5fault.discrepancy import rivals

    def one_rival(lib_X, e_s, n_s, cands, lcols, listed, joint, own_variance=False):
        for r, c in enumerate(cands):
            if c.joint == joint and joint is not None and c.label not in listed and c.n_coef == 1:
                return [(r, np.full(c.n_coef, 0.01))]
        return []

    monkeypatch.setattr(rivals, "in_place", one_rival)
    prefetched: list[int] = []
    plain_prefetch = LogReplay.prefetch

    def counted(self, effect_sets, n=None):
        if self.jobs > 1:  # with one process a prefetch starts nothing
            prefetched.append(len(effect_sets))
        return plain_prefetch(self, effect_sets, n)

    monkeypatch.setattr(LogReplay, "prefetch", counted)
    one = DiscrepancyModel(jobs=1).fit(short_log)
    two = DiscrepancyModel(jobs=2).fit(short_log)
    n_rivals = sum(1 for f in one.findings_ if f.kept and f.candidate.joint is not None)
    assert n_rivals >= 3 and (n_rivals - 1) // 2 in prefetched  # rivals planned, some of them prefetched
    assert _found(summary(one)) == _found(summary(two))
    assert one.overlay() == two.overlay()
    assert two.n_simulated_runs_ == one.n_simulated_runs_ - 1
