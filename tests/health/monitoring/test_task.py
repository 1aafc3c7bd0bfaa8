"""A robot repeating its task: the pairing of a log's targets with a baseline run's (the time shift found by
cross-correlation, refused when the motion differs), and the per-phase reference (a push at a known time is an
event there, the model's error repeated at every start and stop is not)."""

import json
from collections import Counter

import numpy as np
import pytest

from tests.health.monitoring.test_monitoring import PERIOD, part
from ur5fault.health.monitoring import assess, fit_baseline
from ur5fault.health.monitoring.baseline import Baseline
from ur5fault.health.monitoring.task import (
    CHUNK_S,
    CONTEXT_S,
    MAX_FAILED,
    MAX_MATCHES,
    SSD_RESOLUTION,
    TARGET_JITTER_RAD,
    chunks,
    matches,
    reference,
    tolerance,
)
from ur5fault.health.monitoring.verdict import judged_transients, limits


def task(waypoints: np.ndarray, move_s: float = 1.5, dwell_s: float = 0.6, lead_s: float = 0.0) -> np.ndarray:
    """Joint targets ``(n, 6)``: from each waypoint ``(k, 6)`` to the next in a cosine move of ``move_s`` and a
    dwell of ``dwell_s``, after ``lead_s`` at the first."""
    mv = np.arange(int(round(move_s / PERIOD))) * PERIOD / move_s
    parts = [np.repeat(waypoints[:1], int(round(lead_s / PERIOD)), axis=0)]
    for a, b in zip(waypoints[:-1], waypoints[1:]):
        parts.append(a + (b - a) * (0.5 - 0.5 * np.cos(np.pi * mv))[:, None])
        parts.append(np.repeat(b[None], int(round(dwell_s / PERIOD)), axis=0))
    return np.concatenate(parts)


A = np.array([1.27, -2.14, -1.95, -0.38, -2.54, -2.74])
B = np.array([0.80, -3.05, -0.20, -1.56, -3.21, -3.32])
C = np.array([0.85, -3.04, -0.20, -0.77, -2.34, -2.16])


def cycle(n_cycles: int, lead_s: float = 0.0, second=B, move_s: float = 1.5) -> np.ndarray:
    return task(np.array([A, second] * n_cycles + [A]), move_s=move_s, lead_s=lead_s)


def jitter(x: np.ndarray, seed: int) -> np.ndarray:
    return x + np.random.default_rng(seed).uniform(-0.5, 0.5, x.shape) * TARGET_JITTER_RAD


def test_a_known_shift_is_found_and_a_different_motion_refused():
    clean = cycle(3, lead_s=0.5)  # 3 cycles of 4.2 s after 0.5 s standing
    base = jitter(clean, 1)
    k = 42  # samples (0.336 s), not a multiple of anything in the task
    mon = jitter(np.concatenate([np.repeat(clean[:1], k, axis=0), clean]), 2)
    period = 2 * (round(1.5 / PERIOD) + round(0.6 / PERIOD))  # samples of one cycle A -> B -> A
    for a, b, offs in matches(mon, base, PERIOD):
        ctx = int(round(CONTEXT_S / PERIOD))
        if a - ctx >= k and b + ctx <= base.shape[0] + k:  # the base holds the chunk with its context
            assert -k in offs, (a, offs)  # the same cycle, the known shift back
            assert all((o + k) % period == 0 for o in offs)  # and only the task's other cycles
    # another task (the second waypoint differs) and the same path at another speed are refused everywhere but
    # where both stand at A
    for other in (jitter(cycle(3, second=C), 3), jitter(cycle(3, move_s=1.8), 4)):
        for a, b, offs in matches(other, base, PERIOD):
            if np.ptp(other[a:b], axis=0).max() > 1e-2:  # the chunk moves
                assert offs == [], (a, offs)
    # a run pairs with its own repeats, never with its own samples
    own = matches(base, base, PERIOD, same_run=True)
    assert all(abs(o) >= CHUNK_S / PERIOD for _, _, offs in own for o in offs)
    assert sum(bool(offs) for _, _, offs in own) >= len(own) - 2


