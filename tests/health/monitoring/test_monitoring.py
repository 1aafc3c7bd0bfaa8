"""Monitoring's pieces: event limits from the baseline's own residual transients (scaled with the motion, a bar
from the tail of their window maxima), a slow drift not an event while a push of its size is, a baseline's
within-run drift widening the change bar, the baseline file round trip; and on the real NIST log (slow) its
undisturbed rest consistent with its first part."""

import dataclasses
import json
import math
import zlib

import numpy as np
import pytest

from ur5fault.discrepancy.candidates import LibraryCandidate
from ur5fault.errors import ParameterError
from ur5fault.health.monitoring import Observed, assess, fit_baseline
from ur5fault.health.monitoring.baseline import Baseline, overlay_sha256
from ur5fault.health.monitoring.events import multiplier
from ur5fault.util.io import write_json_atomic

PERIOD = 0.008
#: the packaged friction law's Stribeck speed [rad/s] (1 / its stribeck_rate_s_per_rad of 10 s/rad)
STRIBECK_RAD_S = 0.1


def part(name: str, residual: np.ndarray, moving: bool = True, speed: np.ndarray | None = None,
         cands=(), X=None, e=None, position: np.ndarray | None = None, quantum_rad: float = np.nan,
         target: np.ndarray | None = None) -> Observed:
    """A replayed log part: ``residual`` the current residual, ``position`` the position residual (default 0);
    ``target`` the joint targets (default: a ramp at speeds drawn from the name, a motion no other part repeats,
    and that never repeats itself)."""
    n = residual.shape[0]
    if target is None:
        rate = np.random.default_rng(zlib.crc32(name.encode())).uniform(0.1, 1.0, 6)
        target = np.arange(n)[:, None] * PERIOD * rate
    speed = np.full((n, 6), 0.5 if moving else 0.0) if speed is None else speed
    X = np.zeros((0, n, 12)) if X is None else X
    e = np.zeros((n, 12)) if e is None else e
    position = np.zeros((n, 6)) if position is None else position
    return Observed(name, PERIOD, np.arange(n) * PERIOD, residual, speed > 1e-3, np.ones(n, bool), tuple(cands),
                    X, e, speed, np.zeros((n, 6)), position, np.full(6, quantum_rad), target,
                    stribeck_speed_rad_s=STRIBECK_RAD_S)


def noise(seed: int, n: int = 2000, sigma: float = 0.1) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, sigma, (n, 6))


def test_spread_grows_with_speed_as_the_baseline_residual_did():
    """Baseline noise with variance 0.05^2 + 0.1^2 |qd|: the spread at 1.4 rad/s over the one at 0.1 rad/s is
    the ratio of the generating standard deviations, sqrt(0.0165 / 0.0035), whatever the smoothing does to
    both."""
    rng = np.random.default_rng(0)
    runs = []
    for k in range(6):
        speed = np.repeat(rng.uniform(0.01, 1.5, (30, 6)), 150, axis=0)  # 1.2 s plateaus of target speed
        runs.append(part(f"r{k}", rng.normal(0.0, 1.0, speed.shape) * np.sqrt(0.05**2 + 0.1**2 * speed),
                         speed=speed))
    b = fit_baseline(runs, "sha")
    slow, fast = (b.scale[0, :, 0] + b.scale[0, :, 1] + b.scale[0, :, 2] * v for v in (0.1, 1.4))  # moving, no accel.
    np.testing.assert_allclose(np.sqrt(fast / slow), np.sqrt(0.0165 / 0.0035), rtol=0.2)  # 6 x 36 s of noise


def test_a_pulse_is_an_event_on_its_joint_and_time_and_noise_is_not():
    b = fit_baseline([part(f"r{k}", noise(k)) for k in range(3)], "sha")
    quiet = assess(b, part("quiet", noise(10)))
    assert {k: quiet[k] for k in ("log", "verdict", "changes", "events")} == {
        "log": "quiet", "verdict": "consistent", "changes": [], "events": []}
    assert quiet["notes"] == []  # every joint's baseline alike: none called out
    r = noise(11)
    r[1000:1060, 2] += 1.0  # 1 A for 0.48 s on the elbow
    out = assess(b, part("pushed", r))
    assert out["verdict"] == "anomaly" and len(out["events"]) == 1
    ev = out["events"][0]
    assert ev["joints"] == ["elbow_joint"]
    assert abs(ev["t_start_s"] - 8.0) < 0.1 and abs(ev["t_end_s"] - 8.472) < 0.1
    assert 0.85 < ev["peak_A"] < 1.15


