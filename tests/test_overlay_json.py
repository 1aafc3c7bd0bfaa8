"""A JSON file given where a model overlay YAML is expected (a newcomer probe of the wheel: the monitor's own
baseline.json given to ``monitor --baseline`` or ``diagnose --model`` was refused as "1707716 bytes, above the
limit of 1048576 for a YAML file"): said in one line what it is and where it goes."""

from __future__ import annotations

import json

import pytest

from ur5fault.config import Overlay
from ur5fault.errors import ConfigFileError, UnknownNameError
from ur5fault.util.yamlsafe import MAX_BYTES

GOES = "--baseline and --model take the model overlay YAML (model.yaml of discrepancy, or identify's)"


def _baseline_json(path, pad: int) -> None:
    """A stand-in of the monitor's baseline.json: its format key first, as Baseline.to_json writes it."""
    path.write_text(json.dumps({"format": "ur5fault-monitor-baseline-10", "period_s": 0.008, "pad": "x" * pad},
                               indent=2))


@pytest.mark.parametrize("name, pad", [("baseline.json", MAX_BYTES + 10), ("stats.txt", 10)])
def test_a_monitor_baseline_given_as_the_overlay_is_named_with_where_it_goes(tmp_path, name, pad):
    path = tmp_path / name
    _baseline_json(path, pad)
    with pytest.raises(ConfigFileError) as exc:
        Overlay.load(path)
    assert str(exc.value) == f"{path}: a monitor baseline (baseline.json): give it to --baseline-stats; {GOES}"


def test_another_json_is_named_as_json_and_a_json_overlay_still_loads(tmp_path):
    summary = tmp_path / "summary.json"
    summary.write_text(json.dumps({"log": "x.csv", "joints": {}}))
    with pytest.raises(ConfigFileError) as exc:
        Overlay.load(summary)
    assert str(exc.value) == f"{summary}: a JSON file (keys log, joints), not a model overlay; {GOES}"
    big = tmp_path / "big.json"
    big.write_text(json.dumps({"x": "y" * MAX_BYTES}))
    with pytest.raises(ConfigFileError, match=rf"big.json: a JSON file of {big.stat().st_size} bytes, not a model "
                                              r"overlay; --baseline and --model take"):
        Overlay.load(big)
    listed = tmp_path / "list.json"
    listed.write_text("[1, 2]")
    with pytest.raises(ConfigFileError, match=r"list.json: a JSON file \(a list\), not a model overlay"):
        Overlay.load(listed)
    ok = tmp_path / "overlay.json"  # JSON is YAML: an overlay written as JSON is read as before
    ok.write_text(json.dumps({"params": {}, "effects": []}))
    assert Overlay.load(ok) == Overlay({}, ())
    typo = tmp_path / "typo.json"  # an overlay as JSON with a misspelt key: the YAML reader's "did you mean"
    typo.write_text(json.dumps({"params": {}, "effect": []}))
    with pytest.raises(UnknownNameError, match=r"typo.json: unknown key 'effect' \(did you mean 'effects'\?\)"):
        Overlay.load(typo)
    null = tmp_path / "null.json"
    null.write_text("null")
    with pytest.raises(ConfigFileError, match=r"null.json: a JSON file \(null\), not a model overlay"):
        Overlay.load(null)
    flow = tmp_path / "flow.yaml"  # a YAML flow mapping, no JSON: the YAML reader's
    flow.write_text("{params: {}, effects: []}\n")
    assert Overlay.load(flow) == Overlay({}, ())


def test_simulate_given_a_monitor_baseline_as_its_model_says_it_in_one_line(tmp_path, capsys):
    from ur5fault.cli import main

    path = tmp_path / "baseline.json"
    _baseline_json(path, MAX_BYTES + 10)
    capsys.readouterr()
    assert main(["simulate", "--model", str(path), "--duration-s", "1", "--out", str(tmp_path / "r.parquet")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "a monitor baseline (baseline.json): give it to --baseline-stats" in err
