"""The log options of identify / discrepancy: several files, a YAML manifest with per-log options, --hold-out,
and one line for what cannot be used (no simulation runs here: every case stops at reading)."""

from __future__ import annotations

import argparse

import numpy as np
import pytest

from ur5fault.cli import main
from ur5fault.errors import ParameterError
from ur5fault.logs.options import add_log_options, log_entries, read_entry, read_log_options

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
    ("logs: []\n", "'logs' must be a list of at least one log"),
    ("logs: [a.csv]\nspeed: 3\n", "unknown key 'speed'"),
    ("format: rtde\nlogs: [{path: a.csv, payload: 1}]\n", "logs[0]: unknown key 'payload'"),
    ("format: nist\nlogs: [{path: a.csv, payload_kg: 1}]\n", "logs[0]: --payload-kg applies to --format rtde only"),
    ("format: csv\nlogs: [a.csv]\n", "format 'csv' is not one of"),
])
def test_bad_manifest_is_one_line(tmp_path, capsys, text, message):
    m = tmp_path / "robot.yaml"
    m.write_text(text)
    rc = main(["discrepancy", str(m), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and message in err[0], err


def test_format_required_without_a_manifest(tmp_path, capsys):
    rc = main(["identify", str(RUN1), "--out", str(tmp_path / "p.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--format is required" in err[0]


def test_a_log_named_twice_is_refused():
    args = _args([str(RUN1), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0",
                  "--hold-out", str(RUN1)])
    with pytest.raises(ParameterError, match="given twice"):
        read_log_options(args)


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
    assert "payload unknown (no --payload-kg): this command needs the payload stated" in err[0], err
