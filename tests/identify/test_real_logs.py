"""Odd but real logs through `identify`: a robot that never rests (the second UR5's runs), angles
that wrap at +-180 deg, currents logged in milliamperes.  Each gives a correct result or one line,
and nothing the log cannot give is written as if measured."""

from __future__ import annotations

import gzip
import re
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
import yaml

from ur5fault.config import Overlay
from ur5fault.errors import LogFormatError
from ur5fault.logs.readers import read_log
from ur5fault.logs.wrap import unwrap_joints
from ur5fault.sim.params import load_params

from conftest import KUFIETA_DIR, REPO

KUFIETA = KUFIETA_DIR


def _kufieta(tmp_path, name="Movement_No1.csv.gz", edit=None):
    """A copy of a Kufieta run with its `time` column named `timestamp` (what the RTDE reader takes)."""
    src = KUFIETA / name
    if not src.exists():
        pytest.skip(f"no Kufieta log at {src}")
    df = pd.read_csv(src)
    df = df.rename(columns={"time": "timestamp"})
    if edit is not None:
        df = edit(df)
    out = tmp_path / name
    with gzip.open(out, "wt") as fh:
        df.to_csv(fh, index=False)
    return out


def _identify(log, out) -> str:
    """`ur5fault identify` on a Kufieta copy as a user calls it (payload 0 kg at the flange); the overlay's text."""
    r = subprocess.run([sys.executable, "-m", "ur5fault.cli", "identify", str(log), "--format", "rtde",
                        "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0", "--no-sweep", "--bootstrap", "20",
                        "--quiet", "--out", str(out)], capture_output=True, text=True, timeout=600,
                       env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    return out.read_text()


def test_identify_on_a_robot_that_never_rests_writes_no_invented_value(tmp_path):
    """Movement_No1 never rests long enough (was `ValueError: no rest segment`): exit 0; the noise is
    the packaged value, and the file's header says so."""
    log = _kufieta(tmp_path)
    out = tmp_path / "params.yaml"
    text = _identify(log, out)
    assert "# Not identifiable on this log, so the model's own (packaged) value is written" in text
    assert "sensors.current_noise_A (J1, J2, J3, J4, J5, J6)" in text
    written = yaml.safe_load(text)["params"]
    p = load_params()
    np.testing.assert_allclose(written["sensors"]["current_noise_A"], p.sensors.current_noise_A, rtol=1e-3)
    Overlay.load(out)  # the overlay is valid for --model


def test_every_not_identifiable_value_says_why(tmp_path):
    """Movement_No2 has too few starts from rest for a breakaway on any joint whose friction it identifies; the
    header's reason was cut off after the joint ("...; J1: ") where it should say so."""
    log = _kufieta(tmp_path, "Movement_No2.csv.gz")
    out = tmp_path / "params.yaml"
    text = _identify(log, out)
    assert not re.search(r"J\d: *$", text, re.M), [ln for ln in text.splitlines() if re.search(r"J\d: *$", ln)]
    assert "J1: fewer than 5 starts from rest in the log" in text


def test_currents_in_milliamperes_are_named(tmp_path):
    def to_mA(df):
        for j in range(6):
            df[f"actual_current_{j}"] *= 1000.0
        return df

    log = _kufieta(tmp_path, edit=to_mA)
    with pytest.raises(LogFormatError, match="they look like milliamperes"):
        read_log(log, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))


def test_wrapped_angles_are_made_continuous(tmp_path):
    """Joint 1 turned so that it crosses +180 deg and folded into +-180 deg, as some loggers write it:
    read back equal to the continuous angles (up to whole turns), not a 360 deg jump per wrap."""
    log = _kufieta(tmp_path)
    clean = read_log(log, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))
    off = np.pi - clean.q_target_rad[:, 0].max() + 0.05
    assert (clean.q_target_rad[:, 0] + off).min() < np.pi  # it crosses, not only sits beyond

    def wrap(df):
        for col in ("actual_q_0", "target_q_0"):
            df[col] = (df[col] + off + np.pi) % (2 * np.pi) - np.pi
        return df

    (tmp_path / "folded").mkdir()
    folded = _kufieta(tmp_path / "folded", edit=wrap)
    got = read_log(folded, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))
    for name in ("q_target_rad", "q_actual_rad"):
        d = getattr(got, name)[:, 0] - (getattr(clean, name)[:, 0] + off)
        turns = np.round(d / (2 * np.pi))
        assert np.unique(turns).size == 1  # one constant whole-turn offset: continuous
        np.testing.assert_allclose(d, turns * 2 * np.pi, atol=1e-9)
        np.testing.assert_array_equal(getattr(got, name)[:, 1:], getattr(clean, name)[:, 1:])


