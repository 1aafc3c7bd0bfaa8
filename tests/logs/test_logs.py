"""Log readers: real formats accepted (the NIST log, space-separated and BOM-prefixed RTDE, plain
or gzip), values equal to an independent pandas read, plausibility limits at their edges, and the
memory limit enforced before and while loading.  (Refusals through the CLI: test_hostile.py.)"""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ur5fault.errors import LogFormatError
from ur5fault.logs import plausible, read_log, read_nist, read_rtde, source


def rtde_frame(n: int = 1000, period: float = 0.008) -> pd.DataFrame:
    t = np.arange(n) * period
    cols: dict[str, np.ndarray] = {"timestamp": 1.7e9 + t}  # RTDE timestamps are controller seconds
    for j in range(6):
        cols[f"target_q_{j}"] = 0.3 * np.sin(0.5 * t + j)
        cols[f"actual_q_{j}"] = cols[f"target_q_{j}"] + 1e-4
        cols[f"target_qd_{j}"] = 0.15 * np.cos(0.5 * t + j)
        cols[f"actual_qd_{j}"] = cols[f"target_qd_{j}"]
        cols[f"actual_current_{j}"] = 0.1 * np.cos(t) + j
    return pd.DataFrame(cols)


def _write_text(path: Path, text: str, encoding: str = "utf-8") -> Path:
    if path.suffix == ".gz":
        with gzip.open(path, "wt", encoding=encoding, newline="") as f:
            f.write(text)
    else:
        path.write_text(text, encoding=encoding, newline="")
    return path


def test_nist_log_reads_as_pandas_reads_it(nist_path):
    """Independent reference: pandas' own CSV reader on the same file, degrees converted by numpy."""
    log = read_nist(nist_path)
    df = pd.read_csv(nist_path)
    assert log.t_s.size == len(df) == 7906
    # times on the controller's 8 ms tick (the logged clock agrees to 1e-12 s)
    np.testing.assert_allclose(log.t_s, df["ROBOT_TIME"].to_numpy() - df["ROBOT_TIME"].iloc[0], rtol=0, atol=1e-9)
    np.testing.assert_array_equal(log.t_s, 0.008 * np.arange(7906))
    assert log.logged is None and log.notes == ()
    for kind, arr in (("TARGET", log.q_target_rad), ("ACTUAL", log.q_actual_rad)):
        cols = [f"ROBOT_{kind}_JOINT_POSITIONS (J{j})" for j in range(1, 7)]
        np.testing.assert_array_equal(arr, np.radians(df[cols].to_numpy()))
    np.testing.assert_array_equal(log.current_A, df[[f"ROBOT_ACTUAL_JOINT_CURRENT (J{j})" for j in range(1, 7)]])
    assert log.temperature_C.shape == (7906, 6) and log.tcp_m.shape == (7906, 3)
    assert abs(log.period_s - 0.008) < 1e-9


def test_nist_velocities_agree_with_positions(nist_path):
    """The units check's statistic on the real log: dq/dt over the logged velocity is 1 (README:
    positions in degrees, velocities in rad/s), far from 57.3 and 1/57.3."""
    df = pd.read_csv(nist_path)
    t = df["ROBOT_TIME"].to_numpy()
    for kind in ("TARGET", "ACTUAL"):
        q = np.radians(df[[f"ROBOT_{kind}_JOINT_POSITIONS (J{j})" for j in range(1, 7)]].to_numpy())
        v = df[[f"ROBOT_{kind}_JOINT_VELOCITIES (J{j})" for j in range(1, 7)]].to_numpy()
        assert abs(plausible.velocity_ratio(t, q, v) - 1.0) < 0.01


