"""Hostile and careless input, one case per line: every case must end with exit status 2, a single
``ur5fault: error: ...`` line naming the problem, no traceback, no file written or half-written,
and bounded memory.  The command line runs in this process (``ur5fault.cli.main``) so the whole
file takes seconds; memory is the traced Python/numpy peak of the call."""

from __future__ import annotations

import gzip
import json
import os
import tracemalloc
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from ur5fault.cli import main

from conftest import NIST_LOG

NIST = NIST_LOG
MAX_TRACED_MB = 150  # every case is refused before anything large is allocated

GOOD = "name: ok\nsweep: {backlash.joint: [2], backlash.backlash_deg: [0.1]}\n"
BOMB = "a: &a [x, x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{n}: &{n} [{', '.join(['*' + p] * 10)}]\n" for p, n in zip("abcdefgh", "bcdefghi")) + "name: *i\n"


# ------------------------------------------------------------------------------ fixtures of files
def rtde_frame(n: int = 1000, period: float = 0.008) -> pd.DataFrame:
    """A plausible RTDE log: slow sine motion, velocities consistent with the positions."""
    t = np.arange(n) * period
    cols: dict[str, np.ndarray] = {"timestamp": t}
    for j in range(6):
        cols[f"target_q_{j}"] = 0.3 * np.sin(0.5 * t + j)
        cols[f"actual_q_{j}"] = cols[f"target_q_{j}"] + 1e-4
        cols[f"actual_qd_{j}"] = 0.15 * np.cos(0.5 * t + j)
        cols[f"actual_current_{j}"] = 0.1 * np.cos(t)
    return pd.DataFrame(cols)


@pytest.fixture(scope="module")
def nist_small() -> pd.DataFrame:
    """The first 1500 rows (12 s) of the real NIST log."""
    return pd.read_csv(NIST, nrows=1500)


def _write(tmp: Path, name: str, content) -> Path:
    p = tmp / name
    if isinstance(content, bytes):
        p.write_bytes(content)
    elif isinstance(content, str):
        p.write_text(content)
    elif name.endswith(".parquet"):
        content.to_parquet(p)
    else:
        content.to_csv(p, index=False)
    return p


def _nist_variant(frame: pd.DataFrame, kind: str) -> pd.DataFrame:
    f = frame.copy()
    if kind == "ms":
        f["ROBOT_TIME"] = f["ROBOT_TIME"] * 1000.0
    elif kind == "radians":
        for k in ("TARGET", "ACTUAL"):
            for j in range(1, 7):
                f[f"ROBOT_{k}_JOINT_POSITIONS (J{j})"] = np.radians(f[f"ROBOT_{k}_JOINT_POSITIONS (J{j})"])
    elif kind == "seven":
        f["ROBOT_ACTUAL_JOINT_POSITIONS (J7)"] = 0.0
    elif kind == "gap":
        f.loc[700:, "ROBOT_TIME"] += 30.0
    return f