def test_unwrap_leaves_a_continuous_log_alone():
    t = np.arange(0, 10, 0.008)
    q = np.column_stack([np.sin(t)] * 6)
    same, wrapped = unwrap_joints(q)
    assert same is q and wrapped == []
    turn = np.column_stack([2.5 + 0.15 * t] * 6)  # crosses +180 deg at t = 4.3 s
    folded = (turn + np.pi) % (2 * np.pi) - np.pi
    got, wrapped = unwrap_joints(folded)
    assert wrapped == [0, 1, 2, 3, 4, 5]
    np.testing.assert_allclose(got, turn, atol=1e-12)
    bad = q.copy()
    bad[-1, 2] = 12.0  # a bad value, not a fold (spans more than a turn): left for the range check to name
    assert unwrap_joints(bad)[1] == []


def _kufieta_log(name: str):
    src = KUFIETA / f"{name}.csv.gz"
    if not src.exists():
        pytest.skip(f"no Kufieta log at {src}")
    return read_log(src, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))


def test_a_stiffness_the_starts_do_not_give_is_the_models_value_marked():
    """The standstill run is pushed by hand: on wrist_3 its starts give no positive torque change over
    displacement, and the stiffness was written as NaN (with the sweep, identify then stopped on its own overlay,
    blaming the packaged ur5_drive.yaml). It is now not identifiable there and keeps the model's value."""
    from ur5fault.identify import identify

    p = load_params()
    ident = identify([_kufieta_log("Movement_No10_Standstill_WDist"), _kufieta_log("Movement_No8_Singularity_Free_1")],
                     sweep=False, n_boot=20)
    est = ident.get("friction.presliding_stiffness_Nm_per_rad", 5)
    assert not est.identifiable and "no positive torque change" in est.note
    written = ident.overlay(p)["params"]["friction"]["presliding_stiffness_Nm_per_rad"]
    assert np.all(np.isfinite(written)) and written[5] == p.friction.presliding_stiffness_Nm_per_rad[5]
    load_params(overrides=ident.overlay(p)["params"], where="identified")  # every value within its range


def test_a_sweep_over_no_moving_joint_keeps_the_bandwidth_marked():
    """The standstill run moves no joint: the bandwidth sweep scored every candidate 0 and wrote the lowest, 1 Hz,
    with the interval [1, 1], as if measured. Now not identifiable, the model's value kept, and nothing replayed."""
    from ur5fault.identify import identify

    p = load_params()
    ident = identify(_kufieta_log("Movement_No10_Standstill_WDist"), sweep=True, n_boot=20)
    est = ident.get("controller.position_bw_Hz", None)
    assert not est.identifiable and est.value == float(np.mean(p.controller.position_bw_Hz))
    assert "nothing for the sweep to score" in est.note and ident.sweep is None


def test_temperatures_in_kelvin_are_named(tmp_path):
    """Joint temperatures of 308 (kelvin) were taken as degC: identify wrote a viscous friction of 2337 N*m*s/rad
    that every other command refused, and the replays clipped them to 120 degC without a word."""
    def kelvin(df):
        for j in range(6):
            df[f"joint_temperatures_{j}"] = 308.15
        return df

    log = _kufieta(tmp_path, "Movement_No8_Singularity_Free_1.csv.gz", edit=kelvin)
    with pytest.raises(LogFormatError, match=r"joint 1 \(shoulder_pan_joint\) has a median of 308.1 "
                                             r"degC.*look like kelvin \(35.0 degC\)"):
        read_log(log, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))

    def celsius(df):
        for j in range(6):
            df[f"joint_temperatures_{j}"] = 35.0
        return df

    ok = read_log(_kufieta(tmp_path, "Movement_No8_Singularity_Free_1.csv.gz", edit=celsius), "rtde",
                  payload_kg=0.0, tcp_offset_m=(0, 0, 0))
    assert ok.temperature_C is not None and np.all(ok.temperature_C == 35.0)


def test_an_optional_group_present_in_part_is_said(tmp_path):
    """One misspelt header (target_current_3 written target_curent_3) dropped UR's model columns of every joint
    without a word; a group short of one column the same."""
    def typo(df):
        return df.rename(columns={"target_current_3": "target_curent_3"}).drop(columns=["target_moment_5"])

    log = read_log(_kufieta(tmp_path, "Movement_No8_Singularity_Free_1.csv.gz", edit=typo), "rtde",
                   payload_kg=0.0, tcp_offset_m=(0, 0, 0))
    assert log.target_current_A is None and log.target_torque_Nm is None
    said = [n for n in log.notes if "are present" in n]
    assert len(said) == 2
    assert "5 of the 6 columns target_current_0..target_current_5 are present (missing: target_current_3): the " \
           "group is not used" in said[0]
    assert "(missing: target_moment_5)" in said[1]


