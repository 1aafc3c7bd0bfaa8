"""The command line as a first-time user meets it: usage on bare commands, help texts that give every default,
data on stdout and prose on stderr, output files checked before a run, no option or key accepted and dropped,
errors that blame the user's own file and key path, and the example campaigns addressable by name."""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

import pandas as pd
import pytest

from ur5fault.campaign import load_campaign
from ur5fault.cli import build_parser, main
from ur5fault.errors import ConfigFileError, ParameterError, UnknownNameError
from ur5fault.sim.trajectories import TRAJECTORIES

PACKAGE = Path(__file__).resolve().parents[1] / "ur5fault"
SHORT = ["--duration-s", "0.02", "--quiet"]


def _one_error(capsys, *args: str) -> str:
    assert main(list(args)) == 2
    err = capsys.readouterr().err
    assert err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err
    return err


@pytest.mark.parametrize("args, commands", [([], ("simulate", "campaign", "identify", "benchmark")),
                                            (["campaign"], ("run", "status"))])
def test_bare_command_prints_usage(capsys, args, commands):
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("usage: ur5fault") and all(c in err for c in commands), err


def _options(parser: argparse.ArgumentParser, name: str = "ur5fault"):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, subparser in action.choices.items():
                yield from _options(subparser, f"{name} {sub}")
        elif not isinstance(action, (argparse._HelpAction, argparse._VersionAction)) and action.dest != "verbose":
            yield name, action


def test_every_option_has_help_and_every_optional_value_its_default():
    missing = []
    for name, action in _options(build_parser()):
        text = action.help or ""
        takes_value = action.option_strings and action.nargs != 0 and not action.required
        if not text or (takes_value and "default" not in text and "required" not in text):
            missing.append(f"{name} {'/'.join(action.option_strings) or action.dest}")
    assert not missing, missing


