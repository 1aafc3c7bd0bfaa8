"""Inputs a newcomer gave that ended in a traceback, were silently ignored, or silently replaced a result (a
hostile-input sweep on the installed wheel, 2026-11-29): each is now one line, a note, or a refusal."""

from __future__ import annotations

import json

import pandas as pd
import pytest
from test_hostile import _assert_one_line, _run, _write, rtde_frame

from ur5fault.cli import main


def test_identify_with_every_log_held_out_is_one_line(tmp_path, capsys):
    # was: IndexError at `logs[0]`; discrepancy said this in one line
    log = _write(tmp_path, "a.csv", rtde_frame())
    man = _write(tmp_path, "m.yaml", f"format: rtde\npayload_kg: 0\ntcp_offset_m: [0, 0, 0]\n"
                                     f"logs:\n  - {{path: {log}, hold_out: true}}\n")
    rc, err, peak = _run(["identify", str(man), "--no-sweep", "--quiet", "--out", str(tmp_path / "p.yaml")],
                         tmp_path, capsys)
    _assert_one_line(rc, err, peak, "every log given is held out; name at least one log to fit")


@pytest.mark.parametrize("args, message", [
    (["benchmark", "{tmp}", "--seed", "-1"], "--seed = -1 must be"),
    (["benchmark", "{tmp}", "--seed", "99999999999"], "--seed = 99999999999 must be"),
    (["prognose", "{tmp}", "--seed", "-1"], "--seed = -1 must be a non-negative integer"),
], ids=["benchmark-negative", "benchmark-above-sklearn", "prognose-negative"])
def test_seeds_out_of_range_are_one_line(args, message, tmp_path, capsys):
    # were: scikit-learn's InvalidParameterError after 4 s of work, numpy's ValueError
    rc, err, peak = _run([a.format(tmp=tmp_path) for a in args], tmp_path, capsys)
    _assert_one_line(rc, err, peak, message)


def test_a_life_fleet_too_short_to_fit_is_one_line(tmp_path):
    # was: a ValueError traceback from LinearRUL when every unit failed after two inspections
    from ur5fault.errors import ConfigFileError
    from ur5fault.health.prognostics import benchmark

    rows = [{"unit_id": u, "split": "train" if u < 4 else "test", "cycles": c, "censored": False,
             "eol_cycles": 2.0, "inspection": k, "feature": float(k)} for u in range(5) for k, c in enumerate((0, 1))]
    df = pd.DataFrame(rows)

    def short_fleet(*a, **k):
        raise ValueError("LinearRUL needs at least two training units with three inspections or more")

    import unittest.mock as mock

    with mock.patch.object(benchmark, "load_inspections", return_value=(df, {})), \
            mock.patch.object(benchmark, "predict", side_effect=short_fleet):
        with pytest.raises(ConfigFileError, match="three inspections or more .a larger fleet, shorter inspection"):
            benchmark.run_prognose(tmp_path / "fleet", tmp_path / "out")