@pytest.mark.parametrize("name, sep, encoding", [
    ("comma.csv", ",", "utf-8"),
    ("space.csv", " ", "utf-8"),  # UR's record.py
    ("space.csv.gz", " ", "utf-8"),
    ("bom.csv", ",", "utf-8-sig"),
    ("bom-space.csv.gz", " ", "utf-8-sig"),
    ("tab.csv.gz", "\t", "utf-8"),
    ("semicolon.csv", ";", "utf-8"),
])
def test_rtde_formats_read_identically(tmp_path, name, sep, encoding):
    frame = rtde_frame()
    reference = read_rtde(_write_text(tmp_path / "ref.csv", frame.to_csv(index=False)))
    text = frame.to_csv(index=False, sep=sep).replace("\n", "\r\n" if "bom" in name else "\n")
    log = read_rtde(_write_text(tmp_path / name, text, encoding))
    for field in ("t_s", "q_target_rad", "q_actual_rad", "current_A"):
        np.testing.assert_array_equal(getattr(log, field), getattr(reference, field))
    np.testing.assert_allclose(log.q_actual_rad[:, 2], frame["actual_q_2"].to_numpy(), rtol=0, atol=1e-15)


def test_gzip_found_by_content_not_name(tmp_path):
    p = tmp_path / "log.csv"  # gzip data without the .gz suffix
    p.write_bytes(gzip.compress(rtde_frame().to_csv(index=False).encode()))
    assert read_log(p, "rtde").t_s.size == 1000


@pytest.mark.parametrize("period, ok", [(0.0999, True), (0.1001, False), (1.001e-4, True), (0.99e-4, False)])
def test_sample_rate_limits(tmp_path, period, ok):
    n = max(300, int(6.0 / period) + 1) if period >= 1e-3 else 60_000
    frame = rtde_frame(n, period)
    for j in range(6):  # no velocity columns: only the rate is under test here
        frame = frame.drop(columns=[f"target_qd_{j}", f"actual_qd_{j}"])
    p = _write_text(tmp_path / "log.csv", frame.to_csv(index=False))
    if ok:
        assert read_rtde(p).t_s.size == n
    else:
        with pytest.raises(LogFormatError, match="outside 10 Hz..10 kHz"):
            read_rtde(p)


@pytest.mark.parametrize("step_ticks, ok", [(6, True), (7, False)])
def test_gap_limit(tmp_path, step_ticks, ok):
    """Up to 5 ticks missing in a row are interpolated (a step of 6 ticks); a refused gap says where to cut the log
    and which parts are long enough to keep: here neither."""
    frame = rtde_frame()
    frame.loc[500:, "timestamp"] += (step_ticks - 1) * 0.008
    p = _write_text(tmp_path / "log.csv", frame.to_csv(index=False))
    if ok:
        assert read_rtde(p).logged.sum() == 1000
    else:
        msg = (r"a gap of 0.056 s after t = 3.992 s \(data row 500\): 6 ticks of 8 ms missing in a row, more than "
               r"the 5 interpolated; neither side of it is long enough to use as a log of its own: data rows 1..500 "
               r"cover 3.99 s and 501..1000 3.99 s \(fitting needs at least 5 s and 250 samples\)$")
        with pytest.raises(LogFormatError, match=msg):
            read_rtde(p)


@pytest.mark.parametrize("n, ok", [(626, True), (620, False)])
def test_minimum_length(tmp_path, n, ok):
    p = _write_text(tmp_path / "log.csv", rtde_frame(n).to_csv(index=False))  # 5 s = 626 samples at 125 Hz
    if ok:
        read_rtde(p)
    else:
        with pytest.raises(LogFormatError, match="fitting needs at least 5 s and 250 samples"):
            read_rtde(p)


def test_positions_in_degrees_within_range_named_by_velocities(tmp_path):
    """Small motions in degrees stay within +-360 'rad'; only the velocities reveal the unit."""
    frame = rtde_frame()
    t = frame["timestamp"].to_numpy() - frame["timestamp"].iloc[0]
    for j in range(6):
        frame[f"target_q_{j}"] = np.degrees(0.1 * np.sin(2.0 * t + j))  # 5.7 deg amplitude, logged in degrees
        frame[f"target_qd_{j}"] = 0.2 * np.cos(2.0 * t + j)  # rad/s
    with pytest.raises(LogFormatError, match="target_q change 57.3 times faster than the logged velocities"):
        read_rtde(_write_text(tmp_path / "log.csv", frame.to_csv(index=False)))


