"""Where every command writes, the same rules (docs/usage.md, "Where results are written"): missing folders of
``--out`` are created; an earlier result in the place a command writes to is refused in one line naming
``--replace``, before any work, and left as it was; other files in an output folder are left alone; a file
output must carry the suffix of what is written in it."""

from __future__ import annotations

from pathlib import Path

import pytest

from ur5fault.cli import main

from conftest import NIST_LOG

SHORT = ["--duration-s", "0.02", "--quiet"]
MISSING = "no-such-log.csv"  # an input that fails once the output is accepted: proves the check came first

#: command line of each command writing a result folder, with the folder last, and one result file it writes
FOLDER_COMMANDS = {
    "discrepancy": (["discrepancy", MISSING, "--format", "nist", "--quiet", "--out"], "model.yaml"),
    "monitor": (["monitor", MISSING, "--format", "nist", "--baseline", "no-such-model.yaml", "--baseline-logs",
                 MISSING + "2", "--out"], "baseline.json"),
    "diagnose": (["diagnose", MISSING, "--format", "nist", "--detector", "no-such-detector", "--out"], "report.md"),
    "benchmark": (["benchmark", "no-such-campaign", "--out"], "metrics.json"),
    "prognose": (["prognose", "no-such-fleet", "--out"], "report.md"),
}


def _one_error(capsys, args: list[str]) -> str:
    assert main(args) == 2
    err = capsys.readouterr().err
    assert err.startswith("ur5fault: error: ") and len(err.strip().splitlines()) == 1, err
    return err


@pytest.mark.parametrize("name", list(FOLDER_COMMANDS))
def test_earlier_result_in_folder_refused_and_kept(tmp_path, capsys, name):
    if name == "diagnose":
        pytest.importorskip("sklearn")
    args, result = FOLDER_COMMANDS[name]
    out = tmp_path / "earlier"
    out.mkdir()
    (out / result).write_text("an earlier result\n")
    err = _one_error(capsys, [*args, str(out)])
    assert f"--out {out / result}: an earlier result is there; give --replace" in err
    assert (out / result).read_text() == "an earlier result\n"
    # with --replace the output is accepted and the command goes on to its (missing) input
    err = _one_error(capsys, [*args, str(out), "--replace"])
    assert "an earlier result" not in err and "no-such" in err


@pytest.mark.parametrize("name", list(FOLDER_COMMANDS))
def test_other_files_in_folder_and_missing_folders_accepted(tmp_path, capsys, name):
    if name == "diagnose":
        pytest.importorskip("sklearn")
    args, _ = FOLDER_COMMANDS[name]
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("mine\n")
    assert "no-such" in _one_error(capsys, [*args, str(out)])
    assert "no-such" in _one_error(capsys, [*args, str(tmp_path / "a" / "b" / "new")])


def test_simulate_creates_missing_folders(tmp_path, capsys):
    out = tmp_path / "a" / "b" / "run.parquet"
    assert main(["simulate", *SHORT, "--out", str(out)]) == 0
    assert out.is_file()


def test_simulate_earlier_file_refused_unless_replace(tmp_path, capsys):
    out = tmp_path / "run.csv"
    out.write_text("an earlier run\n")
    assert "give --replace to replace it" in _one_error(capsys, ["simulate", *SHORT, "--out", str(out)])
    assert out.read_text() == "an earlier run\n"
    assert main(["simulate", *SHORT, "--out", str(out), "--replace"]) == 0
    assert f"replaced {out}" in capsys.readouterr().err


