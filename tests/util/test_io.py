"""Strict JSON for the files other tools read (``util.io.json_text``)."""

from __future__ import annotations

import json
import math

import numpy as np

from ur5fault.identify import report, stats
from ur5fault.util.io import finite_json, json_float, json_text, write_json_atomic


def _strict(text: str):
    def refuse(token):
        raise AssertionError(f"{token} is not JSON")

    return json.loads(text, parse_constant=refuse)


def test_no_value_is_null_and_numpy_values_are_plain():
    data = {"a": float("nan"), "b": [1.0, float("inf"), -float("inf")], "c": np.float64(2.5),
            "d": np.array([np.nan, 3]), "e": (np.int64(4), "x"), "f": {"g": np.float32(np.nan)}}
    assert _strict(json_text(data)) == {"a": None, "b": [1.0, None, None], "c": 2.5, "d": [None, 3.0], "e": [4, "x"],
                                        "f": {"g": None}}
    assert finite_json(["s", True, None, 7]) == ["s", True, None, 7]


def test_identify_json_of_a_value_the_log_cannot_give_is_strict():
    """identify --json wrote "lo": NaN, "hi": NaN for every estimate without an interval (JSON.parse refuses it)."""
    ident = report.Identification("x", 1.0, (
        stats.fallback("friction.breakaway_A", 0, 0.5, "m", "why"),
        stats.Estimate("motor.torque_constant_Nm_per_A", 1, 0.13, 0.12, 0.14, "m")))
    got = _strict(json.dumps(ident.to_json(), allow_nan=False))
    assert got["estimates"][0]["lo"] is None and got["estimates"][1]["hi"] == 0.14


def test_written_json_files_are_strict_unless_asked(tmp_path):
    """write_json_atomic wrote bare NaN / Infinity (manifests, metrics.json, monitor's and diagnose's files) that
    JavaScript's JSON.parse and jq refuse; now null, read back as NaN by json_float. strict=False keeps Python's
    tokens for a file only ur5fault reads (the twin radius cache: an infinite radius means a failed ray)."""
    data = {"x": float("nan"), "y": [np.float64(np.inf), 2.0]}
    strict = write_json_atomic(tmp_path / "a.json", data)
    got = _strict(strict.read_text())
    assert got == {"x": None, "y": [None, 2.0]}
    assert math.isnan(json_float(got["x"])) and json_float(got["y"][1]) == 2.0 and json_float(3) == 3.0
    loose = write_json_atomic(tmp_path / "b.json", data, strict=False)
    assert "NaN" in loose.read_text() and json.loads(loose.read_text())["y"][0] == math.inf


def test_an_empty_or_cut_checksum_file_is_named_as_such(tmp_path):
    """An empty sidecar was reported as "its bytes differ from the checksum recorded", sending a user to the data
    file when the sidecar is what is damaged (a newcomer probe)."""
    from ur5fault.util.io import checksum_path, verify_checksum, write_bytes_atomic

    f = write_bytes_atomic(tmp_path / "a.bin", b"data", checksum=True)
    assert verify_checksum(f) is None
    for text in ("", "abc123  a.bin\n"):
        checksum_path(f).write_text(text)
        assert verify_checksum(f) == ("its checksum file a.bin.sha256 holds no SHA-256 (damaged, or its write was "
                                      "interrupted)")
    checksum_path(f).write_text("0" * 64 + "  a.bin\n")
    assert "its bytes differ" in verify_checksum(f)
