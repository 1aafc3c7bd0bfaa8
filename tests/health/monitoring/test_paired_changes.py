"""The paired change test (ur5fault/health/monitoring/paired.py) on synthetic residuals of a robot repeating its
task: the twin's error is large and repeats at the same points of the task, so a candidate fitted to a residual
alone absorbs it, while on the difference of residuals at the same point of the task it cancels. A known
current-sensor gain on a repeated task is found on its joint with its size; a healthy repeat is not a change."""

import dataclasses

import numpy as np
import pytest

from tests.health.monitoring.test_monitoring import PERIOD, part
from tests.health.monitoring.test_task import C, cycle, jitter
from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.health.monitoring import assess, fit_baseline
from ur5fault.health.monitoring.paired import difference, estimates
from ur5fault.health.monitoring.task import reference

SIGMA_A = 0.02  # the current sensor's noise, the weights
LABEL = "shoulder_lift_joint: current_sensor_gain.gain"


def currents(target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The simulated motor current ``(n, 6)`` [A] of a commanded motion (gravity at the pose, inertia and
    friction at its speed) and the twin's error on it: a pose-dependent gravity error (0.5 A, three times the
    pose's frequency: what a candidate fitted alone cannot tell from the gain on a 5 s block) and 1 A where the
    target accelerates; both the same on every repeat of the motion."""
    qd = np.gradient(target, PERIOD, axis=0)
    qdd = np.gradient(qd, PERIOD, axis=0)
    sim = 2.0 * np.cos(target) + 0.8 * qdd + 0.5 * np.tanh(qd / 0.05)
    err = 0.5 * np.sin(3.0 * target) + 1.0 * np.tanh(qdd)
    return sim, err


def run(name: str, target: np.ndarray, seed: int, gain: float = 1.0):
    """A replayed run: the measured current ``gain`` x (the true current) + sensor noise, the true current the
    simulated one plus the twin's error; the library columns of a shoulder_lift current-sensor gain and offset
    (the simulated reading per unit coefficient, weighted by the noise)."""
    sim, err = currents(target)
    meas = gain * (sim + err) + np.random.default_rng(seed).normal(0.0, SIGMA_A, sim.shape)
    n = target.shape[0]
    X = np.zeros((2, n, 12))
    X[0, :, 1] = sim[:, 1] / SIGMA_A  # d(reading)/d(gain)
    X[1, :, 1] = 1.0 / SIGMA_A  # d(reading)/d(offset)
    e = np.zeros((n, 12))
    e[:, :6] = (meas - sim) / SIGMA_A
    cands = (LibraryCandidate("current_sensor_gain", 1, param="gain", x0=1.0, probe=1.1),
             LibraryCandidate("current_sensor_offset", 1, param="offset_A", x0=0.0, probe=0.1))
    speed = np.abs(np.gradient(target, PERIOD, axis=0))
    obs = part(name, meas - sim, speed=speed, cands=cands, X=X, e=e, target=jitter(target, seed))
    return dataclasses.replace(obs, current_sigma_A=np.full(6, SIGMA_A))


def other_task(seed: int, seconds: float = 20.0) -> "object":
    """A healthy run of another motion (a slow sweep from C, never at rest): a baseline's second observation for
    its event limits (at least two, :data:`~ur5fault.health.monitoring.baseline.MIN_RUNS`) that repeats nothing,
    so the paired statistics stay the other run's own."""
    n = round(seconds / PERIOD)
    return run(f"other{seed}", C + np.outer(np.arange(n) * PERIOD, np.linspace(0.02, 0.05, 6)), seed)


def test_the_paired_difference_reads_a_known_gain_and_cancels_the_repeated_model_error():
    base = [run(f"b{k}", cycle(4, lead_s=0.3 * k), 20 + k) for k in range(2)]
    refs = [(o.target_rad, np.where(o.logged[:, None], o.residual_A, np.nan)) for o in base]
    for gain in (1.0, 1.1):
        log = run("log", cycle(4, lead_s=0.2), 40, gain=gain)
        ref = reference(log.target_rad, refs, PERIOD)[0]
        _, on = difference(log, ref)
        assert on.mean() > 0.8  # all but the log's first and last second
        est = estimates(log, ref, log.logged)[LABEL]
        # the difference is (gain - 1) x the true current (simulated + the twin's error) + noise, the column the
        # simulated current: its least-squares coefficient on the paired samples, from the generating model
        sim, err = currents(cycle(4, lead_s=0.2))
        s = sim[on, 1]
        expected = (gain - 1.0) * float(np.sum((s + err[on, 1]) * s) / np.sum(s * s))
        assert abs(est.theta - expected) < 0.005, (est, expected)


def test_a_gain_on_a_repeated_task_is_changed_and_a_healthy_repeat_is_not():
    """Three healthy runs of one task (at other leads) as the baseline. A new run of the task with a 10 % gain on
    shoulder_lift's current sensor is "changed" there, read as 1.10 times the true current's share of the
    simulated one by the paired test; the healthy repeat is
    "consistent". The block test alone (the monitor before the paired test) misses the gain: its block estimates
    carry the twin's error."""
    base = [run(f"b{k}", cycle(5, lead_s=0.3 * k), 20 + k) for k in range(3)]
    b = fit_baseline(base, "sha")
    mean, var, k, _ = b.paired_candidates[LABEL]
    assert k >= 10 and abs(mean) < 0.01  # healthy repeats paired with each other: no gain between them
    healthy = assess(b, run("healthy", cycle(5, lead_s=0.2), 40))
    assert healthy["verdict"] == "consistent", healthy
    out = assess(b, run("worn", cycle(5, lead_s=0.2), 41, gain=1.1))
    assert out["verdict"] == "changed", out
    (ch,) = out["changes"]
    assert ch["joint"] == "shoulder_lift_joint" and ch["reference"] == "paired"
    sim, err = (c[:, 1] for c in currents(cycle(5, lead_s=0.2)))
    expected = 1.0 + 0.1 * float(np.sum((sim + err) * sim) / np.sum(sim * sim))  # as read on the simulated current
    assert ch["effect"] == "current_sensor_gain" and abs(ch["value"] - expected) < 0.01, (ch, expected)
    assert abs(ch["baseline_value"] - 1.0) < 0.01
    before = assess(dataclasses.replace(b, paired_candidates={}), run("worn", cycle(5, lead_s=0.2), 41, gain=1.1))
    assert before["changes"] == [], before


def test_the_paired_statistics_survive_baseline_json(tmp_path):
    import json

    from ur5fault.health.monitoring.baseline import Baseline

    b = fit_baseline([run(f"b{k}", cycle(3, lead_s=0.3 * k), 20 + k) for k in range(2)], "sha")
    assert b.paired_candidates
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(b.to_json()))
    back = Baseline.load(path)
    assert back.paired_candidates == b.paired_candidates
    worn = run("worn", cycle(3, lead_s=0.2), 41, gain=1.2)
    assert assess(back, worn) == assess(b, worn)