# ------------------------------------------------------------------------------ the cases
# (id, kind, content, extra arguments, expected part of the message)
CAMPAIGN = [
    # a parameter group given a number: its keys named, not the class behind them (was "GearParams keys")
    ("params-group-not-a-mapping", "base: {params: {gear: 3}}\n" + GOOD,
     "base.params.gear = 3: expected a mapping of its keys (ratio, stiffness_Nm_per_rad, "),
    ("duration-nan", "duration_s: .nan\n" + GOOD, "duration_s = nan must be a finite number"),
    ("log-period-nan", "log_period_s: .nan\n" + GOOD, "log_period_s = nan must be a finite number"),
    ("name-list", "name: [a, b]\nduration_s: 0.5\n", "name = ['a', 'b'] must be a non-empty one-line text"),
    ("out-list", "out: [x]\n" + GOOD, "out = ['x'] must be a non-empty one-line text"),
    ("seed-1e20", "base: {seed: 1e20}\n" + GOOD, "base.seed = 1e+20 must be a non-negative integer"),
    ("seed-bool", "base: {seed: true}\n" + GOOD, "base.seed = True must be a non-negative integer"),
    ("duration-1e5", "duration_s: 1.0e+5\nname: x\n", "duration_s = 100000.0 is out of range (0, 3600] s"),
    ("alias-bomb-in-name", BOMB, "aliases expand to more than 100000 values"),
    ("recursive-alias", "name: &a [*a]\n", "recursive alias"),
    ("deep-nesting", "name: " + "[" * 3000 + "]" * 3000 + "\n", "nested too deeply (more than 64 levels"),
    ("deep-block-nesting", "a:\n" + "".join(" " * i + f"k{i}:\n" for i in range(1, 500)),
     "more than 64 levels of indentation"),
    ("empty-file", "", "the file is empty"),
    ("only-a-comment", "# nothing here\n", "the file is empty"),
    ("top-level-list", "- name\n- x\n", "expected a mapping at the top level, got list"),
    ("threshold-nan", "threshold_mm: .nan\n" + GOOD, "threshold_mm = nan must be a finite number"),
    ("save-timeseries-string", "save_timeseries: 'no'\n" + GOOD, "save_timeseries = 'no' must be true or false"),
    ("save-timeseries-number", "save_timeseries: 0\n" + GOOD, "save_timeseries = 0 must be true or false"),
    ("duplicate-key", "duration_s: 0.5\nduration_s: 0.7\nname: x\n", "line 2: duplicate key 'duration_s'"),
    ("duplicate-nested-key", "base: {seed: 1, seed: 2}\nname: x\n", "duplicate key 'seed'"),
    ("1e9-is-a-number", "sweep: {backlash.joint: [2], backlash.backlash_deg: [1e9]}\nname: x\n",
     "backlash.backlash_deg = 1000000000.0 is out of range [0, 5] deg"),
    ("string-as-number", "base: {payload_kg: '2'}\n" + GOOD, "base.payload_kg = '2' must be a number in [0, 5] kg"),
    ("bool-as-number", "batch_size: true\n" + GOOD, "batch_size = True must be an integer in [1, 1024]"),
    ("bool-in-sweep", "sweep: {temperature_C: [yes]}\nname: x\n", "temperature_C = True must be a number"),
    ("param-string", "base: {params: {gear: {ratio: '50'}}}\n" + GOOD, "gear.ratio = '50' must be a number"),
    ("params-list", "base: {params: [1, 2]}\n" + GOOD, "base.params = [1, 2] must be a mapping"),
    ("effects-mapping", "base: {effects: {effect: backlash}}\n" + GOOD, "base.effects: expected a list of effects"),
    # every run has a payload_kg (2 kg unless given), applied after the base effects: the effect would be lost
    ("payload-effect-in-base", "base: {effects: [{effect: payload, mass_kg: 1}]}\n" + GOOD,
     "base.effects[0]: payload (mass_kg=1) and payload_kg = 2.0 (every run has one"),
    ("payload-effect-swept", "sweep: {payload.mass_kg: [0.5, 1.0]}\nname: x\n",
     "sweep.payload.mass_kg: 'payload.mass_kg' is set by every run's payload_kg: sweep payload_kg instead"),
    ("temperature-effect-zipped", "zip: [{temperature.temperature_C: [20, 30], seed: [0, 1]}]\nname: x\n",
     "'temperature.temperature_C' is set by every run's temperature_C: sweep temperature_C instead"),
    ("temperature-effect-in-base", "base: {temperature_C: 30, effects: [{effect: temperature, temperature_C: 40}]}\n"
     + GOOD, "base.effects[0]: temperature (temperature_C=40) and temperature_C = 30"),
    ("trajectory-seconds-huge", "trajectory: {name: hold, seconds: 1e9}\nname: x\n",
     "trajectory.seconds = 1000000000.0 is out of range [0.01, 3600] s"),
    ("trajectory-option-bool", "trajectory: {name: joint_sweep, speed_scale: true}\nname: x\n",
     "trajectory.speed_scale = True must be a number"),
    ("trajectory-option-unknown", "trajectory: {name: hold, speed: 2}\nname: x\n",
     "unknown option of trajectory 'hold' 'speed'; valid: payload_kg, q_rad, seconds"),
    ("log-period-not-multiple", "log_period_s: 0.00007\n" + GOOD, "must be a whole multiple of physics_dt_s"),
    ("log-period-beyond-run", "log_period_s: 2.0\nduration_s: 0.5\n" + GOOD,
     "log_period_s = 2.0 leaves fewer than 3 logged samples in the run (0.5 s)"),
    # a run of one log period passed, then died in its features with an IndexError (a newcomer probe)
    ("log-period-one-sample", "log_period_s: 0.001\nduration_s: 0.002\n" + GOOD,
     "log_period_s = 0.001 leaves fewer than 3 logged samples in the run (0.002 s)"),
    ("grid-too-large", "name: x\nsweep: {seed: [" + ", ".join(map(str, range(1001))) + "], payload_kg: ["
     + ", ".join(f"{i / 1000:.3f}" for i in range(1001)) + "]}\n", "expands to 1e+06 runs, above the limit"),
    ("large-needs-yes", "name: x\nduration_s: 0.5\nsweep: {seed: [" + ", ".join(map(str, range(1200))) + "]}\n",
     "more than 1000 runs or 2e+09 steps needs --yes"),
    ("memory", "name: x\ntrajectory: {name: hold, seconds: 3000}\nlog_period_s: 0.00005\nbatch_size: 64\n"
     "sweep: {seed: [0, 1, 2, 3]}\n", "of memory, more than 80% of the"),
    ("not-utf8", b"name: \xff\xfe bad\n", "not UTF-8 text"),
    ("binary", bytes(range(256)) * 4, "not UTF-8 text (byte 128)"),
    ("control-characters", bytes(range(1, 32)) * 4, "is not valid YAML"),
    ("python-tag", "name: !!python/object/apply:os.system [echo]\n", "could not determine a constructor"),
]
CAMPAIGN_ARGS = [
    ("jobs-zero", GOOD, ["--jobs", "0"], "--jobs 0: must be a whole number of at least 1"),
    ("threshold-arg-nan", GOOD, ["--threshold-mm", "nan"], "--threshold-mm = nan must be a finite number"),
    ("out-is-a-file", GOOD, ["--out", "{tmp}/c.yaml"], "exists and is not a folder"),
    ("out-under-a-file", GOOD, ["--out", "{tmp}/c.yaml/sub"], "is a file and not a folder"),
    ("out-read-only", GOOD, ["--out", "/proc/ur5fault-test/out"], "cannot write in /proc"),
    ("out-in-file-list", "out: [x]\n" + GOOD, [], "out = ['x'] must be a non-empty one-line text"),
    ("dask-bad-address", GOOD, ["--backend", "dask", "--scheduler", "nonsense"], "cannot connect to a Dask scheduler"),
    ("dask-no-address", GOOD, ["--backend", "dask"], "--backend dask needs --scheduler ADDRESS"),
    ("dask-address-without-dask", GOOD, ["--scheduler", "tcp://127.0.0.1:8786"],  # was run locally, address unused
     "--scheduler tcp://127.0.0.1:8786 is for --backend dask"),
    ("model-duplicate-key", GOOD, ["--model", "{tmp}/dup.yaml"], "duplicate key 'params'"),
    ("model-empty", GOOD, ["--model", "{tmp}/empty.yaml"], "the file is empty"),
    # the overlay's own effect named, not the campaign file's base.effects, which does not hold it
    ("model-sets-a-condition", GOOD, ["--model", "{tmp}/warm.yaml"], "warm.yaml: effects[0]: temperature "
     "(temperature_C=40): every campaign run sets its temperature_C (base.temperature_C of c.yaml, or its default)"),
    ("campaign-missing", None, [], "cannot read (No such file or directory)"),
    ("campaign-is-a-folder", None, ["{tmp}"], "cannot read (Is a directory)"),
]
SIMULATE = [
    # the flags' names, not the run configuration's keys (which a command-line user never typed)
    ("duration-arg-nan", ["--duration-s", "nan"], "--duration-s = nan must be a finite number in (0, 3600] s"),
    ("duration-arg-huge", ["--duration-s", "1e5"], "--duration-s = 100000.0 is out of range (0, 3600] s"),
    ("log-period-arg-zero", ["--log-period-s", "0"], "--log-period-s = 0.0 is out of range (0, inf] s"),
    # checked against the physics step with the run configuration, still under the flag's name
    ("log-period-arg-below-the-step", ["--log-period-s", "3e-5"], "--log-period-s = 3e-05 is out of range [5e-05"),
    ("log-period-arg-off-the-step", ["--log-period-s", "7e-5"], "--log-period-s = 7e-05 must be a whole multiple"),
    ("payload-arg-inf", ["--payload-kg", "inf"], "--payload-kg = inf must be a finite number in [0, 5] kg"),
    ("duration-below-log-period", ["--duration-s", "0.00005"],
     "--duration-s 5e-05 holds fewer than 3 log periods of 0.001 s"),
    ("duration-two-log-periods", ["--duration-s", "0.002"], "--duration-s 0.002 holds fewer than 3 log periods"),
    ("backlash-arg-nan", ["--backlash", "elbow:nan"], "backlash.backlash_deg = nan must be a number"),
    ("effect-arg-nan", ["--effect", "coulomb_friction@2:scale=nan"], "coulomb_friction.scale = nan must be a number"),
    ("backlash-arg-repeated", ["--backlash", "elbow:0.1", "--backlash", "3:0.2"],
     "effects[1]: backlash on elbow_joint (backlash_deg=0.2) repeats effects[0]"),
    ("effect-arg-repeated", ["--effect", "coulomb_friction@2:scale=1.5", "--effect", "coulomb_friction@2:scale=1.2"],
     "repeats effects[0] (coulomb_friction on shoulder_lift_joint (scale=1.5)); give each effect once"),
    ("payload-effect-and-option", ["--effect", "payload:mass_kg=1", "--payload-kg", "2"],
     "command line: effects[0]: payload (mass_kg=1) and payload_kg = 2.0 (--payload-kg) both set "
     "the payload: give it once"),
    ("temperature-effect-and-option", ["--effect", "temperature:temperature_C=40", "--temperature-C", "20"],
     "effects[0]: temperature (temperature_C=40) and temperature_C = 20.0 (--temperature-C) both set "
     "the temperature"),
    ("out-arg-unwritable", ["--out", "/proc/ur5fault-test/run.parquet"], "cannot write in /proc"),
    ("out-arg-folder", ["--out", "{tmp}"], "is a folder; give a file name"),
    ("config-bomb", ["--config", "{tmp}/bomb.yaml"], "aliases expand to more than"),
    ("config-empty", ["--config", "{tmp}/empty.yaml"], "the file is empty"),
    ("config-duplicate", ["--config", "{tmp}/dup.yaml"], "duplicate key 'params'"),
    ("config-memory", ["--config", "{tmp}/long.yaml"], "of memory, more than 80% of the"),
    ("config-seed-float", ["--config", "{tmp}/seed.yaml"], "seed = 1.5 must be a non-negative integer"),
    # was "--duration-s 1 holds fewer than 3 log periods of 1 s": true counted as a log period of 1 s
    ("config-log-period-true", ["--config", "{tmp}/lptrue.yaml", "--duration-s", "1"],
     "lptrue.yaml: log_period_s = True must be a number in [5e-05, inf] s"),
    ("model-negative-link-mass", ["--model", "{tmp}/negmass.yaml"],
     "link_mass on shoulder_pan_joint: mass_kg = -10 would leave the link -6.3 kg (it weighs 3.7 kg)"),
    ("model-int-beyond-float", ["--model", "{tmp}/bigint.yaml"], "coulomb_Nm[1] = 1000000000"),
    ("model-long-effect-list", ["--model", "{tmp}/many.yaml"],
     "the document holds more than 100000 values; a configuration file this large is refused"),
]
LOGS = [
    ("log-empty", "rtde", "log.csv", b"", "empty file"),
    ("log-header-only", "rtde", "log.csv", ",".join(rtde_frame(2).columns) + "\n", "header only, no data rows"),
    ("log-truncated-gzip", "nist", "log.csv.gz", "TRUNCATED", "truncated (the compressed stream ends early)"),
    ("log-corrupt-gzip", "nist", "log.csv.gz", b"\x1f\x8b\x08\x00" + bytes(range(200)) * 3, "corrupt gzip"),
    ("log-binary", "rtde", "log.csv", bytes(range(256)) * 20, "binary data, not a text log"),
    ("log-not-utf8", "rtde", "log.csv", b"timestamp,\xff\xfe\n1,2\n", "not UTF-8 text"),
    ("log-non-numeric", "rtde", "log.csv", "NONNUMERIC",
     "non-numeric value 'abc' in column 'actual_q_2' at data row 6"),
    ("log-ragged-line", "rtde", "log.csv", "RAGGED", "line 12 has 26 fields, the header 25"),
    ("log-column-twice", "rtde", "log.csv", "DUPCOL", "column 'actual_q_0' appears 2 times in the header"),
    ("log-parquet-as-rtde", "rtde", "run.parquet", b"PAR1" + bytes(200) + b"PAR1",
     "binary data, not a text log (a NUL byte at offset 4); a Parquet file: --format sim reads a run of"),
    ("log-three-rows", "rtde", "log.csv", rtde_frame(3), "fitting needs at least 5 s and 250 samples"),
    ("log-broken-sim", "sim", "log.parquet", b"PAR1" + bytes(range(256)) + b"PAR1", "cannot read as Parquet"),
    ("log-sim-wrong-columns", "sim", "log.parquet", pd.DataFrame({"t_s": [0.0, 1.0]}), "missing required column"),
    ("log-missing", "rtde", None, None, "no such file"),
    ("log-folder", "rtde", "", None, "not a file"),
    ("nist-time-in-ms", "nist", "log.csv.gz", "NIST:ms", "sample rate 0.125 Hz"),
    ("nist-positions-in-radians", "nist", "log.csv.gz", "NIST:radians", "they look like radians, but this layout "
     "declares degrees"),
    ("nist-seven-joints", "nist", "log.csv.gz", "NIST:seven", "7 joints in the columns"),
    ("nist-30s-gap", "nist", "log.csv.gz", "NIST:gap", "a gap of 30 s"),
    ("rtde-degrees", "rtde", "log.csv", "DEGREES", "they look like degrees, but this layout declares radians"),
]


