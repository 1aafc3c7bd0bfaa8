"""The log options of identify / discrepancy: several files, a YAML manifest with per-log options, --hold-out,
and one line for what cannot be used (no simulation runs here: every case stops at reading)."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from ur5fault.cli import main
from ur5fault.errors import ParameterError
from ur5fault.logs.options import add_log_options, log_entries
from ur5fault.logs.read_entries import read_entry, read_log_options

from conftest import KUFIETA_DIR, NIST_LOG


def _args(argv):
    p = argparse.ArgumentParser()
    add_log_options(p, ("rtde", "nist", "sim"), hold_out=True)
    return p.parse_args(argv)


RUN1, RUN2, TEST = (KUFIETA_DIR / f"{n}.csv.gz" for n in ("Movement_No8_Singularity_Free_1",
                                                          "Movement_No10_Standstill_WDist", "TEST"))


def test_several_files_and_hold_out():
    args = _args([str(RUN1), str(RUN2), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0",
                  "--hold-out", str(TEST)])
    fit, held = read_log_options(args)
    assert [g.source for g in fit] == [RUN1.name, RUN2.name] and [g.source for g in held] == [TEST.name]
    assert all(g.payload_kg == 0.0 and g.tcp_offset_m == (0.0, 0.0, 0.0) for g in fit + held)


def test_manifest_with_per_log_options(tmp_path):
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs:\n  - {RUN1}\n"
                 f"  - {{path: {RUN2}, payload_kg: 0.5, tcp_offset_m: [0, 0, 0.1]}}\n"
                 f"  - {{path: {NIST_LOG}, format: nist, hold_out: true}}\n")
    entries = log_entries(_args([str(m)]))
    assert [(e.fmt, e.payload_kg, e.tcp_offset_m, e.hold_out) for e in entries] == [
        ("rtde", 0, (0, 0, 0), False), ("rtde", 0.5, (0, 0, 0.1), False), ("nist", None, None, True)]


@pytest.mark.parametrize("text, message", [
    # a manifest (it has 'logs') is not told what it was read as; a YAML without 'logs' is (below)
    ("logs: []\n", "robot.yaml: 'logs' must be a list of at least one log ({path: FILE, ...} or FILE)"),
    ("logs: [a.csv]\nspeed: 3\n", "robot.yaml: unknown key 'speed'"),
    ("speed: 3\n", "robot.yaml: read as a manifest of logs (a .yaml or .yml file among the logs is one): unknown key "
                   "'speed'"),
    ("format: rtde\nlogs: [{path: a.csv, payload: 1}]\n", "logs[0]: unknown key 'payload' (did you mean "
                                                         "'payload_kg'?) (keys: path, format, payload_kg"),
    ("payload: 1\nlogs: [a.csv]\n", "robot.yaml: unknown key 'payload' (did you mean 'payload_kg'?) (keys: format, "
                                    "payload_kg, tcp_offset_m, logs)"),
    # the manifest's key, not the command line's flag (was "logs[0]: --payload-kg applies to --format rtde only")
    ("format: nist\nlogs: [{path: a.csv, payload_kg: 1}]\n", "robot.yaml: logs[0]: payload_kg applies to rtde logs "
                                                            "only (or with payload_kg: unknown)"),
    # the top-level key named where the value came from (was "logs[0]: format 'csv'", as if the log's own)
    ("format: csv\nlogs: [a.csv]\n", "robot.yaml: logs[0]: format (from robot.yaml: format): 'csv' is not one of"),
    # the manifest's key path named, as for every other key (was the bare payload range / "a.csv: no such file")
    ("format: rtde\ntcp_offset_m: [0, 0, 0]\nlogs: [{path: a.csv, payload_kg: -0.5}]\n",
     "robot.yaml: logs[0]: payload_kg = -0.5 is out of range [0, 5] kg"),
    ("format: rtde\npayload_kg: 7\ntcp_offset_m: [0, 0, 0]\nlogs: [a.csv]\n",
     "robot.yaml: logs[0]: payload_kg (from robot.yaml: payload_kg) = 7 is out of range [0, 5] kg"),
    # the tool offset too (was left to the reader, which named the API's keyword and not the manifest)
    ("format: rtde\npayload_kg: 0\nlogs: [{path: a.csv, tcp_offset_m: [0, 0, 5]}]\n",
     "robot.yaml: logs[0]: tcp_offset_m[3] = 5 is out of range [-2, 2] m"),
    ("format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [a.csv]\n",
     "robot.yaml: logs[0]: a.csv: no such file (a log's path is read from the manifest's folder, "),
])
def test_bad_manifest_is_one_line(tmp_path, capsys, text, message):
    m = tmp_path / "robot.yaml"
    m.write_text(text)
    rc = main(["discrepancy", str(m), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], err


@pytest.mark.parametrize("command, options", [("identify", ["--out", "p.yaml"]), ("discrepancy", ["--out", "o"]),
                                             ("monitor", ["--baseline", "ov.yaml", "--baseline-logs", "b.csv",
                                                          "--format", "rtde", "--out", "o"]),
                                             ("diagnose", ["--detector", "d", "--out", "o"])])
def test_a_yaml_that_is_no_manifest_is_told_what_it_was_read_as(tmp_path, capsys, monkeypatch, command, options):
    """A campaign's YAML given where a log goes was refused as `unknown key 'base' (keys: format, ...)`, leaving the
    user to guess what those keys belong to (a newcomer probe); every command that takes logs says it alike."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "campaign.yaml").write_text("name: c\nbase: {duration_s: 1}\nsweep: {backlash.joint: [2]}\n")
    (tmp_path / "ov.yaml").write_text("params: {}\n")
    assert main([command, "campaign.yaml", *options]) == 2
    assert capsys.readouterr().err == ("ur5fault: error: campaign.yaml: read as a manifest of logs (a .yaml or .yml "
                                       "file among the logs is one): unknown key 'base' (keys: format, payload_kg, "
                                       "tcp_offset_m, logs)\n")


