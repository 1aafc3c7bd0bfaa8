"""Health outputs that later commands read back are verified first: saved classifiers, a monitor baseline, the
twin's radius cache and a life campaign's inspections.  Each case changes a stored file by hand and checks that
the reader refuses it in one line naming the file and the command that writes it again (or, for a cache, simulates
its entries again) - never reads the changed value."""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import shutil

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("sklearn")
pytest.importorskip("skops")

from test_benchmark import synthetic, with_twin  # noqa: E402

from ur5fault.cli import main  # noqa: E402
from ur5fault.errors import ParameterError  # noqa: E402
from ur5fault.util.io import (  # noqa: E402
    StoredFileError,
    checksum_path,
    verify_checksum,
    write_json_atomic,
    write_parquet_atomic,
)


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    from ur5fault.health.diagnostics import run_benchmark

    d = tmp_path_factory.mktemp("saved")
    with_twin(synthetic()).to_parquet(d / "features.parquet")
    run_benchmark(d, compare=False)
    return d / "benchmark"


def test_saved_classifiers_carry_checksums_and_the_schema_names_its_classifiers(saved):
    from ur5fault.health.diagnostics.saved import CLASSIFIERS_FILE, SCHEMA_FILE, load_models

    models = saved / "models"
    for name in (CLASSIFIERS_FILE, SCHEMA_FILE):
        assert verify_checksum(models / name) is None
    schema = json.loads((models / SCHEMA_FILE).read_text())
    assert schema["classifiers_sha256"] == hashlib.sha256((models / CLASSIFIERS_FILE).read_bytes()).hexdigest()
    load_models(saved)