def model_error(target: np.ndarray) -> np.ndarray:
    """A repeated model error ``(n, 6)`` [A]: 2 A spikes of 0.2 s wherever the target starts or stops (the
    twin's error at the same points of the task), the same on every repeat."""
    speed = np.abs(np.gradient(target, PERIOD, axis=0)).max(axis=1)
    moving = speed > 1e-3
    edges = np.flatnonzero(np.diff(moving.astype(int)) != 0)
    err = np.zeros(target.shape)
    w = int(round(0.2 / PERIOD))
    for e in edges:
        err[e : e + w] += 2.0 * np.hanning(min(w, target.shape[0] - e))[:, None]
    return err


def run(name: str, target: np.ndarray, seed: int, push_at: int | None = None):
    """A replayed run of the commanded ``target`` (its logged targets with the controller's jitter): the repeated
    model error, sensor noise, and a push at sample ``push_at``."""
    rng = np.random.default_rng(seed)
    r = model_error(target) + rng.normal(0.0, 0.05, target.shape)
    if push_at is not None:
        r[push_at : push_at + 40, 1] += 0.6  # 0.6 A for 0.32 s on shoulder_lift
    speed = np.abs(np.gradient(target, PERIOD, axis=0))
    return part(name, r, speed=speed, target=jitter(target, seed))


def test_the_repeated_model_error_is_not_an_event_a_push_at_a_known_time_is():
    base = [run(f"b{k}", cycle(4, lead_s=0.3 * k), 20 + k) for k in range(2)]
    b = fit_baseline(base, "sha")
    assert b.pairs  # the two baseline runs repeat each other (and their own cycles)
    target = cycle(4, lead_s=0.2)
    quiet = run("quiet", target, 40)
    starts = np.flatnonzero(np.diff((np.abs(np.diff(target, axis=0)).max(axis=1) > 0).astype(int)) == 1)
    push_at = int(starts[2]) - 5  # as the second cycle's first move starts, where the model's error is largest
    pushed = run("pushed", target, 41, push_at=push_at)
    paired = judged_transients(b, pushed)[3]
    assert paired[push_at - 60 : push_at + 100].all()  # judged against the pairs there
    assert paired.mean() > 0.8  # all but the first and last second (their context reaches past the log's ends)

    def paired_events(obs):  # the log's unpaired ends are judged by the motion's spread, not this test's subject
        return [e for e in assess(b, obs)["events"] if paired[np.searchsorted(obs.t_s, e["t_start_s"])]]

    assert paired_events(quiet) == []  # the 2 A spikes at every start and stop repeat: no event
    events = paired_events(pushed)
    assert len(events) == 1, events
    ev = events[0]
    assert ev["joints"] == ["shoulder_lift_joint"]
    assert abs(ev["t_start_s"] - pushed.t_s[push_at]) < 0.25 and abs(ev["t_end_s"] - pushed.t_s[push_at + 40]) < 0.25
    # against runs that pass the same poses at other speeds the log is not paired: judged by the motion's spread
    unpaired = [run(f"u{k}", cycle(4, lead_s=0.3 * k, move_s=1.3 + 0.4 * k), 60 + k)
                for k in range(2)]  # the same poses, moved between at other speeds
    bu = fit_baseline(unpaired, "sha")
    _, _, _, paired = judged_transients(bu, pushed)
    assert bu.pairs and not paired.any()  # the runs repeat their own cycles, the log repeats neither


def test_reference_is_the_paired_runs_residual_and_nan_where_none():
    t1 = jitter(task(np.array([A, B, C, A])), 1)  # no part of it repeats another
    r1 = np.random.default_rng(0).normal(size=t1.shape)
    ref, matched = reference(t1, [(t1, r1)], PERIOD)  # as a reference of another log: paired at lag 0
    first = int(round(CONTEXT_S / PERIOD))  # but not the first and last second: their context is cut
    assert matched[0, first:-first].all() and not matched[0, :first].any() and not matched[0, -first:].any()
    np.testing.assert_allclose(ref[first:-first], r1[first:-first])
    ref, matched = reference(t1, [(t1, r1)], PERIOD, self_index=0)  # as its own: nothing to pair
    assert not matched.any() and np.isnan(ref).all()
    other = jitter(task(np.array([A, C, B, A])), 2)  # the same poses in another order
    ref, matched = reference(other, [(t1, r1)], PERIOD)
    assert np.isnan(ref[~matched[0]]).all() and (~matched[0]).sum() > 0.5 * other.shape[0]
    # a tick the reference run did not log (NaN: a filled gap) is no reference
    gappy = r1.copy()
    gappy[400:410] = np.nan
    ref, matched = reference(t1, [(t1, gappy)], PERIOD)
    assert not matched[0, 400:410].any() and matched[0, first:400].all() and np.isfinite(ref[matched[0]]).all()


