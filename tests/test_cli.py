"""The command line: a real run, and one-line errors with exit status 2 on bad input."""

import re
import subprocess
import sys

import pandas as pd
import pytest

CMD = [sys.executable, "-m", "ur5fault.cli"]


def run(*args, cwd=None):
    return subprocess.run([*CMD, *args], capture_output=True, text=True, cwd=cwd, timeout=600)


def test_simulate_writes_parquet_with_documented_columns(tmp_path):
    out = tmp_path / "run.parquet"
    r = run("simulate", "--backlash", "shoulder_lift_joint:0.1", "--duration-s", "0.3", "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "backlash on shoulder_lift_joint" in r.stderr  # prose on stderr, the JSON summary on stdout
    df = pd.read_parquet(out)
    for col in ("t_s", "q_set_rad_j2", "q_rad_j2", "q_FB_rad_j2", "q_M_rad_j2", "q_M_FB_rad_j2", "i_ref_A_j2",
                "i_FB_A_j2", "v_q_V_j2", "T_gear_Nm_j2", "T_f_Nm_j2", "tcp_x_m", "tcp_des_x_m", "i_a_A_j2"):
        assert col in df.columns
    assert len(df) == 300


def test_simulate_from_yaml(tmp_path):
    cfg = tmp_path / "run.yaml"
    cfg.write_text("trajectory: pick_and_place\nseed: 3\nduration_s: 0.2\ntemperature_C: 40\n"
                   "effects:\n  - {effect: backlash, joint: elbow, backlash_deg: 0.2}\n")
    out = tmp_path / "x.parquet"
    r = run("simulate", "--config", str(cfg), "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "backlash on elbow_joint (backlash_deg=0.2)" in r.stderr and "temperature" in r.stderr


@pytest.mark.parametrize(
    "args, message",
    [
        (["--backlash", "knee:0.1"], "unknown joint 'knee'; valid: 1..6, base, elbow, elbow_joint,"),
        (["--backlash", "elbow:-0.1"], "backlash.backlash_deg = -0.1 is out of range [0, 5] deg"),
        (["--backlash", "elbow"], "expected JOINT:DEGREES"),
        (["--effect", "rust@1:scale=2"], "unknown effect 'rust'; valid: backlash,"),
        (["--trajectory", "zigzag"], "argument --trajectory: invalid choice: 'zigzag'"),
        (["--config", "/nonexistent.yaml"], "/nonexistent.yaml: cannot read"),
    ],
)
def test_bad_input_one_line_exit_2(args, message):
    r = run("simulate", *args, "--quiet")
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("ur5fault: error: "), r.stderr
    assert message in lines[0]
    assert "Traceback" not in r.stderr


def test_bad_yaml_files(tmp_path):
    cases = {
        "broken.yaml": ("a: [1, 2", "is not valid YAML"),
        "key.yaml": ("trajectori: pick_and_place\n",
                     "unknown key 'trajectori' (did you mean 'trajectory'?); valid: duration_s,"),
        "type.yaml": ("seed: -3\n", "seed = -3 must be a non-negative integer"),
        "param.yaml": ("params: {gear: {stiffness_Nm_per_rad: -1}}\n", "gear.stiffness_Nm_per_rad = -1"),
    }
    for name, (text, message) in cases.items():
        f = tmp_path / name
        f.write_text(text)
        r = run("simulate", "--config", str(f), "--quiet")
        assert r.returncode == 2 and message in r.stderr, (name, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1


def test_effects_lists_registry():
    r = run("effects")
    assert r.returncode == 0 and "backlash" in r.stdout and "torque_constant" in r.stdout
    # one column per field: every line's scope ("per joint" / "robot") starts at the same character
    starts = {re.match(r"\S+\s+(per joint|robot) ", line).start(1) for line in r.stdout.splitlines()}
    assert len(starts) == 1, starts


def test_data_lists_the_shipped_logs_and_prints_a_path_for_the_shell():
    """A wheel user had no real log to try identify or discrepancy on: `ur5fault data` names them, `data NAME` prints
    the path(s), one per line, and an unknown name is one line listing the names."""
    from pathlib import Path

    r = run("data")
    assert r.returncode == 0 and r.stdout.startswith("nist ") and "--format nist" in r.stdout
    assert "kufieta/TEST " in r.stdout and "--format rtde --tcp-offset-m 0 0 0" in r.stdout
    r = run("data", "nist")
    path = Path(r.stdout.strip())
    assert r.returncode == 0 and path.name == "ur5testresult_halfspeed_payload1.6lb_1.csv.gz" and path.is_file()
    r = run("data", "kufieta")
    assert r.returncode == 0 and len(r.stdout.splitlines()) == 9
    assert all(Path(line).is_file() for line in r.stdout.splitlines())
    r = run("data", "kufieta/No1")
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "unknown shipped log 'kufieta/No1' (did you mean" in r.stderr


def test_discrepancy_bad_input(tmp_path):
    r = run("discrepancy", str(tmp_path / "nope.csv"), "--format", "rtde", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "no such file" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    r = run("discrepancy", "x.csv", "--format", "excel", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "invalid choice: 'excel'" in r.stderr
    bad = tmp_path / "log.csv"
    bad.write_text("timestamp,target_q_0\n0,0\n")
    r = run("discrepancy", str(bad), "--format", "rtde", "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "missing required column 'target_q_1'" in r.stderr


def _one_line_error(r, text):
    assert r.returncode == 2, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and text in r.stderr, r.stderr


def test_refusals_name_what_the_user_typed(tmp_path):
    """Found by trying the commands as a newcomer with the wheel: each refusal names the user's option or column,
    not an internal keyword or a file the user never wrote."""
    log = tmp_path / "log.csv"
    log.write_text("Time," + ",".join(f"{k}_{j}" for k in ("target_q", "actual_q", "actual_current")
                                       for j in range(6)) + "\n" + ",".join(["0"] * 19) + "\n")
    out = str(tmp_path / "o")
    _one_line_error(run("identify", str(log), "--format", "rtde", "--payload-kg", "0", "--tcp-offset-m", "0", "0",
                        "0", "--out", str(tmp_path / "p.yaml")),
                    "log.csv: 0 s and 1 sample; fitting needs at least 5 s and 250 samples")  # 'Time': any case
    _one_line_error(run("discrepancy", str(log), "--format", "rtde", "--payload-kg", "-1", "--tcp-offset-m", "0",
                        "0", "0", "--out", out), "--payload-kg = -1.0 is out of range [0, 5] kg")
    _one_line_error(run("discrepancy", str(log), "--format", "rtde", "--payload-kg", "1", "--tcp-offset-m", "0",
                        "0", "3", "--out", out), "--tcp-offset-m (value 3) = 3.0 is out of range [-2, 2] m")
    _one_line_error(run("campaign", "run", "paper", "--duration-s", "-1", "--out", out),
                    "command line: --duration-s = -1.0 is out of range (0, 3600] s")
    sim_csv = tmp_path / "run.csv"
    sim_csv.write_text("t_s\n0\n")
    _one_line_error(run("discrepancy", str(sim_csv), "--format", "sim", "--out", out),
                    "run.csv: the sim format reads the Parquet file")
    # the discrepancy workflow's own settings, named as typed (were `fit_fraction = 1.5`, `jobs = 0`)
    for opt, text in ((("--fit-fraction", "1.5"), "--fit-fraction = 1.5 is out of range [0.2, 0.9]"),
                      (("--max-effects", "-1"), "--max-effects -1: must be a whole number of at least 0"),
                      (("--jobs", "0"), "--jobs 0: must be a whole number of at least 1")):
        _one_line_error(run("discrepancy", str(log), "--format", "rtde", "--payload-kg", "1", "--tcp-offset-m",
                            "0", "0", "0", *opt, "--out", out), text)


@pytest.mark.parametrize("args, commands", [((), "(simulate, effects, data, show, campaign,"),
                                            (("campaign",), "(run, status, show, list)")])
def test_a_group_without_its_command_ends_its_help_with_one_error_line(args, commands):
    r = run(*args)
    assert r.returncode == 2 and "usage:" in r.stderr
    last = r.stderr.strip().splitlines()[-1]
    assert last.startswith("ur5fault: error: ") and "name a command" in last and commands in last, r.stderr


def test_version_matches_installed_metadata():
    from importlib.metadata import version

    r = run("--version")
    assert r.returncode == 0
    assert r.stdout.startswith(f"ur5fault {version('ur5fault')} (mujoco {version('mujoco')}")


def test_python_dash_m_ur5fault_is_the_command():
    """``python -m ur5fault`` (a newcomer's first try without the script on PATH) runs the same command, exit
    status included."""
    r = subprocess.run([sys.executable, "-m", "ur5fault", "--version"], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0 and r.stdout == run("--version").stdout
    bad = subprocess.run([sys.executable, "-m", "ur5fault", "nosuch"], capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2 and "ur5fault: error:" in bad.stderr


def _summaries(parser) -> dict[str, str]:
    """The commands of ``parser`` with the one-line help ``ur5fault --help`` lists, in its order."""
    import argparse

    sub = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)][0]
    return {a.dest: a.help for a in sub._choices_actions}


def test_each_command_group_registers_the_commands_and_summaries_the_table_names():
    """cli.COMMAND_GROUPS, read to import only the chosen command's module and to list the commands in `ur5fault
    --help` without importing any, says what each module registers, with the same summaries, in the same order."""
    from ur5fault.cli import COMMAND_GROUPS, build_parser

    for group, summaries in COMMAND_GROUPS.items():
        assert list(_summaries(build_parser([group])).items()) == list(summaries.items()), group
    every = [item for summaries in COMMAND_GROUPS.values() for item in summaries.items()]
    assert list(_summaries(build_parser()).items()) == every
    assert list(_summaries(build_parser(())).items()) == every


@pytest.mark.parametrize("argv", [["--help"], ["-h"], ["-v", "--help", "simulate"], ["-v"]])
def test_the_top_level_help_without_the_command_modules_is_the_one_with_them(argv, capsys, monkeypatch):
    """`ur5fault --help` imported every command's module (1.8 s) to list one line per command: it is made from
    COMMAND_GROUPS' summaries alone, and prints, byte for byte, the help of the parser built with every group (so
    does a command line without a command, on stderr before its error line)."""
    from ur5fault.cli import build_parser, groups_needed, main

    monkeypatch.setenv("COLUMNS", "100")  # one width for both (argparse reads it when it formats)
    full = build_parser().format_help()  # the slow way: every group's module imported and registered
    assert groups_needed(argv) == () and build_parser(()).format_help() == full
    if argv == ["-v"]:
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert err == full + "ur5fault: error: name a command (" + ", ".join(_summaries(build_parser())) + ")\n"
        return
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 0 and capsys.readouterr().out == full


@pytest.mark.parametrize("argv, groups", [(["--version"], ()), (["-vv", "--version", "simulate"], ()),
                                          (["effects"], (".run_cli",)), (["-v", "--verbose", "plot", "x"],
                                                                          (".campaign.cli",)),
                                          (["monitor", "--version"], (".health.monitoring.cli",)),
                                          ([], ()), (["-h"], ()), (["-v", "--help", "show"], ()), (["-v"], ()),
                                          (["show", "-h"], (".run_cli",)), (["simul"], None), (["--he"], None),
                                          (["--verb", "show"], None), (["-vh", "show"], None), (["--", "show"], None)])
def test_a_command_line_imports_its_commands_module_alone(argv, groups):
    """Only the chosen command's module is imported, none for the top-level help (its summaries are
    COMMAND_GROUPS'); whenever the choice is not plain (a misspelled command, an abbreviated option before it),
    every group, so that argparse answers as before."""
    from ur5fault.cli import COMMAND_GROUPS, groups_needed

    assert groups_needed(argv) == (tuple(COMMAND_GROUPS) if groups is None else groups)


@pytest.mark.parametrize("args, absent", [(["--version"], ("ur5fault.run_cli", "ur5fault.sim", "numpy")),
                                          (["--help"], ("ur5fault.run_cli", "ur5fault.campaign", "ur5fault.sim",
                                                        "ur5fault.health", "numpy", "scipy", "sklearn")),
                                          (["effects"], ("ur5fault.campaign", "ur5fault.discrepancy",
                                                         "ur5fault.identify", "ur5fault.health", "scipy", "sklearn",
                                                         "pandas", "matplotlib"))])
def test_a_command_starts_without_the_other_commands_modules(args, absent):
    """`ur5fault --version` and `ur5fault effects` took 2-3 s importing every command's modules (a newcomer
    probe); the package's names are imported on first use."""
    script = ("import sys\nfrom ur5fault.cli import main\n"
              f"try:\n    main({args!r})\nexcept SystemExit:\n    pass\n"
              f"print([m for m in sys.modules if m.split('.')[0] in {absent!r} or m.startswith({absent!r})])\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip().splitlines()[-1] == "[]", (r.stdout, r.stderr)


def test_prognose_offers_the_twin_choices_its_estimators_accept_and_its_help_stays_light():
    """`--twin-friction` and `--twin-calibration` wrote ("learned", "law") and ("direction", "task", "pooled") again
    beside the estimators' own constants: one place (twin_choices.py, which imports nothing, so that building the
    parser loads no estimator: 1.4 s of numpy, pandas and MuJoCo on `prognose --help`)."""
    from ur5fault.cli import build_parser
    from ur5fault.health.prognostics import twin_rul
    from ur5fault.health.prognostics.benchmark import TWIN_FRICTION

    sub = next(a for a in build_parser([".health.prognostics.cli"])._actions if a.dest == "command")
    choices = {a.dest: a.choices for a in sub.choices["prognose"]._actions if a.choices}
    assert choices == {"twin_friction": TWIN_FRICTION, "twin_calibration": twin_rul.CALIBRATIONS}
    script = ("import sys\nfrom ur5fault.cli import main\ntry:\n    main(['prognose', '--help'])\n"
              "except SystemExit:\n    pass\n"
              "print([m for m in sys.modules if m.split('.')[0] in ('numpy', 'pandas', 'mujoco', 'scipy')])\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and r.stdout.strip().splitlines()[-1] == "[]", (r.stdout, r.stderr)


def test_the_other_commands_choices_are_the_constants_their_code_checks():
    """`monitor --event-channels`, `benchmark --features` and `campaign run --backend` write their choices as
    literals in the parser (the modules holding the constants import numpy and pandas, which `--help` should not):
    each literal must equal the constant the code behind it accepts, or a new choice is refused by the parser."""
    import argparse

    from ur5fault.cli import build_parser
    from ur5fault.health.diagnostics.data import FEATURE_SETS
    from ur5fault.health.monitoring.events import CHANNELS

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))

    def choices(*path):
        p = sub.choices[path[0]]
        for name in path[1:]:
            p = next(a for a in p._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
        return {a.dest: tuple(a.choices) for a in p._actions if a.choices and not isinstance(
            a, argparse._SubParsersAction)}

    assert choices("monitor")["event_channels"] == CHANNELS
    assert choices("benchmark")["features"] == FEATURE_SETS
    from ur5fault.campaign.workers import BACKENDS

    assert choices("campaign", "run")["backend"] == BACKENDS


def test_the_command_line_module_imports_little_before_main():
    """Until main() sets up its handlers, Ctrl-C prints a traceback: `import ur5fault.cli` (the console script's
    first line) took 0.9 s importing the simulator, then 40 ms importing importlib.metadata for __version__."""
    script = ("import sys\nbefore = set(sys.modules)\nimport ur5fault.cli\n"
              "print(sorted(m for m in set(sys.modules) - before if m.startswith('ur5fault')))\n"
              "new = set(sys.modules) - before\n"
              "print([m for m in ('importlib.metadata', 'logging', 'numpy', 'subprocess') if m in new])\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.stdout.splitlines() == ["['ur5fault', 'ur5fault.cli', 'ur5fault.errors', 'ur5fault.util', "
                                     "'ur5fault.util.usage']", "[]"], r.stderr


def test_the_packages_names_are_there_on_first_use():
    script = ("import ur5fault\nfrom ur5fault import *\n"
              "print(sorted(ur5fault.__all__) == sorted(n for n in ur5fault.__all__ if n in globals()),\n"
              "      ur5fault.Simulator.__module__, hasattr(ur5fault, 'nothing'), 'Simulator' in dir(ur5fault))\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.stdout.split() == ["True", "ur5fault.sim.engine", "False", "True"], r.stderr


@pytest.mark.parametrize("where", ["before", "after"])
def test_verbose_logs_through_logging(tmp_path, where):
    args = ["simulate", "--duration-s", "0.02", "--out", str(tmp_path / "r.parquet"), "--quiet"]
    r = run(*(["-v", *args] if where == "before" else [*args, "-v"]))
    assert r.returncode == 0, r.stderr
    assert "ur5fault: INFO: ur5fault.sim.engine: simulating 1 run(s) x 400 physics steps" in r.stderr
    quiet = run(*args, "--replace")  # the same file again
    assert quiet.returncode == 0 and "INFO" not in quiet.stderr


def _documented_run_configurations():
    """The run configuration of docs/usage.md and of `ur5fault simulate --help`, as YAML texts."""
    import re
    import textwrap

    from ur5fault.run_cli import RUN_CONFIG_HELP

    from conftest import REPO

    page = (REPO / "docs" / "usage.md").read_text().split("## The run configuration file", 1)[1]
    doc = re.search(r"```yaml\n(.*?)```", page, re.S).group(1)
    lines = RUN_CONFIG_HELP.split("\n\n", 1)[0].splitlines()[1:]  # the indented block after its title line
    return {"usage.md": doc, "simulate --help": textwrap.dedent("\n".join(lines))}


@pytest.mark.parametrize("where", ["usage.md", "simulate --help"])
def test_documented_run_configuration_runs(where, tmp_path, capsys):
    """The example a user copies: it ran into a protective stop (a scalar gear damping of 15 N*m*s/rad on all six
    joints made the wrists' gear mode unstable within 10 ms; exit status 1)."""
    import json

    from ur5fault.cli import main

    cfg = tmp_path / "run.yaml"
    cfg.write_text(_documented_run_configurations()[where])
    rc = main(["simulate", "--config", str(cfg), "--duration-s", "0.05", "--quiet", "--out", str(tmp_path / "r.csv")])
    summary = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert rc == 0 and summary["status"] == "ok", summary


def test_discrepancy_held_out_line_says_the_figures_with_or_without_urs_model():
    """A simulated log has no target currents: the line once stopped after "after the fit" with no figure."""
    from ur5fault.discrepancy.cli import held_out_line

    cur = {"shoulder_pan_joint": 0.0204, "shoulder_lift_joint": 0.0179, "elbow_joint": None}
    assert held_out_line("a.parquet", {"role": "fit", "rms_after": {"current_A": cur}}) == (
        "fit: a.parquet: held-out current RMS after the fit [A], J1..J3: 0.020 / 0.018 / -")
    ur = {"shoulder_pan_joint": 0.04, "shoulder_lift_joint": 0.0, "elbow_joint": 0.1}
    assert held_out_line("b.csv", {"role": "held_out", "rms_after": {"current_A": cur},
                                   "rms_controller_model_current_A": ur}) == (
        "held_out: b.csv: held-out current RMS after the fit, as a multiple of UR's own model: 0.51 / - / -")


def test_simulate_command_line_effects_replace_the_files_and_errors_name_their_source(tmp_path, capsys):
    """"Command-line options override the file": a --backlash on a joint the file gives a backlash was refused as
    a repeat of the file's entry, and a bad command-line value was reported as the file's effects[i]."""
    import pandas as pd

    from ur5fault.cli import main

    cfg = tmp_path / "run.yaml"
    cfg.write_text("effects: [{effect: backlash, joint: 2, backlash_deg: 0.1}, "
                   "{effect: coulomb_friction, joint: 3, scale: 1.2}]\n")
    out = tmp_path / "r.parquet"
    assert main(["simulate", "--config", str(cfg), "--backlash", "shoulder_lift:0.3", "--duration-s", "0.05",
                 "--quiet", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert ("note: the command line's backlash on shoulder_lift_joint (backlash_deg=0.3) replaces run.yaml's "
            "backlash on shoulder_lift_joint (backlash_deg=0.1)") in err
    assert "effects: coulomb_friction on elbow_joint (scale=1.2); backlash on shoulder_lift_joint (backlash_deg=0.3)" \
        in err
    assert len(pd.read_parquet(out)) == 50
    assert main(["simulate", "--config", str(cfg), "--backlash", "2:9", "--out", str(out), "--replace"]) == 2
    assert capsys.readouterr().err.strip() == (
        "ur5fault: error: command line: effects[0]: backlash.backlash_deg = 9.0 is out of range [0, 5] deg")
    assert main(["simulate", "--effect", "payload:mass_kg=1", "--effect", "payload:mass_kg=2", "--out", str(out),
                 "--replace"]) == 2
    assert capsys.readouterr().err.strip().endswith("give each effect once")
    # --effect and --backlash are numbered in the order typed (every --backlash came first)
    assert main(["simulate", "--effect", "backlash@elbow:backlash_deg=0.1", "--backlash", "elbow:0.2", "--out",
                 str(out), "--replace"]) == 2
    assert capsys.readouterr().err.strip() == (
        "ur5fault: error: command line: effects[1]: backlash on elbow_joint (backlash_deg=0.2) repeats effects[0] "
        "(backlash on elbow_joint (backlash_deg=0.1)); give each effect once per joint")
    # the file's own repeat is the file's error under its own indices, whatever the command line adds
    rep = tmp_path / "rep.yaml"
    rep.write_text("effects: [{effect: backlash, joint: 1, backlash_deg: 0.1}, {effect: coulomb_friction, joint: 2, "
                   "scale: 1.1}, {effect: coulomb_friction, joint: 2, scale: 1.2}]\n")
    assert main(["simulate", "--config", str(rep), "--backlash", "2:0.3", "--out", str(out), "--replace"]) == 2
    assert "rep.yaml: effects[2]: coulomb_friction on shoulder_lift_joint (scale=1.2) repeats effects[1]" \
        in capsys.readouterr().err
    # a payload from either side replaces the other side's, said so; both on one side is refused
    pay = tmp_path / "pay.yaml"
    pay.write_text("payload_kg: 1\n")
    assert main(["simulate", "--config", str(pay), "--effect", "payload:mass_kg=3", "--duration-s", "0.05",
                 "--quiet", "--out", str(out), "--replace"]) == 0
    err = capsys.readouterr().err
    assert "note: the command line's payload (mass_kg=3) replaces pay.yaml's payload_kg = 1" in err
    assert "effects: payload (mass_kg=3)\n" in err
    pay.write_text("effects: [{effect: payload, mass_kg: 1}]\n")
    assert main(["simulate", "--config", str(pay), "--payload-kg", "2", "--duration-s", "0.05", "--quiet", "--out",
                 str(out), "--replace"]) == 0
    err = capsys.readouterr().err
    assert "note: the command line's payload_kg = 2.0 replaces pay.yaml's payload (mass_kg=1)" in err
    assert "effects: payload (mass_kg=2)\n" in err
    pay.write_text("payload_kg: 1\neffects: [{effect: payload, mass_kg: 2}]\n")
    assert main(["simulate", "--config", str(pay), "--out", str(out), "--replace"]) == 2
    err = capsys.readouterr().err
    assert "pay.yaml: effects[0]: payload (mass_kg=2) and payload_kg = 1 both set the payload" in err


def test_simulate_trajectory_flag_keeps_the_files_options_for_the_same_motion_and_notes_them_for_another(
        tmp_path, capsys):
    """--trajectory pick_and_place over a file's {name: pick_and_place, speed_scale: 0.5} ran at the default speed,
    silently, and the file recorded only the name: the options are kept, and the metadata records them (not the
    trajectory's default mass, which the run's payload_kg replaces); another motion drops them, said so."""
    import json

    import pyarrow.parquet as pq

    from ur5fault.cli import main

    def options(path):
        meta = json.loads(pq.read_schema(path).metadata[b"ur5fault"])
        return meta["trajectory"], meta["trajectory_options"]

    cfg = tmp_path / "ss.yaml"
    cfg.write_text("trajectory: {name: pick_and_place, speed_scale: 0.5}\n")
    out = tmp_path / "r.parquet"
    assert main(["simulate", "--config", str(cfg), "--trajectory", "pick_and_place", "--duration-s", "0.05",
                 "--quiet", "--out", str(out)]) == 0
    assert "note" not in capsys.readouterr().err
    assert options(out) == ("pick_and_place", {"speed_scale": 0.5, "setpoint_period_s": 0.008})
    assert main(["simulate", "--config", str(cfg), "--trajectory", "joint_sweep", "--duration-s", "0.05",
                 "--quiet", "--out", str(out), "--replace"]) == 0
    assert ("note: the command line's --trajectory joint_sweep replaces ss.yaml's trajectory 'pick_and_place' and "
            "its options (speed_scale: 0.5); joint_sweep runs with its defaults") in capsys.readouterr().err
    assert options(out) == ("joint_sweep", {"speed_scale": 1.0})


def test_show_of_a_robot_log_says_it_is_one_and_which_commands_read_it(tmp_path, capsys, monkeypatch):
    """Found from the wheel: `ur5fault show LOG.csv.gz` said 'cannot read as Parquet (... magic bytes ...)'."""
    import gzip

    from ur5fault.cli import main

    log = tmp_path / "robot.csv.gz"
    with gzip.open(log, "wt") as f:
        f.write("timestamp,actual_q_0,target_q_0\n0.0,0.1,0.1\n0.008,0.1,0.1\n")
    assert main(["show", str(log)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"ur5fault: error: {log}: not a ur5fault time series (a CSV without simulate's t_s and q_set_rad_j1 columns); "
        "`ur5fault show` reads simulate's Parquet (or CSV) output; a robot log is read by identify, discrepancy, "
        "monitor or diagnose with --format nist|rtde")

    # a file it cannot open is left to the reader's own one line (a permission error raised a traceback here)
    from ur5fault import run_cli

    def refused(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(run_cli, "open", refused, raising=False)
    assert run_cli._refuse_robot_log(log) is None


def test_a_run_past_its_trajectory_is_noted_and_plot_of_a_file_is_named(tmp_path):
    """Found trying the wheel as a newcomer: a --duration-s past the trajectory's end ran silently (the robot holds
    its last setpoint), and `plot RUN.parquet` called the file a campaign folder without a features table."""
    out = tmp_path / "run.parquet"
    r = run("simulate", "--trajectory", "pick_and_place", "--duration-s", "13.05", "--out", str(out), "--quiet")
    assert r.returncode == 0, r.stderr
    assert "note: the trajectory ends at 13 s; the robot holds its last setpoint for the remaining 0.05 s" in r.stderr
    _one_line_error(run("plot", str(out)), "run.parquet: a file, not a campaign folder")