def test_a_baseline_screened_whole_gives_paired_blocks_past_the_first_20_s():
    """Two healthy runs of 7 cycles (about 30 s each), screened whole (as the monitor screens a baseline run):
    the paired statistics count a block per 0.5 s of the paired samples of both runs (each pair of repeats once),
    past the 20 s a monitored log is screened on, while the block test keeps its 5 s blocks of each run's first
    20 s (4 per run). Their autocorrelation makes them worth fewer, but more than 20 of them."""
    from ur5fault.health.monitoring.paired import (
        PAIRED_BLOCK_S,
        baseline_references,
        independent_blocks,
        paired_seconds,
    )

    base = [run(f"b{k}", cycle(7, lead_s=0.3 * k), 20 + k) for k in range(2)]
    assert all(o.n * PERIOD > 29.0 for o in base)
    b = fit_baseline(base, "sha")
    refs = [(o.target_rad, np.where(o.logged[:, None], o.residual_A, np.nan)) for o in base]
    secs = [paired_seconds(o, ref) for o, ref in zip(base, baseline_references(base, refs, one_way=True))]
    # paired past 20 s (the first run's first cycle has no earlier repeat: each pair is compared once)
    assert all(s > 20.0 for s in secs), secs
    k = independent_blocks(base, refs)
    assert k == sum(round(s / PAIRED_BLOCK_S) for s in secs) > 2 * 20 / PAIRED_BLOCK_S  # blocks past 20 s
    assert 20 < b.paired_candidates[LABEL][2] <= k
    assert b.candidates[LABEL][2] == 2 * 4