def test_a_slow_drift_at_rest_is_not_an_event_and_a_push_of_its_size_is():
    """The real wrists at rest: a current that moves by 0.3 A over 3 s (TEST's wrist_2) on sensor noise of
    0.02 A; the baseline runs stand still with noise only. The drift is no event; a 0.5 s push of 0.3 A is,
    on its joint, within 0.1 s of its edges."""
    b = fit_baseline([part(f"r{k}", noise(k, sigma=0.02), moving=False) for k in range(3)], "sha")
    n = 2000
    t = np.arange(n) * PERIOD
    drift = noise(20, sigma=0.02)
    drift[:, 4] += 0.3 * np.clip((t - 6.0) / 3.0, 0.0, 1.0)  # 0.3 A over 3 s from 6 s on, wrist_2
    out = assess(b, part("drift", drift, moving=False))
    assert out["events"] == [] and out["verdict"] == "consistent", out
    pushed = noise(21, sigma=0.02)
    pushed[(t >= 7.0) & (t < 7.5), 4] += 0.3
    out = assess(b, part("pushed", pushed, moving=False))
    assert out["verdict"] == "anomaly" and len(out["events"]) == 1, out
    ev = out["events"][0]
    assert ev["joints"] == ["wrist_2_joint"]
    assert abs(ev["t_start_s"] - 7.0) < 0.1 and abs(ev["t_end_s"] - 7.5) < 0.1


def test_a_longer_log_gets_a_higher_bar_not_more_false_alarms():
    b = fit_baseline([part(f"r{k}", noise(k)) for k in range(3)], "sha")
    assert np.all(multiplier(b.tail[0], 400) > multiplier(b.tail[0], 100))
    # 20 undisturbed logs of 64 s from the baseline's own noise: at 1 % per log, at most one may raise an event
    alarms = sum(assess(b, part(f"q{k}", noise(100 + k, n=8000)))["verdict"] != "consistent" for k in range(20))
    assert alarms <= 1


def offset_run(name: str, offset_A: np.ndarray, seed: int) -> Observed:
    """A run whose wrist_3 current carries ``offset_A`` ``(n,)`` plus 0.05 A of noise, with the one library
    column of a wrist_3 current-sensor offset (weighted by a 1 A sigma)."""
    n = offset_A.size
    X = np.zeros((1, n, 12))
    X[0, :, 5] = 1.0
    e = np.random.default_rng(seed).normal(0.0, 0.05, (n, 12))
    e[:, 5] += offset_A
    cand = LibraryCandidate("current_sensor_offset", 5, param="offset_A", x0=0.0, probe=0.01)
    return part(name, np.zeros((n, 6)), cands=(cand,), X=X, e=e)


def test_a_drift_within_the_baseline_runs_widens_the_change_bar():
    """Three baseline runs of 20 s, wrist_3 offset -0.10 A: steady, or drifting -0.08 -> -0.12 A within each run.
    A new run steady at -0.16 A is a change against the steady baseline, not against the drifting one."""
    n = 2500
    steady = fit_baseline([offset_run(f"s{k}", np.full(n, -0.10), k) for k in range(3)], "sha")
    drifting = fit_baseline([offset_run(f"d{k}", np.linspace(-0.08, -0.12, n), k) for k in range(3)], "sha")
    label = "wrist_3_joint: current_sensor_offset.offset_A"
    (m_s, v_s, k_s), (m_d, v_d, k_d) = steady.candidates[label], drifting.candidates[label]
    assert k_s == k_d == 12  # four 5 s blocks of each run
    assert m_s == pytest.approx(-0.10, abs=0.005) and m_d == pytest.approx(-0.10, abs=0.005)
    assert v_d > 20 * v_s
    new = offset_run("new", np.full(n, -0.16), 9)
    assert assess(steady, new)["verdict"] == "changed"
    assert assess(drifting, new)["verdict"] == "consistent"