def test_diagnose_and_show_say_what_they_read():
    """`diagnose --help` called its log a "measured log file" (a manifest naming one is read too), `show --help` a
    Parquet file (CSV is read too)."""
    from ur5fault.cli import build_parser

    def help_of(command: str, dest: str) -> str:
        sub = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)][0].choices[command]
        return next(a.help for a in sub._actions if a.dest == dest)

    assert help_of("diagnose", "log") == "measured log file, or a YAML manifest of logs that names one"
    assert help_of("show", "target").startswith("a time-series Parquet or CSV file (from `simulate`")


def test_manifest_takes_the_command_lines_values_under_the_flags_names(tmp_path, capsys):
    """A manifest's log that takes its tool offset from the command line is refused naming the flag."""
    m = tmp_path / "robot.yaml"
    m.write_text("format: rtde\npayload_kg: 0\nlogs: [a.csv]\n")
    rc = main(["discrepancy", str(m), "--tcp-offset-m", "0", "0", "3", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--tcp-offset-m (value 3) = 3.0 is out of range [-2, 2] m" in err[0], err


def test_format_required_without_a_manifest(tmp_path, capsys):
    rc = main(["identify", str(RUN1), "--out", str(tmp_path / "p.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--format is required" in err[0]


def test_a_log_named_twice_is_refused():
    args = _args([str(RUN1), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0",
                  "--hold-out", str(RUN1)])
    with pytest.raises(ParameterError, match=f"{RUN1.name} is both fitted and held out: one recording counts once"):
        read_log_options(args)


STATED = ["--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0"]


def test_one_recording_under_two_names_is_refused(tmp_path):
    """A copy of a log is the same recording: fitted twice it counts twice; held out, its score is on the samples it
    was fitted on."""
    copy = tmp_path / "copy.csv.gz"
    copy.write_bytes(TEST.read_bytes())
    with pytest.raises(ParameterError, match="copy.csv.gz and TEST.csv.gz hold the same samples \\(fitted twice\\)"):
        read_log_options(_args([str(TEST), str(copy), *STATED]))
    with pytest.raises(ParameterError, match="hold the same samples \\(both fitted and held out\\)"):
        read_log_options(_args([str(TEST), *STATED, "--hold-out", str(copy)]))


def test_a_part_of_a_fitted_log_held_out_is_refused(tmp_path):
    """A held-out run cut from the first 10.4 s of a fitted log passed (only whole files were compared) and was scored
    as held out on the samples the model was fitted on; the same holds with its time restarted at 0."""
    import pandas as pd

    raw = pd.read_csv(RUN1)
    head = tmp_path / "head.csv"
    raw.iloc[:1300].to_csv(head, index=False)
    with pytest.raises(ParameterError, match=r"head.csv and Movement_No8_Singularity_Free_1.csv.gz \(fitted and held "
                                             r"out\) share \d+ rows in motion .*parts of one recording"):
        read_log_options(_args([str(RUN1), *STATED, "--hold-out", str(head)]))
    restarted = raw.iloc[600:1300].assign(time=lambda d: d["time"] - d["time"].iloc[0])
    restarted.to_csv(head, index=False)
    with pytest.raises(ParameterError, match="rows in motion"):
        read_log_options(_args([str(RUN1), *STATED, "--hold-out", str(head)]))
    fit, held = read_log_options(_args([str(RUN1), str(RUN2), *STATED, "--hold-out", str(TEST)]))  # three runs
    assert len(fit) == 2 and len(held) == 1


def test_shared_rows_at_rest_or_of_one_noise_seed_are_not_a_cut():
    """Rows at rest may repeat in two recordings of a coarse logger, and two simulations of one noise seed repeat
    each other's samples until their effects act: neither is a part of one recording."""
    from ur5fault.logs import MeasuredLog
    from ur5fault.logs.same_samples import refuse_same_samples

    n = 400
    t = np.arange(n) * 0.008
    q = np.tile(np.linspace(0.0, 0.5, n)[:, None], (1, 6))
    cur = np.sin(np.arange(n * 6, dtype=float)).reshape(n, 6)

    def log(name, q_target, current, **kw):
        return MeasuredLog(name, t, q_target, q_target.copy(), current, **kw)

    still = np.zeros((n, 6))
    a, b = log("a", still, cur), log("b", still, cur + np.r_[np.zeros(n - 1), 1.0][:, None])  # differ at the end
    refuse_same_samples([("fitted", [a]), ("held out", [b])])  # at rest throughout: no row in motion
    moved = cur + np.r_[np.zeros(n - 1), 1.0][:, None]
    with pytest.raises(ParameterError, match="share 398 rows in motion"):
        refuse_same_samples([("fitted", [log("a", q, cur)]), ("held out", [log("b", q, moved)])])
    refuse_same_samples([("fitted", [log("a", q, cur, simulated=True)]),
                         ("held out", [log("b", q, moved, simulated=True)])])


def test_logs_of_one_file_name_in_two_folders_are_named_by_their_folders(tmp_path):
    """Recorders write one file name per session folder: two recordings, named apart, notes included."""
    for folder, src in (("day1", RUN1), ("day2", TEST)):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "robot.csv.gz").write_bytes(src.read_bytes())
    fit, held = read_log_options(_args([str(tmp_path / "day1" / "robot.csv.gz"), *STATED, "--hold-out",
                                        str(tmp_path / "day2" / "robot.csv.gz")]))
    assert [g.source for g in fit] == ["day1/robot.csv.gz"] and [g.source for g in held] == ["day2/robot.csv.gz"]
    notes = [n for n in held[0].notes if "robot.csv.gz" in n]  # TEST's: its target at rest is its reading
    assert notes and all(n.startswith("day2/robot.csv.gz: ") for n in notes), held[0].notes
    # a refusal while reading names it so too
    with pytest.raises(ParameterError, match="^day1/robot.csv.gz: --tcp-offset-m missing"):
        read_log_options(_args([str(tmp_path / "day1" / "robot.csv.gz"), "--format", "rtde", "--payload-kg", "0",
                                "--hold-out", str(tmp_path / "day2" / "robot.csv.gz")]))


def test_a_link_keeps_its_own_name_and_two_spellings_of_one_file_are_one_log(tmp_path, monkeypatch):
    (tmp_path / "latest.csv.gz").symlink_to(TEST)
    fit, _ = read_log_options(_args([str(tmp_path / "latest.csv.gz"), *STATED]))
    assert [g.source for g in fit] == ["latest.csv.gz"]
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ParameterError, match="^latest.csv.gz is fitted twice"):
        read_log_options(_args(["latest.csv.gz", str(tmp_path / "latest.csv.gz"), *STATED]))


def test_payload_unknown_and_omitted_are_equal():
    """rtde: no --payload-kg and --payload-kg unknown both leave the payload (and without --tcp-offset-m its
    position) unknown, for the command that fits it; a stated offset stays."""
    omitted = read_log_options(_args([str(RUN1), "--format", "rtde"]), allow_unknown=True)[0][0]
    unknown = read_log_options(_args([str(RUN1), "--format", "rtde", "--payload-kg", "unknown"]),
                               allow_unknown=True)[0][0]
    assert omitted.payload_kg is None and omitted.tcp_offset_m is None and not omitted.payload_known
    for f in ("payload_kg", "tcp_offset_m", "source"):
        assert getattr(omitted, f) == getattr(unknown, f)
    np.testing.assert_array_equal(omitted.current_A, unknown.current_A)
    at = read_log_options(_args([str(RUN1), "--format", "rtde", "--tcp-offset-m", "0", "0", "0.1"]),
                          allow_unknown=True)[0][0]
    assert at.payload_kg is None and at.tcp_offset_m == (0.0, 0.0, 0.1)


def test_manifest_payload_unknown(tmp_path):
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\npayload_kg: unknown\nlogs:\n  - {RUN1}\n"
                 f"  - {{path: {RUN2}, payload_kg: 0.5, tcp_offset_m: [0, 0, 0.1]}}\n"
                 f"  - {{path: {NIST_LOG}, format: nist, payload_kg: unknown, tcp_offset_m: [0, 0, 0.186]}}\n"
                 f"  - {{path: {NIST_LOG}, format: nist, hold_out: true}}\n")
    entries = log_entries(_args([str(m)]))
    assert [e.payload_unknown for e in entries] == [True, False, True, False]
    nist = read_entry(entries[2], allow_unknown=True)
    assert nist.payload_kg is None and nist.tcp_offset_m == (0, 0, 0.186)  # the nist log's own payload set aside
    assert read_entry(entries[3]).payload_kg == pytest.approx(0.726)


@pytest.mark.parametrize("argv, message", [
    (["--format", "rtde", "--payload-kg", "heavy"], "argument --payload-kg: 'heavy' is neither a number of kg nor "
                                                    "'unknown'"),
    (["--format", "nist", "--tcp-offset-m", "0", "0", "0"], "--tcp-offset-m applies to --format rtde only (or with "
                                                            "--payload-kg unknown)"),
])
def test_bad_payload_values_are_one_line(tmp_path, capsys, argv, message):
    try:
        rc = main(["discrepancy", str(RUN1), *argv, "--out", str(tmp_path / "o")])
    except SystemExit as stop:  # argparse's own refusal of a value its type rejects
        rc = stop.code
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], err


def test_bad_manifest_payload_is_one_line(tmp_path, capsys):
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\nlogs:\n  - {{path: {RUN1}, payload_kg: heavy}}\n")
    rc = main(["discrepancy", str(m), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "logs[0]: payload_kg = 'heavy' is neither a number of kg nor 'unknown'" \
        in err[0], err


@pytest.mark.parametrize("command", ["monitor"])
def test_commands_that_cannot_fit_it_refuse_an_unknown_payload(tmp_path, capsys, command):
    extra = ["--baseline", str(tmp_path / "b.yaml"), "--baseline-logs", str(RUN2), "--out", str(tmp_path / "o")]
    (tmp_path / "b.yaml").write_text("params: {}\n")
    rc = main([command, str(RUN1), "--format", "rtde", *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert ("payload unknown (no --payload-kg nor a manifest's payload_kg, or either given as unknown): this "
            "command needs the payload stated") in err[0], err
    # a stated mass without its position: the advice does not offer the unknown payload this command refuses
    rc = main([command, str(RUN1), "--format", "rtde", "--payload-kg", "0", *extra])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].endswith("needs its position (0 0 0 for a bare flange)"), err


def test_diagnose_refuses_an_unknown_payload_before_any_work(tmp_path, capsys):
    """diagnose said "payload unknown" only after loading the classifiers and reading the log (8 s on a Kufieta
    run, a newcomer probe): now from the options, before the detector folder is even looked at."""
    rc = main(["diagnose", str(RUN1), "--format", "rtde", "--detector", str(tmp_path / "nothing"),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "payload unknown (no --payload-kg" in err[0], err
    rc = main(["diagnose", str(RUN1), "--format", "rtde", "--payload-kg", "0", "--detector", str(tmp_path / "nothing"),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].endswith("needs its position (0 0 0 for a bare flange)"), err


@pytest.mark.parametrize("command", ["diagnose", "monitor"])
def test_a_misspelt_log_is_said_missing_before_its_payload(tmp_path, capsys, command):
    """`diagnose nonexist.csv --format rtde ...` without a payload said the payload was unknown, not that the file
    was not there (a newcomer probe): a log the payload check would refuse is said missing first (a missing log
    with its payload stated is the reader's to say, after the output folder's check: tests/test_outputs.py)."""
    extra = (["--detector", str(tmp_path / "nothing")] if command == "diagnose" else
             ["--baseline", str(tmp_path / "b.yaml"), "--baseline-logs", str(RUN2)])
    (tmp_path / "b.yaml").write_text("params: {}\n")
    rc = main([command, str(tmp_path / "nonexist.csv"), "--format", "rtde", *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].endswith("nonexist.csv: no such file"), err
    rc = main([command, str(tmp_path), "--format", "rtde", *extra, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and err[0].endswith(f"{tmp_path}: not a file"), err


@pytest.mark.parametrize("which", ["judged", "baseline"])
def test_monitor_refuses_hold_out_in_a_manifest(tmp_path, capsys, which):
    """monitor judges every log it is given and builds its baseline from every baseline log: a manifest's hold_out
    would be dropped without a word (a monitored log marked so gave an empty monitor.json)."""
    (tmp_path / "b.yaml").write_text("params: {}\n")
    m = tmp_path / "logs.yaml"
    m.write_text(f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs:\n  - {{path: {RUN1}, hold_out: true}}\n")
    judged, base = (str(m), str(RUN2)) if which == "judged" else (str(RUN2), str(m))
    rc = main(["monitor", judged, "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0",
               "--baseline", str(tmp_path / "b.yaml"), "--baseline-logs", base, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    where = "the logs monitor judges" if which == "judged" else "a monitor baseline"
    assert rc == 2 and len(err) == 1 and f"{RUN1.name}: hold_out has no meaning in {where}" in err[0], err
    assert not (tmp_path / "o").exists()


def test_hold_out_beside_a_manifest_takes_its_defaults(tmp_path):
    """`--hold-out LOG` next to a manifest: the held log is read with the manifest's format, payload and tool
    (it had no format at all, `unknown log format None`)."""
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\npayload_kg: 0.5\ntcp_offset_m: [0, 0, 0.1]\nlogs:\n  - {RUN1}\n")
    entries = log_entries(_args([str(m), "--hold-out", str(TEST)]))
    assert [(e.path, e.fmt, e.payload_kg, e.tcp_offset_m, e.hold_out) for e in entries] == [
        (RUN1, "rtde", 0.5, (0, 0, 0.1), False), (TEST, "rtde", 0.5, (0, 0, 0.1), True)]
    fit, held = read_log_options(_args([str(m), "--hold-out", str(TEST)]))
    assert [g.source for g in held] == [TEST.name] and held[0].payload_kg == 0.5


@pytest.mark.parametrize("manifest, argv, message", [
    ("format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n", ["--format", "nist"],
     "robot.yaml: --format nist applies to no log: the manifest states each log's format (rtde)"),
    ("format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n", ["--payload-kg", "1.2"],
     "robot.yaml: --payload-kg 1.2 applies to no log: the manifest states each log's payload_kg (0)"),
    ("format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n", ["--tcp-offset-m", "0", "0", "0.1"],
     "robot.yaml: --tcp-offset-m 0 0 0.1 applies to no log: the manifest states each log's tcp_offset_m (0 0 0)"),
    ("format: nist\nlogs: [{NIST}]\n", ["--payload-kg", "1.2", "--tcp-offset-m", "0", "0", "0"],
     "robot.yaml: --payload-kg 1.2 applies to no log: the manifest states each log's payload_kg (the log's own)"),
])
def test_a_command_line_option_no_log_takes_is_refused(tmp_path, capsys, manifest, argv, message):
    """A command-line default every log of the manifest overrides was dropped without a word (the run went on
    with the manifest's values)."""
    m = tmp_path / "robot.yaml"
    m.write_text(manifest.format(RUN1=RUN1, NIST=NIST_LOG))
    rc = main(["identify", str(m), *argv, "--out", str(tmp_path / "p.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], err
    assert not (tmp_path / "p.yaml").exists()


@pytest.mark.parametrize("manifest, message", [
    ("format: nist\npayload_kg: 3\nlogs:\n  - {NIST}\n",
     "robot.yaml: payload_kg 3 applies to no log: its logs are nist logs, which carry their own payload and tool "
     "offset (a manifest's top-level payload_kg and tcp_offset_m are defaults of rtde logs; state payload_kg: "
     "unknown on a log to have its payload fitted)"),
    ("format: rtde\npayload_kg: 0.5\ntcp_offset_m: [0, 0, 0.2]\nlogs:\n"
     "  - {{path: {RUN1}, payload_kg: 0, tcp_offset_m: [0, 0, 0]}}\n",
     "robot.yaml: payload_kg 0.5 applies to no log: every log states its own payload_kg (0); drop it or edit the logs"),
    ("format: rtde\ntcp_offset_m: [0, 0, 0.2]\nlogs:\n  - {{path: {RUN1}, payload_kg: 0, tcp_offset_m: [0, 0, 0]}}\n",
     "robot.yaml: tcp_offset_m 0 0 0.2 applies to no log: every log states its own tcp_offset_m (0 0 0)"),
    ("format: nist\nlogs:\n  - {{path: {RUN1}, format: rtde, payload_kg: 0, tcp_offset_m: [0, 0, 0]}}\n",
     "robot.yaml: format nist applies to no log: every log states its own format (rtde)"),
])
def test_a_manifest_default_no_log_takes_is_refused(tmp_path, capsys, manifest, message):
    """A default at the top of a manifest that no log takes was dropped without a word (a newcomer probe of the
    wheel: `payload_kg: 3` over a nist log, which carries its own 0.726 kg, wrote the same overlay as without it),
    while the same value on the command line or on the log was refused."""
    m = tmp_path / "robot.yaml"
    m.write_text(manifest.format(RUN1=RUN1, NIST=NIST_LOG))
    rc = main(["identify", str(m), "--out", str(tmp_path / "p.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], err
    assert not (tmp_path / "p.yaml").exists()


def test_a_manifest_default_some_log_takes_or_every_log_repeats_is_kept(tmp_path):
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\npayload_kg: 0.5\ntcp_offset_m: [0, 0, 0]\nlogs:\n"
                 f"  - {{path: {RUN1}, payload_kg: 0}}\n  - {RUN2}\n")
    assert [e.payload_kg for e in log_entries(_args([str(m)]))] == [0, 0.5]  # RUN2 takes the default
    m.write_text(f"format: rtde\npayload_kg: 0\nlogs:\n  - {{path: {RUN1}, payload_kg: 0, tcp_offset_m: [0, 0, 0]}}\n")
    assert [e.payload_kg for e in log_entries(_args([str(m)]))] == [0]  # the same as the log's own: harmless
    # null at the top is no default (a review's find: refused as "the log's own applies to no log"), and the case of
    # 'unknown' does not matter
    m.write_text(f"format: rtde\ntcp_offset_m: null\npayload_kg: Unknown\nlogs:\n"
                 f"  - {{path: {RUN1}, payload_kg: unknown, tcp_offset_m: [0, 0, 0]}}\n")
    assert [(e.payload_kg, e.tcp_offset_m) for e in log_entries(_args([str(m)]))] == [("unknown", (0, 0, 0))]


def test_a_command_line_option_some_log_takes_or_repeats_is_kept(tmp_path):
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\nlogs:\n  - {{path: {RUN1}, payload_kg: 0.5, tcp_offset_m: [0, 0, 0]}}\n"
                 f"  - {RUN2}\n")
    entries = log_entries(_args([str(m), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0"]))
    assert [(e.fmt, e.payload_kg) for e in entries] == [("rtde", 0.5), ("rtde", 0.0)]  # RUN2 takes the default


def test_a_baseline_group_that_takes_the_command_line_options_keeps_them(tmp_path):
    """monitor / diagnose: the command line's options serve the logs and the baseline logs; a manifest of one
    group that states its own does not make them unused while the other group's files take them."""
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n")
    args = _args([str(m), "--format", "rtde", "--payload-kg", "0.5", "--tcp-offset-m", "0", "0", "0"])
    base = argparse.Namespace(**{**vars(args), "log": [str(RUN2)], "hold_out": []})
    assert [e.payload_kg for e in log_entries(args, base)] == [0]
    with pytest.raises(ParameterError, match="--payload-kg 0.5 applies to no log"):
        log_entries(args)


def test_a_manifest_is_the_only_log(tmp_path, capsys):
    m = tmp_path / "robot.yaml"
    m.write_text(f"format: rtde\nlogs: [{RUN1}]\n")
    rc = main(["discrepancy", str(m), str(RUN2), "--format", "rtde", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "robot.yaml: a manifest of logs must be the only log given" in err[0], err


def test_a_baseline_of_plain_files_beside_a_manifest_is_named_without_a_format(tmp_path, capsys):
    """The monitored logs' manifest names its format; the baseline's plain files have none: the refusal names the
    baseline (it said '--format is required', which the manifest had seemed to give)."""
    (tmp_path / "b.yaml").write_text("params: {}\n")
    m = tmp_path / "logs.yaml"
    m.write_text(f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n")
    rc = main(["monitor", str(m), "--baseline", str(tmp_path / "b.yaml"), "--baseline-logs", str(RUN2),
               "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and f"--baseline-logs {RUN2}: no format: give --format" in err[0], err


def test_a_manifest_listing_another_manifest_is_refused_as_such(tmp_path, capsys):
    # was: "ok.yaml: missing required column 'timestamp' (or 'time')", the inner manifest read as a CSV log
    (tmp_path / "ok.yaml").write_text(f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n")
    m = tmp_path / "nested.yaml"
    m.write_text("format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [ok.yaml]\n")
    rc = main(["discrepancy", str(m), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err == ["ur5fault: error: nested.yaml: logs[0]: ok.yaml: a manifest cannot list another "
                               "manifest; list that manifest's logs here, or give it alone"], err


def test_a_manifest_given_to_hold_out_is_refused_as_such(tmp_path, capsys):
    # was: read as a CSV log and refused for a missing 'timestamp' column
    (tmp_path / "held.yaml").write_text(f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\nlogs: [{RUN1}]\n")
    rc = main(["discrepancy", str(RUN1), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0",
               "--hold-out", str(tmp_path / "held.yaml"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and err == [f"ur5fault: error: --hold-out {tmp_path / 'held.yaml'}: a manifest cannot be held "
                               "out; mark its logs 'hold_out: true' in one manifest, or give --hold-out log files"], err