def _materialise(tmp: Path, content, name: str, nist_small) -> Path:
    if not isinstance(content, str):
        return _write(tmp, name, content)
    if content == "TRUNCATED":
        raw = NIST.read_bytes()
        return _write(tmp, name, raw[: len(raw) // 3])
    if content == "NONNUMERIC":
        f = rtde_frame().astype(object)
        f.loc[5, "actual_q_2"] = "abc"
        return _write(tmp, name, f)
    if content == "RAGGED":
        p = _write(tmp, name, rtde_frame())
        lines = p.read_text().splitlines()
        lines[11] += ",7"
        p.write_text("\n".join(lines) + "\n")
        return p
    if content == "DUPCOL":  # the header names a column twice (the second was read as 'actual_q_0.1')
        p = _write(tmp, name, rtde_frame())
        lines = p.read_text().splitlines()
        lines[0] = lines[0].replace("actual_q_1", "actual_q_0")
        p.write_text("\n".join(lines) + "\n")
        return p
    if content == "DEGREES":
        f = rtde_frame()
        for j in range(6):
            f[f"actual_q_{j}"] = np.degrees(f[f"actual_q_{j}"])
        return _write(tmp, name, f)
    if content.startswith("NIST:"):
        p = tmp / name
        with gzip.open(p, "wt") as fh:
            _nist_variant(nist_small, content[5:]).to_csv(fh, index=False)
        return p
    return _write(tmp, name, content)


def _files(tmp: Path) -> dict[str, int]:
    return {str(p.relative_to(tmp)): p.stat().st_size for p in tmp.rglob("*")}


def _run(argv: list[str], tmp: Path, capsys) -> tuple[int, str, float]:
    capsys.readouterr()
    before = _files(tmp)
    tracemalloc.start()
    try:
        rc = main(argv)
    finally:
        peak = tracemalloc.get_traced_memory()[1] / 1e6
        tracemalloc.stop()
    err = capsys.readouterr().err
    after = _files(tmp)
    assert after == before, f"files changed: {set(after) ^ set(before)}"  # nothing written, nothing half-written
    return rc, err, peak


def _assert_one_line(rc: int, err: str, peak_mb: float, message: str) -> None:
    lines = err.strip().splitlines()
    assert rc == 2, err
    assert "Traceback" not in err
    assert len(lines) == 1 and lines[0].startswith("ur5fault: error: "), err
    assert message in lines[0], lines[0]
    assert peak_mb < MAX_TRACED_MB, f"{peak_mb:.0f} MB traced"


@pytest.fixture
def support_files(tmp_path):
    _write(tmp_path, "bomb.yaml", BOMB)
    _write(tmp_path, "empty.yaml", "")
    _write(tmp_path, "warm.yaml", "effects:\n  - {effect: temperature, temperature_C: 40}\n")
    _write(tmp_path, "dup.yaml", "params: {}\nparams: {gear: {ratio: 50}}\n")
    _write(tmp_path, "long.yaml", "trajectory: {name: hold, seconds: 3500}\nlog_period_s: 0.00005\n")
    _write(tmp_path, "seed.yaml", "seed: 1.5\n")
    _write(tmp_path, "lptrue.yaml", "log_period_s: true\n")
    _write(tmp_path, "negmass.yaml", "effects:\n  - {effect: link_mass, joint: 1, mass_kg: -10}\n")
    _write(tmp_path, "bigint.yaml", f"params:\n  friction:\n    coulomb_Nm: [{10 ** 400}, 1, 1, 1, 1, 1]\n")
    _write(tmp_path, "many.yaml", "effects:\n" + "  - {effect: current_sensor_offset, joint: 1, offset_A: 0.001}\n"
           * 15000)
    return tmp_path


@pytest.mark.parametrize("text, message", [c[1:] for c in CAMPAIGN], ids=[c[0] for c in CAMPAIGN])
def test_campaign_file(text, message, support_files, capsys):
    tmp = support_files
    f = _write(tmp, "c.yaml", text.encode() if isinstance(text, str) else text)
    rc, err, peak = _run(["campaign", "run", str(f), "--out", str(tmp / "out"), "--quiet", "--jobs", "1"], tmp, capsys)
    _assert_one_line(rc, err, peak, message)


@pytest.mark.parametrize("text, args, message", [c[1:] for c in CAMPAIGN_ARGS], ids=[c[0] for c in CAMPAIGN_ARGS])
def test_campaign_arguments(text, args, message, support_files, capsys):
    tmp = support_files
    args = [a.format(tmp=tmp) for a in args]
    if text is None:
        target = args.pop(0) if args else str(tmp / "absent.yaml")
    else:
        target = str(_write(tmp, "c.yaml", text))
    out = [] if "--out" in args else ["--out", str(tmp / "out")]
    rc, err, peak = _run(["campaign", "run", target, *out, "--quiet", *args], tmp, capsys)
    _assert_one_line(rc, err, peak, message)


@pytest.mark.parametrize("args, message", [c[1:] for c in SIMULATE], ids=[c[0] for c in SIMULATE])
def test_simulate(args, message, support_files, capsys):
    tmp = support_files
    args = [a.format(tmp=tmp) for a in args]
    out = [] if "--out" in args else ["--out", str(tmp / "run.parquet")]
    rc, err, peak = _run(["simulate", *args, *out, "--quiet"], tmp, capsys)
    _assert_one_line(rc, err, peak, message)


@pytest.mark.parametrize("fmt, name, content, message", [c[1:] for c in LOGS], ids=[c[0] for c in LOGS])
def test_log_for_discrepancy(fmt, name, content, message, tmp_path, nist_small, capsys):
    if name is None:
        log = tmp_path / "absent.csv"
    elif name == "":
        log = tmp_path
    else:
        log = _materialise(tmp_path, content, name, nist_small)
    rc, err, peak = _run(["discrepancy", str(log), "--format", fmt, "--out", str(tmp_path / "out")], tmp_path, capsys)
    _assert_one_line(rc, err, peak, message)


def test_a_simulated_run_given_to_identify_is_not_sent_to_a_format_it_lacks(tmp_path, capsys):
    """identify reads real logs only: a Parquet run of `ur5fault simulate` given to it was told "--format sim
    reads a run of `ur5fault simulate`", and identify then refused --format sim (a newcomer probe of the wheel)."""
    log = _write(tmp_path, "run.parquet", b"PAR1" + bytes(200) + b"PAR1")
    rc, err, peak = _run(["identify", str(log), "--format", "rtde", "--out", str(tmp_path / "p.yaml")], tmp_path,
                         capsys)
    _assert_one_line(rc, err, peak, "a Parquet file, a run of `ur5fault simulate`: this command reads nist and rtde "
                                    "logs, not simulated runs (`ur5fault discrepancy` reads one with --format sim)")
    assert "--format sim reads" not in err


def test_total_steps_above_limit(support_files, capsys, monkeypatch):
    """The 1e12-step limit needs 14 000 hour-long runs; the same check at 1e10 needs 140 (faster to parse)."""
    from ur5fault.campaign import limits

    monkeypatch.setattr(limits, "MAX_RUN_STEPS", 1e10)
    f = _write(support_files, "c.yaml", "name: x\nduration_s: 3600\nlog_period_s: 0.1\nbatch_size: 1\nsweep: "
               "{seed: [" + ", ".join(map(str, range(140))) + "]}\n")
    rc, err, peak = _run(["campaign", "run", str(f), "--out", str(support_files / "o"), "--yes", "--jobs", "1"],
                         support_files, capsys)
    _assert_one_line(rc, err, peak, "140 runs, 1.01e+10 physics steps (about 12 core-hours), about")
    assert "above the limit of 1e+10 physics steps: split the sweep or shorten duration_s" in err


def test_jobs_above_cores_capped_with_a_note():
    from ur5fault.campaign.limits import available_cores, effective_jobs

    cores = available_cores()
    assert effective_jobs(cores + 7) == (cores, f"--jobs {cores + 7} capped at the {cores} cores available")
    assert effective_jobs(1) == (1, None)


def test_yaml_1_1_numbers_mean_what_they_say(tmp_path):
    """The strict loader reads 1e9 / 6.7e4 as floats (PyYAML: strings) and 010 as ten."""
    from ur5fault.campaign import load_campaign
    from ur5fault.util.yamlsafe import loads

    assert loads("a: [1e9, 6.7e4, -1E3, 1.5e-3, 010, 0x10, 1:30]") == {
        "a": [1e9, 67000.0, -1000.0, 0.0015, 10, 16, "1:30"]}
    f = _write(tmp_path, "c.yaml", "base: {seed: 1e9, params: {gear: {stiffness_Nm_per_rad: 5e4}}}\nduration_s: 5e-1\n")
    camp = load_campaign(f)
    assert camp.runs[0].cond["seed"] == 1_000_000_000 and camp.duration_s == 0.5
    assert camp.base_params["gear"]["stiffness_Nm_per_rad"] == 5e4


def test_packaged_parameters_load_as_before():
    """The strict loader gives the packaged UR5 file the values PyYAML plus the old string
    conversion gave (6.7e4 etc. were strings converted later)."""
    import yaml

    from ur5fault.sim.params import DEFAULT_PARAMS_PATH, RobotParams, load_params

    def floats(x):
        if isinstance(x, dict):
            return {k: floats(v) for k, v in x.items()}
        if isinstance(x, list):
            return [floats(v) for v in x]
        if isinstance(x, str):
            try:
                return float(x)
            except ValueError:
                return x
        return x

    reference = RobotParams.from_dict(floats(yaml.safe_load(DEFAULT_PARAMS_PATH.read_text())), "ref")
    assert load_params() == reference


def test_sigterm_frees_the_lock_and_stops_workers(tmp_path):
    """A real process: SIGTERM mid-campaign exits 143 with one line, removes .lock, and leaves no
    worker process behind."""
    import signal
    import subprocess
    import sys
    import time

    f = _write(tmp_path, "c.yaml", "name: t\nduration_s: 3.0\nbatch_size: 2\n"
               "sweep: {backlash.joint: [2, 3, 4], backlash.backlash_deg: [0.1, 0.2]}\n")
    out = tmp_path / "out"
    # its own process group, signalled as a whole (as `kill %1` or a service manager does): the workers get SIGTERM
    # too, and loky's thread sees them die, maybe before the main thread has run its handler
    proc = subprocess.Popen([sys.executable, "-m", "ur5fault.cli", "campaign", "run", str(f), "--out", str(out),
                             "--jobs", "2", "--quiet"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    def loky_workers() -> list[int]:  # not any child: a short-lived one (git, for the manifest) comes first
        return [c for c in _children(proc.pid) if b"loky" in _cmdline(c)]

    deadline = time.time() + 60
    while time.time() < deadline and not loky_workers():
        time.sleep(0.2)
    time.sleep(1.0)
    workers = loky_workers()
    assert workers, "no worker processes seen"
    os.killpg(proc.pid, signal.SIGTERM)
    err = proc.communicate(timeout=60)[1]
    assert proc.returncode == 143 and err.strip().splitlines()[-1] == "ur5fault: terminated", err
    assert "Traceback" not in err, err  # loky's manager thread, stopped with its workers, is not printed
    assert not (out / ".lock").exists()
    deadline = time.time() + 10.0  # the workers are killed at once; a loaded machine may take a moment to reap them
    while time.time() < deadline and any(_alive(p) for p in workers):
        time.sleep(0.1)
    assert not [p for p in workers if _alive(p)], "worker processes survived SIGTERM"


def test_once_stopped_the_executors_thread_prints_no_traceback():
    """After SIGTERM or Ctrl-C, loky's ExecutorManagerThread could print a thread traceback (a KeyError of a task it
    no longer tracked) after "ur5fault: terminated", 1 time in 2 (a newcomer probe); with a SIGTERM sent to the
    process group the thread may see the workers die before the main thread's handler runs (3 in 6 when the hook
    was installed by the handler). Dropped once the command is stopping, within a grace time; printed while it runs,
    and other threads' exceptions always."""
    import threading
    import time

    from ur5fault import cli

    seen = []
    stopping = threading.Event()
    hook = cli.quiet_when_stopping(lambda args: seen.append(args.thread.name), stopping, grace_s=0.5)

    def fail():
        raise KeyError(5)

    def run(name):
        t = threading.Thread(target=fail, name=name)
        previous, threading.excepthook = threading.excepthook, hook
        try:
            t.start()
            t.join()
        finally:
            threading.excepthook = previous

    run("ExecutorManagerThread")  # the command runs: printed (after the grace time)
    assert seen == ["ExecutorManagerThread"]
    threading.Timer(0.1, stopping.set).start()  # the stop arrives while the thread's exception waits
    t0 = time.monotonic()
    run("ExecutorManagerThread")
    assert seen == ["ExecutorManagerThread"] and time.monotonic() - t0 < 0.5
    run("Thread-mine")
    assert seen == ["ExecutorManagerThread", "Thread-mine"]


@pytest.mark.parametrize("signame, line, status", [("SIGINT", "ur5fault: interrupted", 130),
                                                    ("SIGTERM", "ur5fault: terminated", 143)])
def test_a_stop_while_the_parser_is_built_is_one_line(signame, line, status):
    """Ctrl-C or SIGTERM in a command's first second, while the parser imports the command's modules, printed a
    KeyboardInterrupt traceback (`timeout -s INT 1 ur5fault --version`, a newcomer probe): the same one line, and
    the same status, as a stop later on. The parser is held there (a stand-in waiting for the signal) so that the
    signal lands inside it every time."""
    import signal
    import subprocess
    import sys

    script = ("import signal, sys, time\n"
              "signal.signal(signal.SIGINT, signal.default_int_handler)\n"  # as in a terminal, not a background job
              "from ur5fault import cli\n"
              "def build_parser(*args, **kwargs):\n"
              "    print('building', flush=True)\n"
              "    time.sleep(60)\n"
              "cli.build_parser = build_parser\n"
              "sys.exit(cli.main(['--version']))\n")
    proc = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        assert proc.stdout.readline() == "building\n"
        proc.send_signal(getattr(signal, signame))
        err = proc.communicate(timeout=30)[1]
    finally:
        proc.kill()
    assert (proc.returncode, err) == (status, line + "\n")


@pytest.mark.parametrize("stop, line, status", [(KeyboardInterrupt, "ur5fault: interrupted", 130),
                                                ("Terminated", "ur5fault: terminated", 143)])
def test_a_stop_while_the_handlers_are_set_up_is_one_line(monkeypatch, capsys, stop, line, status):
    """From main()'s first line: a stop before its handlers are in place (here: while the executor's thread hook
    is made) was a traceback too."""
    from ur5fault import cli

    exc = cli.Terminated if stop == "Terminated" else stop

    def stopped(*args, **kwargs):
        raise exc()

    monkeypatch.setattr(cli, "quiet_when_stopping", stopped)
    assert cli.main(["--version"]) == status
    assert capsys.readouterr().err == line + "\n"


def _cmdline(pid: int) -> bytes:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as fh:
            return fh.read()
    except OSError:
        return b""


def _children(pid: int) -> list[int]:
    try:
        with open(f"/proc/{pid}/task/{pid}/children") as fh:
            return [int(x) for x in fh.read().split()]
    except OSError:
        return []


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().split()[2] != "Z"
    except OSError:
        return False


def test_files_are_group_readable(tmp_path):
    from ur5fault.util.io import write_json_atomic, write_parquet_atomic

    old = os.umask(0o077)  # even under a strict umask, outputs are 0644 as the docs say
    try:
        p = write_parquet_atomic(pd.DataFrame({"a": [1]}), tmp_path / "x.parquet")
        j = write_json_atomic(tmp_path / "m.json", {"a": 1})
    finally:
        os.umask(old)
    assert p.stat().st_mode & 0o777 == 0o644 and j.stat().st_mode & 0o777 == 0o644


@pytest.mark.parametrize("args, message", [
    (["--payload-kg", "nan"], "--payload-kg = nan must be a finite number in [0, 5] kg"),
    (["--payload-kg", "-1"], "--payload-kg = -1.0 is out of range [0, 5] kg"),
    (["--tcp-offset-m", "0", "0", "inf"], "--tcp-offset-m (value 3) = inf must be a finite number in [-2, 2] m"),
    (["--fit-fraction", "nan"], "--fit-fraction = nan must be a finite number in [0.2, 0.9]"),
    (["--max-terms", "-1"], "--max-terms -1: must be a whole number of at least 0"),
    (["--jobs", "0"], "--jobs 0: must be a whole number of at least 1"),
], ids=["payload-nan", "payload-negative", "tcp-offset-inf", "fit-fraction-nan", "max-terms-negative", "jobs-zero"])
def test_discrepancy_log_arguments(args, message, tmp_path, capsys):
    log = _write(tmp_path, "log.csv", rtde_frame())
    rc, err, peak = _run(["discrepancy", str(log), "--format", "rtde", *args, "--out", str(tmp_path / "out")],
                         tmp_path, capsys)
    _assert_one_line(rc, err, peak, message)


def test_discrepancy_unwritable_out_fails_before_reading_the_log(tmp_path, capsys):
    """An output folder that cannot be made is refused first (the log is not even read)."""
    (tmp_path / "afile").write_text("x")
    rc, err, peak = _run(["discrepancy", str(tmp_path / "missing.csv"), "--format", "rtde", "--out",
                          str(tmp_path / "afile" / "out")], tmp_path, capsys)
    _assert_one_line(rc, err, peak, "is a file and not a folder")


def test_dask_scheduler_that_does_not_answer(support_files, capsys, monkeypatch):
    """A closed port: one line after the connect timeout (shortened here from 10 s), nothing written."""
    pytest.importorskip("dask.distributed")
    import time

    from ur5fault.campaign import workers

    monkeypatch.setattr(workers, "DASK_CONNECT_TIMEOUT_S", 1.0)
    f = _write(support_files, "c.yaml", GOOD)
    t0 = time.perf_counter()
    rc, err, peak = _run(["campaign", "run", str(f), "--out", str(support_files / "o"), "--backend", "dask",
                          "--scheduler", "tcp://127.0.0.1:9"], support_files, capsys)
    _assert_one_line(rc, err, peak, "--scheduler tcp://127.0.0.1:9: cannot connect to a Dask scheduler (timeout 1 s")
    assert time.perf_counter() - t0 < 8.0


@pytest.mark.parametrize("args, message", [
    (["simulate", "--seed", "1", "--seed", "2"], "--seed given twice; give it once"),
    (["simulate", "--out", "a.parquet", "--out=b.parquet"], "--out given twice; give it once"),
    (["simulate", "--dur", "1", "--duration-s", "2"], "--duration-s given twice; give it once"),
    (["identify", "x.csv", "--format", "rtde", "--format", "nist", "--out", "p.yaml"], "--format given twice"),
    (["campaign", "run", "paper", "--jobs", "1", "--jobs", "2"], "--jobs given twice; give it once"),
    (["discrepancy", "x.csv", "--format", "rtde", "--tcp-offset-m", "0", "0", "0", "--tcp-offset-m", "0", "0", "1",
      "--out", "d"], "--tcp-offset-m given twice"),
    # options of an argument group (monitor's baseline source): argparse adds them past add_argument
    (["monitor", "x.csv", "--format", "rtde", "--baseline", "m.yaml", "--baseline-logs", "a.csv", "--baseline-logs",
      "b.csv", "--out", "mo"], "--baseline-logs given twice"),
    (["monitor", "x.csv", "--format", "rtde", "--baseline", "m.yaml", "--baseline-stats", "a.json",
      "--baseline-stats", "b.json", "--out", "mo"], "--baseline-stats given twice"),
], ids=["simulate-seed", "simulate-out-equals", "abbreviation", "identify-format", "campaign-jobs", "tcp-offset",
        "monitor-baseline-logs", "monitor-baseline-stats"])
def test_option_given_twice_refused(args, message, tmp_path, capsys, monkeypatch):
    """argparse keeps the last of two values silently; the first would be an option accepted and ignored."""
    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as exc:
        main(args)
    err = capsys.readouterr().err
    assert exc.value.code == 2 and err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err
    assert message in err and list(tmp_path.iterdir()) == []


def test_repeatable_options_and_flags_still_repeat(tmp_path, capsys):
    out = tmp_path / "r.parquet"
    assert main(["-v", "simulate", "-v", "--backlash", "2:0.1", "--backlash", "3:0.1", "--quiet", "--quiet",
                 "--duration-s", "0.01", "--out", str(out)]) == 0
    assert "backlash on shoulder_lift_joint" in capsys.readouterr().err and out.is_file()


@pytest.mark.parametrize("args, message", [
    (["--sweep-window-s", "nan"], "--sweep-window-s = nan must be a positive number of seconds"),
    (["--out", "{tmp}"], "is a folder; give a file name for the output"),
    (["--out", "{tmp}/afile/p.yaml"], "is a file and not a folder"),
    (["--json", "{tmp}/afile/x.json"], "is a file and not a folder"),
    # an option that applies to nothing is refused, not dropped
    (["--no-sweep", "--sweep-window-s", "10"], "--sweep-window-s applies to the bandwidth sweep, which --no-sweep"),
], ids=["sweep-window-nan", "out-folder", "out-under-a-file", "json-under-a-file", "sweep-window-without-sweep"])
def test_identify_arguments_refused_before_the_fit(args, message, tmp_path, capsys):
    """identify checked its output only after the fit (seconds to minutes), and a NaN window crashed in it."""
    log = _write(tmp_path, "log.csv", rtde_frame())
    _write(tmp_path, "afile", "x")
    args = [a.format(tmp=tmp_path) for a in args]
    out = [] if "--out" in args else ["--out", str(tmp_path / "p.yaml")]
    rc, err, peak = _run(["identify", str(log), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0",
                          "0", *out, *args], tmp_path, capsys)
    _assert_one_line(rc, err, peak, message)


@pytest.mark.parametrize("args, message", [
    (["benchmark", "{tmp}/afile"], "afile: not a campaign folder, and cannot read it as a feature table"),
    (["benchmark", "{tmp}", "--out", "{tmp}/afile"], "afile: exists and is not a folder"),
    (["plot", "{tmp}", "--out", "{tmp}/afile"], "afile: exists and is not a folder"),
    (["show", "{tmp}/run.parquet", "--out", "{tmp}/afile/x.png"], "is a file and not a folder"),
    (["show", "{tmp}/run.parquet", "--out", "{tmp}/fig.txt"], "the figure is written as PNG; give a .png file name"),
], ids=["benchmark-dir-is-a-file", "benchmark-out-is-a-file", "plot-out-is-a-file", "show-out-under-a-file",
        "show-out-not-png"])
def test_figure_and_benchmark_paths(args, message, tmp_path, capsys):
    """A file given for a folder: tracebacks from pyarrow and mkdir before; a .txt figure was a PNG under that name."""
    _write(tmp_path, "afile", "x")
    _write(tmp_path, "run.parquet", pd.DataFrame({"t_s": [0.0]}))
    rc, err, peak = _run([a.format(tmp=tmp_path) for a in args], tmp_path, capsys)
    _assert_one_line(rc, err, peak, message)


def test_show_default_figure_path_with_a_folder_in_the_way(tmp_path, capsys):
    """``show RUN.parquet`` writes RUN.png beside it; a folder of that name gave a traceback at the write."""
    _write(tmp_path, "run.parquet", pd.DataFrame({"t_s": [0.0]}))
    (tmp_path / "run.png").mkdir()
    rc, err, peak = _run(["show", str(tmp_path / "run.parquet")], tmp_path, capsys)
    _assert_one_line(rc, err, peak, "run.png: is a folder")


def test_campaign_status_of_a_folder_that_holds_no_campaign(tmp_path, capsys):
    """It printed an empty report with exit 0, as if a mistyped folder were a sound campaign."""
    (tmp_path / "notes.txt").write_text("x")
    rc, err, peak = _run(["campaign", "status", str(tmp_path)], tmp_path, capsys)
    _assert_one_line(rc, err, peak, "not a campaign folder (no manifest.json, runs/ or feature table in it)")


def test_a_run_cut_to_its_last_logged_sample_is_said(tmp_path, capsys):
    """A duration that is not a whole number of log periods ends at the last logged sample: said, not silent."""
    out = tmp_path / "r.parquet"
    assert main(["simulate", "--duration-s", "0.0105", "--quiet", "--out", str(out)]) == 0
    cap = capsys.readouterr()
    assert "note: the run ends at 0.01 s, its last logged sample (0.0105 s is not a whole number" in cap.err
    assert json.loads(cap.out)["duration_s"] == pytest.approx(0.01)
    assert main(["simulate", "--duration-s", "0.01", "--quiet", "--out", str(out), "--replace"]) == 0
    assert "note:" not in capsys.readouterr().err


@pytest.mark.parametrize("args, message", [
    (["simulate", "--out", ""], "--out: an empty value"),
    (["campaign", "run", ""], "FILE|NAME: an empty value"),
    (["campaign", "status", "afile"], "afile: a file, not a campaign folder"),
], ids=["simulate-out-empty", "campaign-file-empty", "status-of-a-file"])
def test_empty_paths_and_files_for_folders(args, message, tmp_path, capsys, monkeypatch):
    """An empty path is not the current folder ('.: is a folder' named a path the user never gave), and a file
    given for a campaign folder exists (it was 'no such campaign folder')."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("x")
    try:
        rc = main(args)
    except SystemExit as exc:
        rc = exc.code
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err
    assert message in err and sorted(p.name for p in tmp_path.iterdir()) == ["afile"]
