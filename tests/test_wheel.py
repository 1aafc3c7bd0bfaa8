"""The package as a user gets it: build the wheel from a copy of the sources, install it into a fresh
virtual environment, and run the installed ``ur5fault`` from a folder outside the repository.

The fresh environment reaches the third-party dependencies (mujoco, numpy, numba, ...) through a ``.pth``
line to this environment's site-packages, so the test needs no package index; what it checks is ur5fault
itself: the installed copy (not the editable one) is imported, and it finds its MJCF and data files as
package data.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pandas as pd
import pytest

from ur5fault import __version__

from conftest import REPO

pytestmark = pytest.mark.slow

#: what the wheel must carry besides the Python modules
PACKAGE_DATA = ("ur5fault/models/ur5.xml", "ur5fault/data/ur5_drive.yaml", "ur5fault/py.typed",
                *(f"ur5fault/campaigns/{name}.yaml" for name in ("default", "paper", "diagnostics")),
                # the real logs (`ur5fault data`), their READMEs and the Kufieta licence
                "ur5fault/data/nist-ur5/ur5testresult_halfspeed_payload1.6lb_1.csv.gz",
                "ur5fault/data/nist-ur5/README.md",
                "ur5fault/data/kufieta-ur5/TEST.csv.gz", "ur5fault/data/kufieta-ur5/README.md",
                "ur5fault/data/kufieta-ur5/LICENSE-Apache-2.0.txt")
#: the pages whose command blocks a wheel user follows literally
DOCS = (REPO / "README.md", REPO / "docs" / "usage.md")
#: shortened durations: (command, what is added to it); the documented command itself is run unchanged otherwise
SHORTER = (("ur5fault simulate", ["--duration-s", "1", "--quiet"]),
           ("ur5fault campaign run", ["--duration-s", "0.5", "--quiet"]),
           ("ur5fault discrepancy", ["--quiet", "--jobs", "2"]),
           ("ur5fault identify", ["--no-sweep", "--bootstrap", "50", "--quiet"]))


def doc_commands() -> list[tuple[str, str]]:
    """(page, command) for every command line of every ```sh block of :data:`DOCS`, comments removed."""
    out = []
    for page in DOCS:
        for block in re.findall(r"```sh\n(.*?)```", page.read_text(), re.S):
            for line in block.splitlines():
                cmd = re.split(r"\s#", line)[0].strip()
                if cmd:
                    out.append((page.name, cmd))
    return out


def _sh(*cmd, cwd: Path, env: dict[str, str] | None = None, timeout: float = 600) -> subprocess.CompletedProcess:
    r = subprocess.run([str(c) for c in cmd], cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert r.returncode == 0, f"{' '.join(map(str, cmd))}\n{r.stdout}\n{r.stderr}"
    return r


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from a copy of pyproject.toml, README.md and ur5fault/ (so the build sees no other file
    of the checkout and leaves nothing in it)."""
    src = tmp_path_factory.mktemp("src")
    shutil.copy(REPO / "pyproject.toml", src)
    shutil.copy(REPO / "README.md", src)
    shutil.copytree(REPO / "ur5fault", src / "ur5fault", ignore=shutil.ignore_patterns("__pycache__", "*.nbi",
                                                                                          "*.nbc"))
    dist = tmp_path_factory.mktemp("dist")
    _sh(sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "--no-index", "-w", dist, src,
        cwd=src)
    (whl,) = dist.glob("ur5fault-*.whl")
    return whl


def test_wheel_carries_model_and_data(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    for path in PACKAGE_DATA:
        assert path in names, path
    from ur5fault.logs.shipped import LOGS_DIR, shipped_logs  # every shipped log, not the few named above

    for lg in shipped_logs().values():
        assert f"ur5fault/data/{lg.path.relative_to(LOGS_DIR).as_posix()}" in names, lg.name
    assert "ur5fault/sim/drive/kernel.py" in names and "ur5fault/campaign/spec.py" in names
    assert not [n for n in names if n.startswith(("tests/", "bench/", "campaigns/"))]


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory) -> tuple[Path, Path, dict[str, str]]:
    """(venv, its site-packages, environment): the wheel installed into a fresh virtual environment."""
    tmp = tmp_path_factory.mktemp("venv")
    venv = tmp / "venv"
    _sh(sys.executable, "-m", "venv", venv, cwd=tmp)
    py = venv / "bin" / "python"
    site = Path(_sh(py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])", cwd=tmp).stdout.strip())
    _sh(py, "-m", "pip", "install", "--no-deps", "--no-index", "--quiet", wheel, cwd=tmp)
    # third-party dependencies from this environment, after the fresh site-packages (the wheel's copy wins)
    (site / "zz_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
    env["PATH"] = f"{venv / 'bin'}{os.pathsep}{env.get('PATH', '')}"  # `ur5fault` and `pip` are the venv's
    return venv, site, env


def test_installed_wheel_simulates_from_another_folder(installed, tmp_path):
    venv, site, env = installed
    py = venv / "bin" / "python"
    work = tmp_path / "elsewhere"
    work.mkdir()

    where = _sh(py, "-c", "import ur5fault.sim.engine as e; print(e.__file__); print(e.DEFAULT_MODEL_PATH)", cwd=work,
                env=env).stdout.split()
    assert all(Path(p).is_relative_to(site) for p in where), where  # the installed copy, its packaged MJCF

    exe = venv / "bin" / "ur5fault"
    r = _sh(exe, "--version", cwd=work, env=env)
    assert r.stdout.startswith(f"ur5fault {__version__} (mujoco ")
    r = _sh(exe, "simulate", "--backlash", "shoulder:0.1", "--duration-s", "0.05", "--quiet", "--out", "run.parquet",
            cwd=work, env=env)
    assert "wrote run.parquet (50 samples" in r.stderr
    df = pd.read_parquet(work / "run.parquet")
    assert len(df) == 50 and df.attrs["ur5fault"]["model_path"].startswith(str(site))


def _rtde_log(nist_path: Path, out: Path, seconds: float = 20.0) -> None:
    """``robot.csv`` of the README: the first ``seconds`` of the real NIST UR5 log in UR's RTDE layout."""
    from ur5fault.logs.readers import UR_CURRENT_SIGN, read_log

    log = read_log(nist_path, "nist")
    keep = log.t_s <= seconds
    cols = {"timestamp": log.t_s[keep]}
    for name, arr in (("target_q", log.q_target_rad), ("actual_q", log.q_actual_rad),
                      ("actual_current", log.current_A / UR_CURRENT_SIGN)):
        cols.update({f"{name}_{j}": arr[keep, j] for j in range(6)})
    pd.DataFrame(cols).to_csv(out, index=False)


def _documented(cmd: str, work: Path, wheel: Path) -> list[str] | None:
    """The command a wheel user types for a documented line (None: not a wheel user's command)."""
    words = shlex.split(cmd)
    if words[0] == "make":  # the checkout's Makefile: README says these need the checkout
        return None
    if words[0] == ".venv/bin/ur5fault":  # the checkout's virtual environment; a wheel user's is on PATH
        words[0] = "ur5fault"
    if words[:2] == ["pip", "install"]:
        if not words[2].endswith(".whl"):
            return None  # an install from the checkout
        shutil.copy(wheel, work / words[2])  # the documented file name must be the wheel's
        return [*words, "--no-deps", "--no-index", "--quiet", "--force-reinstall"]
    if "RUN_ID" in words:
        features = pd.read_parquet(work / words[words.index("--campaign") + 1] / "features.parquet")
        words[words.index("RUN_ID")] = features.loc[features["fault"] == "backlash", "run_id"].iloc[0]
    line = " ".join(words)
    for prefix, extra in SHORTER:
        if line.startswith(prefix):
            words += extra
    return words


def test_every_documented_command_works_from_a_wheel(wheel, installed, tmp_path, nist_path):
    """Each command line of README.md and docs/usage.md, in order, from a folder outside the checkout, with the
    installed wheel: exit 0 and no traceback (durations shortened by :data:`SHORTER`)."""
    _, _, env = installed
    work = tmp_path / "user"
    work.mkdir()
    _rtde_log(nist_path, work / "robot.csv")
    failed, ran = [], []
    for page, cmd in doc_commands():
        words = _documented(cmd, work, wheel)
        if words is None:
            continue
        r = subprocess.run(words, cwd=work, env=env, capture_output=True, text=True, timeout=1800)
        ran.append(cmd)
        if r.returncode != 0 or "Traceback" in r.stderr:
            failed.append(f"{page}: {cmd}\n  ran {shlex.join(words)}: exit {r.returncode}\n  {r.stderr[-1500:]}")
    assert not failed, "\n".join(failed)
    documented = {c for _, c in doc_commands()}
    assert len(ran) >= 12 and any("campaign run" in c for c in ran), ran
    assert {c for c in documented if "ur5fault" in c and not c.startswith("make")} <= set(ran)


def doc_python_blocks() -> list[tuple[str, str]]:
    """(page, code) for every ```python block of :data:`DOCS` written as a script (an IPython session
    transcript, ``In [1]: ...``, shows the same calls as a README block and is not a script)."""
    return [(page.name, block) for page in DOCS for block in re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
            if not block.lstrip().startswith("In [")]


def test_every_documented_python_block_runs_from_a_wheel(installed, tmp_path):
    """Each Python block of README.md and docs/usage.md, run as written with the installed wheel from a folder
    outside the checkout (one folder per page): exit 0 and no traceback.  A README block reads the default
    campaign's results, which `make campaign` writes in a checkout; a wheel user writes them with the shipped
    campaign (durations shortened here)."""
    venv, _, env = installed
    env = {**env, "MPLBACKEND": "Agg"}
    blocks = doc_python_blocks()
    assert {page for page, _ in blocks} == {"README.md", "usage.md"} and len(blocks) >= 4, blocks
    failed = []
    for page in sorted({page for page, _ in blocks}):
        work = tmp_path / page.replace(".", "_")
        work.mkdir()
        if page == "README.md":
            _sh(venv / "bin" / "ur5fault", "campaign", "run", "default", "--out", "results/default",
                "--duration-s", "0.5", "--quiet", cwd=work, env=env)
        for code in (c for p, c in blocks if p == page):
            r = subprocess.run([venv / "bin" / "python", "-c", code], cwd=work, env=env, capture_output=True,
                               text=True, timeout=1800)
            if r.returncode != 0 or "Traceback" in r.stderr:
                failed.append(f"{page}:\n{code}\n  exit {r.returncode}\n  {r.stderr[-1500:]}")
    assert not failed, "\n".join(failed)