def test_an_effect_given_on_top_of_the_overlays_is_named(tmp_path, capsys):
    # was: both listed as the run's effects, only the second simulated, nothing said
    ov = _write(tmp_path, "ov.yaml", "effects: [{effect: backlash, joint: 3, backlash_deg: 0.1}]\n")
    out = tmp_path / "r.parquet"
    assert main(["simulate", "--model", str(ov), "--backlash", "3:0.2", "--duration-s", "0.01", "--quiet",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert ("note: backlash on elbow_joint (backlash_deg=0.2) is given on top of the model overlay's backlash on "
            "elbow_joint (backlash_deg=0.1)") in err
    assert main(["simulate", "--model", str(ov), "--backlash", "2:0.2", "--duration-s", "0.01", "--quiet",
                 "--out", str(tmp_path / "s.parquet")]) == 0
    assert "on top of the model overlay" not in capsys.readouterr().err  # another joint: no note


def test_show_refuses_what_it_would_ignore_and_names_what_a_folder_needs(tmp_path, capsys):
    run = tmp_path / "run.parquet"
    assert main(["simulate", "--duration-s", "0.01", "--quiet", "--out", str(run)]) == 0
    rc, err, peak = _run(["show", str(run), "--campaign", str(tmp_path / "nowhere")], tmp_path, capsys)
    _assert_one_line(rc, err, peak, "names the campaign of a run id")
    rc, err, peak = _run(["show", str(tmp_path)], tmp_path, capsys)
    _assert_one_line(rc, err, peak, f"ur5fault plot {tmp_path}")


def test_a_life_campaign_folder_points_to_prognose(tmp_path, capsys):
    (tmp_path / "inspections.parquet").write_bytes(b"")
    (tmp_path / "manifest.json").write_text("{}")
    for args in (["plot", str(tmp_path), "--out", str(tmp_path / "figs")], ["show", "r1", "--campaign", str(tmp_path)]):
        rc, err, peak = _run(args, tmp_path, capsys)
        _assert_one_line(rc, err, peak, f"a life campaign (inspections.parquet, no features.parquet): its results are "
                                        f"read by ur5fault prognose {tmp_path}")


TINY = """name: {name}
out: {out}
trajectory: pick_and_place
duration_s: 0.05
sweep: {{seed: [1]}}
"""


def test_another_campaign_does_not_take_over_a_campaign_folder(tmp_path, capsys):
    out = tmp_path / "res"
    a = _write(tmp_path, "a.yaml", TINY.format(name="first", out=out))
    b = _write(tmp_path, "b.yaml", TINY.format(name="second", out=out))
    assert main(["campaign", "run", str(a), "--jobs", "1", "--quiet"]) == 0
    table = (out / "features.parquet").read_bytes()
    rc = main(["campaign", "run", str(b), "--jobs", "1", "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2 and "holds the results of campaign 'first', not 'second'" in err, err
    assert (out / "features.parquet").read_bytes() == table  # nothing replaced
    assert json.loads((out / "manifest.json").read_text())["name"] == "first"
    assert main(["campaign", "run", str(b), "--jobs", "1", "--quiet", "--replace-changed"]) == 0
    assert json.loads((out / "manifest.json").read_text())["name"] == "second"
    # a third campaign of other runs: not called "another version" of this one (the review found the note naming
    # the new campaign as the folder's earlier version)
    c = _write(tmp_path, "c.yaml", TINY.format(name="third", out=out).replace("seed: [1]", "seed: [2]"))
    capsys.readouterr()
    assert main(["campaign", "run", str(c), "--jobs", "1", "--replace-changed"]) == 0
    err = capsys.readouterr().err
    assert "another version of campaign" not in err, err


def test_a_typo_of_life_is_told(tmp_path, capsys):
    c = _write(tmp_path, "c.yaml", "name: x\nlif: {}\n")
    rc, err, peak = _run(["campaign", "run", str(c), "--out", str(tmp_path / "o")], tmp_path, capsys)
    _assert_one_line(rc, err, peak, "unknown key 'lif' (did you mean 'life'?)")


@pytest.mark.parametrize("command", ["discrepancy", "monitor"])
@pytest.mark.parametrize("effect", ["{effect: payload, mass_kg: 2}", "{effect: payload_com, dz_m: 0.1}"],
                         ids=["payload", "payload_com"])
def test_a_payload_in_the_model_overlay_is_refused(command, effect, tmp_path, capsys):
    # was: ignored for the fit (the payload is the log's), then copied into discrepancy's model.yaml, which
    # simulate --model applied; refused as the overlay's tcp_offset_m is (diagnose: tests/twin/test_replay.py)
    ov = _write(tmp_path, "ov.yaml", f"params: {{}}\neffects:\n- {effect}\n")
    log = _write(tmp_path, "a.csv", rtde_frame())
    opts = ["--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0", "0", "--out", str(tmp_path / "out")]
    if command == "discrepancy":
        argv = ["discrepancy", str(log), "--model", str(ov), *opts]
    else:
        others = []
        for k in (1, 2):  # other recordings (one shared with the monitored log is refused first); a baseline is two
            frame = rtde_frame()
            for j in range(6):
                frame[[f"target_q_{j}", f"actual_q_{j}"]] += 0.05 * k
            others.append(str(_write(tmp_path, f"b{k}.csv", frame)))
        argv = ["monitor", str(log), "--baseline", str(ov), "--baseline-logs", *others, *opts]
    rc, err, peak = _run(argv, tmp_path, capsys)
    name = effect.split(",")[0].split()[-1]
    # refused before any log is read: no log's note printed before it (they were)
    _assert_one_line(rc, err, peak, f"the model overlay holds a {name} effect, but the payload is the log's "
                                    "(--payload-kg and --tcp-offset-m, a manifest's payload_kg, or the log's layout; "
                                    "fitted where unknown), not the robot's model; leave it out of the overlay")