def test_simulate_help_names_the_trajectories_and_the_run_file_format(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    out = capsys.readouterr().out
    assert all(t in out for t in TRAJECTORIES)
    assert "effects:" in out and "backlash_deg: 0.1" in out and "docs/usage.md" not in out


def test_simulate_data_on_stdout_prose_on_stderr_and_csv(tmp_path, capsys):
    out = tmp_path / "run.csv"
    assert main(["simulate", "--backlash", "shoulder_lift_joint:0.1", *SHORT, "--out", str(out)]) == 0
    cap = capsys.readouterr()
    summary = json.loads(cap.out)  # stdout is exactly one JSON line
    assert summary["status"] == "ok" and len(cap.out.strip().splitlines()) == 1
    assert f"wrote {out} (20 samples" in cap.err and "backlash on shoulder_lift_joint" in cap.err
    df = pd.read_csv(out)  # CSV, not Parquet under a .csv name
    assert len(df) == 20 and "q_FB_rad_j2" in df.columns
    assert main(["simulate", *SHORT, "--out", str(out), "--replace"]) == 0  # without it: tests/test_outputs.py
    assert f"replaced {out}" in capsys.readouterr().err


@pytest.mark.parametrize("name, message", [("x.txt", "unknown file type '.txt'; give a .parquet or .csv file"),
                                           ("no/such/dir/x.txt", "unknown file type '.txt'")])
def test_simulate_out_refused_before_running(tmp_path, capsys, name, message):
    assert message in _one_error(capsys, "simulate", *SHORT, "--out", str(tmp_path / name))
    assert list(tmp_path.iterdir()) == []  # nothing created


def test_configured_effect_without_size_refused(tmp_path, capsys):
    cfg = tmp_path / "run.yaml"
    cfg.write_text("effects:\n  - {effect: backlash, joint: shoulder_lift_joint}\n")
    err = _one_error(capsys, "simulate", "--config", str(cfg), *SHORT, "--out", str(tmp_path / "r.parquet"))
    assert "run.yaml: effects[0]: effect 'backlash' has no size; give backlash_deg [0..5 deg]" in err
    err = _one_error(capsys, "simulate", "--effect", "coulomb_friction@elbow", *SHORT)
    assert "effect 'coulomb_friction' has no size" in err


def test_repeated_effect_key_refused(capsys):
    err = _one_error(capsys, "simulate", "--effect", "coulomb_friction@elbow:scale=2,scale=3", *SHORT)
    assert "scale given twice" in err


@pytest.mark.parametrize("option", ["--model", "--config"])
def test_params_typo_blamed_on_the_users_file(tmp_path, capsys, option):
    f = tmp_path / "mine.yaml"
    f.write_text("params:\n  gear: {dampingg_Nms_per_rad: 15}\n")
    err = _one_error(capsys, "simulate", option, str(f), *SHORT)
    assert "mine.yaml: params.gear: unknown key 'dampingg_Nms_per_rad' (did you mean 'damping_Nms_per_rad'" in err
    assert "ur5_drive.yaml" not in err


def test_campaign_sweep_typo_names_file_and_key_path(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text("name: c\nsweep:\n  backlash.joint: [1]\n  backlash.backlash_dg: [0.1]\n")
    with pytest.raises(UnknownNameError, match=re.escape("c.yaml: sweep.backlash.backlash_dg: unknown parameter of "
                                                         "effect 'backlash' 'backlash_dg' (did you mean "
                                                         "'backlash_deg'?)")):
        load_campaign(f)


def test_shipped_campaigns_by_name_from_any_folder(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    camp = load_campaign("paper")
    assert camp.path == PACKAGE / "campaigns" / "paper.yaml" and camp.name == "paper"
    assert load_campaign("default.yaml").name == "default"
    (tmp_path / "paper.yaml").write_text("name: mine\nsweep: {backlash.joint: [1], backlash.backlash_deg: [0.1]}\n")
    assert load_campaign("paper.yaml").name == "mine"  # a file of the user's wins over the shipped one
    with pytest.raises(ConfigFileError, match="nope: no such file, and no shipped campaign of that name "
                                              r"\(shipped: default, diagnostics, diagnostics_other_motions, "
                                              r"diagnostics_reduced, diagnostics_urlog, paper, prognostics, "
                                              r"prognostics_small; `ur5fault campaign list` describes them\)"):
        load_campaign("nope")
    # a folder of that name (the campaign's own --out) is not the campaign file: `campaign run paper --out paper`
    # resumed by the same command read the folder ("paper: cannot read (Is a directory)")
    (tmp_path / "paper.yaml").unlink()
    (tmp_path / "paper").mkdir()
    assert load_campaign("paper").path == PACKAGE / "campaigns" / "paper.yaml"
    (tmp_path / "nope").mkdir()
    with pytest.raises(ConfigFileError, match="nope: a folder, not a campaign file, and no shipped campaign"):
        load_campaign("nope")


def test_checkout_paths_of_the_readme_still_work():
    assert load_campaign(Path(__file__).resolve().parents[1] / "campaigns" / "paper.yaml").name == "paper"


def test_show_run_id_without_campaign_says_how(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    err = _one_error(capsys, "show", "r0123456789ab")
    assert "r0123456789ab: no such file; to show a run of a campaign, give its folder" in err and "--campaign" in err


def test_hints_hold_for_a_wheel_user():
    """No hint names a package index entry that does not exist (ur5fault is not on PyPI) or an internal issue."""
    from ur5fault.identify.report import NOT_IDENTIFIABLE

    for path in PACKAGE.rglob("*.py"):
        assert "install 'ur5fault[" not in path.read_text(), path
    assert not [t for t in NOT_IDENTIFIABLE if re.search(r"issue \d", t)]


def test_effect_spec_refuses_a_joint_given_the_users_way():
    """Joints are 1..6 everywhere a user writes them; the 0-based array index is named joint_index, so the
    ambiguous ``EffectSpec(joint=1)`` fails loudly instead of meaning the second joint."""
    from ur5fault import make_effect
    from ur5fault.sim.effects import EffectSpec

    with pytest.raises(TypeError, match="joint"):
        EffectSpec("backlash", joint=1, values=(("backlash_deg", 0.1),))
    with pytest.raises(ParameterError, match="joint_index = 6 must be 0..5"):
        EffectSpec("backlash", 6, (("backlash_deg", 0.1),))
    spec = make_effect("backlash", 1, backlash_deg=0.1)
    assert spec.joint_index == 0 and spec.describe() == "backlash on shoulder_pan_joint (backlash_deg=0.1)"


def test_campaign_sweeping_a_joint_without_a_size_refused(tmp_path):
    f = tmp_path / "j.yaml"
    f.write_text("name: j\nsweep:\n  backlash.joint: [1, 2]\n")  # ran as one healthy run before
    with pytest.raises(ParameterError, match=re.escape("j.yaml: sweep of effect 'backlash' gives joints but no "
                                                       "size; sweep 'backlash.backlash_deg' [deg] too")):
        load_campaign(f)