def test_a_stiffness_beyond_the_parameters_range_is_the_models_value_marked(monkeypatch):
    """Starts with almost no displacement give a positive stiffness beyond the parameter's 1e9 N*m/rad, which the
    overlay then could not hold; kept at the model's value and said why, as a NaN is."""
    from types import SimpleNamespace

    from ur5fault.identify import core, stats, stickslip

    found = [e for j in range(6) for e in (
        stats.Estimate("friction.breakaway_A", j, 0.8, 0.7, 0.9, "m"),
        stats.Estimate("friction.presliding_stiffness_Nm_per_rad", j, 3e9 if j == 0 else 5e4, 1e4, 5e9, "m"))]
    monkeypatch.setattr(stickslip, "identify_stickslip", lambda *a, **k: found)
    fit = SimpleNamespace(ok=np.ones(6, dtype=bool))
    prior = np.full(6, 1.2e4)
    out = core._breakaway(None, fit, np.zeros((4, 6)), np.full(6, 0.5), np.zeros(6), 20, 0, prior)
    stiff = [x for x in out if x.key == "friction.presliding_stiffness_Nm_per_rad"]
    assert not stiff[0].identifiable and stiff[0].value == 1.2e4 and "beyond the model's 1e+09" in stiff[0].note
    assert all(x.identifiable and x.value == 5e4 for x in stiff[1:])


def test_a_dead_current_sensor_is_named(tmp_path):
    """A joint whose recorded current is 0.0 in every row was fitted as a Coulomb level of 0.04 A and an offset of
    -1.36 A, without a word."""
    def dead(df):
        df["actual_current_2"] = 0.0
        return df

    log = _kufieta(tmp_path, "Movement_No8_Singularity_Free_1.csv.gz", edit=dead)
    with pytest.raises(LogFormatError, match=r"the current of joint 3 \(elbow_joint\) reads 0 A in "
                                             r"every row: a dead sensor"):
        read_log(log, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))


def test_a_log_whose_currents_have_the_other_sign_writes_no_overlay(tmp_path, capsys):
    """The first 12 s of TEST with every current negated (target currents too, so that the reader cannot tell):
    identify exited 0 with a negative torque constant and negative friction in the overlay, which simulate --model
    then refused. Now one line naming the sign, exit 2, nothing written (refused before the resampling)."""
    from ur5fault.cli import main

    def flip(df):
        df = df[df["timestamp"] - df["timestamp"].iloc[0] <= 12.0].copy()
        for j in range(6):
            for name in ("actual_current", "target_current"):
                df[f"{name}_{j}"] = -df[f"{name}_{j}"]
        return df

    log = _kufieta(tmp_path, "TEST.csv.gz", edit=flip)
    out = tmp_path / "params.yaml"
    assert main(["identify", str(log), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0",
                 "--no-sweep", "--bootstrap", "20", "--quiet", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert re.fullmatch(r"ur5fault: error: TEST.csv.gz: the torque constant of J2 \(-0.10\d N\*m/A\) and the Coulomb "
                        r"friction of J2, J3, J4 \(-0.\d+, -0.\d+, -0.\d+ A\) come out negative: the current runs "
                        r"against the torque and the motion it drives, as in a log with currents of the other sign "
                        r"\(its sign convention is opposite to the torque's; .*\); negate the current columns of the "
                        r"other sign \(nothing written\)", err), err
    assert not out.exists()


def test_an_identified_value_outside_its_range_is_named_and_not_written():
    """Whatever the cause, identify writes no overlay that --model refuses: the text is checked as Overlay.load
    reads it, and a value outside its parameter's range is named."""
    from ur5fault.errors import ParameterError
    from ur5fault.identify import report, stats

    def ident(coulomb_A):
        est = [stats.Estimate("motor.torque_constant_Nm_per_A", j, 0.1, 0.09, 0.11, "m") for j in range(6)]
        est += [stats.Estimate("friction.coulomb_A", j, c, 0.1, 0.3, "m") for j, c in enumerate(coulomb_A)]
        est += [stats.Estimate("friction.viscous_A_s_per_rad", j, 0.5, 0.4, 0.6, "m") for j in range(6)]
        return report.Identification("x.csv", 1.0, tuple(est))

    p = load_params()
    Overlay.from_data(yaml.safe_load(ident([0.2] * 6).to_yaml(p)), "ok")
    with pytest.raises(ParameterError, match=r"^the overlay identified from x.csv: params.friction.coulomb_Nm\[5\] = "
                                             r"-2.02 is out of range \[0, 500\] N\*m; --model would refuse the "
                                             r"overlay, so nothing is written$"):
        ident([0.2, 0.2, 0.2, 0.2, -0.2, 0.2]).to_yaml(p)


def test_a_log_of_two_rows_is_refused_as_too_short_not_as_a_dead_sensor(tmp_path):
    """A 2-row RTDE log was refused as "current ... reads -0.955011 A in every row: a dead sensor"."""
    log = _kufieta(tmp_path, "Movement_No8_Singularity_Free_1.csv.gz", edit=lambda df: df.head(2))
    with pytest.raises(LogFormatError, match=r"Free_1.csv.gz: 0.0\d+ s and 2 samples; fitting needs at least 5 s and "
                                             r"250 samples$"):
        read_log(log, "rtde", payload_kg=0.0, tcp_offset_m=(0, 0, 0))