def test_a_baseline_too_short_to_see_a_change_says_so():
    """Two 6 s baseline runs give the change test two 5 s blocks: Student's bar at one degree of freedom is about
    10^4 standard deviations, and a newcomer's 0.3 A offset (5 x the event limit) was "consistent" without a
    word. The log's entry now says why and what to give; three 20 s runs (12 blocks) say nothing."""
    from ur5fault.health.monitoring.verdict import WEAK_BAR_FACTOR

    short = fit_baseline([offset_run(f"s{k}", np.full(750, -0.10), k) for k in range(2)], "sha")
    out = assess(short, offset_run("new", np.full(750, -0.40), 9))
    weak = [n for n in out["notes"] if n.startswith("changes are judged against 2 block(s) of 5 s")]
    assert len(weak) == 1 and "give longer or more baseline runs" in weak[0], out["notes"]
    bar_sd = float(weak[0].split("a change must lie ")[1].split(" standard")[0])
    # Student's t with one degree of freedom at the normal's 4-sigma tail, in closed form: cot(pi p)
    p = 0.5 * math.erfc(4.0 / math.sqrt(2.0))
    assert bar_sd == pytest.approx(1.0 / math.tan(math.pi * p), rel=5e-3)  # printed to 3 digits
    assert bar_sd > WEAK_BAR_FACTOR * 4.0
    n = 2500
    steady = fit_baseline([offset_run(f"s{k}", np.full(n, -0.10), k) for k in range(3)], "sha")
    assert not any(n.startswith("changes are judged") for n in assess(steady, offset_run("new", np.full(n, -0.16),
                                                                                          9))["notes"])


def test_baseline_round_trip_and_refusals(tmp_path):
    b = fit_baseline([part("a", noise(1)), part("b", noise(2))], overlay_sha256({}, ()))
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(b.to_json()))
    back = Baseline.load(path)
    np.testing.assert_array_equal(back.scale, b.scale)
    np.testing.assert_array_equal(back.tail, b.tail)
    assert back.segments == ("a", "b") and back.overlay_sha256 == b.overlay_sha256
    np.testing.assert_array_equal(back.quantum_rad, b.quantum_rad)
    np.testing.assert_array_equal(back.cond_scale, b.cond_scale)
    np.testing.assert_array_equal(back.cond_tail, b.cond_tail)
    assert back.slow_rad_s == b.slow_rad_s
    # a statistic with no value (NaN) is written as null (strict JSON) and read back as NaN
    label = "wrist_3_joint: current_sensor_offset.offset_A"
    holes = dataclasses.replace(b, scale=np.where(np.arange(b.scale.size).reshape(b.scale.shape) == 0, np.nan, b.scale),
                                candidates={**b.candidates, label: (0.01, np.nan, 1)})
    write_json_atomic(path, holes.to_json())
    assert "NaN" not in path.read_text()
    back = Baseline.load(path)
    np.testing.assert_array_equal(back.scale, holes.scale)
    assert np.isnan(back.candidates[label][1]) and back.candidates[label][2] == 1
    path.write_text(json.dumps({**b.to_json(), "channels": 3}))
    with pytest.raises(ParameterError, match="not a valid monitor baseline"):
        Baseline.load(path)
    # the earlier format (current channel only, keys "scale" / "tail" at the top) is refused, not misread
    path.write_text(json.dumps({**b.to_json(), "format": "ur5fault-monitor-baseline-2"}))
    with pytest.raises(ParameterError, match="ur5fault-monitor-baseline-2.*expected 'ur5fault-monitor-baseline-10'"):
        Baseline.load(path)
    # the last format (no task runs) likewise: rebuilt, not read without its pairing
    path.write_text(json.dumps({**b.to_json(), "format": "ur5fault-monitor-baseline-3"}))
    old = "ur5fault-monitor-baseline-3.*rebuild|ur5fault-monitor-baseline-3.*write"
    with pytest.raises(ParameterError, match=old) as e:
        Baseline.load(path)
    assert "not a valid monitor baseline" not in str(e.value)  # its own line, not wrapped in the generic one
    # formats 4 and 5 (no statistics per motion condition) likewise
    for old_format in ("ur5fault-monitor-baseline-4", "ur5fault-monitor-baseline-5"):
        path.write_text(json.dumps({**b.to_json(), "format": old_format}))
        with pytest.raises(ParameterError, match=f"{old_format}.*write") as e:
            Baseline.load(path)
        assert "not a valid monitor baseline" not in str(e.value)
    with pytest.raises(ParameterError, match="too few judged samples"):
        fit_baseline([part("short", noise(4, n=40)), part("short2", noise(5, n=40))], "sha")  # 2 x 0.32 s
    with pytest.raises(ParameterError, match="sample period"):
        assess(b, dataclasses.replace(part("x", noise(3)), period_s=0.002))


