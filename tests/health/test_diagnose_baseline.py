"""``ur5fault diagnose --baseline-logs`` (ur5fault/health/diagnosis/baseline.py): each classifier input of a
diagnosed window referred to the robot's own healthy baseline.

The mapping is tested on constructed features whose medians and spreads are set by hand (five baseline values
b - 2d, b - d, b, b + d, b + 2d have median b and median absolute deviation d), so every expected value below is
worked out from the rule x' = m + (x - b) * s / max(r, s) (r = 1.4826 d), not by the code under test.  The
command-line option is tested with the stand-in detector of test_diagnose.py on short simulated logs.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("sklearn")
pytest.importorskip("skops")

from ur5fault.cli import main  # noqa: E402
from ur5fault.errors import ConfigFileError, ParameterError  # noqa: E402
from ur5fault.health.diagnosis.baseline import Reference, fit_map, training_reference  # noqa: E402
from ur5fault.health.diagnosis.windows import Window  # noqa: E402

MAD_TO_SD = 1.4826
NAMES = ("wide", "narrow", "few", "flat", "absent", "payload_kg")
TRAIN_MEDIAN = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 0.0])
TRAIN_SCALE = np.array([0.01, 0.5, 0.01, 0.01, 0.01, 1.0])
B = {"wide": 0.5, "narrow": 1.2, "few": 2.5, "flat": 3.5}  # the robot's healthy medians
D = {"wide": 0.1 / MAD_TO_SD, "narrow": 0.1 / MAD_TO_SD, "few": 0.2, "flat": 0.0}  # their MADs


def _window(values: dict[str, float]) -> Window:
    return Window(0.0, 1.0, dict(values), (1.0,) * 6)


def _baseline_windows() -> list[Window]:
    out = []
    for k, step in enumerate((-2, -1, 0, 1, 2)):
        f = {c: B[c] + step * D[c] for c in ("wide", "narrow", "flat")}
        f["few"] = B["few"] + step * D["few"] if k < 4 else np.nan  # four values only
        f["absent"] = np.nan  # e.g. an encoder-mismatch input of a log without motor encoders
        f["payload_kg"] = 2.0
        out.append(_window(f))
    return out


@pytest.fixture()
def bmap():
    ref = Reference(NAMES, TRAIN_MEDIAN, TRAIN_SCALE, "by hand")
    return fit_map(ref, [("robot_a", _baseline_windows()[:2]), ("robot_b", _baseline_windows()[2:])], 0.008)


def test_a_shifted_and_scaled_healthy_distribution_maps_back_onto_the_training_runs(bmap):
    # "wide": the robot's healthy windows lie around 0.5 with spread 0.1, the training runs' around 0 with 0.01:
    # the robot's median maps to 0, two of its spreads above it to two training spreads (0.02)
    x = np.array([[0.5, 1.2, 2.5, 3.5, 7.0, 2.0],
                  [0.7, 1.3, 2.6, 3.6, 7.0, 0.0],
                  [0.3, 1.0, 2.4, 3.4, np.nan, 1.0]])
    y = bmap.apply(x)
    np.testing.assert_allclose(y[:, 0], [0.0, 0.02, -0.02], atol=1e-12)
    # "narrow": the robot varies less (0.1) than the training runs (0.5): shifted by its median only, so a
    # deviation keeps its size in the input's unit (1.3 - 1.2 = 0.1 above the training median of 1)
    np.testing.assert_allclose(y[:, 1], [1.0, 1.1, 0.8], atol=1e-12)
    # "few": four baseline values (median 2.5 - 0.2 / 2 = 2.4): its spread is not estimated, shifted only
    np.testing.assert_allclose(y[:, 2], [2.1, 2.2, 2.0], atol=1e-12)
    # "flat": zero spread in the baseline: shifted only
    np.testing.assert_allclose(y[:, 3], [3.0, 3.1, 2.9], atol=1e-12)
    # "absent": no baseline value: left as measured; the payload: a known condition, left as measured
    np.testing.assert_array_equal(y[:2, 4], [7.0, 7.0])
    assert np.isnan(y[2, 4])
    np.testing.assert_array_equal(y[:, 5], x[:, 5])


def test_a_fault_moves_the_mapped_input_by_its_size_over_the_robots_spread(bmap):
    # a fault adding 0.3 to "wide" on the robot: 0.3 / 0.1 = 3 robot spreads -> 3 training spreads (0.03)
    healthy = np.array([[0.55, 1.2, 2.5, 3.5, 7.0, 2.0]])
    faulty = healthy + np.array([[0.3, 0.3, 0.0, 0.0, 0.0, 0.0]])
    d = bmap.apply(faulty) - bmap.apply(healthy)
    np.testing.assert_allclose(d[0, :2], [0.03, 0.3], atol=1e-12)


def test_the_summary_names_the_baseline_and_each_rule(bmap):
    s = bmap.summary()
    assert s["logs"] == ["robot_a", "robot_b"] and s["n_windows"] == 5 and s["n_windows_per_log"] == [2, 3]
    assert s["log_period_s"] == 0.008 and s["reference"] == "by hand"
    r = s["rules"]
    assert r["scaled"]["n_inputs"] == 1 and r["shifted"]["inputs"] == ["narrow"]
    assert r["shifted_few_windows"]["inputs"] == ["few"] and r["shifted_zero_spread"]["inputs"] == ["flat"]
    assert r["left_as_measured"]["inputs"] == ["absent"] and r["condition"]["inputs"] == ["payload_kg"]
    assert s["largest_spread_ratio"] == [{"input": "wide", "baseline_over_training": pytest.approx(10.0)}]
    json.dumps(s)  # written into diagnosis.json as it is


def test_an_input_the_healthy_training_runs_never_vary_on_is_shifted_not_erased():
    """A spike count the simulated healthy runs always show as 0 (training spread 0): a factor 0 set every window
    to the training median, a backlash's 50 spikes included; now shifted by the robot's healthy median only."""
    ref = Reference(("spikes",), np.array([0.0]), np.array([0.0]), "by hand")
    healthy = [_window({"spikes": v}) for v in (0.0, 1.0, 2.0, 0.0, 3.0, 1.0, 0.0, 2.0)]  # median 1
    m = fit_map(ref, [("robot", healthy)], 0.008)
    np.testing.assert_allclose(m.apply(np.array([[50.0], [1.0]]))[:, 0], [49.0, 0.0], atol=1e-12)
    assert m.summary()["rules"]["shifted_training_zero_spread"]["inputs"] == ["spikes"]


def test_a_baseline_without_a_window_is_refused():
    ref = Reference(NAMES, TRAIN_MEDIAN, TRAIN_SCALE, "by hand")
    with pytest.raises(ParameterError, match="no whole window"):
        fit_map(ref, [("robot_a", [])], 0.008)


# --- the reference of the healthy training runs, and the command line (stand-in detector of test_diagnose) ---

from test_diagnose import LOG_S, WINDOW_S, _rewrite_schema, _save_stand_in, _synthetic_table  # noqa: E402


@pytest.fixture(scope="module")
def detector(tmp_path_factory) -> Path:
    return _save_stand_in(tmp_path_factory.mktemp("campaign") / "benchmark", calibrated=False)


@pytest.fixture(scope="module")
def logs(tmp_path_factory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("logs")
    out = {}
    for name, seed, dur in (("diagnosed", 3, LOG_S), ("healthy_a", 5, LOG_S), ("healthy_b", 6, LOG_S),
                            ("short", 7, 2.0)):
        out[name] = folder / f"{name}.parquet"
        assert main(["simulate", "--duration-s", str(dur), "--seed", str(seed), "--out", str(out[name])]) == 0
    return out


def _healthy_train(table: pd.DataFrame, c: str) -> np.ndarray:
    return table.loc[(table["split"] == "train") & (table["fault"] == "healthy"), c].to_numpy(float)


def test_the_training_reference_is_saved_with_the_classifiers_and_read_from_the_campaign_otherwise(detector):
    from ur5fault.health.diagnostics.saved import load_models

    table = _synthetic_table(np.random.default_rng(0))  # the stand-in's training table (same seed)
    schema = load_models(detector)[1]
    ref = training_reference(detector, schema)
    for k, c in enumerate(ref.names):
        v = _healthy_train(table, c)
        assert ref.median[k] == pytest.approx(np.median(v))
        assert ref.scale[k] == pytest.approx(MAD_TO_SD * np.median(np.abs(v - np.median(v))))
    # classifiers saved before the reference was: read from the campaign's feature table beside the benchmark
    old = {k: v for k, v in schema.items() if k != "healthy_training_inputs"}
    with pytest.raises(ConfigFileError, match="no campaign feature table"):
        training_reference(detector, old)
    table.to_parquet(detector.parent / "features.parquet")
    try:
        np.testing.assert_allclose(training_reference(detector, old).median, ref.median)
        other = _synthetic_table(np.random.default_rng(1))
        other.to_parquet(detector.parent / "features.parquet")
        with pytest.raises(ConfigFileError, match="not the training set"):
            training_reference(detector, old)
    finally:
        (detector.parent / "features.parquet").unlink()


def _run(argv: list[str], capsys) -> tuple[int, str]:
    capsys.readouterr()
    rc = main(argv)
    return rc, capsys.readouterr().err.strip()


@pytest.mark.slow
def test_baseline_logs_are_used_and_reported_and_without_them_nothing_changes(logs, detector, tmp_path, capsys):
    base = ["diagnose", str(logs["diagnosed"]), "--format", "sim", "--detector", str(detector)]
    assert main([*base, "--out", str(tmp_path / "plain")]) == 0
    assert main([*base, "--baseline-logs", str(logs["healthy_a"]), str(logs["healthy_b"]),
                 "--out", str(tmp_path / "with")]) == 0
    plain = json.loads((tmp_path / "plain" / "diagnosis.json").read_text())
    d = json.loads((tmp_path / "with" / "diagnosis.json").read_text())
    assert plain["baseline"] is None
    b = d["baseline"]
    assert [Path(p).name for p in b["logs"]] == ["healthy_a.parquet", "healthy_b.parquet"]
    assert b["n_windows"] == 4 and b["n_windows_per_log"] == [2, 2]  # 5.2 s logs, windows of 2.5 s
    # four baseline windows: fewer than five, so every input's spread is left unestimated and it is shifted only
    assert b["rules"]["scaled"]["n_inputs"] == 0
    assert b["rules"]["condition"]["inputs"] == ["payload_kg", "temperature_C"]
    assert any("healthy baseline (4 windows of 2 log(s))" in n for n in d["notes"])
    # a 5.2 s log in windows of 2.5 s: its last 0.2 s are not scored, and the notes say so
    assert [n for n in d["notes"] if n.startswith("only whole windows are scored: the last 0.2")], d["notes"]
    # the robot's own threshold: each log's two windows held out against the other log; four scores, so the
    # conformal rank ceil(0.95 * 5) = 5 does not exist and the largest is taken (a new window exceeds it with 1/5)
    t = b["robot_threshold"]
    assert t["n_held_out_windows"] == 4 and len(t["groups"]) == 2 and t["rank"] == 5
    assert t["score"] == max(t["held_out_scores"]) and t["false_alarm_bound"] == pytest.approx(0.2)
    # the largest held-out score is some joint's largest: that joint is named as setting the threshold
    assert max(t["held_out_max_by_joint"].values()) == t["score"]
    assert t["held_out_max_by_joint"][t["set_by_joint"]] == t["score"]
    assert plain["flag_threshold"]["score"] == plain["detector"]["threshold_5pct_false_alarms"]
    flag = d["flag_threshold"]["score"]
    assert flag == max(t["score"], d["detector"]["threshold_5pct_false_alarms"])
    assert [w["flagged"] for w in d["windows"]] == [w["p_fault_score"] > flag for w in d["windows"]]
    report = (tmp_path / "with" / "report.md").read_text()
    assert "Baseline: 4 windows of 2 healthy log(s)" in report
    # which joint's healthy window the robot's threshold is: said where that threshold is the bar, not otherwise
    said = f"is {t['set_by_joint']}'s raw score in a held-out healthy window" in report
    assert said == (d["flag_threshold"]["score"] > d["detector"]["threshold_5pct_false_alarms"]), report
    assert "No baseline of this robot" in (tmp_path / "plain" / "report.md").read_text()
    # the size estimates are the window's own, whatever the baseline
    for w0, w1 in zip(plain["windows"], d["windows"]):
        assert [k["size"] for j in w0["joints"] for k in j["kinds"]] == \
            [k["size"] for j in w1["joints"] for k in j["kinds"]]


def test_bad_baselines_are_one_line(logs, detector, tmp_path, capsys):
    base = ["diagnose", str(logs["diagnosed"]), "--format", "sim", "--detector", str(detector),
            "--out", str(tmp_path / "o")]
    garbage = tmp_path / "garbage.parquet"
    garbage.write_text("not a parquet file")
    manifest = tmp_path / "base.yaml"
    shutil.copy(logs["healthy_a"], tmp_path / "healthy_a.parquet")
    manifest.write_text("format: sim\nlogs:\n  - {path: healthy_a.parquet, hold_out: true}\n")
    copy = tmp_path / "renamed_copy_of_the_diagnosed.parquet"  # another name, the same recording
    shutil.copy(logs["diagnosed"], copy)
    for extra, words in (([str(logs["diagnosed"])], "is both diagnosed and a baseline log"),
                         ([str(copy)], "renamed_copy_of_the_diagnosed.parquet and diagnosed.parquet hold the same "
                                       "samples (both diagnosed and a baseline log)"),  # named as given, before replay
                         ([str(tmp_path / "missing.parquet")], "missing.parquet"),
                         ([str(garbage)], "garbage.parquet"),
                         ([str(logs["short"])], f"one window of {WINDOW_S:g} s"),
                         ([str(logs["healthy_a"]), str(logs["healthy_a"])], "given twice"),
                         ([str(manifest)], "hold_out has no meaning")):
        rc, err = _run([*base, "--baseline-logs", *extra], capsys)
        assert rc == 2 and err.startswith("ur5fault: error:") and words in err and len(err.splitlines()) == 1, err
        assert not (tmp_path / "o").exists()
    # the diagnosed log marked hold_out in its manifest: refused as in a baseline, not dropped without a word
    scored = tmp_path / "scored.yaml"
    shutil.copy(logs["diagnosed"], tmp_path / "diagnosed.parquet")
    scored.write_text("format: sim\nlogs:\n  - {path: diagnosed.parquet, hold_out: true}\n")
    rc, err = _run(["diagnose", str(scored), *base[2:], "--baseline-logs", str(logs["healthy_a"])], capsys)
    assert rc == 2 and "hold_out has no meaning in the log diagnose scores" in err and len(err.splitlines()) == 1
    capsys.readouterr()
    with pytest.raises(SystemExit) as exc:  # the option without a log: argparse's own one line
        main([*base, "--baseline-logs"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and "expected at least one argument" in err and len(err.splitlines()) == 1


def test_a_detector_without_a_training_reference_is_refused_with_a_baseline(logs, detector, tmp_path, capsys):
    old = _rewrite_schema(detector, tmp_path / "camp" / "old", healthy_training_inputs=None)
    rc, err = _run(["diagnose", str(logs["diagnosed"]), "--format", "sim", "--detector", str(old),
                    "--baseline-logs", str(logs["healthy_a"]), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "no campaign feature table" in err and len(err.splitlines()) == 1


class _Log:
    """A stand-in of a MeasuredLog for the baseline notes: its source, target at rest, payload and assumptions."""

    def __init__(self, source: str, rest_target: str | None, payload_kg: float | None, notes: tuple[str, ...] = ()):
        self.source, self.rest_target, self.payload_kg, self._notes = source, rest_target, payload_kg, notes

    def assumptions(self, temperature_C) -> list[str]:
        return list(self._notes)


def test_the_baseline_notes_name_two_controllers_and_a_payload_outside_the_baselines():
    from ur5fault.health.diagnosis.cli import baseline_notes

    nist = _Log("nist.csv.gz", "setpoint", 0.726)
    kufieta = [_Log(f"k{i}.csv", "reading", 0.0, ("temperature not logged",)) for i in range(2)]
    notes = baseline_notes(nist, kufieta, None)
    assert notes[0] == "baseline temperature not logged"  # said once for both logs
    assert len(notes) == 3
    assert "logs of two controllers, likely two robots" in notes[1]
    assert notes[2].startswith("nist.csv.gz carries 0.726 kg, the baseline runs 0 kg: ")
    same = _Log("k9.csv", "reading", 0.0)
    assert baseline_notes(same, kufieta, None) == ["baseline temperature not logged"]


def test_the_baseline_notes_are_written_into_the_diagnosis_and_its_report(logs, detector, tmp_path):
    light = tmp_path / "light.parquet"  # the baseline logs carry the default 2 kg
    assert main(["simulate", "--duration-s", str(LOG_S), "--seed", "8", "--payload-kg", "0", "--out",
                 str(light)]) == 0
    assert main(["diagnose", str(light), "--format", "sim", "--detector", str(detector), "--baseline-logs",
                 str(logs["healthy_a"]), str(logs["healthy_b"]), "--out", str(tmp_path / "o"), "--quiet"]) == 0
    d = json.loads((tmp_path / "o" / "diagnosis.json").read_text())
    said = [n for n in d["notes"] if n.startswith("light.parquet carries 0 kg, the baseline runs 2 kg: ")]
    assert len(said) == 1, d["notes"]
    assert f"- {said[0]}" in (tmp_path / "o" / "report.md").read_text()


def test_the_robots_threshold_note_states_the_rule_not_that_a_window_was_flagged(logs, detector, tmp_path):
    assert main(["diagnose", str(logs["diagnosed"]), "--format", "sim", "--detector", str(detector),
                 "--baseline-logs", str(logs["healthy_a"]), str(logs["healthy_b"]), "--out", str(tmp_path / "o"),
                 "--quiet"]) == 0
    d = json.loads((tmp_path / "o" / "diagnosis.json").read_text())
    assert d["baseline"]["robot_threshold"] is not None
    # read beside "0 of N windows flagged" too: a rule windows are flagged by, never "flagged ... too"
    rule = [n for n in d["notes"] if "the robot's own threshold" in n]
    assert len(rule) == 1 and rule[0].startswith("a window counts as flagged only where it exceeds the robot's own "
                                                 "threshold as well as the training runs': "), rule