@pytest.mark.parametrize("out, json_name, message", [
    ("p.txt", None, "--out {tmp}/p.txt: unknown file type '.txt'; give a .yaml or .yml file"),
    ("p", None, "unknown file type '(no suffix)'"),
    ("dir.yaml", None, "is a folder; give a file name"),
    ("p.yaml", "p.yaml", "--json {tmp}/p.yaml: unknown file type '.yaml'; give a .json file"),
    ("p.yaml", "e.txt", "--json {tmp}/e.txt: unknown file type '.txt'"),
    ("earlier.yaml", None, "--out {tmp}/earlier.yaml: an earlier result is there; give --replace"),
    ("p.yaml", "earlier.json", "--json {tmp}/earlier.json: an earlier result is there; give --replace"),
])
def test_identify_odd_output_names_refused_before_reading(tmp_path, capsys, out, json_name, message):
    (tmp_path / "dir.yaml").mkdir()
    for name in ("earlier.yaml", "earlier.json"):
        (tmp_path / name).write_text("kept\n")
    args = ["identify", str(NIST_LOG), "--format", "nist", "--out", str(tmp_path / out)]
    if json_name:
        args += ["--json", str(tmp_path / json_name)]
    assert message.format(tmp=tmp_path) in _one_error(capsys, args)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["dir.yaml", "earlier.json", "earlier.yaml"]
    assert (tmp_path / "earlier.yaml").read_text() == "kept\n"


def test_identify_accepts_replace_and_missing_folders(tmp_path, capsys):
    (tmp_path / "earlier.yaml").write_text("kept\n")
    for out in (tmp_path / "earlier.yaml", tmp_path / "a" / "b" / "p.yaml"):
        err = _one_error(capsys, ["identify", MISSING, "--format", "nist", "--out", str(out), "--replace"])
        assert MISSING in err


def test_benchmark_python_api_refuses_only_when_asked(tmp_path):
    from ur5fault.health.diagnostics import run_benchmark
    from ur5fault.util.io import OutputError

    out = tmp_path / "rep"
    out.mkdir()
    (out / "report.md").write_text("kept\n")
    with pytest.raises(OutputError, match="give --replace"):
        run_benchmark(tmp_path / "no-such-campaign", out, replace=False)
    assert Path(out / "report.md").read_text() == "kept\n"


def test_simulate_summary_of_a_protective_stop_is_strict_json(tmp_path, capsys):
    """A gear stiffness in its range (1e8 N*m/rad at most) that the 50 us step cannot follow on the wrists: the run
    ends in a protective stop before any finite sample (exit 1), and stdout is still valid JSON (the figures as
    null, not NaN, which JSON does not have), with no numpy warning on stderr."""
    import json

    cfg = tmp_path / "run.yaml"
    cfg.write_text("params:\n  gear: {stiffness_Nm_per_rad: 9.0e7}\n")
    assert main(["simulate", "--config", str(cfg), "--duration-s", "0.05", "--quiet",
                 "--out", str(tmp_path / "r.parquet")]) == 1
    cap = capsys.readouterr()

    def refuse(name):
        raise ValueError(f"{name} in the summary")

    summary = json.loads(cap.out, parse_constant=refuse)
    assert summary["status"] == "protective_stop" and summary["peak_current_A"] is None
    assert "RuntimeWarning" not in cap.err and "All-NaN" not in cap.err


def test_identify_says_replaced_for_the_files_replace_replaced(tmp_path, capsys, monkeypatch):
    """`identify --replace` said "wrote" over the user's earlier overlay, where simulate, show and plot say
    "replaced". The fit is a stand-in: what is checked is the closing line."""
    from types import SimpleNamespace

    import ur5fault.identify

    fitted = SimpleNamespace(payloads=[], notes=[], table=lambda: "estimates", to_json=lambda: {"estimates": []},
                             to_yaml=lambda params: "params: {}\n")
    monkeypatch.setattr(ur5fault.identify, "identify", lambda *a, **kw: fitted)
    out, js = tmp_path / "p.yaml", tmp_path / "p.json"
    out.write_text("an earlier overlay\n")
    args = ["identify", str(NIST_LOG), "--format", "nist", "--out", str(out), "--json", str(js), "--quiet"]
    assert main([*args, "--replace"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"replaced {out}; wrote {js}"
    assert out.read_text() == "params: {}\n"
    assert main([*args, "--replace"]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"replaced {out}, {js}"
    assert main([*args[:4], "--quiet", "--out", str(tmp_path / "new.yaml")]) == 0
    assert capsys.readouterr().out.splitlines()[-1] == f"wrote {tmp_path / 'new.yaml'}"