def test_a_baseline_of_one_run_is_refused_in_python_and_from_baseline_json(tmp_path):
    """One healthy observation cannot give the event limits' tail (each run normalised by the spread fitted on the
    others): judged by its own fit, a spread of 0 where it holds little of a motion called healthy runs anomalies.
    Refused by fit_baseline (a part of a log counts as an observation; one without judged samples does not), and a
    baseline.json of one run (written by an earlier version) is refused on loading with the same reason."""
    why = "at least 2 healthy runs or log parts .* got 1: the event limits' tail .*leave one out"
    with pytest.raises(ParameterError, match=why):
        fit_baseline([part("one", noise(1))], "sha")
    with pytest.raises(ParameterError, match=why):  # 0.16 s: under the replay's first 0.25 s, nothing judged
        fit_baseline([part("one", noise(1)), part("blip", noise(2, n=20))], "sha")
    two = fit_baseline([part("a", noise(1)), part("b", noise(2))], "sha").to_json()
    for key in ("rest_targets", "motion_max", "payloads_kg", "samples_sha256"):  # not recorded by one-run versions
        two.pop(key, None)
    one = {**two, "segments": two["segments"][:1], "task_runs": two["task_runs"][:1]}
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(one))
    with pytest.raises(ParameterError, match=r"built from 1 healthy run\(s\) \(a\); a baseline needs at least 2: "
                                             r"the event limits' tail .*rebuild it with --baseline-logs"):
        Baseline.load(path)


def test_baseline_json_records_its_runs_target_at_rest_for_the_two_controllers_note(tmp_path):
    """A CB3 log judged against the baseline.json of CB2 runs gets the note that --baseline-logs gives (logs of two
    controllers, likely two robots): the file records each run's target at rest. A baseline.json written before
    it did still loads, with nothing recorded (the command line then says it cannot check)."""
    from ur5fault.logs import MeasuredLog
    from ur5fault.logs.measured import assumption_notes

    cb2 = [dataclasses.replace(part(n, noise(k)), rest_target="reading") for k, n in enumerate(("no8.csv", "no2.csv"))]
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(fit_baseline(cb2, "sha").to_json()))
    assert json.loads(path.read_text())["rest_targets"] == ["reading", "reading"]
    back = Baseline.load(path)
    assert back.rest_targets == ("reading", "reading")
    q = np.zeros((10, 6))
    cb3 = MeasuredLog("nist15.csv", np.arange(10) * PERIOD, q, q, q, rest_target="setpoint")
    notes = assumption_notes([cb3], [28.0] * 6, others=list(zip(back.segments, back.rest_targets)))
    assert ("the target at rest is the previous reading in no8.csv, no2.csv (as a CB2 controller logs it) and a "
            "fixed setpoint in nist15.csv (as a CB3's): logs of two controllers, likely two robots, under one "
            "model") in notes
    older = json.loads(path.read_text())
    del older["rest_targets"]
    path.write_text(json.dumps(older))
    assert Baseline.load(path).rest_targets is None
    assert "rest_targets" not in Baseline.load(path).to_json()  # written back still saying nothing
    path.write_text(json.dumps({**older, "rest_targets": ["reading"]}))  # not one per run
    with pytest.raises(ParameterError, match="not a valid monitor baseline.*rest_targets"):
        Baseline.load(path)