def test_observe_screens_the_whole_part_when_asked():
    """``screen_s=None`` (a baseline run's, :data:`BASELINE_SCREEN_S`): the library columns and the weighted
    residual cover every sample of the part; a number: its first stretch."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "bench"))
    from monitor_labels import QUIET, read

    from ur5fault.health.monitoring.observe import BASELINE_SCREEN_S, observe

    assert BASELINE_SCREEN_S is None
    log = read(QUIET)
    kinds = ("current_sensor_offset",)
    whole = observe(log, part_s=(0.0, 3.0), kinds=kinds, screen_s=None)
    head = observe(log, part_s=(0.0, 3.0), kinds=kinds, screen_s=1.0)
    assert whole.n == head.n > round(2.9 / log.period_s)
    assert whole.e.shape[0] == whole.X.shape[1] == whole.n and whole.X.shape[0] == 6
    assert head.e.shape[0] == head.X.shape[1] == round(1.0 / log.period_s)
    np.testing.assert_array_equal(whole.e[: head.e.shape[0]], head.e)


def test_a_self_paired_baseline_counts_each_difference_once():
    """One healthy run that repeats its task twice (two 9.2 s cycles) as the baseline. Paired both ways, its
    second cycle is compared with its first and its first with its second: the difference at t + L is minus the
    one at t, to the bit (one difference, counted twice). The baseline's paired statistics pair each sample only
    with the earlier repeat: the first cycle has no reference, and the blocks are those of the second cycle's
    paired seconds alone, half of what the two-way pairing gave."""
    from ur5fault.health.monitoring.paired import (
        PAIRED_BLOCK_S,
        baseline_references,
        independent_blocks,
        paired_seconds,
    )

    o = run("b0", cycle(2, move_s=4.0), 20)
    L = 2 * (round(4.0 / PERIOD) + round(0.6 / PERIOD))  # samples of one cycle
    refs = [(o.target_rad, np.where(o.logged[:, None], o.residual_A, np.nan))]
    two_way = reference(o.target_rad, refs, PERIOD, self_index=0)[0]
    d = o.residual_A - two_way
    first = np.flatnonzero(np.isfinite(d[:L]).all(axis=1) & np.isfinite(d[L : 2 * L]).all(axis=1))
    assert first.size > 0.5 * L  # 5.2 s of the 9.2 s cycle (the chunks whose context fits in the run)
    np.testing.assert_allclose(d[first] + d[first + L], 0.0, atol=1e-12)  # the reproduction
    (one_way,) = baseline_references([o], refs, one_way=True)
    assert np.isnan(one_way[:L]).all()  # the first cycle: no earlier repeat
    np.testing.assert_array_equal(one_way[first + L], two_way[first + L])  # the second: against the first
    secs_two, secs_one = paired_seconds(o, two_way), paired_seconds(o, one_way)
    assert abs(secs_one - secs_two / 2) < 1.0, (secs_one, secs_two)  # half, to within the 2 s chunks' grid
    k = independent_blocks([o], refs)
    assert k == round(secs_one / PAIRED_BLOCK_S) and k <= round(secs_two / PAIRED_BLOCK_S) / 2 + 1, (k, secs_one,
                                                                                          secs_two)
    assert fit_baseline([o, other_task(30)], "sha").paired_candidates[LABEL][2] <= k  # worth at most that many


def test_the_paired_statistics_do_not_depend_on_the_baselines_order():
    """Two healthy runs, the second with a 3 % gain on shoulder_lift against the first (a systematic difference
    between healthy runs): in either order the blocks paired both ways have the same mean and variance (each
    difference enters with both signs), the mean near 0, and the variance holds the 3 %; paired one way only, the
    order would set the sign of the mean. And the difference holds over the whole run, so every one-way block
    sits 3 % off that mean: correlation at every lag, one independent difference, not a block per 0.5 s; with
    fewer than 2 independent blocks the gain has no paired statistics (it cannot be told from the runs' own
    difference)."""
    from ur5fault.health.monitoring.changes import spreads
    from ur5fault.health.monitoring.paired import baseline_references, block_estimates, independent_blocks

    a = run("a", cycle(4), 20)
    b = run("b", cycle(4, lead_s=0.3), 21, gain=1.03)
    stats = []
    for pair in ([a, b], [b, a]):
        refs = [(o.target_rad, np.where(o.logged[:, None], o.residual_A, np.nan)) for o in pair]
        stats.append(spreads(blk for o, ref in zip(pair, baseline_references(pair, refs))
                             for blk in block_estimates(o, ref))[LABEL])
        assert independent_blocks(pair, refs) > 10  # blocks of 0.5 s, one way
        assert LABEL not in fit_baseline(pair, "sha").paired_candidates
    ab, ba = stats
    np.testing.assert_allclose(ab[:2], ba[:2], rtol=1e-9, atol=1e-12)
    assert abs(ab[0]) < 0.01 and np.sqrt(ab[1]) > 0.02, ab  # mean ~0, spread of the order of the 3 %


def test_both_tests_on_one_log_each_spend_half_the_false_alarm_probability(monkeypatch):
    """A log that repeats the baseline's task for 5 cycles, then moves to a pose the baseline never visits for 7 s:
    its paired samples are judged by the paired test, the rest by the block test, each at half the workflow's
    tail (their bars raised: z 4 -> 4.16 for one block; Student's t at half the tail for k blocks); a log paired
    throughout is judged by the paired test alone at the full tail."""
    from scipy import stats

    from ur5fault.health.monitoring import verdict
    from ur5fault.health.monitoring.changes import bar

    tail = stats.norm.sf(4.0)
    assert bar(1) == 4.0
    assert abs(bar(1, 0.5) - 4.161) < 1e-3  # the standard normal's quantile at 1.58e-5 (1 - 0.9999842)
    for k in (3, 5, 12):
        assert abs(stats.t.sf(bar(k, 0.5), k - 1) - tail / 2) < 1e-3 * tail
        assert bar(k, 0.5) > bar(k)
    shares = []
    real = verdict.find_changes

    def spy(*args, **kw):
        shares.append((args[4] if len(args) > 4 else kw.get("reference", "blocks"),
                       args[5] if len(args) > 5 else kw.get("share", 1.0)))
        return real(*args, **kw)

    monkeypatch.setattr(verdict, "find_changes", spy)
    b = fit_baseline([run(f"b{k}", cycle(5, lead_s=0.3 * k), 20 + k) for k in range(2)], "sha")
    tail_away = cycle(2, second=C)[1:]  # starts where the cycles end (A), then C: not in the baseline
    both = np.concatenate([cycle(5, lead_s=0.2), tail_away])
    assess(b, run("both", both, 40))
    assert shares == [("paired", 0.5), ("blocks", 0.5)], shares
    shares.clear()
    assess(b, run("paired only", cycle(5, lead_s=0.2), 41))
    assert shares == [("paired", 1.0)], shares


def test_a_baseline_run_is_refused_as_a_monitored_log():
    """A monitored log that is one of the baseline's runs (or a part of one) pairs with its own samples at lag 0
    and could never change: refused with one line naming the run. A repeat of the same task is not refused."""
    import pytest

    from ur5fault.errors import ParameterError
    from ur5fault.health.monitoring.verdict import baseline_run_of

    base = [run(f"b{k}", cycle(3, lead_s=0.3 * k), 20 + k) for k in range(2)]
    b = fit_baseline(base, "sha")
    with pytest.raises(ParameterError, match=r"b1 is one of the baseline's runs \(b1: the same samples\)"):
        assess(b, base[1])
    o = base[0]  # a later part of b0's samples
    later = dataclasses.replace(o, target_rad=o.target_rad[200:], residual_A=o.residual_A[200:],
                                logged=o.logged[200:])
    assert baseline_run_of(b, later) == "b0"
    # another run of the same program: its targets to the bit, what it measured not (a push, another run's noise)
    other = dataclasses.replace(base[1], residual_A=base[1].residual_A + 0.01)
    assert baseline_run_of(b, other) is None
    assert assess(b, run("repeat", cycle(3, lead_s=0.2), 41))["verdict"] == "consistent"


def test_a_small_gain_on_a_task_one_baseline_run_repeats_is_found():
    """One healthy run of 6 cycles as the baseline's only repeated task (NIST's case: its reference is its own
    cycles paired with each other; a second run of another motion for the event limits, which need two): its
    0.5 s blocks, paired one way, are worth more independent blocks than its 2 s stretches are in number (the
    healthy difference is the sensors' noise: little autocorrelation), so a 2 % gain on
    shoulder_lift is "changed" there with its size (read on the simulated current, as the first test derives),
    and a healthy repeat is "consistent"."""
    from ur5fault.health.monitoring.paired import baseline_references, paired_seconds

    base = run("b0", cycle(6), 20)
    refs = [(base.target_rad, np.where(base.logged[:, None], base.residual_A, np.nan))]
    secs = paired_seconds(base, baseline_references([base], refs, one_way=True)[0])
    b = fit_baseline([base, other_task(30)], "sha")
    assert b.paired_candidates[LABEL][2] > secs / 2.0, (b.paired_candidates[LABEL], secs)
    assert assess(b, run("healthy", cycle(5, lead_s=0.2), 40))["verdict"] == "consistent"
    out = assess(b, run("worn", cycle(5, lead_s=0.2), 41, gain=1.02))
    assert out["verdict"] == "changed", out
    (ch,) = out["changes"]
    sim, err = (c[:, 1] for c in currents(cycle(5, lead_s=0.2)))
    expected = 1.0 + 0.02 * float(np.sum((sim + err) * sim) / np.sum(sim * sim))
    assert ch["joint"] == "shoulder_lift_joint" and ch["reference"] == "paired"
    assert ch["effect"] == "current_sensor_gain" and abs(ch["value"] - expected) < 0.003, (ch, expected)


def test_healthy_runs_that_each_sit_a_few_percent_apart_are_worth_about_one_block_each():
    """Three healthy runs of one task whose shoulder_lift currents read 1.00, 1.03 and 0.97 times the true one (a
    spread between healthy runs that holds over each whole run): their 0.5 s blocks are over 100, but every
    block of a run sits off the mean the same way, so they are worth about the 3 runs (the design effect of
    their autocorrelation), and a new run at 1.06, twice the healthy runs' spread, is not called changed."""
    from ur5fault.health.monitoring.paired import independent_blocks

    base = [run(f"b{k}", cycle(5, lead_s=0.3 * k), 20 + k, gain=g) for k, g in enumerate((1.0, 1.03, 0.97))]
    refs = [(o.target_rad, np.where(o.logged[:, None], o.residual_A, np.nan)) for o in base]
    assert independent_blocks(base, refs) > 100
    b = fit_baseline(base, "sha")
    _, var, k_eff, _ = b.paired_candidates[LABEL]
    assert 2.0 <= k_eff < 4.0, k_eff
    assert 0.02 < np.sqrt(var) < 0.06  # the runs' spread (differences of 3-6 %), not the blocks' noise
    out = assess(b, run("log", cycle(5, lead_s=0.2), 41, gain=1.06))
    assert not any(c["joint"] == "shoulder_lift_joint" for c in out["changes"]), out


def test_the_reference_of_a_log_scales_one_blocks_spread_by_the_design_effect_over_its_length():
    """Hand-computed: one block's variance 1, k_eff 4, design effect 2. A log of 10 s paired (20 blocks of 0.5 s)
    is predicted to vary by ``1 x 2 / 20 = 0.1``, the mean by ``1 / 4``: with the log's own SE under the
    prediction (0.2: 0.04) the prediction variance is ``0.1 + 0.25 = 0.35``, its SE counted once, not added
    (0.39); with its SE above it (0.5: 0.25), its own: ``0.25 + 0.25 = 0.5``. A log of one block (or a design effect
    above its blocks) is never predicted narrower than one block: ``1 + 0.25``."""
    from ur5fault.health.monitoring.paired import for_log

    stats = {"x": (0.5, 1.0, 4.0, 2.0)}
    ref = for_log(stats, 10.0)["x"]
    assert (ref.mean, ref.k) == (0.5, 4.0)
    assert (ref.log_var, ref.mean_var) == (pytest.approx(0.1), pytest.approx(0.25))
    assert ref.variance(0.2) == pytest.approx(0.35) and ref.variance(0.5) == pytest.approx(0.5)
    assert ref.z(0.5 + 0.7, 0.2) == pytest.approx(0.7 / np.sqrt(0.35))
    assert for_log(stats, 0.5)["x"].variance(0.0) == pytest.approx(1.25)
    assert for_log({"x": (0.0, 1.0, 4.0, 40.0)}, 10.0)["x"].variance(0.0) == pytest.approx(1.25)


def test_the_block_tests_reference_counts_the_logs_noise_once():
    """Hand-computed, the block test's reference (:func:`.changes.block_reference`): blocks of variance 0.04 over
    8 blocks predict the log's estimate to vary as one block's, 0.04, and the mean by 0.005: a log SE of 0.1
    (0.01, under the prediction) gives 0.045 (0.055 before, with its SE added); one of 0.3 (0.09) gives 0.095. A
    single block (its variance its own SE squared, 0.04) predicts nothing for the log: its SE 0.1 gives
    0.01 + 0.04, as before. A reference with a negative variance or under one block is refused."""
    from ur5fault.health.monitoring.changes import Reference, block_reference

    refs = block_reference({"x": (1.0, 0.04, 8), "y": (2.0, 0.04, 1)})
    assert refs["x"].variance(0.1) == pytest.approx(0.045) and refs["x"].variance(0.3) == pytest.approx(0.095)
    assert refs["x"].k == 8 and refs["y"].k == 1
    assert refs["y"].variance(0.1) == pytest.approx(0.05)
    for bad in ((0.0, -1.0, 0.1, 3.0), (0.0, 1.0, 0.1, 0.5), (float("nan"), 1.0, 0.1, 3.0)):
        with pytest.raises(ValueError):
            Reference(*bad)



def sweep(name: str, rates: np.ndarray, seed: int, gain: float = 1.0, seconds: float = 20.0):
    """A run of a sweep from C at ``rates`` [rad/s] per joint whose twin is right but for the noise: the measured
    current ``gain`` x the simulated one (gravity at the pose, friction at the speed: :func:`currents`) + noise."""
    target = C + np.outer(np.arange(round(seconds / PERIOD)) * PERIOD, rates)
    sim = currents(target)[0]
    obs = run(name, target, seed, gain)
    meas = gain * sim + np.random.default_rng(seed).normal(0.0, SIGMA_A, sim.shape)
    e = np.zeros_like(obs.e)
    e[:, :6] = (meas - sim) / SIGMA_A
    return dataclasses.replace(obs, residual_A=meas - sim, e=e)


def test_a_joint_the_log_holds_still_is_judged_for_an_offset_not_a_gain(monkeypatch):
    """Baseline: two healthy runs of slow sweeps (every joint moving). A log of another sweep with a 30 % gain on
    shoulder_lift's current sensor is "changed" there by a gain when the log moves that joint; where the log holds
    shoulder_lift at one pose its current is a holding current, which a gain and an offset shift alike: no gain
    is named there, not even as an alternative (the shift is read as an offset if at all), and a note names the
    joint. Without the rule (monkeypatched away) the held joint's gain is named beside the offset."""
    from ur5fault.health.monitoring import changes

    b = fit_baseline([sweep(f"b{k}", np.linspace(0.02 + 0.01 * k, 0.05, 6), k) for k in range(2)], "sha")
    rates = np.linspace(0.03, 0.06, 6)
    moved = assess(b, sweep("moved", rates, 50, gain=1.3))
    assert [(c["joint"], c["effect"]) for c in moved["changes"]] == [("shoulder_lift_joint", "current_sensor_gain")]
    assert not any("held still" in note for note in moved["notes"]), moved["notes"]
    rates[1] = 0.0
    log = sweep("held", rates, 50, gain=1.3)
    out = assess(b, log)
    assert named(out) <= {"current_sensor_offset"}, out["changes"]
    (note,) = [note for note in out["notes"] if "held still" in note]
    assert note.startswith("shoulder_lift_joint: held still"), note
    monkeypatch.setattr(changes, "NEEDS_OWN_MOTION", ())
    assert "current_sensor_gain" in named(assess(b, log))


def named(out: dict) -> set[str]:
    """The effects a monitor entry names on shoulder_lift, its changes' alternatives included."""
    return {e for c in out["changes"] if c["joint"] == "shoulder_lift_joint"
            for e in [c["effect"]] + [a["effect"] for a in c["alternatives"]]}