def test_without_repeats_the_judgement_is_the_motions_and_the_baseline_round_trips(tmp_path):
    runs = [part(f"r{k}", np.random.default_rng(k).normal(0, 0.1, (2000, 6))) for k in range(3)]
    b = fit_baseline(runs, "sha")
    assert not b.pairs  # ramps at distinct speeds: no run repeats another, nor itself
    new = part("new", np.random.default_rng(9).normal(0, 0.1, (2000, 6)))
    hs, lims, judged, paired = judged_transients(b, new)
    assert not paired.any()
    from ur5fault.health.monitoring.event_fit import segment

    h, feats, ok, cond = segment(new, b.slow_rad_s)
    np.testing.assert_array_equal(lims["current"], limits(b, new, feats, ok, cond, ("current",))["current"])
    np.testing.assert_array_equal(hs["current"], h[0])
    # a baseline that pairs keeps its runs and statistics through baseline.json
    base = [run(f"b{k}", cycle(4, lead_s=0.3 * k), 20 + k) for k in range(2)]
    bp = fit_baseline(base, "sha")
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(bp.to_json()))
    back = Baseline.load(path)
    assert back.pairs
    np.testing.assert_allclose(back.task_scale, bp.task_scale)
    np.testing.assert_allclose(back.task_tail, bp.task_tail)
    for x, y in zip(back.task_target_rad + back.task_residual_A, bp.task_target_rad + bp.task_residual_A):
        np.testing.assert_allclose(x, y, atol=1e-6)
    pushed = run("pushed", cycle(4, lead_s=0.2), 41, push_at=int(round(6.1 / PERIOD)))
    a, b = assess(back, pushed), assess(bp, pushed)  # the same, up to the file's rounding of the residuals
    assert a["verdict"] == b["verdict"] == "anomaly" and len(a["events"]) == len(b["events"]) >= 1
    for ea, eb in zip(a["events"], b["events"]):
        for key in ("t_start_s", "t_end_s", "joints", "channels"):
            assert ea[key] == eb[key]
        assert ea["peak_A"] == pytest.approx(eb["peak_A"], abs=1e-5)


@pytest.mark.parametrize("n", [10, 300])
def test_short_logs_pair_or_not_without_error(n):
    t = jitter(cycle(1), 5)
    ref, matched = reference(t[:n], [(t, np.zeros_like(t))], PERIOD)
    assert ref.shape == (n, 6) and matched.shape == (1, n)


def plain_ssd(chunk, ref):
    """The sum of squared differences of ``chunk`` with every stretch of ``ref``, per joint by scipy's FFT
    convolution."""
    from scipy.signal import fftconvolve

    L = chunk.shape[0]
    cross = sum(fftconvolve(ref[:, j], chunk[::-1, j], mode="valid") for j in range(chunk.shape[1]))
    csum = np.concatenate([[0.0], np.cumsum((ref**2).sum(axis=1))])
    return (chunk**2).sum() + (csum[L:] - csum[:-L]) - 2.0 * cross