def test_baseline_json_records_its_runs_samples_and_refuses_a_log_of_them_before_its_replay(tmp_path):
    """The SHA-256 of each whole run's samples rides in baseline.json (a part's is not recorded), so that a log that
    is one of the runs is refused from its samples alone (verdict.refuse_baseline_runs, called before any replay);
    a baseline.json written before it recorded them still loads and refuses nothing there (assess does, after)."""
    from ur5fault.health.monitoring.verdict import refuse_baseline_runs
    from ur5fault.logs import MeasuredLog

    q = np.cumsum(np.full((10, 6), 0.01), axis=0)
    logs = [MeasuredLog(f"run{k}.csv", np.arange(10) * PERIOD, q, q + 1e-4 * k, q) for k in range(3)]
    runs = [dataclasses.replace(part(lg.source, noise(k)), samples_sha256=lg.content_sha256())
            for k, lg in enumerate(logs[:2])]
    path = tmp_path / "baseline.json"
    path.write_text(json.dumps(fit_baseline([*runs, part("a part", noise(5))], "sha").to_json()))
    back = Baseline.load(path)
    assert back.samples_sha256 == (logs[0].content_sha256(), logs[1].content_sha256(), None)
    with pytest.raises(ParameterError, match=r"^run1.csv is one of the baseline's runs \(run1.csv: the same samples\)"):
        refuse_baseline_runs(back, [logs[2], logs[1]])
    refuse_baseline_runs(back, [logs[2]])  # another recording of the same motion: judged
    older = json.loads(path.read_text())
    del older["samples_sha256"]
    path.write_text(json.dumps(older))
    assert Baseline.load(path).samples_sha256 is None and "samples_sha256" not in Baseline.load(path).to_json()
    refuse_baseline_runs(Baseline.load(path), logs)
    path.write_text(json.dumps({**older, "samples_sha256": ["0" * 64, None]}))  # not one per run
    with pytest.raises(ParameterError, match="not a valid monitor baseline.*samples_sha256"):
        Baseline.load(path)

@pytest.mark.slow
def test_nist_rest_consistent_with_its_first_part_despite_the_wrist_3_offset_drift(nist_path):
    """Baseline: the first FIT_FRACTION of the real NIST log under the packaged model (whose values were fitted
    on this log), as two parts (a baseline needs two observations for its event limits' tail). The logged wrist_3
    current's offset moves from about -0.10 A there to -0.14 A in the rest (the reading of docs/monitoring.md's
    earlier version, which called the rest 'changed' for it); the drift between the first part's time blocks now
    bounds it, and the undisturbed rest raises no event."""
    from ur5fault.health.monitoring import observe
    from ur5fault.logs import read_log
    from ur5fault.twin.residuals import FIT_FRACTION

    log = read_log(nist_path, "nist")
    span = float(log.t_s[-1] - log.t_s[0])
    split = FIT_FRACTION * span
    b = fit_baseline([observe(log, part_s=(0.0, split / 2), jobs=2), observe(log, part_s=(split / 2, split), jobs=2)],
                     overlay_sha256({}, ()))
    assert b.candidates["wrist_3_joint: current_sensor_offset.offset_A"][2] == 8  # four 4.8 s blocks of each 19 s
    out = assess(b, observe(log, part_s=(split, span + 1), jobs=2))
    assert out["verdict"] == "consistent", out


def test_a_push_names_every_joint_it_loads_above_the_events_own_bar():
    """A push loads several joints: 1 A on the elbow finds the event; a second joint pushed to between the bar
    for the event's own windows and the log's bar is named in it too, and alone it raises no event (the log's
    bar); the joints the push does not load are not named."""
    from ur5fault.health.monitoring.events import WINDOW_S, n_windows
    from ur5fault.health.monitoring.verdict import transients_and_limits

    b = fit_baseline([part(f"r{k}", noise(k)) for k in range(3)], "sha")
    _, limits_at, judged, _ = transients_and_limits(b, part("quiet", noise(10)))
    rows = slice(1000, 1060)  # 0.48 s
    share = np.ceil(0.48 / WINDOW_S) / n_windows(judged, PERIOD)
    log_bar, event_bar = (float(limits_at(s)["current"][1030, 3]) for s in (1.0, share))
    assert event_bar < 0.8 * log_bar
    second = 0.5 * (log_bar + event_bar)
    r = noise(11)
    r[rows, 2] += 1.0
    r[rows, 3] += second
    ev = assess(b, part("pushed", r))["events"]
    assert len(ev) == 1 and ev[0]["joints"] == ["elbow_joint", "wrist_1_joint"], ev
    alone = noise(11)
    alone[rows, 3] += second
    assert assess(b, part("wrist_1 alone", alone))["events"] == []


