"""The package as a user gets it: build the wheel from a copy of the sources, install it into a fresh
virtual environment, and run the installed ``ur5fault`` from a folder outside the repository.

The fresh environment reaches the third-party dependencies (mujoco, numpy, numba, ...) through a ``.pth``
line to this environment's site-packages, so the test needs no package index; what it checks is ur5fault
itself: the installed copy (not the editable one) is imported, and it finds its MJCF and data files as
package data.
"""

from __future__ import annotations

import os
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
PACKAGE_DATA = ("ur5fault/models/ur5.xml", "ur5fault/data/ur5_drive.yaml", "ur5fault/py.typed")


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
    assert "ur5fault/sim/drive/kernel.py" in names and "ur5fault/campaign/spec.py" in names
    assert not [n for n in names if n.startswith(("tests/", "bench/", "campaigns/"))]


def test_installed_wheel_simulates_from_another_folder(wheel, tmp_path):
    venv = tmp_path / "venv"
    _sh(sys.executable, "-m", "venv", venv, cwd=tmp_path)
    py = venv / "bin" / "python"
    site = Path(_sh(py, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])", cwd=tmp_path).stdout.strip())
    _sh(py, "-m", "pip", "install", "--no-deps", "--no-index", "--quiet", wheel, cwd=tmp_path)
    # third-party dependencies from this environment, after the fresh site-packages (the wheel's copy wins)
    (site / "zz_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}
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