def test_velocities_disagreeing_otherwise(tmp_path):
    frame = rtde_frame()
    for j in range(6):
        frame[f"actual_qd_{j}"] *= 3.0
    with pytest.raises(LogFormatError, match="actual_q and the logged velocities disagree by a factor 0.333"):
        read_rtde(_write_text(tmp_path / "log.csv", frame.to_csv(index=False)))


def test_memory_estimate_refuses_before_loading(tmp_path, monkeypatch):
    p = _write_text(tmp_path / "log.csv", rtde_frame(5000).to_csv(index=False))
    layout = source.sniff(p, "log.csv")
    true_rows = 5000
    assert abs(layout.rows_estimate - true_rows) / true_rows < 0.1
    monkeypatch.setattr(source, "MAX_LOG_ARRAY_BYTES", 5000 * 31 * source.BYTES_PER_VALUE * 0.5)
    with pytest.raises(LogFormatError, match=r"about 5\.\d+e\+03 rows x 31 columns need about .* above the limit"):
        read_rtde(p)  # 31: time, 6 x (target_q, actual_q, actual_current, target_qd, actual_qd)


def test_streaming_stops_at_the_limit_whatever_the_estimate(tmp_path, monkeypatch):
    """A gzip whose first lines are long but the rest short (the estimate is low): the chunked
    reader still stops at the row limit."""
    frame = rtde_frame(30_000, 0.008)
    text = frame.to_csv(index=False, float_format="%.17g")
    lines = text.splitlines()
    short = frame.round(2).to_csv(index=False).splitlines()
    p = _write_text(tmp_path / "log.csv.gz", "\n".join(lines[:300] + short[300:]) + "\n")
    layout = source.sniff(p, "log.csv.gz")
    assert layout.rows_estimate < 20_000  # fooled by the long first lines
    monkeypatch.setattr(source, "CHUNK_ROWS", 5000)
    monkeypatch.setattr(source, "MAX_LOG_ARRAY_BYTES", 20_000 * 31 * source.BYTES_PER_VALUE)
    with pytest.raises(LogFormatError, match="more than 20000 rows, above the memory limit"):
        read_rtde(p)


def test_sim_log_round_trip(tmp_path):
    from ur5fault import RunSpec, Simulator
    from ur5fault.logs import read_sim
    from ur5fault.sim.trajectories import hold

    res = Simulator().run(hold(seconds=6.0), [RunSpec("x", 1)], log_period_s=0.008)
    path = res.to_parquet(tmp_path / "x.parquet", 0)
    log = read_sim(path)
    np.testing.assert_array_equal(log.q_actual_rad, res["q_FB_rad"][0])
    np.testing.assert_array_equal(log.current_A, res["i_FB_A"][0])
    assert log.temperature_C.shape == (res.t_s.size, 6)


def test_logs_of_two_controllers_are_told_by_their_target_at_rest_and_a_log_never_at_rest_tells_nothing():
    """A CB2 logs the previous reading as its target at rest, a CB3 a fixed setpoint: one note names both groups
    (diagnose's baseline uses it too); a log that never stands still (``None``) neither adds nor removes one."""
    from ur5fault.logs.measured import controllers_note

    assert controllers_note([("a.csv", "reading"), ("b.csv", "reading"), ("c.csv", None)]) == []
    assert controllers_note([("n.csv", "setpoint"), ("c.csv", None)]) == []
    assert controllers_note([("a.csv", "reading"), ("n.csv", "setpoint"), ("c.csv", None), ("b.csv", "reading")]) == [
        "the target at rest is the previous reading in a.csv, b.csv (as a CB2 controller logs it) and a fixed "
        "setpoint in n.csv (as a CB3's): logs of two controllers, likely two robots, under one model"]