def test_the_figure_draws_the_event_limit_that_named_each_joint():
    """The monitor figure shows, over an event on each joint it names, the limit for the event's own windows (the
    bar that named it, below the log's): a joint named between the two bars no longer shows its transient under
    the only red line. Not on the joints the event does not name."""
    from ur5fault.health.monitoring.events import WINDOW_S, n_windows
    from ur5fault.health.monitoring.report import figure
    from ur5fault.health.monitoring.verdict import transients_and_limits

    b = fit_baseline([part(f"r{k}", noise(k)) for k in range(3)], "sha")
    r = noise(11)
    rows = slice(1000, 1060)
    _, limits_at, judged, _ = transients_and_limits(b, part("quiet", noise(10)))
    share = np.ceil(0.48 / WINDOW_S) / n_windows(judged, PERIOD)
    log_bar, event_bar = (float(limits_at(s)["current"][1030, 3]) for s in (1.0, share))
    r[rows, 2] += 1.0
    r[rows, 3] += 0.5 * (log_bar + event_bar)
    log = part("pushed", r)
    entry = assess(b, log)
    assert entry["events"][0]["joints"] == ["elbow_joint", "wrist_1_joint"]
    fig = figure(b, log, entry, ("current",))
    label = "limit for the event's own windows"
    axes = np.array(fig.axes).reshape(6, 2)
    for j in range(6):
        own = [ln for ln in axes[j, 0].get_lines() if ln.get_label() == label]
        assert len(own) == (1 if j in (2, 3) else 0), j
        if own:
            lim = np.asarray(own[0].get_ydata())
            full = [ln for ln in axes[j, 0].get_lines() if ln.get_label() == "limit"][0].get_ydata()
            start = int(np.flatnonzero(np.asarray(own[0].get_xdata())[0] == log.t_s)[0])
            assert np.all(lim < 0.8 * np.asarray(full)[start : start + lim.size])  # the event's bar, not the log's
    assert label in [t.get_text() for t in axes[0, 0].get_legend().get_texts()]  # in the column's one legend


def test_joints_the_push_does_not_load_are_seldom_named():
    """40 logs with 1 A on the elbow for 0.48 s and noise on the other five joints: a joint named beside the
    elbow in the push's event is a false naming, each event's at most 1 % by the bar's design (binomial: 3 or
    more of 40 has probability 0.008)."""
    b = fit_baseline([part(f"r{k}", noise(k)) for k in range(3)], "sha")
    extra = 0
    for seed in range(100, 140):
        r = noise(seed)
        r[1000:1060, 2] += 1.0
        ev = [e for e in assess(b, part(f"p{seed}", r))["events"] if e["t_start_s"] < 8.48 and e["t_end_s"] > 8.0]
        assert len(ev) == 1 and "elbow_joint" in ev[0]["joints"], ev  # (an event elsewhere: the log's own 1 %)
        extra += len(ev[0]["joints"]) - 1
    assert extra <= 2


def test_a_joint_judged_against_a_limit_far_above_the_others_is_called_out():
    """Two clean baseline runs that hardly moved wrist 2 set its current limit at 29,191 x its spread: a 5 A bump of
    0.5 s there was "consistent" without a word, where the same bump on the base was an event. The verdict now names
    a joint whose typical limit is BLIND_FACTOR times the joints' median or more."""
    from ur5fault.health.monitoring.verdict import BLIND_FACTOR, blind_joints

    typical = {"current": np.array([0.9, 1.1, 0.8, 0.3, 46.0, 0.2]), "position": np.full(6, 2e-4)}
    notes = blind_joints(typical)
    assert len(notes) == 1 and notes[0].startswith("wrist_2_joint: its current events are judged against a limit "
                                                   "of 46 A"), notes
    healthy = {"current": np.array([0.9, 1.1, 0.8, 0.3, 0.6 * BLIND_FACTOR * 0.7, 0.2])}
    assert blind_joints(healthy) == []
    assert blind_joints({"current": np.full(6, np.nan)}) == []  # nothing judged: nothing said