def test_a_changed_threshold_digit_in_the_schema_is_refused(saved, tmp_path, capsys):
    from ur5fault.health.diagnostics.saved import SCHEMA_FILE, load_models

    d = tmp_path / "benchmark"
    shutil.copytree(saved, d)
    shutil.copy(saved.parent / "features.parquet", tmp_path / "features.parquet")
    p = d / "models" / SCHEMA_FILE
    thr = json.loads(p.read_text())["joint_kind_threshold_5pct_false_alarms"]
    text = p.read_text()
    changed = text.replace(f'"joint_kind_threshold_5pct_false_alarms": {thr!r}',
                           f'"joint_kind_threshold_5pct_false_alarms": {thr / 2!r}')
    assert changed != text
    p.write_text(changed)  # valid JSON, another operating point: loaded silently before the sidecar
    with pytest.raises(StoredFileError, match=f"{SCHEMA_FILE}: its bytes differ.*ur5fault benchmark"):
        load_models(d)
    assert main(["benchmark", str(tmp_path), "--test", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and SCHEMA_FILE in err and "ur5fault benchmark" in err


def test_a_flipped_byte_in_the_classifiers_is_refused(saved, tmp_path):
    from ur5fault.health.diagnostics.saved import CLASSIFIERS_FILE, load_models

    d = tmp_path / "benchmark"
    shutil.copytree(saved, d)
    p = d / "models" / CLASSIFIERS_FILE
    b = bytearray(p.read_bytes())
    b[len(b) // 2] ^= 0x01
    p.write_bytes(bytes(b))
    with pytest.raises(StoredFileError, match=f"{CLASSIFIERS_FILE}: its bytes differ"):
        load_models(d)


def test_classifiers_from_another_save_are_refused(saved, tmp_path):
    """A folder mixed from two saves (a save interrupted between its two files, or files copied by hand), each
    file sound on its own: the schema's recorded SHA-256 of its classifiers tells them apart."""
    import skops.io as sio

    from ur5fault.health.diagnostics.saved import CLASSIFIERS_FILE, load_models
    from ur5fault.util.io import write_bytes_atomic

    d = tmp_path / "benchmark"
    shutil.copytree(saved, d)
    models, _ = load_models(d)
    other = {"detector": models.detector, "localiser": models.localiser, "kind": models.kind,
             "joint_kind": models.joint_kind, "calibrator": models.calibrator, "extra": np.arange(3)}
    write_bytes_atomic(d / "models" / CLASSIFIERS_FILE, sio.dumps(other), checksum=True)
    with pytest.raises(StoredFileError, match="not the classifiers schema.json was saved with"):
        load_models(d)


def test_classifiers_saved_before_the_checksums_still_load(saved, tmp_path):
    from ur5fault.health.diagnostics.saved import CLASSIFIERS_FILE, SCHEMA_FILE, load_models

    d = tmp_path / "benchmark"
    shutil.copytree(saved, d)
    p = d / "models" / SCHEMA_FILE
    s = json.loads(p.read_text())
    s.pop("classifiers_sha256")
    p.write_text(json.dumps(s))
    for name in (CLASSIFIERS_FILE, SCHEMA_FILE):
        checksum_path(d / "models" / name).unlink()
    _, schema = load_models(d)
    assert "classifiers_sha256" not in schema


def test_a_schema_without_its_checksum_file_is_said_to_be_read_unverified(saved, tmp_path):
    """An edited schema.json whose sidecar was deleted loads (files saved before the sidecars do); diagnose and
    benchmark --test say so, as monitor --baseline-stats says of a baseline.json (a newcomer's probe: a window
    length edited x 10 was used without a word)."""
    from ur5fault.health.diagnostics.saved import SCHEMA_FILE, unverified_notes

    d = tmp_path / "benchmark"
    shutil.copytree(saved, d)
    assert unverified_notes(d) == []
    checksum_path(d / "models" / SCHEMA_FILE).unlink()
    (note,) = unverified_notes(d)
    assert note.startswith(f"{d / 'models' / SCHEMA_FILE}: no schema.json.sha256 beside it; read unverified")
    assert unverified_notes(d / "models") == [note]


def test_a_changed_monitor_baseline_is_refused_before_it_is_parsed(tmp_path):
    from ur5fault.health.monitoring.baseline import Baseline

    p = write_json_atomic(tmp_path / "baseline.json", {"format": 9, "period_s": 0.008}, checksum=True)
    with pytest.raises(ParameterError, match="not a monitor baseline of this version"):  # sound: parsed, judged
        Baseline.load(p)
    p.write_text(p.read_text().replace("0.008", "0.009"))
    with pytest.raises(ParameterError, match=r"baseline.json: its bytes differ.*--baseline-logs"):
        Baseline.load(p)


def test_a_json_without_a_format_is_not_a_monitor_baseline_not_one_of_another_version(tmp_path):
    """A discrepancy's summary.json given to --baseline-stats was called a baseline of another version
    (format None); the version wording is kept for a baseline of another format."""
    from ur5fault.health.monitoring.baseline import Baseline

    summary = write_json_atomic(tmp_path / "summary.json", {"log": "x.csv", "joints": {}})
    for data, where in ((json.loads(summary.read_text()), "summary.json"), ([1, 2], "list.json")):
        with pytest.raises(ParameterError) as exc:
            Baseline.from_json(data, where)
        assert str(exc.value) == (f"{where}: not a monitor baseline (no format key): give --baseline-stats the "
                                  "baseline.json `ur5fault monitor --baseline-logs` writes")
    with pytest.raises(ParameterError, match=r"not a monitor baseline of this version \(format 9, expected"):
        Baseline.from_json({"format": 9}, "old.json")


def test_the_monitor_writes_its_baseline_with_a_checksum(tmp_path, monkeypatch):
    from ur5fault.health.monitoring import report

    @dataclasses.dataclass
    class Stub:
        def to_json(self):
            return {"format": 9}

    monkeypatch.setattr(report, "markdown", lambda *a, **k: "")
    report.write(tmp_path, Stub(), [], [], "model.yaml", ())
    assert verify_checksum(tmp_path / "baseline.json") is None


def test_a_changed_radius_in_the_twin_cache_is_simulated_again(tmp_path, monkeypatch, caplog):
    import ur5fault.health.prognostics.twin_boundary as TB
    from ur5fault.health.prognostics.spec import Failure
    from ur5fault.health.prognostics.twin_boundary import Ray, TwinSetup
    from ur5fault.health.prognostics.twin_cache import RadiusCache
    from ur5fault.health.prognostics.wear import WearLaw

    calls = []

    def fake(setup, traj, pts):
        calls.append(len(pts))
        return np.array([5.0 * s for _, s in pts])

    monkeypatch.setattr(TB, "_criteria", fake)
    setup = TwinSetup(WearLaw(), Failure("tcp_dev_max_mm", 0.5))
    rays = [Ray("t", 1.0, 25.0, (0.0, 0.6, 0.8, 0.0, 0.0, 0.0), 1e-7, 0.05)]  # as test_twin_calibration.py
    path = tmp_path / "radii.json"
    first = RadiusCache(path).radii(setup, rays)
    n = len(calls)
    data = json.loads(path.read_text())
    key = next(iter(data["radii"]))
    data["radii"][key] = 7.0  # a wrong radius in a sound JSON file
    path.write_text(json.dumps(data, indent=2))
    with caplog.at_level(logging.WARNING):
        again = RadiusCache(path)
    assert again.entries == {} and "radii.json" in caplog.text and "simulated again" in caplog.text
    np.testing.assert_array_equal(again.radii(setup, rays), first)
    assert len(calls) > n and verify_checksum(path) is None


def test_a_radius_cache_of_another_version_is_rebuilt_when_it_is_ours_and_refused_when_not(tmp_path, caplog):
    from ur5fault.errors import ConfigFileError
    from ur5fault.health.prognostics.twin_cache import RadiusCache

    path = write_json_atomic(tmp_path / "radii.json", {"version": 0, "radii": {"k": 1.0}}, checksum=True)
    with caplog.at_level(logging.WARNING):
        assert RadiusCache(path).entries == {}  # ours (a sound sidecar): rebuilt, no human needed
    assert "version 0" in caplog.text
    checksum_path(path).unlink()  # not known to be ours: a user's file is never overwritten
    with pytest.raises(ConfigFileError, match="remove it"):
        RadiusCache(path)


def test_changed_inspections_or_manifest_of_a_life_campaign_are_refused(tmp_path):
    from ur5fault.health.prognostics.benchmark import NEEDED, load_inspections

    df = pd.DataFrame({c: [1.0, 2.0] for c in NEEDED})
    t = write_parquet_atomic(df, tmp_path / "inspections.parquet", checksum=True)
    m = write_json_atomic(tmp_path / "manifest.json", {"kind": "life", "wear": 1.5}, checksum=True)
    got, man = load_inspections(tmp_path)
    pd.testing.assert_frame_equal(got, df)
    assert man == {"kind": "life", "wear": 1.5}
    m.write_text(m.read_text().replace("1.5", "2.5"))
    with pytest.raises(StoredFileError, match="manifest.json: its bytes differ.*life campaign"):
        load_inspections(tmp_path)
    m.write_text(m.read_text().replace("2.5", "1.5"))
    b = bytearray(t.read_bytes())
    b[len(b) // 2] ^= 0x01
    t.write_bytes(bytes(b))
    with pytest.raises(StoredFileError, match="inspections.parquet: its bytes differ.*life campaign"):
        load_inspections(tmp_path)
