"""Logs as robots write them: the Kufieta runs of a second UR5 read as they are (``time`` column, no
temperatures, NaN tails in optional columns, rows missing in gaps, a clock 0.35 % off the 8 ms tick), and
what a reader cannot use refused with one line. References: pandas' own reading of the same files."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from ur5fault.cli import main
from ur5fault.errors import LogFormatError, ParameterError
from ur5fault.logs import read_log, read_nist, read_rtde

from conftest import KUFIETA_DIR, KUFIETA_RUNS, NIST_LOG


def test_the_nine_runs_are_in_the_repository():
    assert len(KUFIETA_RUNS) == 9 and (KUFIETA_DIR / "LICENSE-Apache-2.0.txt").exists()
    assert NIST_LOG.exists()


@pytest.mark.parametrize("path", KUFIETA_RUNS, ids=lambda p: p.name.split(".")[0])
def test_every_kufieta_run_reads_as_written(path):
    """Each logged row lands on its 8 ms tick with the file's own values; only ticks with no row are filled."""
    log = read_rtde(path, payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
    df = pd.read_csv(path)
    assert log.period_s == pytest.approx(0.008, abs=1e-12)
    np.testing.assert_allclose(np.diff(log.t_s), 0.008, atol=1e-12)
    rows = log.logged_rows()
    n = int(rows.sum())
    assert len(df) - 25 <= n <= len(df)  # at most the NaN tail cut
    first = df.iloc[:n]
    np.testing.assert_array_equal(log.current_A[rows], first[[f"actual_current_{j}" for j in range(6)]].to_numpy())
    np.testing.assert_array_equal(log.q_target_rad[rows], first[[f"target_q_{j}" for j in range(6)]].to_numpy())
    assert log.temperature_C is None and log.target_current_A is not None
    assert all(np.isfinite(a).all() for a in (log.current_A, log.q_actual_rad, log.target_current_A))
    gaps = np.diff(df["time"].to_numpy()).max() > 0.012
    assert (log.logged is not None) == gaps
    if gaps:  # half the ticks of Movement_No1-No3 have no row: the replay spans the run's real duration
        assert log.t_s[-1] == pytest.approx(df["time"].iloc[-1] - df["time"].iloc[0], rel=0.01)
        assert any("missing in gaps of up to 2" in s for s in log.notes)
    notes = log.assumptions([28.0] * 6)
    assert any("no joint temperatures in the log; the model's 28, 28, 28, 28, 28, 28 degC assumed" in s
               for s in notes)


def test_a_note_several_logs_share_is_said_once():
    """Nine runs without temperatures printed nine identical notes; now one line naming the logs, while a
    note only one log has keeps its own line."""
    from ur5fault.logs.measured import assumption_notes

    a, b = (read_rtde(KUFIETA_DIR / f"{n}.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
            for n in ("Movement_No1", "Movement_No4_Acc"))
    lines = assumption_notes([a, b], [28.0] * 6)
    shared = [s for s in lines if "no joint temperatures" in s]
    assert shared == ["2 logs (Movement_No1.csv.gz, Movement_No4_Acc.csv.gz): no joint temperatures in the log; "
                      "the model's 28, 28, 28, 28, 28, 28 degC assumed"]
    assert any(s.startswith("Movement_No4_Acc.csv.gz: ") and "NaN there" in s for s in lines)
    assert any(s.startswith("Movement_No1.csv.gz: ") and "missing in gaps" in s for s in lines)
    assert assumption_notes([a], [28.0] * 6) == a.assumptions([28.0] * 6)


def test_a_logs_content_hash_follows_its_samples_not_its_name():
    import dataclasses

    a = read_rtde(KUFIETA_DIR / "Movement_No1.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
    renamed = dataclasses.replace(a, source="elsewhere/Movement_No1.csv.gz")
    changed = dataclasses.replace(a, current_A=a.current_A + np.eye(1, a.current_A.size).reshape(a.current_A.shape))
    assert renamed.content_sha256() == a.content_sha256() != changed.content_sha256()


def test_nan_tails_cut_and_named():
    log = read_rtde(KUFIETA_DIR / "Movement_No4_Acc.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
    df = pd.read_csv(KUFIETA_DIR / "Movement_No4_Acc.csv.gz")
    last = int(df[[f"actual_TCP_pose_{j}" for j in range(3)]].dropna().index.max())  # TCP ends first (22 rows)
    assert log.t_s.size == last + 1 and log.tcp_m is not None and log.target_torque_Nm is not None
    assert any("end early (NaN there); the log cut to rows 1..2823 of 2844" in s for s in log.notes)


def _frame(n=1000, period=0.008):
    t = np.arange(n) * period
    cols = {"time": t}
    for j in range(6):
        cols[f"target_q_{j}"] = 0.3 * np.sin(0.5 * t + j)
        cols[f"actual_q_{j}"] = cols[f"target_q_{j}"] + 1e-4
        cols[f"actual_current_{j}"] = 0.1 * np.cos(t)
        cols[f"target_moment_{j}"] = np.cos(t)
    return pd.DataFrame(cols)


def _read(tmp_path, df, **kw):
    p = tmp_path / "log.csv"
    df.to_csv(p, index=False)
    return read_rtde(p, payload_kg=0.0, tcp_offset_m=(0, 0, 0), **kw)


def test_time_or_timestamp(tmp_path):
    df = _frame()
    a = _read(tmp_path, df)
    b = _read(tmp_path, df.rename(columns={"time": "timestamp"}))
    np.testing.assert_array_equal(a.current_A, b.current_A)


def test_nan_inside_an_optional_column_drops_it_with_a_note(tmp_path):
    df = _frame()
    df.loc[500, "target_moment_2"] = np.nan
    log = _read(tmp_path, df)
    assert log.target_torque_Nm is None and log.t_s.size == 1000
    assert any("target_torque missing from data row 501" in s and "not used" in s for s in log.notes)


def test_a_few_rows_without_a_required_value_are_ticks_the_robot_did_not_log(tmp_path):
    """A recorder that lost a value lost the tick: rows with NaN or inf in a required column stay where they are
    (the tick grid and every row number are the file's), their values interpolated in time for the replay and the
    ticks left out of every RMS figure (``logged`` False), with a note."""
    df = _frame()
    df.loc[500:502, "actual_current_2"] = np.nan  # data rows 501..503
    df.loc[700, "target_q_0"] = np.inf
    log = _read(tmp_path, df)
    assert log.t_s.size == 1000 and np.allclose(np.diff(log.t_s), 0.008)
    assert list(np.flatnonzero(~log.logged)) == [500, 501, 502, 700]
    i = df["actual_current_2"].to_numpy()  # the filled values lie on the line between the neighbours
    np.testing.assert_allclose(np.abs(log.current_A[500:503, 2]),
                               np.abs(i[499] + (i[503] - i[499]) * np.arange(1, 4) / 4), rtol=1e-9)
    q = df["target_q_0"].to_numpy()
    assert log.q_target_rad[700, 0] == pytest.approx((q[699] + q[701]) / 2, rel=1e-9)
    assert ("log.csv: 4 data row(s) with NaN or inf in target_q_0, actual_current_2 (from data row 501; at most 3 in "
            "a row): values interpolated for the replay, those ticks left out of every RMS figure") in log.notes


def test_rows_without_a_value_and_missing_ticks_beside_them_count_together_as_one_gap(tmp_path):
    """At most 5 ticks in a row without a whole reading, whether rows are missing or hold NaN: the refusal counts
    both and names the file's rows, where to cut."""
    df = _frame()
    df.loc[500:505, "actual_current_2"] = np.nan  # 6 rows
    with pytest.raises(LogFormatError) as err:
        _read(tmp_path, df)
    assert str(err.value) == (
        "log.csv: NaN or inf in actual_current_2 in data rows 501..506: 6 ticks in a row without a whole reading, "
        "more than the 5 interpolated; neither side of it is long enough to use as a log of its own: data rows "
        "1..500 cover 3.99 s and 507..1000 3.94 s (fitting needs at least 5 s and 250 samples)")
    df = _frame().drop(index=[300, 301, 302])  # 3 ticks missing after data row 300 of the file
    df.loc[303:305, "actual_current_0"] = np.nan  # and the next 3 rows (data rows 301..303 of the file) without
    with pytest.raises(LogFormatError, match=r"^log.csv: NaN or inf in actual_current_0 in data rows 301..303: 6 "
                                             r"ticks in a row without a whole reading \(with the ticks missing beside "
                                             r"them\), more than the 5 interpolated; keep data rows 304..997 \(cut "
                                             r"the log there\): data rows 1..300 cover 2.39 s in 300 samples, too "
                                             r"short to use"):
        _read(tmp_path, df)
    df.loc[304:305, "actual_current_0"] = 0.1  # 1 row without a value beside the 3 missing ticks: 4 in a row
    log = _read(tmp_path, df)
    assert log.t_s.size == 1000 and int((~log.logged).sum()) == 4


def test_the_advice_to_cut_names_only_the_parts_long_enough_to_use(tmp_path):
    """NaN in data rows 501..511 of Movement_No4_Acc was refused with "cut the log there into two logs (data rows
    1..500 and 512..2844)", and the first part (4 s) was then refused as shorter than a log must be: the advice
    names the part to keep and the part to drop, and says so where neither side is long enough."""
    df = pd.read_csv(KUFIETA_DIR / "Movement_No4_Acc.csv.gz")
    n, t = len(df), df["time"].to_numpy()
    cut = df.copy()
    cut.loc[500:510, "actual_current_1"] = np.nan  # data rows 501..511
    with pytest.raises(LogFormatError) as err:
        _read(tmp_path, cut)
    assert str(err.value).endswith(
        f"more than the 5 interpolated; keep data rows 512..{n} (cut the log there): data rows 1..500 cover "
        f"{t[499] - t[0]:.3g} s in 500 samples, too short to use (fitting needs at least 5 s and 250 samples)"), err
    assert _read(tmp_path, df.iloc[511:]).t_s.size > 2000  # the part it keeps is a log
    with pytest.raises(LogFormatError, match="fitting needs at least 5 s"):
        _read(tmp_path, df.iloc[:500])  # the part it drops is not
    cut = df.copy()
    cut.loc[n - 501:n - 490, "actual_current_1"] = np.nan  # the short part at the end
    with pytest.raises(LogFormatError, match=rf"; keep data rows 1..{n - 501} \(cut the log there\): data rows "
                                             rf"{n - 488}..{n} cover [0-9.]+ s in 489 samples, too short to use"):
        _read(tmp_path, cut)
    short = _frame()
    short.loc[500:505, "actual_current_2"] = np.nan  # 4 s either side
    with pytest.raises(LogFormatError, match=r"more than the 5 interpolated; neither side of it is long enough to use "
                                             r"as a log of its own: data rows 1..500 cover 3.99 s and 507..1000 3.94 s "
                                             r"\(fitting needs at least 5 s and 250 samples\)$"):
        _read(tmp_path, short)


def test_rows_without_a_value_at_the_ends(tmp_path):
    """At the start the log is refused with the rows to cut to (the replay starts from the first row's state); at
    the end, within 1 s, the rows are cut with a note."""
    df = _frame()
    df.loc[0:1, "actual_q_1"] = np.nan
    with pytest.raises(LogFormatError, match=r"^log.csv: NaN or inf in actual_q_1 in data rows 1..2, the log's first: "
                                             r"the replay starts from the first row's state; cut the log to data rows "
                                             r"3..1000$"):
        _read(tmp_path, df)
    df = _frame()
    df.loc[990:, "actual_current_5"] = np.nan
    log = _read(tmp_path, df)
    assert log.t_s.size == 990 and log.logged is None
    assert "log.csv: NaN or inf in actual_current_5 in the last 10 data row(s); the log cut to rows 1..990" in log.notes
    df = _frame()
    df.loc[800:, "actual_current_5"] = np.nan  # 1.6 s
    with pytest.raises(LogFormatError, match=r"in data rows 801..1000, the log's last 1.6 s \(more than the 1 s cut by "
                                             r"itself\); cut the log to data rows 1..800$"):
        _read(tmp_path, df)


def test_the_advice_to_cut_a_log_at_its_ends_names_only_a_usable_rest(tmp_path):
    """NaN at a log's start, or over more than 1 s at its end, was refused with "cut the log to data rows ..." whatever
    the rest's length, which the next reading then refused as too short (the advice for a stretch in the middle
    already checked it): a rest shorter than a log must be is said to leave no usable part."""
    df = _frame()  # 1000 rows, 8 s
    df.loc[0:399, "actual_q_1"] = np.nan
    with pytest.raises(LogFormatError, match=r"the replay starts from the first row's state; the rest, data rows "
                                             r"401..1000, covers 4.79 s in 600 samples, too short to use \(fitting "
                                             r"needs at least 5 s and 250 samples\): no usable part remains$"):
        _read(tmp_path, df)
    with pytest.raises(LogFormatError, match="fitting needs at least 5 s"):
        _read(tmp_path, _frame().iloc[400:])  # it is not: the advice was right
    df = _frame()
    df.loc[600:, "actual_current_5"] = np.nan  # 3.2 s
    with pytest.raises(LogFormatError, match=r"the log's last 3.2 s \(more than the 1 s cut by itself\); the rest, "
                                             r"data rows 1..600, covers 4.79 s in 600 samples, too short to use "
                                             r"\(fitting needs at least 5 s and 250 samples\): no usable part "
                                             r"remains$"):
        _read(tmp_path, df)
    df = _frame()
    df.loc[0:1, "actual_q_1"] = np.nan
    df.loc[800:, "actual_current_5"] = np.nan  # both ends: the rest is between them
    with pytest.raises(LogFormatError, match=r"data rows 1..2, the log's first: the replay starts from the first "
                                             r"row's state; cut the log to data rows 3..800$"):
        _read(tmp_path, df)


def test_every_row_without_a_value_in_one_column_or_another_is_one_line(tmp_path):
    df = _frame()
    df.loc[df.index[::2], "actual_current_2"] = np.nan
    df.loc[df.index[1::2], "actual_current_3"] = np.nan
    with pytest.raises(LogFormatError, match=r"^log.csv: NaN or inf in every data row \(in actual_current_2, "
                                             r"actual_current_3\): no row holds a whole reading$"):
        _read(tmp_path, df)


def test_a_row_without_a_value_at_a_wrap_is_filled_on_the_continuous_angle(tmp_path):
    """A joint logged folded into (-pi, pi] wraps between two rows; a NaN row there is filled after the angle is
    made continuous, not halfway across the turn."""
    df = _frame()
    t = df["time"].to_numpy()
    q = 3.0 + 0.05 * t  # crosses pi at 2.8 s
    df["actual_q_5"] = np.angle(np.exp(1j * q))
    df["target_q_5"] = df["actual_q_5"] - 1e-4
    k = int(np.argmax(np.abs(np.diff(df["actual_q_5"].to_numpy())) > 3)) + 1  # the first row after the wrap
    df.loc[k, "actual_q_5"] = np.nan
    log = _read(tmp_path, df)
    np.testing.assert_allclose(log.q_actual_rad[k, 5] - log.q_actual_rad[0, 5], 0.05 * t[k], atol=1e-9)


def test_gaps_filled_on_the_grid_only_where_rows_are_missing(tmp_path):
    df = _frame().drop(index=[100, 101, 300]).reset_index(drop=True)
    log = _read(tmp_path, df)
    assert log.t_s.size == 1000 and log.logged.sum() == 997
    assert not log.logged[[100, 101, 300]].any()
    # the filled setpoint lies between its neighbours (linear), the logged rows are the file's
    np.testing.assert_array_equal(log.q_target_rad[log.logged], df[[f"target_q_{j}" for j in range(6)]].to_numpy())
    mid = 0.5 * (log.q_target_rad[299] + log.q_target_rad[301])
    np.testing.assert_allclose(log.q_target_rad[300], mid, atol=1e-15)


def test_stamps_off_the_tick_are_refused(tmp_path):
    df = _frame()
    df.loc[500, "time"] += 0.0036  # 0.45 of a tick late: beyond host time-stamp jitter
    with pytest.raises(LogFormatError, match=r"data row 501 .* off the controller's"):
        _read(tmp_path, df)


def test_payload_for_a_format_that_carries_its_own_is_refused(capsys, tmp_path):
    with pytest.raises(ParameterError, match="payload_kg applies to the rtde format only"):
        read_log(NIST_LOG, "nist", payload_kg=3.0)
    rc = main(["identify", str(NIST_LOG), "--format", "nist", "--payload-kg", "3", "--out", str(tmp_path / "p.yaml")])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "--payload-kg applies to --format rtde only" in err[0]
    assert read_nist(NIST_LOG).payload_kg == pytest.approx(0.726)


@pytest.mark.parametrize("command, extra, text", [
    ("identify", ("--payload-kg", "0"), "--tcp-offset-m missing (a manifest's tcp_offset_m): a stated payload "
                                        "needs its position (0 0 0 for a bare flange), or give --payload-kg unknown"),
    ("discrepancy", ("--payload-kg", "0"), "--tcp-offset-m missing (a manifest's tcp_offset_m): a stated payload"),
])
def test_rtde_without_payload_is_refused_not_defaulted(capsys, tmp_path, command, extra, text):
    """A stated mass without its position is refused by every command (an unknown payload is fitted by discrepancy
    and identify: tests/discrepancy/test_payload.py, tests/identify/test_unknown_payload.py; refused by the others:
    tests/logs/test_options.py)."""
    out = ["--out", str(tmp_path / ("p.yaml" if command == "identify" else "o"))]
    rc = main([command, str(KUFIETA_RUNS[0]), "--format", "rtde", *extra, *out])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and text in err[0], err
    log = read_rtde(KUFIETA_RUNS[0])
    assert log.payload_kg is None and not log.payload_known
    with pytest.raises(ParameterError, match="payload and tool offset unknown"):
        log.to_trajectory()


def test_a_cb2_target_at_rest_that_follows_the_reading_is_said():
    """Where every target speed is 0, the CB2 runs log the previous reading as the target (counted here from the
    files with pandas); the reader says so once per log, and not for NIST's CB3 log, whose setpoint at rest is
    fixed, nor for a log whose target at rest holds a pose while the reading wanders."""
    from ur5fault.logs.rest_target import rest_target_style

    path = KUFIETA_DIR / "TEST.csv.gz"
    df = pd.read_csv(path)
    cols = lambda p: df[[f"{p}_{j}" for j in range(6)]].to_numpy()  # noqa: E731
    rest = (cols("target_qd")[1:] == 0.0).all(axis=1)
    follows = (cols("target_q")[1:] == cols("actual_q")[:-1]).all(axis=1)
    assert rest.sum() > 1000 and follows[rest].mean() > 0.99  # the fact the note rests on
    note = [s for s in read_rtde(path, 0.0, (0.0, 0.0, 0.0)).notes if "at rest" in s]
    assert len(note) == 1 and note[0].startswith("TEST.csv.gz: at rest (every target speed 0) the logged target is "
                                                 "the previous measured position")
    assert not any("at rest" in s for s in read_nist(NIST_LOG).notes)
    # the same rows with the target at rest held at the last moving row's target (within 10 urad of the end pose)
    t = df["time"].to_numpy()
    held = cols("target_q").copy()
    for i in range(1, held.shape[0]):
        if rest[i - 1]:
            held[i] = held[i - 1]
    assert rest_target_style(t, cols("target_q"), cols("actual_q"), cols("target_qd")) == "reading"
    assert rest_target_style(t, held, cols("actual_q"), cols("target_qd")) != "reading"
    assert rest_target_style(t, cols("target_q"), cols("actual_q"), None) is None  # no target speeds: cannot say


def test_the_rest_target_note_compares_only_rows_one_tick_apart():
    """Movement_No3_Acc's merge dropped rows: after a gap the previous row is not the previous tick's reading, so
    only 328 of its 629 rows at rest are compared (all of them follow the reading: the note is given); No1 never
    holds every target speed at 0 (no note)."""
    df = pd.read_csv(KUFIETA_DIR / "Movement_No3_Acc.csv.gz")
    cols = lambda p: df[[f"{p}_{j}" for j in range(6)]].to_numpy()  # noqa: E731
    rest = (cols("target_qd")[1:] == 0.0).all(axis=1)
    follows = (cols("target_q")[1:] == cols("actual_q")[:-1]).all(axis=1)
    one_tick = np.diff(df["time"].to_numpy()) < 0.012
    assert rest.sum() == 629 and follows[rest].mean() < 0.7  # counted over every row at rest: no note would be due
    assert (rest & one_tick).sum() == 328 and follows[rest & one_tick].all()
    notes = read_rtde(KUFIETA_DIR / "Movement_No3_Acc.csv.gz", 0.0, (0.0, 0.0, 0.0)).notes
    assert sum("at rest (every target speed 0)" in s for s in notes) == 1
    no1 = read_rtde(KUFIETA_DIR / "Movement_No1.csv.gz", 0.0, (0.0, 0.0, 0.0))
    assert not any("at rest" in s for s in no1.notes)


def test_logs_of_two_controllers_under_one_model_are_said():
    """A CB2 logs the previous reading as its target at rest, a CB3 a fixed setpoint: logs of both under one
    command are most likely two robots, which one identify or one monitor baseline would mix without a word."""
    from ur5fault.logs.measured import assumption_notes

    cb2 = [read_rtde(KUFIETA_DIR / f"{n}.csv.gz", payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
           for n in ("TEST", "Movement_No1")]
    cb3 = read_nist(NIST_LOG)
    assert [g.rest_target for g in (*cb2, cb3)] == ["reading", None, "setpoint"]  # No1 never stands
    mixed = [n for n in assumption_notes([*cb2, cb3], [28.0] * 6) if "two controllers" in n]
    assert mixed == [f"the target at rest is the previous reading in TEST.csv.gz (as a CB2 controller logs it) and "
                     f"a fixed setpoint in {cb3.source} (as a CB3's): logs of two controllers, likely two robots, "
                     "under one model"]
    assert not [n for n in assumption_notes(cb2, [28.0] * 6) if "two controllers" in n]


def _first_12_s_of_test(tmp_path, edit=None):
    """The first 12 s of the Kufieta TEST run as an RTDE CSV, ``edit`` applied to its columns."""
    df = pd.read_csv(KUFIETA_DIR / "TEST.csv.gz")
    df = df[df["time"] - df["time"].iloc[0] <= 12.0].copy()
    if edit is not None:
        edit(df)
    out = tmp_path / "test12.csv"
    df.to_csv(out, index=False)
    return out


def test_a_log_whose_currents_have_the_other_sign_is_refused_when_read(tmp_path):
    """Every actual current negated: identify wrote a negative torque constant and negative friction, which
    simulate --model then refused. UR's target currents tell it at read time (shoulder and elbow run against
    them); every real log of data/ passes the same check."""
    for path in (*KUFIETA_RUNS, NIST_LOG):
        fmt = "nist" if path == NIST_LOG else "rtde"
        read_log(path, fmt, **({"payload_kg": 0.0, "tcp_offset_m": (0.0, 0.0, 0.0)} if fmt == "rtde" else {}))

    def negate(names):
        def edit(df):
            for j in range(6):
                for name in names:
                    df[f"{name}_{j}"] = -df[f"{name}_{j}"]
        return edit

    kw = {"payload_kg": 0.0, "tcp_offset_m": (0.0, 0.0, 0.0)}
    read_log(_first_12_s_of_test(tmp_path), "rtde", **kw)
    with pytest.raises(LogFormatError, match=r"test12.csv: the current of joint 2 \(shoulder_lift_joint\), joint 3 "
                                             r"\(elbow_joint\) runs against UR's target "
                                             r"current \(cosine -0.99, -0.9\d\): its sign convention is opposite to "
                                             r"the torque's, as in a log with currents of the other sign"):
        read_log(_first_12_s_of_test(tmp_path, negate(["actual_current"])), "rtde", **kw)
    # both negated: the target cannot tell (identify's own check does, ur5fault/identify/core.py)
    read_log(_first_12_s_of_test(tmp_path, negate(["actual_current", "target_current"])), "rtde", **kw)


def test_a_log_where_the_arm_stands_throughout_is_said_to():
    """A standstill-only log: discrepancy named five effects (a shoulder torque constant x0.80 at z 407) and nothing
    said the arm never moved. Only the standstill run of data/ gets the note (its target spans 1.4 mrad)."""
    for f in sorted(KUFIETA_DIR.glob("*.csv.gz")):
        log = read_rtde(f, payload_kg=0.0, tcp_offset_m=(0.0, 0.0, 0.0))
        stands = [s for s in log.assumptions([28.0] * 6) if "the arm stands throughout" in s]
        assert len(stands) == (f.name == "Movement_No10_Standstill_WDist.csv.gz"), (f.name, stands)


KW = {"payload_kg": 0.0, "tcp_offset_m": (0.0, 0.0, 0.0)}


def test_a_reading_far_from_its_target_is_refused_when_read(tmp_path):
    """J2's reading frozen for 3 s while its setpoint moves (a stuck encoder, a recorder's fill): monitor called the
    log consistent and identify wrote a velocity feed-forward of -1.2. A UR stops itself on a far smaller following
    error; every real log of data/ stays within 0.008 rad (pushes included; the constant's comment)."""
    for path in (*KUFIETA_RUNS, NIST_LOG):
        fmt = "nist" if path == NIST_LOG else "rtde"
        read_log(path, fmt, **(KW if fmt == "rtde" else {}))

    def freeze(df):
        t = df["time"] - df["time"].iloc[0]
        moving = (t >= 5.0) & (t < 8.0)
        df.loc[moving, "actual_q_1"] = df.loc[moving, "actual_q_1"].iloc[0]

    with pytest.raises(LogFormatError, match=r"test12.csv: the measured position of joint 2 \(shoulder_lift_joint\) "
                                             r"departs from its target "
                                             r"by up to 1.14 rad \(at t = 7.99 s; more than 0.05 rad from t = 6.67 "
                                             r"to 7.99 s\), far beyond what a running UR allows.*a stuck encoder"):
        read_log(_first_12_s_of_test(tmp_path, freeze), "rtde", **KW)


def test_a_dead_current_channel_is_refused_where_the_target_current_tells(tmp_path):
    """A current channel reading noise (or a constant plus noise) where UR's target current is 4 A RMS: monitor
    reported a torque constant scale of 1.89 on J2, identify a sign error or an out-of-range friction. The
    reading's RMS against the target's tells (0.84..2.40 on every real log of data/; the constant's comment)."""
    rng = np.random.default_rng(0)

    def noise(offset):
        def edit(df):
            df["actual_current_1"] = offset + rng.normal(0.0, 0.01, len(df))
        return edit

    for offset in (0.0, 0.3):
        with pytest.raises(LogFormatError, match=r"test12.csv: the current of joint 2 "
                                                 r"\(shoulder_lift_joint\) reads 0.\d+ A RMS where UR's "
                                                 r"target current is 4.\d+ A RMS.*a dead channel or a column of "
                                                 r"another quantity"):
            read_log(_first_12_s_of_test(tmp_path, noise(offset)), "rtde", **KW)
    # a wrist's target (0.06 A RMS on TEST's J4) is too small to tell: its reading may be anything near it
    read_log(_first_12_s_of_test(tmp_path, lambda df: df.__setitem__("actual_current_3", rng.normal(0, 0.01, len(df)))),
             "rtde", **KW)


def test_temperatures_of_exactly_zero_everywhere_are_taken_as_not_recorded(tmp_path):
    """0 degC on every joint in every row (a recorder's fill) was fitted as 0 degC: identify's viscous friction came
    out 39-43 % low. Now the columns are dropped with a note, as a log without temperatures is read."""
    def temps(values):
        def edit(df):
            for j in range(6):
                df[f"joint_temperatures_{j}"] = values[j]
        return edit

    log = read_log(_first_12_s_of_test(tmp_path, temps([0.0] * 6)), "rtde", **KW)
    assert log.temperature_C is None
    assert any("joint temperatures read exactly 0 degC on every joint in every row" in s for s in log.notes)
    assert any("no joint temperatures in the log; the model's 28" in s for s in log.assumptions([28.0] * 6))
    # one joint at 30 degC, or a single row of 0.5 degC, is a temperature (only the all-zero fill is dropped)
    def one_joint(df):
        temps([0.0] * 6)(df)
        df["joint_temperatures_1"] = 30.0

    def one_row(df):
        temps([0.0] * 6)(df)
        df.loc[df.index[-1], "joint_temperatures_5"] = 0.5

    for edit in (one_joint, one_row):
        log = read_log(_first_12_s_of_test(tmp_path, edit), "rtde", **KW)
        assert log.temperature_C is not None and not any("exactly 0 degC" in s for s in log.notes)


@pytest.mark.parametrize("fmt", ["nist", "rtde"])
def test_a_gap_is_judged_in_whole_missing_ticks_alike_in_both_formats(tmp_path, fmt):
    """4 rows dropped from the NIST log were refused ("a gap of 0.04 s ...; at most 5 sample periods (0.04 s)
    allowed": its clock, 10578 s, left the step 5.0000000002 periods) while the Kufieta log took the same gap with a
    note. Now both count the ticks missing in a row: up to 5 interpolated (as docs/discrepancy.md says), 6 refused
    with the remedy, the log cut at the gap into two logs of one robot."""
    if fmt == "nist":
        df, time = pd.read_csv(NIST_LOG).iloc[:1875], "ROBOT_TIME"
    else:
        df, time = pd.read_csv(KUFIETA_DIR / "TEST.csv.gz").iloc[:1875], "time"
    p = tmp_path / "gap.csv"
    kw = KW if fmt == "rtde" else {}
    for dropped in (4, 5):
        df.drop(index=range(937, 937 + dropped)).to_csv(p, index=False)
        log = read_log(p, fmt, **kw)
        assert int((~log.logged).sum()) == dropped
        assert any(f"{dropped} of 1875 controller ticks (8 ms) missing in gaps of up to {dropped}" in s
                   for s in log.notes)
    df.drop(index=range(937, 943)).to_csv(p, index=False)
    t0 = df[time].iloc[0]
    with pytest.raises(LogFormatError) as err:
        read_log(p, fmt, **kw)
    assert str(err.value) == (
        f"gap.csv: a gap of 0.056 s after t = {df[time].iloc[936] - t0:.3f} s (data row 937): 6 ticks of 8 ms "
        "missing in a row, more than the 5 interpolated; cut the log at the gap into two logs (data rows 1..937 and "
        "938..1869), which identify, discrepancy and monitor take together as logs of one robot")
    # diagnose reads one log: told the part to keep (the longer), not two logs it would take together
    from ur5fault.health.diagnosis.windows import window_length

    with pytest.raises(LogFormatError) as err:
        read_log(p, fmt, length=window_length(5.0), **kw)
    assert str(err.value).endswith(
        "more than the 5 interpolated; keep data rows 1..937 (cut the log at the gap), the longer part; data rows "
        "938..1869 are long enough to be read as a log of their own too"), err


def test_rtde_column_names_are_matched_whatever_their_case(tmp_path):
    """Every column upper-cased (TIME, ACTUAL_Q_0, ...) was refused as "missing required column 'timestamp'"; now
    matched case-insensitively, to the same log. Two columns that differ only in case cannot be told apart: refused,
    both named."""
    plain = read_log(_first_12_s_of_test(tmp_path), "rtde", **KW)
    def spelt(case):
        def edit(df):
            df.columns = [case(c) for c in df.columns]
        return edit

    for case in (str.upper, str.title):  # TIME, ACTUAL_Q_0; Time, Actual_Q_0
        log = read_log(_first_12_s_of_test(tmp_path, spelt(case)), "rtde", **KW)
        assert log.content_sha256() == plain.content_sha256() and log.notes == plain.notes
        np.testing.assert_array_equal(log.target_current_A, plain.target_current_A)
        np.testing.assert_array_equal(log.tcp_m, plain.tcp_m)

    def twice(df):
        df["ACTUAL_Q_2"] = df["actual_q_2"]

    with pytest.raises(LogFormatError, match=r"test12.csv: columns 'actual_q_2' and 'ACTUAL_Q_2' differ only in case: "
                                             r"which one is meant cannot be told; rename or drop one"):
        read_log(_first_12_s_of_test(tmp_path, twice), "rtde", **KW)


def test_nan_in_a_required_column_is_named_with_its_column_and_extent(tmp_path):
    """"NaN or inf in actual_current at data row 1" named no joint, nor whether the NaN went on (cutting the log
    helps only then). Each format names its own column."""
    def nan_rows(column, rows):
        def edit(df):
            df.loc[df.index[rows], column] = np.nan
        return edit

    n = pd.read_csv(_first_12_s_of_test(tmp_path)).shape[0]
    for column, rows, said in (("actual_current_2", slice(None), "at data row 1 (every row)"),
                               ("actual_current_2", slice(900, 1276), "in data rows 901..1276: 376 ticks in a row "
                                                                      "without a whole reading, more than the 5 "
                                                                      "interpolated; keep data rows 1..900 (cut the "
                                                                      f"log there): data rows 1277..{n} cover 1.79 s "
                                                                      f"in {n - 1276} samples, too short to use "
                                                                      "(fitting needs at least 5 s and 250 samples)"),
                               ("target_q_4", list(range(7, 13)), "in data rows 8..13: 6 ticks in a row without a "
                                                                  "whole reading, more than the 5 interpolated; keep "
                                                                  f"data rows 14..{n} (cut the log there): data rows "
                                                                  "1..7 cover 0.048 s in 7 samples, too short to use "
                                                                  "(fitting needs at least 5 s and 250 samples)")):
        with pytest.raises(LogFormatError) as err:
            read_log(_first_12_s_of_test(tmp_path, nan_rows(column, rows)), "rtde", **KW)
        assert str(err.value) == f"test12.csv: NaN or inf in {column} {said}"
    df = pd.read_csv(NIST_LOG).iloc[:1000]
    df["ROBOT_ACTUAL_JOINT_CURRENT (J3)"] = np.nan
    df.to_csv(tmp_path / "nist.csv", index=False)
    with pytest.raises(LogFormatError, match=r"^nist.csv: NaN or inf in ROBOT_ACTUAL_JOINT_CURRENT \(J3\) at data "
                                             r"row 1 \(every row\)$"):
        read_log(tmp_path / "nist.csv", "nist")


def test_the_readers_called_directly_make_the_checks_read_log_makes(tmp_path):
    """`read_rtde` / `read_nist` are the package's API too (a notebook calls them): they refused less than
    `read_log` (current sign, dead channel, units, following error were read_log's alone)."""
    def negate(df):
        for j in range(6):
            df[f"actual_current_{j}"] = -df[f"actual_current_{j}"]

    with pytest.raises(LogFormatError, match=r"test12.csv: the current of joint 2 .* runs against UR's target"):
        read_rtde(_first_12_s_of_test(tmp_path, negate), **KW)

    def freeze(df):
        t = df["time"] - df["time"].iloc[0]
        df.loc[(t >= 5.0) & (t < 8.0), "actual_q_1"] = df.loc[t >= 5.0, "actual_q_1"].iloc[0]

    with pytest.raises(LogFormatError,
                       match=r"test12.csv: the measured position of joint 2 .* departs from its target"):
        read_rtde(_first_12_s_of_test(tmp_path, freeze), **KW)
    read_nist(NIST_LOG)  # the real log passes as before


def test_a_log_read_with_the_wrong_format_names_the_right_one(tmp_path):
    """A newcomer's first try: the NIST log as rtde, a Kufieta run as nist: the one line says which layout the
    columns are and the --format that reads it; a sim read of a CSV names the CSV formats."""
    with pytest.raises(LogFormatError, match=r"missing required column 'timestamp' \(or 'time'\): the time \[s\]; "
                                             r"its columns are the nist layout's: give --format nist$"):
        read_log(NIST_LOG, "rtde", **KW)
    with pytest.raises(LogFormatError, match=r"missing required column 'ROBOT_TIME' \(and 18 more\); its columns are "
                                             r"the rtde layout's: give --format rtde$"):
        read_log(KUFIETA_DIR / "TEST.csv.gz", "nist")
    with pytest.raises(LogFormatError, match=r"a robot's CSV log: --format rtde, or nist for the NIST layout\)$"):
        read_log(NIST_LOG, "sim")
    df = _frame().rename(columns={"time": "t"})  # neither layout's: no hint
    df.to_csv(tmp_path / "x.csv", index=False)
    with pytest.raises(LogFormatError, match=r"missing required column 'timestamp' \(or 'time'\): the time \[s\]$"):
        read_log(tmp_path / "x.csv", "rtde", **KW)
