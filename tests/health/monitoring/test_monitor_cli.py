"""``ur5fault monitor`` on short parts of the real Kufieta runs: the schema of monitor.json, a healthy run
consistent, a labelled push flagged on its joint, the baseline reused; bad input refused with one line."""

import json
import subprocess
import sys

import pandas as pd
import pytest

from tests.conftest import KUFIETA_DIR
from ur5fault.sim.axes import JOINT_NAMES

CMD = [sys.executable, "-m", "ur5fault.cli", "monitor"]
RTDE = ["--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0"]


def run(*args):
    return subprocess.run([*CMD, *args], capture_output=True, text=True, timeout=1200)


def head(tmp_path, run_name: str, seconds: float):
    """The first ``seconds`` of a Kufieta run as an RTDE file of its own (as the robot wrote it)."""
    df = pd.read_csv(KUFIETA_DIR / f"{run_name}.csv.gz")
    path = tmp_path / f"{run_name}_{seconds:g}s.csv"
    df[df["time"] - df["time"].iloc[0] < seconds].to_csv(path, index=False)
    return path


@pytest.fixture(scope="module")
def monitored(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("monitor")
    model = tmp / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    # the robot's other undisturbed runs (the pair below excepted), as long as the monitored parts
    base = [head(tmp, n, 14.0) for n in ("Movement_No1", "Movement_No2", "Movement_No3_Acc", "Movement_No4_Acc",
                                         "Movement_No8_Singularity_Free_1")]
    logs = [head(tmp, "Movement_No5_Acc_slow_no_disturbance", 14.0),
            head(tmp, "Movement_No5_Acc_slow_w_disturbance", 14.0)]
    out = tmp / "out"
    r = run(*map(str, logs), *RTDE, "--baseline", str(model), "--baseline-logs", *map(str, base), "--out", str(out),
            "--jobs", "2")
    assert r.returncode == 0, r.stderr
    return tmp, model, logs, out, r


@pytest.mark.slow
def test_monitor_json_schema(monitored):
    _, _, logs, out, _ = monitored
    data = json.loads((out / "monitor.json").read_text())
    assert list(data) == ["logs", "notes"]
    assert [e["log"] for e in data["logs"]] == [p.name for p in logs]
    for e in data["logs"]:
        assert set(e) == {"log", "verdict", "changes", "events", "event_limit_median", "events_not_seen", "notes"}
        assert set(e["event_limit_median"]["current"]) == set(JOINT_NAMES)
        # each joint whose events are not seen is the subject of a note
        assert all(any(n.startswith(f"{s.split()[0]}: its {s.split()[1]} events") for n in e["notes"])
                   for s in e["events_not_seen"])
        assert e["verdict"] in ("consistent", "changed", "anomaly")
        for ev in e["events"]:
            assert set(ev) == {"t_start_s", "t_end_s", "joints", "channels", "peak_A", "peak_rad"}
            assert ev["t_start_s"] <= ev["t_end_s"] and ev["peak_A"] > 0 and ev["joints"]
            assert ev["channels"] == ["current"]  # the default: events on the current alone
        for ch in e["changes"]:
            assert set(ch) == {"joint", "effect", "parameter", "value", "interval", "baseline_value", "distance",
                               "alternatives", "reference"}
            assert ch["reference"] in ("paired", "blocks")
    for f in ("report.md", "baseline.json", "monitor_1.png", "monitor_2.png"):
        assert (out / f).is_file()


@pytest.mark.slow
def test_healthy_run_consistent_and_push_flagged_on_its_joint(monitored):
    _, _, _, out, _ = monitored
    quiet, pushed = json.loads((out / "monitor.json").read_text())["logs"]
    assert quiet["verdict"] == "consistent", quiet
    # the push at 12.7 s of Movement_No5_Acc_slow_w_disturbance: the base joint's current leaves UR's own model
    # by 4 A there (data/kufieta-ur5: 12.6-12.95 s), the paired undisturbed run never by more than 1.6 A
    assert pushed["verdict"] == "anomaly", pushed
    hit = [ev for ev in pushed["events"] if ev["t_start_s"] < 13.4 and ev["t_end_s"] > 12.2]
    assert hit and "shoulder_pan_joint" in hit[0]["joints"]
    assert abs(hit[0]["t_start_s"] - 12.65) < 0.5 and abs(hit[0]["t_end_s"] - 12.95) < 0.5


@pytest.mark.slow
def test_baseline_stats_reused_and_refused_under_another_overlay(monitored):
    tmp, model, logs, out, _ = monitored
    again = tmp / "again"
    r = run(str(logs[0]), *RTDE, "--baseline", str(model), "--baseline-stats", str(out / "baseline.json"),
            "--out", str(again), "--jobs", "2")
    assert r.returncode == 0, r.stderr
    first = json.loads((out / "monitor.json").read_text())["logs"][0]
    assert json.loads((again / "monitor.json").read_text())["logs"][0] == first
    assert "read unverified" not in r.stderr
    assert "does not record" not in r.stderr  # this version's file records what it covered
    older = tmp / "older.json"  # written before baseline.json recorded the runs' motion range and payloads
    data = json.loads((out / "baseline.json").read_text())
    assert data["payloads_kg"] == [0.0] * 5 and set(data["motion_max"]) == {"speed_rad_s",
                                                                              "others_speed_standing_rad_s"}
    speed_only = tmp / "speed_only.json"  # written before it recorded the joints standing while others move
    speed_only.write_text(json.dumps({**data, "motion_max": {"speed_rad_s": data["motion_max"]["speed_rad_s"]}}))
    r = run(str(logs[0]), *RTDE, "--baseline", str(model), "--baseline-stats", str(speed_only), "--out",
            str(tmp / "s"), "--jobs", "2")
    assert r.returncode == 0 and ("speed_only.json does not record its runs' other joints' speed while a joint "
                                  "stands (written by an earlier version)") in r.stderr, r.stderr
    older.write_text(json.dumps({k: v for k, v in data.items() if k not in ("motion_max", "payloads_kg")}))
    r = run(str(logs[0]), *RTDE, "--baseline", str(model), "--baseline-stats", str(older), "--out", str(tmp / "o"),
            "--jobs", "2")
    assert r.returncode == 0 and ("older.json does not record its runs' motion range and payloads (written by an "
                                  "earlier version)") in r.stderr, r.stderr
    assert json.loads((tmp / "o" / "monitor.json").read_text())["logs"][0]["verdict"] == first["verdict"]
    bare = tmp / "bare.json"  # copied without its checksum file, or edited by hand: used, and said so
    bare.write_bytes((out / "baseline.json").read_bytes())
    r = run(str(logs[0]), *RTDE, "--baseline", str(model), "--baseline-stats", str(bare), "--out", str(tmp / "b"),
            "--jobs", "2")
    assert r.returncode == 0 and "bare.json: no bare.json.sha256 beside it; read unverified" in r.stderr, r.stderr
    # written back without a checksum: a fresh one would vouch for statistics nothing checked
    assert (tmp / "b" / "baseline.json").is_file() and not (tmp / "b" / "baseline.json.sha256").exists()
    assert (again / "baseline.json.sha256").exists()  # read against its checksum: written with one
    other = tmp / "other.yaml"
    other.write_text("params: {}\neffects:\n  - {effect: coulomb_friction, joint: 1, scale: 1.1}\n")
    r = run(str(logs[0]), *RTDE, "--baseline", str(other), "--baseline-stats", str(out / "baseline.json"),
            "--out", str(tmp / "x"))
    assert r.returncode == 2 and "another model overlay" in r.stderr and "Traceback" not in r.stderr


@pytest.mark.parametrize("extra, message", [
    ([], "one of the arguments --baseline-logs --baseline-stats is required"),
    (["--baseline-stats", "BASE"], "not a monitor baseline"),
    (["--baseline-stats", "NOFILE"], "no such file"),
    (["--baseline-logs", "LOG"], "both monitored and a baseline log"),
    # one healthy run: no run to leave out for the event limits' tail (healthy runs were called anomalies)
    (["--baseline-logs", "OTHER"], "--baseline-logs: 1 healthy run given; a baseline needs at least 2"),
    (["--baseline-logs", "LOG", "--jobs", "0"], "--jobs 0 must be at least 1"),
    (["--baseline-logs", "LOG", "--event-channels", "torque"], "invalid choice: 'torque'"),
])
def test_bad_input_one_line(tmp_path, extra, message):
    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    log = head(tmp_path, "Movement_No2", 6.0)
    bad = tmp_path / "base.json"
    bad.write_text('{"format": "something else"}')
    other = head(tmp_path, "Movement_No8_Singularity_Free_1", 6.0) if "OTHER" in extra else None
    extra = [{"BASE": str(bad), "NOFILE": str(tmp_path / "none.json"), "LOG": str(log), "OTHER": str(other)}.get(a, a)
             for a in extra]
    r = run(str(log), *RTDE, "--baseline", str(model), *extra, "--out", str(tmp_path / "out"))
    assert r.returncode == 2, r.stderr
    assert message in r.stderr and "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) <= 2  # argparse: usage + the error line


def test_bad_model_one_line(tmp_path):
    model = tmp_path / "model.yaml"
    model.write_text("params: {nonsense: 1}\n")
    log = head(tmp_path, "Movement_No2", 6.0)
    r = run(str(log), *RTDE, "--baseline", str(model), "--baseline-logs", str(log), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and r.stderr.startswith("ur5fault: error:") and "Traceback" not in r.stderr


def test_a_short_log_is_refused_as_too_short_to_judge_a_short_baseline_log_to_fit(tmp_path, capsys):
    """A monitored log under 5 s was refused with "fitting needs at least 5 s", though monitor fits nothing to the
    logs it judges: the same rule said as judging; a baseline log, which the limits are fitted on, as fitting."""
    from ur5fault.cli import main

    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    short, log = head(tmp_path, "Movement_No2", 3.0), head(tmp_path, "Movement_No1", 6.0)
    base = [str(head(tmp_path, n, 6.0)) for n in ("Movement_No4_Acc", "Movement_No8_Singularity_Free_1")]
    for monitored, baseline, need in ((short, base, "judging"), (log, [*base, str(short)], "fitting")):
        capsys.readouterr()
        assert main(["monitor", str(monitored), *RTDE, "--baseline", str(model), "--baseline-logs", *baseline,
                     "--out", str(tmp_path / "out"), "--quiet"]) == 2
        err = [line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith("note: ")]
        assert len(err) == 1 and err[0].startswith(f"ur5fault: error: {short.name}: 2.9"), err
        assert err[0].endswith(f"; {need} needs at least 5 s and 250 samples"), err
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_a_baseline_run_monitored_against_its_own_statistics_refused(monitored):
    """One of the baseline's runs monitored against the baseline.json it is part of: it would pair with its own
    samples at lag 0 and never change; refused with one line naming the run (before its replay: the baseline the
    real replays built records its runs' samples)."""
    tmp, model, _, out, _ = monitored
    own = tmp / "Movement_No2_14s.csv"  # one of the fixture's baseline logs
    r = run(str(own), *RTDE, "--baseline", str(model), "--baseline-stats", str(out / "baseline.json"),
            "--out", str(tmp / "self"), "--jobs", "2")
    assert r.returncode == 2, r.stderr
    last = r.stderr.strip().splitlines()[-1]  # after the reader's notes (the log's clock), if any
    assert last.startswith("ur5fault: error:") and "is one of the baseline's runs" in last
    assert "Movement_No2_14s.csv: the same samples" in last and "Traceback" not in r.stderr
    assert r.stderr.count("ur5fault: error:") == 1


def test_a_log_of_another_rate_than_its_baseline_is_refused_before_any_replay(tmp_path):
    """A log decimated to 16 ms judged against a baseline of 8 ms runs was refused only after seconds of replays, with
    no word on what to do. Now before any replay, saying to build a baseline at the log's rate."""
    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    base = [str(head(tmp_path, run, 6.0)) for run in ("Movement_No8_Singularity_Free_1", "Movement_No4_Acc")]
    df = pd.read_csv(head(tmp_path, "Movement_No5_Acc_slow_no_disturbance", 12.0))  # one row every tick
    slow = tmp_path / "slow.csv"
    df.iloc[::2].to_csv(slow, index=False)
    r = run(str(slow), *RTDE, "--baseline", str(model), "--baseline-logs", *base, "--out", str(tmp_path / "out"))
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    err = [line for line in r.stderr.strip().splitlines() if not line.startswith("note: ")]
    assert len(err) == 1 and "slow.csv: logged every 16 ms, the baseline's runs every 8 ms" in err[0], r.stderr
    assert "build one from healthy logs at this rate with --baseline-logs" in err[0]


def test_a_baseline_run_given_again_is_refused_before_any_replay(tmp_path, monkeypatch, capsys):
    """`monitor RUN --baseline-stats baseline.json` with RUN one of the runs baseline.json was built from was refused
    only after RUN's replay (minutes on a long log): its samples' SHA-256, recorded in baseline.json, now refuses it
    before any replay, in the same line. The replays are stand-ins (their residual noise): the baseline is built
    through the command, the refusal must come with the replay patched to fail."""
    import dataclasses
    import importlib

    from tests.health.monitoring.test_monitoring import noise, part
    from ur5fault.cli import main

    def stand_in(log, params=None, effects=(), **kw):  # what observe keeps of a whole log, its residual noise
        o = part(log.source, noise(len(log.source), log.t_s.size - 1), target=log.q_target_rad[1:])
        return dataclasses.replace(o, rest_target=log.rest_target, payload_kg=log.payload_kg,
                                   samples_sha256=log.content_sha256())

    observe_module = importlib.import_module("ur5fault.health.monitoring.observe")  # the package exports the function
    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    base = [head(tmp_path, n, 6.0) for n in ("Movement_No1", "Movement_No2", "Movement_No4_Acc")]
    monkeypatch.setattr(observe_module, "observe", stand_in)
    built = tmp_path / "built"
    assert main(["monitor", str(base[2]), *RTDE, "--baseline", str(model), "--baseline-logs", *map(str, base[:2]),
                 "--out", str(built), "--jobs", "1"]) == 0
    capsys.readouterr()

    def replayed(*args, **kw):
        raise AssertionError("replayed")

    monkeypatch.setattr(observe_module, "observe", replayed)
    monkeypatch.setattr(observe_module, "LogReplay", replayed)
    out = tmp_path / "self"
    assert main(["monitor", str(base[1]), *RTDE, "--baseline", str(model), "--baseline-stats",
                 str(built / "baseline.json"), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0] == (
        "ur5fault: error: Movement_No2_6s.csv is one of the baseline's runs (Movement_No2_6s.csv: the same samples); "
        "judged against itself it pairs at lag 0 and can never change: monitor it against a baseline without it"), err
    assert not out.exists()


def test_progress_counts_each_replay_once_and_quiet_switches_it_off(tmp_path, monkeypatch, capsys):
    """`monitor` was silent for minutes while it replayed its logs: a bar of logs replayed (each once: the baseline
    runs screened, the monitored logs not), off with --quiet. Stand-in replays, as in the test above."""
    import dataclasses
    import importlib

    from tests.health.monitoring.test_monitoring import noise, part
    from ur5fault.cli import main
    from ur5fault.util import progress

    calls = []

    def stand_in(log, params=None, effects=(), **kw):
        calls.append((log.source, "screen_s" in kw))
        o = part(log.source, noise(len(log.source), log.t_s.size - 1), target=log.q_target_rad[1:])
        return dataclasses.replace(o, rest_target=log.rest_target, payload_kg=log.payload_kg,
                                   samples_sha256=log.content_sha256())

    bars = []

    class Bar:  # tqdm counts nothing when stderr is no terminal (here): a bar that does
        n = 0

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return False

        def update(self, k):
            self.n += k

    def recorded(total, desc, unit="it", enabled=True, **kw):
        b = Bar()
        bars.append((total, desc, enabled, b))
        return b

    monkeypatch.setattr(importlib.import_module("ur5fault.health.monitoring.observe"), "observe", stand_in)
    monkeypatch.setattr(progress, "bar", recorded)
    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    base = [head(tmp_path, n, 6.0) for n in ("Movement_No1", "Movement_No2", "Movement_No4_Acc")]
    assert main(["monitor", str(base[2]), *RTDE, "--baseline", str(model), "--baseline-logs", *map(str, base[:2]),
                 "--out", str(tmp_path / "a"), "--jobs", "1"]) == 0
    assert calls == [(base[0].name, True), (base[1].name, True), (base[2].name, False)]
    total, desc, enabled, b = bars[-1]
    assert (total, desc, enabled, b.n) == (3, "monitor: logs replayed", True, 3)
    calls.clear()
    assert main(["monitor", str(base[2]), *RTDE, "--baseline", str(model), "--baseline-stats",
                 str(tmp_path / "a" / "baseline.json"), "--out", str(tmp_path / "b"), "--quiet"]) == 0
    assert calls == [(base[2].name, False)]
    total, _, enabled, b = bars[-1]
    assert (total, enabled, b.n) == (1, False, 1)
    capsys.readouterr()


def test_a_result_replaced_with_replace_is_said_replaced(tmp_path, monkeypatch, capsys):
    """`monitor --replace` over an earlier result said "wrote", where simulate, show and plot say "replaced".
    Stand-in replays, as in the tests above: what is checked is the closing line."""
    import dataclasses
    import importlib

    from tests.health.monitoring.test_monitoring import noise, part
    from ur5fault.cli import main

    def stand_in(log, params=None, effects=(), **kw):
        o = part(log.source, noise(len(log.source), log.t_s.size - 1), target=log.q_target_rad[1:])
        return dataclasses.replace(o, rest_target=log.rest_target, payload_kg=log.payload_kg,
                                   samples_sha256=log.content_sha256())

    monkeypatch.setattr(importlib.import_module("ur5fault.health.monitoring.observe"), "observe", stand_in)
    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    base = [head(tmp_path, n, 6.0) for n in ("Movement_No1", "Movement_No2", "Movement_No4_Acc")]
    out = tmp_path / "out"
    args = ["monitor", str(base[2]), *RTDE, "--baseline", str(model), "--baseline-logs", *map(str, base[:2]),
            "--out", str(out), "--jobs", "1", "--quiet"]
    files = ", ".join(str(out / n) for n in ("monitor.json", "baseline.json", "report.md"))
    assert main(args) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {files}"
    assert main([*args, "--replace"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"replaced {files}"


def test_a_baseline_refused_is_refused_before_the_monitored_logs_are_replayed(tmp_path, monkeypatch, capsys):
    """The baseline is fitted as soon as its runs are replayed: a refusal of it (here a stand-in one) comes before
    minutes of the monitored logs' replays (the review found the fit moved after them with the progress bar)."""
    import dataclasses
    import importlib

    from tests.health.monitoring.test_monitoring import noise, part
    from ur5fault.cli import main
    from ur5fault.errors import ParameterError

    replayed = []

    def stand_in(log, params=None, effects=(), **kw):
        replayed.append(log.source)
        o = part(log.source, noise(len(log.source), log.t_s.size - 1), target=log.q_target_rad[1:])
        return dataclasses.replace(o, rest_target=log.rest_target, payload_kg=log.payload_kg,
                                   samples_sha256=log.content_sha256())

    def refused(runs, sha):
        raise ParameterError("baseline refused (stand-in)")

    monkeypatch.setattr(importlib.import_module("ur5fault.health.monitoring.observe"), "observe", stand_in)
    monkeypatch.setattr(importlib.import_module("ur5fault.health.monitoring.baseline"), "fit_baseline", refused)
    model = tmp_path / "model.yaml"
    model.write_text("params: {}\neffects: []\n")
    base = [head(tmp_path, n, 6.0) for n in ("Movement_No1", "Movement_No2", "Movement_No4_Acc")]
    assert main(["monitor", str(base[2]), *RTDE, "--baseline", str(model), "--baseline-logs", *map(str, base[:2]),
                 "--out", str(tmp_path / "a"), "--quiet"]) == 2
    assert replayed == [base[0].name, base[1].name]
    assert "baseline refused (stand-in)" in capsys.readouterr().err