def plain_matches(target, ref_target, period_s, same_run=False):
    """The pairing as first written, every lag in order of its squared difference (equal ones nearest first)
    checked in a Python loop and kept unless within half a chunk of one kept before (no cap): the slow obvious
    path."""
    n = target.shape[0]
    ctx = int(round(CONTEXT_S / period_s))
    out = []
    for a, b in chunks(n - 2 * ctx, period_s):
        a, b = a + ctx, b + ctx
        ch = target[a - ctx : b + ctx]
        ssd = plain_ssd(ch, ref_target)
        tol = tolerance(ch, period_s)
        lags = np.arange(ssd.size)
        ok = ssd <= ch.size * tol**2
        if same_run:
            ok &= np.abs(lags - (a - ctx)) >= round(CHUNK_S / period_s)
        found = []
        key = np.floor(ssd / (SSD_RESOLUTION * (ch**2).sum()))  # equal to the FFT's rounding: the nearest first
        for k in sorted(lags[ok], key=lambda k: (key[k], abs(k - (a - ctx)))):
            far = all(abs(k - f) >= (b - a) // 2 for f in found)
            if far and np.abs(ref_target[k : k + ch.shape[0]] - ch).max() <= tol:
                found.append(int(k))
        out.append((a, b, [k - (a - ctx) for k in found]))
    return out


def test_pairing_keeps_the_best_repeats_the_plain_loop_finds():
    """A cyclic task of 24 cycles (more repeats than MAX_MATCHES) against itself and against a shifted run: each
    chunk keeps the first MAX_MATCHES lags of the plain loop's, which finds them all."""
    base = jitter(cycle(24), 11)
    other = jitter(np.concatenate([np.repeat(cycle(24)[:1], 37, axis=0), cycle(24)]), 12)
    for mon, same in ((base, True), (other, False)):
        plain = plain_matches(mon, base, PERIOD, same)
        fast = matches(mon, base, PERIOD, same_run=same)[1:-1]
        assert [(a, b) for a, b, _ in plain] == [(a, b) for a, b, _ in fast]
        assert max(len(offs) for _, _, offs in plain) > MAX_MATCHES  # the cap is exercised
        for (_, _, p), (_, _, f) in zip(plain, fast):
            assert f == sorted(p[:MAX_MATCHES])


def test_a_long_rest_pairs_with_a_bounded_number_of_checks():
    """A robot standing for 240 s at one pose (targets within the controller's jitter) against itself: every
    lag of at least CHUNK_S agrees; each chunk keeps MAX_MATCHES and checks no more (the loop checked every lag:
    about cubic in the log's length). A rest 2.5e-4 rad off that pose on every joint passes the squared-difference
    bound at every lag but not the largest difference: MAX_FAILED checks per chunk, none kept."""
    n = int(round(240.0 / PERIOD))
    rest = jitter(np.repeat(A[None], n, axis=0), 21)
    count: Counter = Counter()
    pairs = matches(rest, rest, PERIOD, same_run=True, counter=count)
    inner = pairs[1:-1]
    assert len(inner) == len(chunks(n - 2 * int(round(CONTEXT_S / PERIOD)), PERIOD)) == 119
    assert all(len(offs) == MAX_MATCHES for _, _, offs in inner)
    assert all(abs(o) >= CHUNK_S / PERIOD for _, _, offs in inner for o in offs)
    assert count["kept"] == count["checked"] == MAX_MATCHES * len(inner)
    ref, matched = reference(rest, [(rest, np.ones_like(rest))], PERIOD, self_index=0)
    assert matched[0, pairs[0][1] : pairs[-1][0]].all()
    np.testing.assert_array_equal(ref[matched[0]], 1.0)
    off = jitter(np.repeat(A[None] + 2.5e-4, n, axis=0), 22)
    count = Counter()
    pairs = matches(rest, off, PERIOD, counter=count)
    assert all(offs == [] for _, _, offs in pairs)
    assert count["kept"] == 0 and count["checked"] == MAX_FAILED * len(inner)


def test_a_reloaded_baseline_is_the_fitted_one(tmp_path):
    """baseline.json keeps the task runs' targets and residuals at full precision: reloaded, they are bit for bit
    the fitted ones (NaN where a tick was not logged), and so are the verdicts."""
    base = [run(f"b{k}", cycle(4, lead_s=0.3 * k), 20 + k) for k in range(2)]
    base[0].logged[100:110] = False  # two unlogged ticks' worth of gap: NaN in the reference, null in the file
    bp = fit_baseline(base, "sha")
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(bp.to_json(), indent=2))
    back = Baseline.load(path)
    assert np.isnan(bp.task_residual_A[0][100:110]).all()
    for x, y in zip(back.task_target_rad + back.task_residual_A, bp.task_target_rad + bp.task_residual_A):
        np.testing.assert_array_equal(x, y)
    pushed = run("pushed", cycle(4, lead_s=0.2), 41, push_at=int(round(6.1 / PERIOD)))
    assert assess(back, pushed) == assess(bp, pushed)