def test_a_limit_above_every_current_the_joint_draws_is_called_out_where_the_median_is_far_out_too():
    """A newcomer's baseline of two runs of other tasks: TEST judged against current limits of 8.65 / 54.9 / 11.3 /
    0.77 / 0.20 / 0.53 A (report.md), a +3 A bump of 2 s on the base "consistent", and only the shoulder named (54.9
    is 10 x the median, which the other far-out joints raise). A limit above the largest current the joint draws in
    the log is named too (TEST's peaks; wrist_1's limit is just above its 0.764 A); the position channel has no such
    bound."""
    from ur5fault.health.monitoring.observe import peak_current
    from ur5fault.health.monitoring.verdict import blind_joints

    limits = np.array([8.65, 54.9, 11.3, 0.766, 0.198, 0.532])
    peak = np.array([1.30, 7.52, 3.02, 0.764, 0.54, 0.61])  # TEST's largest |current| per joint
    typical = {"current": limits, "position": np.full(6, 2e-4)}
    assert [n.split(":")[0] for n in blind_joints(typical)] == ["shoulder_lift_joint"]  # the median rule alone
    notes = blind_joints(typical, peak)
    assert [n.split(":")[0] for n in notes] == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                                 "wrist_1_joint"], notes
    assert "limit of 8.65 A at this log's motion, above the largest current it draws in this log (1.3 A)" in notes[0]
    assert "12 x the joints' median (4.71 A)" in notes[1] and "largest" not in notes[1]  # once, the median's words
    # a working baseline (the pushed run against its undisturbed repeat, report.md): nothing said
    assert blind_joints({"current": np.array([0.581, 1.25, 0.466, 0.161, 0.0896, 0.0693])}, peak) == []
    # the peak over logged samples only; a joint never logged is NaN, and nothing is said of it
    cur = np.array([[1.0, -2.0], [-3.0, 0.5], [9.0, 9.0]])
    assert peak_current(cur, np.array([True, True, False])).tolist() == [3.0, 2.0]
    assert blind_joints({"current": np.array([5.0, 0.1])}, np.array([np.nan, 0.2])) == []


def test_the_joints_whose_events_are_not_seen_stand_beside_the_verdict():
    """A newcomer read "consistent (0 changes, 0 events)" on a Kufieta run whose shoulder_lift events were judged
    against a limit of 107 A (17 x the median): only a note on stderr said it. The joints the notes name are listed
    in monitor.json's ``events_not_seen`` and on the console line beside the verdict, the same joints as the notes."""
    from ur5fault.health.monitoring.verdict import blind_joints, unseen

    limits = np.array([8.65, 54.9, 11.3, 0.766, 0.198, 0.532])
    peak = np.array([1.30, 7.52, 3.02, 0.764, 0.54, 0.61])
    typical = {"current": limits, "position": np.array([2e-4, 2e-4, 2e-4, 2e-4, 2e-4, 9e-3])}
    names = unseen(typical, peak)
    assert names == ["shoulder_pan_joint current", "shoulder_lift_joint current", "elbow_joint current",
                     "wrist_1_joint current", "wrist_3_joint position"]
    assert [n.split(":")[0] for n in blind_joints(typical, peak)] == [n.split()[0] for n in names]
    assert unseen({"current": np.array([0.581, 1.25, 0.466, 0.161, 0.0896, 0.0693])}, peak) == []


def test_the_peak_rule_holds_only_for_joints_the_log_moves():
    """A joint the log holds still draws its holding current and noise (the standstill run's wrists: 0.05 A), under
    any limit a spread gives: not called blind for that (the review's case). Its peak is left out; a moved joint's
    is kept."""
    from ur5fault.health.monitoring.verdict import blind_joints, moved_peak

    speed = np.full((2000, 6), 0.5)
    speed[:, 4:] = 0.0  # wrist_2 and wrist_3 never move
    speed[:30, 3] = 0.5  # (wrist_1 moves throughout)
    obs = dataclasses.replace(part("still wrists", noise(5), speed=speed),
                              current_peak_A=np.array([2.0, 7.5, 3.0, 0.8, 0.056, 0.05]))
    peak = moved_peak(obs)
    np.testing.assert_array_equal(np.isnan(peak), [False, False, False, False, True, True])
    limits = {"current": np.array([0.58, 1.25, 0.47, 0.16, 0.2, 0.2])}
    assert blind_joints(limits, obs.current_peak_A) != []  # the raw peaks would call the still wrists blind
    assert blind_joints(limits, peak) == []
    brief = speed.copy()
    brief[:50, 4] = 0.3  # 0.4 s of motion: under the half second a coverage note needs
    assert np.isnan(moved_peak(dataclasses.replace(obs, speed_rad_s=brief, moving=brief > 1e-3))[4])
    assert moved_peak(dataclasses.replace(obs, current_peak_A=None)) is None
